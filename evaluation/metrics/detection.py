"""Metrics of people detection on the grid, of belief grids, and of tracking.

Batista & Pereira (2015), Sect. 4 and Table 2 define the detection metrics:

- **recall** = TP / (TP + FN): correct detections over the real number of persons;
- **precision** (PPV) = TP / (TP + FP): correct detections over all detections;
- **FPCPF**, false-positive cells per frame: the average over frames of the number of cells classified as
  people that are free in the ground truth.

The paper compares its classification "with the image ground truth projected on the grid" without saying
how a detection is matched to a person. Here a detection is *correct* when it is matched one-to-one to a true
person (:func:`match_people`):

- ``rule="distance"`` (default): pairs closer than ``gate`` metres (inclusive, default 0.5 m) can match; a
  maximum-cardinality, minimum-total-distance assignment (:func:`scipy.optimize.linear_sum_assignment` with
  out-of-gate pairs priced above any sum of in-gate distances) decides which;
- ``rule="overlap"``: a detection's cell mask and a person's cell mask must share at least one cell; the
  assignment maximises the number of matches, then the total number of shared cells.

Unmatched detections are FP, unmatched persons FN. ``recall`` and ``precision`` of zero counts (0/0) return
NaN, meaning "undefined: there was nobody to find" (recall) or "nothing was reported" (precision).

Grid scores compare a belief grid with the true occupancy (bool grid), optionally over a mask (e.g. the
field of view): Brier score (mean squared error), log-loss (mean negative log-likelihood, probability of
the true class clipped to ``[eps, 1 - eps]``, ``eps = 1e-12`` by default) and ROC AUC (the probability that
a random occupied cell scores higher than a random free cell, ties counting 1/2 -- the Mann-Whitney form,
equal to scikit-learn's ``roc_auc_score``; NaN when only one class is present).

Tracking helpers (:func:`tracking_summary`) take per-frame arrays from the tracking application
(:mod:`pfpeople.track.blob_tracker`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment
from scipy.stats import rankdata

from gridbridge.validation import check_positions, check_positive

__all__ = [
    "DetectionAccumulator",
    "Match",
    "assign_one_to_one",
    "brier_score",
    "false_positive_cells",
    "fpcpf",
    "log_loss",
    "match_people",
    "precision",
    "recall",
    "roc_auc",
    "tracking_summary",
]

DEFAULT_EPS = 1e-12


def _masks(value: ArrayLike | None, name: str, n: int) -> NDArray[np.bool_]:
    if value is None:
        raise ValueError(f"{name} is required for rule='overlap'")
    arr = np.asarray(value)
    if arr.dtype != bool:
        raise ValueError(f"{name} must be a bool array (N, nx, ny), got dtype {arr.dtype}")
    if arr.ndim != 3 or arr.shape[0] != n:
        raise ValueError(f"{name} must have shape ({n}, nx, ny), got {arr.shape}")
    return arr


@dataclass(frozen=True, eq=False)
class Match:
    """One frame's one-to-one matching of detections to true persons.

    Attributes
    ----------
    tp, fp, fn : int
        True positives (matched pairs), false positives (unmatched detections), false negatives
        (unmatched persons).
    pairs : ndarray, shape (tp, 2), int
        ``(detection index, person index)`` of each matched pair.
    distances : ndarray, shape (tp,)
        Distance (m) between the positions of each matched pair (with ``rule='overlap'`` too).
    """

    tp: int
    fp: int
    fn: int
    pairs: NDArray[np.intp]
    distances: NDArray[np.float64]


def match_people(
    detected: ArrayLike,
    truth: ArrayLike,
    *,
    gate: float = 0.5,
    rule: Literal["distance", "overlap"] = "distance",
    detected_masks: ArrayLike | None = None,
    truth_masks: ArrayLike | None = None,
) -> Match:
    """Match classified people to true persons one-to-one and count TP, FP, FN.

    Parameters
    ----------
    detected : array_like, shape (K, 2)
        Classified people positions (m, sensor frame).
    truth : array_like, shape (P, 2)
        True person positions (m, same frame).
    gate : float
        Largest distance (m, inclusive) for a match under ``rule='distance'``.
    rule : {'distance', 'overlap'}
        Matching rule (module docstring).
    detected_masks : array_like of bool, shape (K, nx, ny), optional
        Cells of each detection; required for ``rule='overlap'``.
    truth_masks : array_like of bool, shape (P, nx, ny), optional
        Cells of each person; required for ``rule='overlap'``.

    Returns
    -------
    Match
    """
    det = check_positions(detected, "detected")
    tru = check_positions(truth, "truth")
    k, p = det.shape[0], tru.shape[0]
    if rule not in ("distance", "overlap"):
        raise ValueError(f"rule must be 'distance' or 'overlap', got {rule!r}")
    check_positive(gate, "gate", allow_zero=True)
    dist = np.linalg.norm(det[:, None, :] - tru[None, :, :], axis=-1) if k and p else np.zeros((k, p))
    if rule == "distance":
        feasible = dist <= gate
        score = dist
    else:
        dm = _masks(detected_masks, "detected_masks", k)
        tm = _masks(truth_masks, "truth_masks", p)
        if k and p and dm.shape[1:] != tm.shape[1:]:
            raise ValueError(f"detected_masks grid {dm.shape[1:]} differs from truth_masks grid {tm.shape[1:]}")
        overlap = np.einsum("kij,pij->kp", dm.astype(np.int64), tm.astype(np.int64)) if k and p else dist
        feasible = overlap > 0
        score = -overlap.astype(float)
    rows, cols = assign_one_to_one(score, feasible)
    pairs = np.stack([rows, cols], axis=1)
    tp = int(rows.size)
    return Match(tp=tp, fp=k - tp, fn=p - tp, pairs=pairs, distances=dist[rows, cols])


def assign_one_to_one(
    score: NDArray[np.float64], feasible: NDArray[np.bool_]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """One-to-one assignment of rows to columns among ``feasible`` pairs (Hungarian algorithm).

    Maximises the number of pairs first, then minimises the total ``score`` of the pairs
    (:func:`scipy.optimize.linear_sum_assignment` with infeasible pairs priced above any total of feasible ones).

    Parameters
    ----------
    score : ndarray, shape (K, P)
        Cost of each pair (e.g. a distance); only feasible entries are used.
    feasible : ndarray of bool, shape (K, P)
        Which pairs may be matched.

    Returns
    -------
    rows, cols : ndarray of int, shape (T,)
        The matched pairs, in increasing row order.
    """
    empty = np.zeros(0, dtype=np.intp)
    if not feasible.any():
        return empty, empty
    span = float(np.abs(score[feasible]).sum()) + 1.0
    cost = np.where(feasible, score, 2.0 * span * (1 + min(feasible.shape)))
    rows, cols = linear_sum_assignment(cost)
    keep = feasible[rows, cols]
    return rows[keep].astype(np.intp), cols[keep].astype(np.intp)


def recall(tp: int, fn: int) -> float:
    """TP / (TP + FN); NaN when there was nobody to find (0/0)."""
    _counts(tp=tp, fn=fn)
    return float("nan") if tp + fn == 0 else tp / (tp + fn)


def precision(tp: int, fp: int) -> float:
    """TP / (TP + FP); NaN when nothing was reported (0/0)."""
    _counts(tp=tp, fp=fp)
    return float("nan") if tp + fp == 0 else tp / (tp + fp)


def _counts(**counts: int) -> None:
    for name, value in counts.items():
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
            raise ValueError(f"{name} must be a non-negative integer count, got {value!r}")


def _bool_grids(value: ArrayLike, name: str) -> NDArray[np.bool_]:
    arr = np.asarray(value)
    if arr.dtype != bool:
        raise ValueError(f"{name} must be a bool array, got dtype {arr.dtype}")
    if arr.ndim not in (2, 3):
        raise ValueError(f"{name} must be one (nx, ny) grid or a stack (F, nx, ny), got shape {arr.shape}")
    return arr


def false_positive_cells(classified: ArrayLike, truth: ArrayLike) -> int:
    """Number of cells classified as people that are free in the ground truth (one frame).

    Parameters
    ----------
    classified : array_like of bool, shape (nx, ny)
        Cells classified as people.
    truth : array_like of bool, shape (nx, ny)
        True occupancy by people.
    """
    c = _bool_grids(classified, "classified")
    t = _bool_grids(truth, "truth")
    if c.ndim != 2 or c.shape != t.shape:
        raise ValueError(f"classified {c.shape} and truth {t.shape} must be (nx, ny) grids of the same shape")
    return int(np.count_nonzero(c & ~t))


def fpcpf(classified: ArrayLike, truth: ArrayLike) -> float:
    """False-positive cells per frame (paper, Table 2): mean over frames of :func:`false_positive_cells`.

    Parameters
    ----------
    classified, truth : array_like of bool, shape (F, nx, ny)
        Per frame: cells classified as people; true occupancy.

    Raises
    ------
    ValueError
        On shape mismatch or no frames (F = 0).
    """
    c = _bool_grids(classified, "classified")
    t = _bool_grids(truth, "truth")
    if c.ndim != 3 or c.shape != t.shape:
        raise ValueError(f"classified {c.shape} and truth {t.shape} must be (F, nx, ny) stacks of the same shape")
    if c.shape[0] == 0:
        raise ValueError("classified holds no frames (F = 0)")
    return float(np.count_nonzero(c & ~t, axis=(1, 2)).mean())


def _scores(
    belief: ArrayLike, truth: ArrayLike, mask: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    b = np.asarray(belief, dtype=float)
    t = np.asarray(truth)
    if t.dtype != bool:
        raise ValueError(f"truth must be a bool occupancy array, got dtype {t.dtype}")
    if b.shape != t.shape:
        raise ValueError(f"belief {b.shape} and truth {t.shape} must have the same shape")
    if not np.all(np.isfinite(b)) or (b.size and (b.min() < 0 or b.max() > 1)):
        raise ValueError("belief must hold finite probabilities in [0, 1]")
    if mask is not None:
        m = np.asarray(mask)
        if m.dtype != bool or m.shape != b.shape:
            raise ValueError(f"mask must be a bool array of shape {b.shape}, got {m.dtype} {m.shape}")
        b, t = b[m], t[m]
    b, t = b.ravel(), t.ravel()
    if b.size == 0:
        raise ValueError("no cells to score (empty belief or mask)")
    return b, t


def brier_score(belief: ArrayLike, truth: ArrayLike, *, mask: ArrayLike | None = None) -> float:
    """Brier score: mean over cells of ``(belief - truth)^2`` (0 best, 1 worst).

    Parameters
    ----------
    belief : array_like, shape (...)
        Probability of a person per cell (e.g. ``(nx, ny)`` or ``(F, nx, ny)``).
    truth : array_like of bool, same shape
        True occupancy.
    mask : array_like of bool, same shape, optional
        Only these cells are scored (e.g. the field of view).
    """
    b, t = _scores(belief, truth, mask)
    return float(np.mean((b - t) ** 2))


def log_loss(belief: ArrayLike, truth: ArrayLike, *, mask: ArrayLike | None = None, eps: float = DEFAULT_EPS) -> float:
    """Mean negative log-likelihood (nats) of the truth under the belief.

    The probability given to each cell's true class is clipped to ``[eps, 1 - eps]`` (so a confident miss
    costs ``-log(eps)``, 27.6 nats for the default 1e-12).

    Parameters as :func:`brier_score`; ``eps`` in (0, 0.5).
    """
    if not (0.0 < eps < 0.5):
        raise ValueError(f"eps must be in (0, 0.5), got {eps!r}")
    b, t = _scores(belief, truth, mask)
    return float(np.mean(_nll(b, t, eps)))


def _nll(b: NDArray[np.float64], t: NDArray[np.bool_], eps: float) -> NDArray[np.float64]:
    """Per-cell negative log-likelihood; the probability of the true class is clipped to [eps, 1 - eps]."""
    p_true = np.clip(np.where(t, b, 1.0 - b), eps, 1.0 - eps)
    return -np.log(p_true)


def roc_auc(belief: ArrayLike, truth: ArrayLike, *, mask: ArrayLike | None = None) -> float:
    """Area under the ROC curve of the belief as a score for occupancy (rank-based, ties count 1/2).

    ``AUC = (R_pos - n_pos (n_pos + 1) / 2) / (n_pos n_neg)`` with ``R_pos`` the sum of the mid-ranks of the
    occupied cells; equal to scikit-learn's ``roc_auc_score``. Returns NaN when all scored cells are of one
    class (AUC undefined). Parameters as :func:`brier_score`.
    """
    b, t = _scores(belief, truth, mask)
    n_pos = int(t.sum())
    n_neg = int(t.size - n_pos)
    if n_pos == 0 or n_neg == 0:
        return float("nan")
    ranks = rankdata(b)  # average ranks for ties
    r_pos = float(ranks[t].sum())
    return (r_pos - n_pos * (n_pos + 1) / 2.0) / (n_pos * n_neg)


class DetectionAccumulator:
    """Running totals of detection and grid metrics over frames; :meth:`summary` gives the dict.

    Parameters
    ----------
    gate : float
        Matching distance (m) for :func:`match_people`.
    rule : {'distance', 'overlap'}
        Matching rule.
    eps : float
        Log-loss clipping.
    """

    def __init__(
        self,
        *,
        gate: float = 0.5,
        rule: Literal["distance", "overlap"] = "distance",
        eps: float = DEFAULT_EPS,
    ):
        if rule not in ("distance", "overlap"):
            raise ValueError(f"rule must be 'distance' or 'overlap', got {rule!r}")
        check_positive(gate, "gate", allow_zero=True)
        if not (0.0 < eps < 0.5):
            raise ValueError(f"eps must be in (0, 0.5), got {eps!r}")
        self.gate = gate
        self.rule: Literal["distance", "overlap"] = rule
        self.eps = eps
        self.frames = 0
        self.tp = 0
        self.fp = 0
        self.fn = 0
        self.error_sum = 0.0
        self.fp_cells = 0
        self.fp_cell_frames = 0
        self.cells_scored = 0
        self.brier_sum = 0.0
        self.log_loss_sum = 0.0
        self._pos_scores: list[NDArray[np.float64]] = []
        self._neg_scores: list[NDArray[np.float64]] = []

    def add(
        self,
        detected: ArrayLike,
        truth: ArrayLike,
        *,
        detected_masks: ArrayLike | None = None,
        truth_masks: ArrayLike | None = None,
        classified: ArrayLike | None = None,
        occupancy: ArrayLike | None = None,
        belief: ArrayLike | None = None,
        mask: ArrayLike | None = None,
    ) -> Match:
        """Add one frame.

        Parameters
        ----------
        detected, truth, detected_masks, truth_masks
            As :func:`match_people`.
        classified : array_like of bool, shape (nx, ny), optional
            Cells classified as people (for FPCPF; requires ``occupancy``).
        occupancy : array_like of bool, shape (nx, ny), optional
            True occupancy (for FPCPF and the grid scores).
        belief : array_like, shape (nx, ny), optional
            Belief grid (for Brier, log-loss and AUC; requires ``occupancy``).
        mask : array_like of bool, shape (nx, ny), optional
            Cells to score the belief on.

        Returns
        -------
        Match
            The frame's matching.
        """
        match = match_people(
            detected,
            truth,
            gate=self.gate,
            rule=self.rule,
            detected_masks=detected_masks,
            truth_masks=truth_masks,
        )
        fp_cells: int | None = None
        if classified is not None:
            if occupancy is None:
                raise ValueError("occupancy is required with classified")
            fp_cells = false_positive_cells(classified, occupancy)
        if belief is not None:
            if occupancy is None:
                raise ValueError("occupancy is required with belief")
            b, t = _scores(belief, occupancy, mask)
        # All checks passed: update the totals.
        self.frames += 1
        self.tp += match.tp
        self.fp += match.fp
        self.fn += match.fn
        self.error_sum += float(match.distances.sum())
        if fp_cells is not None:
            self.fp_cells += fp_cells
            self.fp_cell_frames += 1
        if belief is not None:
            self.cells_scored += b.size
            self.brier_sum += float(np.sum((b - t) ** 2))
            self.log_loss_sum += float(np.sum(_nll(b, t, self.eps)))
            self._pos_scores.append(b[t])
            self._neg_scores.append(b[~t])
        return match

    def summary(self) -> dict[str, Any]:
        """Totals and metrics so far: frames, tp, fp, fn, recall, precision, mean matched distance (m),
        fpcpf, brier, log_loss, auc (NaN where undefined)."""
        nan = float("nan")
        out: dict[str, Any] = {
            "frames": self.frames,
            "tp": self.tp,
            "fp": self.fp,
            "fn": self.fn,
            "recall": recall(self.tp, self.fn),
            "precision": precision(self.tp, self.fp),
            "mean_match_distance_m": self.error_sum / self.tp if self.tp and self.rule == "distance" else nan,
            "fpcpf": self.fp_cells / self.fp_cell_frames if self.fp_cell_frames else nan,
            "cells_scored": self.cells_scored,
            "brier": self.brier_sum / self.cells_scored if self.cells_scored else nan,
            "log_loss": self.log_loss_sum / self.cells_scored if self.cells_scored else nan,
        }
        if self.cells_scored:
            pos = np.concatenate(self._pos_scores)
            neg = np.concatenate(self._neg_scores)
            scores = np.concatenate([pos, neg])
            labels = np.concatenate([np.ones(pos.size, bool), np.zeros(neg.size, bool)])
            out["auc"] = roc_auc(scores, labels)
        else:
            out["auc"] = nan
        return out


def tracking_summary(
    tracked: ArrayLike,
    centroids: ArrayLike,
    truth: ArrayLike,
    *,
    all_missed: ArrayLike | None = None,
    gate: float = 0.5,
) -> dict[str, float | int]:
    """Summary of a tracking run against the true positions of the tracked person.

    Parameters
    ----------
    tracked : array_like of bool, shape (F,)
        Whether the tracker had a blob for the person in each frame.
    centroids : array_like, shape (F, 2)
        Tracked centroid (m, sensor frame); ignored (may be NaN) where not tracked.
    truth : array_like, shape (F, 2)
        True position of the person (m, sensor frame); NaN rows where the person is not in the grid
        (those frames are left out of every figure).
    all_missed : array_like of bool, shape (F,), optional
        Frames where every detector missed the person.
    gate : float
        A tracked frame is *correct* when its error is at most ``gate`` (m).

    Returns
    -------
    dict
        ``frames`` (with the person present), ``tracked_fraction``, ``correct_fraction`` (tracked and within
        the gate), ``mean_error_m``, ``median_error_m``, ``max_error_m`` (over tracked frames),
        ``all_missed_frames`` and ``held_while_all_missed`` (tracked and correct in those frames).
    """
    check_positive(gate, "gate", allow_zero=True)
    tr = np.asarray(tracked)
    if tr.dtype != bool or tr.ndim != 1:
        raise ValueError(f"tracked must be a 1-D bool array, got {tr.dtype} {tr.shape}")
    n = tr.shape[0]
    c = np.asarray(centroids, dtype=float)
    t = np.asarray(truth, dtype=float)
    if c.shape != (n, 2):
        raise ValueError(f"centroids must have shape ({n}, 2), got {c.shape}")
    if t.shape != (n, 2):
        raise ValueError(f"truth must have shape ({n}, 2), got {t.shape}")
    if np.any(tr & ~np.all(np.isfinite(c), axis=1)):
        raise ValueError("centroids must be finite in tracked frames")
    present = np.all(np.isfinite(t), axis=1)
    if all_missed is None:
        missed = np.zeros(n, dtype=bool)
    else:
        missed = np.asarray(all_missed)
        if missed.dtype != bool or missed.shape != (n,):
            raise ValueError(f"all_missed must be a bool array of shape ({n},), got {missed.dtype} {missed.shape}")
    err = np.full(n, np.nan)
    ok = tr & present
    err[ok] = np.linalg.norm(c[ok] - t[ok], axis=1)
    correct = ok & (err <= gate)
    nan = float("nan")
    n_present = int(present.sum())
    errs = err[ok]
    return {
        "frames": n_present,
        "tracked_fraction": float(ok.sum()) / n_present if n_present else nan,
        "correct_fraction": float(correct.sum()) / n_present if n_present else nan,
        "mean_error_m": float(errs.mean()) if errs.size else nan,
        "median_error_m": float(np.median(errs)) if errs.size else nan,
        "max_error_m": float(errs.max()) if errs.size else nan,
        "all_missed_frames": int((missed & present).sum()),
        "held_while_all_missed": int((missed & correct).sum()),
    }
