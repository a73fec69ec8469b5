"""The ``pfpeople`` command: what a robot user runs (see ``pfpeople --help``)."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from pfpeople.cli import commands
from pfpeople.cli.support import run


def main(argv: Sequence[str] | None = None) -> int:
    return run("pfpeople", "Fuse people detectors into a local semantic grid.", commands, argv)


if __name__ == "__main__":
    sys.exit(main())
