"""``python -m blossomquad ...``: the command line."""

from ._cli import main

main()
