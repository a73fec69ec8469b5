"""Average precision of scored person detections (DROW's evaluation: Beyer et al. 2018, Jia et al. 2020).

Every detection has a position (m) and a score. Lowering the threshold accepts detections in descending score; at
every threshold each frame's accepted detections are matched one to one to the frame's true people within the
association radius (0.3 m or 0.5 m), with as many pairs as possible (the Hungarian algorithm, as DROW's
``_prec_rec_2d``). A frame's matched count can only grow as detections are accepted, so each detection brings a
*gain*: the number of pairs it adds (0 or 1). With the detections of all frames in descending score (a stable
sort: ties keep their order), the cumulative gains are the true positives ``TP``, the rest the false positives
``FP``, and

    recall = TP / P,   precision = TP / (TP + FP)   (P: the true people of all frames)

at every distinct score. The average precision is the area under that curve as a step function,

    AP = sum_k (R_k - R_{k-1}) P_k,   R_0 = 0,

over the distinct thresholds ``k`` in descending score (scikit-learn's ``average_precision_score``). DROW takes
the trapezoid area of the same points; the two differ only by half the first step, and the step form gives a
detector without scores (every score equal: one threshold) its recall x precision rather than 0.

People the sensor cannot see (e.g. fewer than 3 returns on them) are *ignored*, not missed (as KITTI's "don't
care" labels): they are matched too, after the counted people (pairs with counted people first), and a detection
matched to an ignored person is neither a true nor a false positive; ignored people are not in ``P``.

Recall at a precision (e.g. 0.90) is the largest recall of a threshold whose precision reaches it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

__all__ = ["PrCurve", "ScoredFrame", "average_precision", "frame_gains", "pr_curve", "recall_at_precision"]


@dataclass(frozen=True, kw_only=True, eq=False)
class ScoredFrame:
    """One frame's detections and true people (positions in one frame, m).

    Attributes
    ----------
    detections : ndarray, shape (D, 2)
    scores : ndarray, shape (D,)
    truth : ndarray, shape (P, 2)
    ignore : ndarray, shape (P,), bool
        True people that count neither as found nor as missed (module docstring).
    """

    detections: NDArray[np.float64]
    scores: NDArray[np.float64]
    truth: NDArray[np.float64]
    ignore: NDArray[np.bool_]

    @classmethod
    def of(
        cls, detections: ArrayLike, scores: ArrayLike, truth: ArrayLike, ignore: ArrayLike | None = None
    ) -> ScoredFrame:
        """A frame from array-likes, checked: ``(D, 2)`` detections with ``(D,)`` finite scores, ``(P, 2)`` truth."""
        det = np.asarray(detections, dtype=float).reshape(-1, 2)
        sc = np.asarray(scores, dtype=float).reshape(-1)
        tru = np.asarray(truth, dtype=float).reshape(-1, 2)
        ign = np.zeros(len(tru), dtype=bool) if ignore is None else np.asarray(ignore, dtype=bool).reshape(-1)
        if sc.shape[0] != det.shape[0]:
            raise ValueError(f"{det.shape[0]} detections but {sc.shape[0]} scores")
        if ign.shape[0] != tru.shape[0]:
            raise ValueError(f"{tru.shape[0]} true people but {ign.shape[0]} ignore flags")
        if not (np.isfinite(det).all() and np.isfinite(sc).all() and np.isfinite(tru).all()):
            raise ValueError("detections, scores and true positions must be finite")
        return cls(detections=det, scores=sc, truth=tru, ignore=ign)


@dataclass(frozen=True, kw_only=True, eq=False)
class PrCurve:
    """A precision-recall curve at the distinct score thresholds, in descending score.

    Attributes
    ----------
    thresholds, recall, precision : ndarray, shape (T,)
    positives : int
        The counted true people ``P``.
    """

    thresholds: NDArray[np.float64]
    recall: NDArray[np.float64]
    precision: NDArray[np.float64]
    positives: int


def _matched(within: NDArray[np.bool_], ignore: NDArray[np.bool_]) -> tuple[int, int]:
    """Pairs of a maximum matching of detections (rows) to people (columns) ``within`` the radius, counted people
    first: ``(pairs with counted people, pairs with ignored people)``."""
    if not within.any():
        return 0, 0
    cost = np.where(within, np.where(ignore[None, :], 1.0, 0.0), 1e6)
    rows, cols = linear_sum_assignment(cost)
    ok = within[rows, cols]
    ign = ignore[cols[ok]]
    return int(np.count_nonzero(~ign)), int(np.count_nonzero(ign))


def frame_gains(frame: ScoredFrame, radius: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Each detection's gain of counted and of ignored pairs when it is accepted after the frame's detections of
    higher score (ties: the earlier first), shape ``(D,)`` each; the rest of its 1 is a false positive."""
    d = frame.detections.shape[0]
    tp, ig = np.zeros(d, dtype=np.int64), np.zeros(d, dtype=np.int64)
    if d == 0 or frame.truth.shape[0] == 0:
        return tp, ig
    order = np.argsort(-frame.scores, kind="mergesort")
    dist = np.linalg.norm(frame.detections[order, None, :] - frame.truth[None, :, :], axis=-1)
    within = dist <= radius
    prev = (0, 0)
    for k in range(d):
        now = _matched(within[: k + 1], frame.ignore)
        tp[order[k]], ig[order[k]] = now[0] - prev[0], now[1] - prev[1]
        prev = now
    return tp, ig


