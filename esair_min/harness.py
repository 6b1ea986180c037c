"""``python -m esair_min.harness ROBOT SCRIPT``: run a stimulus script on the Python core.

The documented entry point (docs/trace-format.md); the harness itself is
:mod:`esair_min.core.stimulus`.
"""

import sys

from esair_min.cli.pipes import quiet_on_closed_pipe
from esair_min.core.stimulus import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(quiet_on_closed_pipe(main))     # `... | head`: a quiet exit, no error
