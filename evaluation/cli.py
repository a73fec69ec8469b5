"""The ``pfpeople-eval`` command: scenarios, scoring, calibration, A/B evaluation, benchmarks."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from evaluation import commands
from pfpeople.cli.support import run


def main(argv: Sequence[str] | None = None) -> int:
    return run("pfpeople-eval", "Evaluate people-detector fusion against ground truth.", commands, argv)


if __name__ == "__main__":
    sys.exit(main())
