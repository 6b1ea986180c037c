"""``python -m esair_min.cli``: the same as the ``esair`` command."""

from esair_min.cli import main

main()
