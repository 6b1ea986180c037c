"""``python -m esair_min.harness ROBOT SCRIPT``: run a stimulus script on the Python core.

The documented entry point (docs/trace-format.md); the harness itself is
:mod:`esair_min.core.harness`.
"""

import sys

from esair_min.core.harness import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
