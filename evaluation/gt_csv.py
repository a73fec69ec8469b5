"""Ground truth from a CSV file: moved to :mod:`pfpeople.gt_csv` (``pfpeople view --gt`` reads it too).

Kept here so that ``from evaluation.gt_csv import read_gt_csv`` goes on working.
"""

from pfpeople.gt_csv import *  # noqa: F403
from pfpeople.gt_csv import KEY_COLUMNS, GroundTruth, gt_to_grid, read_gt_csv, resolve_gt_frame, truth_per_frame

__all__ = ["KEY_COLUMNS", "GroundTruth", "gt_to_grid", "read_gt_csv", "resolve_gt_frame", "truth_per_frame"]
