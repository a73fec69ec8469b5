"""The tracker's measurements from a fused belief grid: the classified people plus the weaker belief peaks.

The pipeline's people are the belief peaks above the classifier's threshold (0.7). A person the grid still
holds but at a lower belief (a few detector misses) makes a weaker peak; fed to the tracker with its belief as
confidence, it updates the person's track (``TrackerConfig.birth_min_score`` = the classifier's threshold keeps
it from starting one), so the track follows the person through the dip instead of coasting on its prediction.

:func:`tracker_inputs` returns the people unchanged (same positions and scores, so ``people.csv`` and the tracker
see the same strong peaks) plus the peaks that :func:`gridbridge.classifiers.classify_peaks` with the lower
threshold would add: local maxima of the (observed) belief in ``(low, high]``. They are computed directly, not by
a second classifier pass (whose per-peak loops over every person would double the classification cost of a
frame): a weaker local maximum is never suppressed by a person's peak (non-maximum suppression reaches no farther
than the local-maximum window, so a stronger peak that close would have made it no maximum), only by an equal
weaker one (a plateau: the first in row-major order is kept); its position is the belief-weighted mean of the
cells within ``centroid_radius`` of at least half the lower threshold, its score its belief, as there. A weaker
peak whose cell lies within half ``min_separation`` of a person is that person (a classifier with hysteresis,
:class:`gridbridge.classifiers.HysteresisPeaks`, keeps people below its threshold) and is not added again.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.classifiers import PeakClassifier, People, ordered_candidates
from gridbridge.grid import GridSpec

__all__ = ["tracker_inputs"]


def tracker_inputs(
    people: People,
    belief: ArrayLike,
    spec: GridSpec,
    *,
    low: PeakClassifier,
    high: float,
    observed: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions ``(K, 2)`` (m, grid frame) and confidences ``(K,)`` for :meth:`MultiPersonTracker.update`.

    Parameters
    ----------
    people : People
        The frame's people (the peaks above ``high``).
    belief : array_like, shape (nx, ny)
        The belief grid they were classified from.
    spec : GridSpec
    low : PeakClassifier
        The classifier with the lower threshold (``low.threshold < high``); its other settings should be the
        people classifier's (only its threshold, ``min_separation``, ``centroid_radius``, ``only_observed`` and
        ``smooth`` are used: it is not run).
    high : float
        The people classifier's threshold.
    observed : array_like of bool, shape (nx, ny), optional
        Cells some detector observes (as given to the classifier).

    Returns
    -------
    positions, scores : ndarray
        The people first (unchanged), then the weaker peaks (belief in ``(low.threshold, high]``).
    """
    if not isinstance(low, PeakClassifier):
        raise TypeError(f"low must be a PeakClassifier, got {type(low).__name__}")
    if not low.threshold < high:
        raise ValueError(f"low.threshold ({low.threshold}) must be below high ({high})")
    pos = np.asarray(people.positions, dtype=float).reshape(-1, 2)
    sc = np.asarray(people.scores, dtype=float).reshape(-1)
    grid = spec.check_grid(belief, "belief")
    if low.only_observed and observed is not None:
        grid = np.where(np.asarray(observed, dtype=bool), grid, 0.0)
    # classify_peaks' candidates above the lower threshold, by decreasing belief (ties: row-major order)
    cand, values = ordered_candidates(grid, spec, low.threshold, low.min_separation, low.smooth)
    sel = values <= high
    if not sel.any():
        return pos, sc
    cand, values = cand[sel], values[sel]
    kept = _weak_maxima(cand, (low.min_separation / spec.resolution) ** 2 - 1e-9)
    if len(pos) and kept:  # a peak the people already hold (a classifier with hysteresis keeps people below high)
        kept = _not_held(cand, kept, pos, spec, 0.5 * low.min_separation)
    x, y = _centroids(grid, spec, cand[kept], low.centroid_radius, 0.5 * low.threshold)
    return np.concatenate([pos, np.column_stack((x, y))]), np.concatenate([sc, values[kept]])


def _weak_maxima(cand: NDArray[np.intp], sep2: float) -> list[int]:
    """The weaker local maxima kept by non-maximum suppression among themselves (module docstring).

    Parameters
    ----------
    cand : ndarray of int, shape (K, 2)
        The weaker maxima's cells ``(i, j)``, by decreasing belief (ties: row-major order).
    sep2 : float
        The squared suppression distance (cells^2): a maximum closer than it to a kept one is dropped.

    Returns
    -------
    list of int
        Indices into ``cand`` of the kept maxima, in increasing order (by decreasing belief).
    """
    kept: list[int] = []
    cl = cand.tolist()
    for k, (i, j) in enumerate(cl):
        if any((i - cl[m][0]) ** 2 + (j - cl[m][1]) ** 2 < sep2 for m in kept):
            continue
        kept.append(k)
    return kept


def _not_held(
    cand: NDArray[np.intp], kept: list[int], pos: NDArray[np.float64], spec: GridSpec, radius: float
) -> list[int]:
    """The kept maxima whose cell centre is ``radius`` (m) or farther from every person position ``pos`` (P, 2)
    (m, grid frame); ``cand`` (K, 2) cells, ``kept`` indices into it (order kept)."""
    kc = cand[kept]
    kx, ky = spec.cell_centre(kc[:, 0], kc[:, 1])
    d2 = (kx[:, None] - pos[None, :, 0]) ** 2 + (ky[:, None] - pos[None, :, 1]) ** 2
    near: NDArray[np.bool_] = np.any(d2 < radius**2, axis=1)
    return [k for k, n in zip(kept, near, strict=True) if not n]


def _centroids(
    grid: NDArray[np.float64], spec: GridSpec, peaks: NDArray[np.intp], radius: float, floor: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each peak's position: the belief-weighted mean of the cell centres within ``radius`` of it.

    Parameters
    ----------
    grid : ndarray, shape (nx, ny)
        The belief (zero outside the observed cells with ``only_observed``).
    spec : GridSpec
    peaks : ndarray of int, shape (K, 2)
        The peaks' cells ``(i, j)``.
    radius : float
        The centroid disk's radius (m).
    floor : float
        Cells of a lower belief are left out (half the lower threshold).

    Returns
    -------
    x, y : ndarray, shape (K,)
        The positions (m, grid frame).
    """
    r = spec.resolution
    reach = math.floor(radius / r + 1e-9)
    di, dj = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    disk = (di**2 + dj**2) * r * r <= radius**2 + 1e-12
    di, dj = di[disk], dj[disk]
    ci, cj = peaks[:, 0], peaks[:, 1]
    ii, jj = ci[:, None] + di[None, :], cj[:, None] + dj[None, :]  # (K, D) cells of each centroid disk
    ok = (ii >= 0) & (ii < spec.nx) & (jj >= 0) & (jj < spec.ny)
    w = grid[np.clip(ii, 0, spec.nx - 1), np.clip(jj, 0, spec.ny - 1)]
    w = np.where(ok & (w >= floor), w, 0.0)
    tot = w.sum(axis=1)
    return spec.cell_centre((w * ii).sum(axis=1) / tot, (w * jj).sum(axis=1) / tot)
