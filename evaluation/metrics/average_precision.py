"""Average precision of scored person detections: :mod:`pfpeople.detect.precision_recall` (the learned detector's
training scores its held-out folds with it), re-exported for the benchmark."""

from pfpeople.detect.precision_recall import (
    PrCurve,
    ScoredFrame,
    average_precision,
    frame_gains,
    pr_curve,
    recall_at_precision,
)

__all__ = ["PrCurve", "ScoredFrame", "average_precision", "frame_gains", "pr_curve", "recall_at_precision"]