def pr_curve(frames: Iterable[ScoredFrame], radius: float) -> PrCurve:
    """The precision-recall curve of ``frames`` at association radius ``radius`` (m); see the module docstring."""
    if not radius > 0:
        raise ValueError(f"radius must be > 0 m, got {radius!r}")
    scores, tps, igs = [], [], []
    positives = 0
    for f in frames:
        tp, ig = frame_gains(f, radius)
        scores.append(f.scores)
        tps.append(tp)
        igs.append(ig)
        positives += int(np.count_nonzero(~f.ignore))
    if not scores or sum(s.size for s in scores) == 0:
        empty = np.zeros(0)
        return PrCurve(thresholds=empty, recall=empty, precision=empty, positives=positives)
    s, tp, ig = np.concatenate(scores), np.concatenate(tps), np.concatenate(igs)
    order = np.argsort(-s, kind="mergesort")
    s, tp, ig = s[order], tp[order], ig[order]
    ctp = np.cumsum(tp)
    cfp = np.cumsum(1 - tp - ig)
    last = np.r_[np.flatnonzero(np.diff(s) != 0), s.size - 1]  # the last detection of each distinct score
    ctp, cfp = ctp[last], cfp[last]
    with np.errstate(invalid="ignore", divide="ignore"):
        rec = ctp / positives if positives else np.full(ctp.shape, np.nan)
        prec = np.where(ctp + cfp > 0, ctp / np.maximum(ctp + cfp, 1), np.nan)
    return PrCurve(thresholds=s[last], recall=rec.astype(float), precision=prec.astype(float), positives=positives)


def average_precision(curve: PrCurve) -> float:
    """Step-wise area under ``curve`` (module docstring); NaN without counted true people."""
    if curve.positives == 0:
        return float("nan")
    if curve.recall.size == 0:
        return 0.0
    prec = np.nan_to_num(curve.precision, nan=0.0)
    steps = np.diff(np.r_[0.0, curve.recall])
    return float(np.sum(steps * prec))


def recall_at_precision(curve: PrCurve, precision: float = 0.9) -> float:
    """The largest recall of a threshold with precision >= ``precision`` (0 when none; NaN without true people)."""
    if curve.positives == 0:
        return float("nan")
    ok = np.nan_to_num(curve.precision, nan=0.0) >= precision
    return float(curve.recall[ok].max()) if ok.any() else 0.0
