"""Scores of a scored person detector on labelled scans: AP, recall at a precision, PPV / FNR, false people per scan.

A *scored detector* has ``detect_scored(scan) -> (centres (M, 2), scores (M,))`` and, when it looks at past scans,
``reset()`` and ``observe_motion(pose or None)`` (the learned and the motion detector). :func:`scored_frames` runs
one over labelled scans in order, giving it each scan's ego-motion, and keeps only what the labels can judge:
detections inside the annotation's region (leg_tracker's box; everywhere else) and the people there, the people
with fewer than :data:`~pfpeople.detect.learned.samples.SEEN_RETURNS` returns ignored
(:mod:`pfpeople.detect.precision_recall`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pfpeople.detect.learned.samples import LabelledScan, motion_since_previous
from pfpeople.detect.precision_recall import (
    PrCurve,
    ScoredFrame,
    average_precision,
    frame_gains,
    pr_curve,
    recall_at_precision,
)
from pfpeople.detect.score_ppv import ScorePpv

__all__ = [
    "Counts",
    "DetectorScores",
    "calibration",
    "counts_at",
    "detector_scores",
    "operating_point",
    "ppv_by_score",
    "scored_frames",
]


def scored_frames(detector: Any, scans: Sequence[LabelledScan]) -> list[ScoredFrame]:
    """Run ``detector`` over ``scans`` (in order) and pair its detections with each scan's people (module
    docstring)."""
    frames = []
    previous: LabelledScan | None = None
    temporal = hasattr(detector, "observe_motion")
    for ls in scans:
        if temporal:
            motion = motion_since_previous(ls, previous)
            if motion is None and hasattr(detector, "reset"):
                detector.reset()
            detector.observe_motion(motion)
        previous = ls
        centres, scores = detector.detect_scored(ls.scan)
        inside = ls.region.contains(centres, ls.people)
        judged = ls.region.contains(ls.people, ls.people) if ls.region.box is not None else slice(None)
        frames.append(ScoredFrame.of(centres[inside], scores[inside], ls.people[judged], ~ls.seen[judged]))
    return frames


@dataclass(frozen=True, kw_only=True)
class DetectorScores:
    """A detector's scores on a set of frames (NaN where undefined: no true people)."""

    ap_03: float
    ap_05: float
    recall_at_p90: float
    false_per_scan: float
    frames: int


def detector_scores(frames: Sequence[ScoredFrame], *, threshold: float = -math.inf) -> DetectorScores:
    """AP at 0.3 and 0.5 m, recall at precision 0.90 (0.5 m), and the false people per frame of the detections
    scoring at least ``threshold`` (unmatched within 0.5 m, ignored people not counted)."""
    c05 = pr_curve(frames, 0.5)
    fp = _false_at(c05, frames, threshold)
    return DetectorScores(
        ap_03=average_precision(pr_curve(frames, 0.3)),
        ap_05=average_precision(c05),
        recall_at_p90=recall_at_precision(c05, 0.9),
        false_per_scan=fp / max(len(frames), 1),
        frames=len(frames),
    )


def _false_at(curve: PrCurve, frames: Sequence[ScoredFrame], threshold: float) -> float:
    """False positives of the detections scoring at least ``threshold`` (from the curve, or by counting all
    detections where no frame has true people)."""
    if curve.positives == 0:
        return float(sum(int(np.count_nonzero(f.scores >= threshold)) for f in frames))
    ok = curve.thresholds >= threshold
    if not ok.any():
        return 0.0
    k = int(np.flatnonzero(ok)[-1])
    tp = curve.recall[k] * curve.positives
    prec = curve.precision[k]
    return float(tp / prec - tp) if prec > 0 else 0.0


@dataclass(frozen=True, kw_only=True)
class Counts:
    """True and false positives of the detections at or above a threshold, and the counted true people (0.5 m)."""

    tp: float
    fp: float
    positives: int


def counts_at(frames: Sequence[ScoredFrame], threshold: float) -> Counts:
    """:class:`Counts` of ``frames`` at ``threshold``."""
    c = pr_curve(frames, 0.5)
    fp = _false_at(c, frames, threshold)
    ok = c.thresholds >= threshold
    tp = float(c.recall[np.flatnonzero(ok)[-1]] * c.positives) if (c.positives and ok.any()) else 0.0
    return Counts(tp=tp, fp=fp, positives=c.positives)


def calibration(
    scenes: Sequence[Sequence[ScoredFrame]], negatives: Sequence[ScoredFrame], threshold: float
) -> tuple[float, float]:
    """PPV and FNR at ``threshold`` as the built-in detectors' are measured (:data:`gridbridge.params.
    CALIBRATED_LASER_DETECTORS`): PPV the pooled true over all detections of the ``scenes`` (each a sequence of
    frames with people) and of the people-free ``negatives``; FNR the mean of the scenes' miss rates."""
    counts = [counts_at(f, threshold) for f in scenes]
    fp_neg = counts_at(negatives, threshold).fp if negatives else 0.0
    tp = sum(c.tp for c in counts)
    fp = sum(c.fp for c in counts) + fp_neg
    ppv = tp / (tp + fp) if tp + fp > 0 else float("nan")
    misses = [1.0 - c.tp / c.positives for c in counts if c.positives]
    return ppv, float(np.mean(misses)) if misses else float("nan")


def operating_point(frames: Sequence[ScoredFrame], precision: float) -> tuple[float, float, float]:
    """The lowest score threshold whose precision on ``frames`` (0.5 m) is at least ``precision``, with the
    precision (PPV) and the miss rate (FNR = 1 - recall) there: ``(threshold, ppv, fnr)``. When no threshold
    reaches ``precision``, the one of highest precision."""
    c = pr_curve(frames, 0.5)
    if c.thresholds.size == 0:
        raise ValueError("no detections to choose an operating threshold from")
    prec = np.nan_to_num(c.precision, nan=0.0)
    ok = np.flatnonzero(prec >= precision)
    k = int(ok[-1]) if ok.size else int(np.argmax(prec))
    return float(c.thresholds[k]), float(prec[k]), float(1.0 - c.recall[k])


def ppv_by_score(
    scenes: Sequence[Sequence[ScoredFrame]], negatives: Sequence[ScoredFrame], *, min_count: int = 200
) -> ScorePpv | None:
    """``PPV(score)`` (:class:`pfpeople.detect.score_ppv.ScorePpv`) of every detection of the ``scenes`` and the
    people-free ``negatives``: true when matched to a counted person within 0.5 m (one-to-one, in descending score),
    false when unmatched; a detection matched to an ignored person is left out, as in the PPV of
    :func:`calibration`, whose pooled value this step function averages to over the detections at its threshold.
    None with fewer than ``min_count`` such detections (too few to measure a curve)."""
    scores, true = [], []
    for frame in [f for frames in scenes for f in frames] + list(negatives):
        tp, ig = frame_gains(frame, 0.5)
        judged = ig == 0
        scores.append(frame.scores[judged])
        true.append(tp[judged])
    s, y = np.concatenate(scores), np.concatenate(true)
    return ScorePpv.fit(s, y, min_count=min_count) if s.size >= min_count else None
