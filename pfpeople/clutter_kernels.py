"""Compiled free-space tracing and evidence update of :class:`pfpeople.clutter.StaticClutterMap` (numba; see
:mod:`gridbridge.jit`, scope ``"pfpeople"``).

:func:`update_evidence` does what the numpy code of ``StaticClutterMap.update`` does after the scan's cells are
known (the free cells along the traced rays, the people's cells, the protection of the cells beside a return,
the relaxation towards unknown, the hits and the free decrements), in one pass over the samples and one over the
map, with the same floating-point operations, so the two give the same evidence bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from gridbridge.jit import jit as njit
from gridbridge.kernels import pairwise_sum

__all__ = ["ball_means", "update_evidence", "warm_up"]


@njit
def update_evidence(
    s: NDArray[np.float64],
    n: int,
    hit_cells: NDArray[np.intp],
    human_cells: NDArray[np.intp],
    ru: NDArray[np.float64],
    n_free: NDArray[np.intp],
    steps: NDArray[np.float64],
    origin: NDArray[np.float64],
    neighbours: NDArray[np.intp],
    params: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    """Update the flat evidence ``s`` (n * n,) of one scan in place.

    Parameters
    ----------
    s : ndarray, shape (n * n,)
        Evidence (s) per cell, flat index ``i * n + j``.
    n : int
        Cells per side of the window.
    hit_cells, human_cells : ndarray of intp
        Flat cells of the returns inside the window away from people (hits) and near them (traced free).
    ru : ndarray, shape (R, 2)
        Unit direction of every traced ray in the map frame, divided by the resolution (cells per m).
    n_free : ndarray of intp, shape (R,)
        Samples traced along each ray (the first ``n_free[r]`` of ``steps``).
    steps : ndarray, shape (K,)
        Sample distances along a ray (m).
    origin : ndarray, shape (2,)
        The sensor's position in cells from the window's corner.
    neighbours : ndarray of intp
        Flat offsets of the cells protected beside a hit (the hit's own cell included).
    params : ndarray, shape (6,)
        ``(unknown_evidence, decay, dt, s_max, free decrement, s_min)``: ``s`` relaxes to
        ``(s - unknown) * decay + unknown``, hits gain ``dt`` up to ``s_max``, free cells lose the decrement down
        to ``s_min``.
    """
    free, hit = _marks(n, hit_cells, human_cells, ru, n_free, steps, origin, neighbours)
    s0, decay, dt, s_max, dec, s_min = params[0], params[1], params[2], params[3], params[4], params[5]
    for i in range(n * n):
        v = s[i] - s0
        v = v * decay
        v = v + s0
        if hit[i]:
            v = v + dt
            v = v if v <= s_max else s_max
        if free[i]:
            v = v - dec
            v = v if v >= s_min else s_min
        s[i] = v


@njit
def _marks(
    n: int,
    hit_cells: NDArray[np.intp],
    human_cells: NDArray[np.intp],
    ru: NDArray[np.float64],
    n_free: NDArray[np.intp],
    steps: NDArray[np.float64],
    origin: NDArray[np.float64],
    neighbours: NDArray[np.intp],
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:  # pragma: no cover - compiled
    """The free and the hit cells of one scan, flat (n * n,) each (the arguments are :func:`update_evidence`'s):
    free along the traced rays and at the people's returns, not beside a hit (``neighbours``)."""
    ncell = n * n
    free = np.zeros(ncell, dtype=np.bool_)
    for b in range(n_free.size):
        for k in range(n_free[b]):
            fi = math.floor(ru[b, 0] * steps[k] + origin[0])
            fj = math.floor(ru[b, 1] * steps[k] + origin[1])
            if fi >= 0 and fi < n and fj >= 0 and fj < n:
                free[fi * n + fj] = True
    for c in human_cells:
        free[c] = True
    hit = np.zeros(ncell, dtype=np.bool_)
    for c in hit_cells:
        hit[c] = True
        for off in neighbours:
            free[(c + off) % ncell] = False
    return free, hit


@njit
def ball_means(
    xy: NDArray[np.float64], score: NDArray[np.float64], pos: NDArray[np.float64], radius: float
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """Mean ``score`` of the points ``xy`` within ``radius`` of each position, as
    ``score[cKDTree(xy).query_ball_point(pos, radius)].mean()`` (0 where none).

    Parameters
    ----------
    xy : ndarray, shape (H, 2)
        Points (m).
    score : ndarray, shape (H,)
        Their scores.
    pos : ndarray, shape (M, 2)
        Query positions (m, the frame of ``xy``).
    radius : float
        Query radius (m): a point counts when ``dx * dx + dy * dy <= radius * radius`` (the k-d tree's test).

    Returns
    -------
    ndarray, shape (M,)
        The means: the points in index order (the tree's sorted answer) summed as numpy's mean does
        (:func:`gridbridge.kernels.pairwise_sum`), divided by their number.
    """
    r2 = radius * radius
    out = np.zeros(pos.shape[0])
    buf = np.empty(xy.shape[0])
    for m in range(pos.shape[0]):
        k = 0
        for i in range(xy.shape[0]):
            dx = xy[i, 0] - pos[m, 0]
            dy = xy[i, 1] - pos[m, 1]
            if dx * dx + dy * dy <= r2:
                buf[k] = score[i]
                k += 1
        if k:
            out[m] = pairwise_sum(buf, 0, k) / k
    return out


def warm_up() -> None:
    """Load (or compile) :func:`update_evidence` and :func:`ball_means` now, so the first scan of a run does not
    wait for them (nothing happens when ``gridbridge.jit.enabled("pfpeople")`` is False)."""
    if not _jit.enabled("pfpeople"):
        return
    no = np.zeros(0, dtype=np.intp)
    params = np.array([1.0, 1.0, 0.1, 20.0, 0.05, -1.0])
    ev = np.zeros(4)
    update_evidence(ev, 2, no, no, np.zeros((1, 2)), np.ones(1, dtype=np.intp), np.ones(1), np.zeros(2), no, params)
    ball_means(np.zeros((1, 2)), np.ones(1), np.zeros((1, 2)), 0.1)
