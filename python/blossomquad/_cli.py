"""The ``blossomquad`` command installed by the package: the same command line as the
Rust binary (same flags, messages and exit codes), run in-process."""

import sys

from . import _native


def main() -> None:
    """Runs the command line on ``sys.argv`` and exits with its code."""
    sys.exit(_native.cli(["blossomquad", *sys.argv[1:]]))


if __name__ == "__main__":
    main()
