"""Compiled kernels of the grid-filter step (:mod:`gridbridge.jit`), each with its numpy twin elsewhere.

=====================  ===========================================  ==========================================
kernel                 numpy twin                                   agreement
(``tests/gridbridge/test_kernels_grid.py``)
=====================  ===========================================  ==========================================
:func:`predict_paper`  :func:`gridbridge.people_motion._predict_paper`  bit for bit (same sums, same order)
:func:`convolve_const` ``scipy.ndimage.convolve(mode="constant")``  1e-12 (scipy sums the taps in its order)
:func:`warp_bilinear`  :func:`gridbridge.ego_motion.warp_belief`     1e-12 (scipy's spline weights, BLAS sum)
:func:`warp_outside`   :func:`warp_bilinear` of a zero belief       bit for bit (the cells it skips add +0.0)
:func:`warp_at`        :func:`warp_bilinear` at some cells          bit for bit (the same sums, only there)
:func:`warp_taps`      the cells :func:`warp_at` reads               exact (the same coordinates and indices)
:func:`convolve_at`    :func:`convolve_const` at some cells          bit for bit (the same sums, only there)
:func:`peak_candidates` :func:`gridbridge.classifiers.peak_maxima`   exact (maxima and comparisons only)
:func:`peak_centroids` :func:`gridbridge.classifiers._peak_people`   bit for bit (numpy's pairwise sums)
:func:`fuse_update`    :func:`gridbridge.measurement.fuse_detectors`  bit for bit (products in detector order)
:func:`bayes_update`   :func:`gridbridge.measurement.bayes_update_unchecked`  bit for bit (the same operations)
:func:`all_probabilities`  :func:`gridbridge.validation.check_grid_array`'s  the same answer (``0 <= v <= 1``);
                       value check                                  the ``*_checked`` kernels run it first
:func:`appear`         :meth:`gridbridge.components.Appearance.apply`  bit for bit (the same operations)
:func:`point_map`      :func:`gridbridge.measurement.detection_map`  bit for bit
:func:`gaussian_args`  :func:`gridbridge.measurement.detection_map`  bit for bit (with numpy's ``exp`` between
                       and :func:`scatter_max`                      the two kernels)
=====================  ===========================================  ==========================================

:func:`independent_terms` and :func:`add_where` are the terms of
:class:`gridbridge.likelihoods.IndependentLikelihood` (its numpy path the twin), bit for bit with numpy's ``log``
between them and its ``exp`` after.

:func:`pairwise_sum` is numpy's pairwise summation (the order of ``np.add.reduce`` and ``np.add.reduceat``)
for kernels elsewhere that must add as numpy does (:mod:`pfpeople.detect.segment_kernels`).

Grids are ``(nx, ny)`` float64 arrays; ``grid = (x0, y0, resolution)`` (m) places cell ``[i, j]``'s centre at
``(x0 + (i + 0.5) r, y0 + (j + 0.5) r)`` in the sensor frame.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit

__all__ = [
    "add_where",
    "all_probabilities",
    "appear",
    "bayes_update",
    "bayes_update_checked",
    "convolve_at",
    "convolve_const",
    "fuse_update",
    "gaussian_args",
    "independent_terms",
    "pairwise_sum",
    "peak_candidates",
    "peak_centroids",
    "point_map",
    "predict_paper",
    "predict_people_checked",
    "scatter_max",
    "warp_at",
    "warp_bilinear",
    "warp_bilinear_checked",
    "warp_outside",
    "warp_taps",
]


@jit
def _padded(bel: NDArray[np.float64], rad: int, outside: float) -> NDArray[np.float64]:
    nx, ny = bel.shape
    out = np.full((nx + 2 * rad, ny + 2 * rad), outside)
    out[rad : rad + nx, rad : rad + ny] = bel
    return out


@jit
def _tap_values(kernel: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """The distinct off-centre nonzero values of a kernel and, per tap, the index of its value (-1: no tap)."""
    side = kernel.shape[0]
    rad = side // 2
    values = np.zeros(side * side)
    n_values = 0
    slot = np.full((side, side), -1, dtype=np.intp)
    for a in range(side):
        for b in range(side):
            k = kernel[a, b]
            if k == 0.0 or (a == rad and b == rad):
                continue
            for v in range(n_values):
                if values[v] == k:
                    slot[a, b] = v
            if slot[a, b] < 0:
                values[n_values] = k
                slot[a, b] = n_values
                n_values += 1
    return values[:n_values], slot


@jit
def predict_paper(bel: NDArray[np.float64], kernel: NDArray[np.float64], outside: float) -> NDArray[np.float64]:
    """The paper's people prediction, eq. 6 with eq. 8: ``bel' = p_stay bel + P_col (1 - bel)``.

    Parameters
    ----------
    bel : ndarray, shape (nx, ny)
        bel(x_{t-1}).
    kernel : ndarray, shape (2R + 1, 2R + 1)
        The paper kernel (centre: p_stationary; off-centre entries below 1).
    outside : float
        Belief beyond the border.

    Returns
    -------
    ndarray, shape (nx, ny)
        ``P_col = S / (1 + S)``, ``S = sum_k q_k / (1 - q_k)``, ``q_k = p_k bel_k`` over the off-centre nonzero
        taps in row-major order (the numpy code's order, tap by tap over the whole grid).

    Notes
    -----
    ``q / (1 - q)`` depends only on the tap's value and the source cell's belief, and the kernel is radially
    symmetric, so it is computed once per distinct tap value over the padded grid (8 values for the paper's
    37 taps) and each tap adds its shifted copy (:func:`_odds_sum_by_value`): the same numbers added in the same
    order, without a division per tap and cell. A kernel whose distinct values would need more than
    ``max(2**22, 16 nx ny)`` such numbers (at most ``(R + 1)(R + 2) / 2`` values: a step of several seconds) has its
    division made per tap and cell instead (:func:`_odds_sum_by_tap`): the same numbers, in memory of the grid's
    size, where the table of values would take gigabytes (1.4 GB for a 3 s step on the paper's grid).
    """
    nx, ny = bel.shape
    side = kernel.shape[0]
    rad = side // 2
    padded = _padded(bel, rad, outside)
    px, py = padded.shape
    if (rad + 1) * (rad + 2) // 2 * px * py <= max(2**22, 16 * nx * ny):
        s = _odds_sum_by_value(padded, kernel, nx, ny)
    else:
        s = _odds_sum_by_tap(padded, kernel, nx, ny)
    p_stay = kernel[rad, rad]
    out = np.empty((nx, ny))
    for i in range(nx):
        for j in range(ny):
            p_col = s[i, j] / (1.0 + s[i, j])
            out[i, j] = p_stay * bel[i, j] + p_col * (1.0 - bel[i, j])
    return out


@jit
def _odds_sum_by_value(
    padded: NDArray[np.float64], kernel: NDArray[np.float64], nx: int, ny: int
) -> NDArray[np.float64]:
    """``S`` of :func:`predict_paper` from ``q / (1 - q)`` computed once per distinct tap value and padded cell."""
    side = kernel.shape[0]
    rad = side // 2
    px, py = padded.shape
    values, slot = _tap_values(kernel)
    n_values = values.size
    odds = np.empty((n_values, px, py))  # q / (1 - q) of every padded cell, per tap value
    for v in range(n_values):
        k = values[v]
        for i in range(px):
            for j in range(py):
                q = k * padded[i, j]
                odds[v, i, j] = q / (1.0 - q)
    s = np.zeros((nx, ny))
    for a in range(side):
        for b in range(side):
            if slot[a, b] < 0:
                continue
            src = odds[slot[a, b]]
            for i in range(nx):
                row, srow = s[i], src[2 * rad - a + i]
                for j in range(ny):
                    row[j] += srow[2 * rad - b + j]
    return s


@jit
def _odds_sum_by_tap(padded: NDArray[np.float64], kernel: NDArray[np.float64], nx: int, ny: int) -> NDArray[np.float64]:
    """``S`` of :func:`predict_paper` with ``q / (1 - q)`` computed per tap and cell (the same numbers, the same
    order as :func:`_odds_sum_by_value`)."""
    side = kernel.shape[0]
    rad = side // 2
    s = np.zeros((nx, ny))
    for a in range(side):
        for b in range(side):
            k = kernel[a, b]
            if k == 0.0 or (a == rad and b == rad):
                continue
            for i in range(nx):
                row, srow = s[i], padded[2 * rad - a + i]
                for j in range(ny):
                    q = k * srow[2 * rad - b + j]
                    row[j] += q / (1.0 - q)
    return s


@jit
def _tap_offsets(kernel: NDArray[np.float64], width: int) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The nonzero taps of a square kernel in row-major order ``(a, b)``: each one's offset into a belief padded
    by the kernel's radius (row width ``width``), ``(2 rad - a) width + 2 rad - b``, and its value."""
    side = kernel.shape[0]
    rad = side // 2
    offsets = np.empty(side * side, dtype=np.intp)
    values = np.empty(side * side)
    n = 0
    for a in range(side):
        for b in range(side):
            if kernel[a, b] != 0.0:
                offsets[n] = (2 * rad - a) * width + 2 * rad - b
                values[n] = kernel[a, b]
                n += 1
    return offsets[:n], values[:n]


@jit
def convolve_const(bel: NDArray[np.float64], kernel: NDArray[np.float64], outside: float) -> NDArray[np.float64]:
    """``sum_k T(c <- k) bel_k`` (the linear people prediction) with ``outside`` beyond the border, clipped to
    [0, 1]: ``scipy.ndimage.convolve(bel, kernel, mode="constant", cval=outside)`` to round-off.

    Each cell's sum runs over the kernel's nonzero taps in row-major order from 0.0. A row's sums are kept side
    by side and each tap adds its products to all of them (the same additions per cell, in the same order, over
    contiguous cells the compiler vectorises).
    """
    nx, ny = bel.shape
    rad = kernel.shape[0] // 2
    width = ny + 2 * rad
    flat = _padded(bel, rad, outside).ravel()
    offsets, values = _tap_offsets(kernel, width)
    out = np.empty((nx, ny))
    acc = np.empty(ny)
    for i in range(nx):
        base = i * width
        acc[:] = 0.0
        for t in range(values.size):
            k = values[t]
            src = flat[base + offsets[t] : base + offsets[t] + ny]
            for j in range(ny):
                acc[j] += k * src[j]
        row = out[i]
        for j in range(ny):
            row[j] = min(max(acc[j], 0.0), 1.0)
    return out


@jit
def convolve_at(
    bel: NDArray[np.float64], kernel: NDArray[np.float64], outside: float, at: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """:func:`convolve_const` at the cells ``at`` only (by blocks of four cells of a row), bit for bit.

    Parameters
    ----------
    bel : ndarray, shape (nx, ny)
        The belief.
    kernel : ndarray, shape (2R + 1, 2R + 1)
        The linear people-motion kernel.
    outside : float
        Belief beyond the border.
    at : ndarray of bool, shape (nx, ny)
        The cells to compute (e.g. :func:`warp_taps`).

    Returns
    -------
    ndarray, shape (nx, ny)
        :func:`convolve_const`'s value (each cell's sum over the kernel's nonzero taps in row-major order from
        0.0, clipped to [0, 1]) at every cell of ``at`` and at the other cells of its block ``[4 q, 4 q + 4)`` of
        the row (four sums side by side, as there); 0.0 at the cells of the other blocks.
    """
    nx, ny = bel.shape
    rad = kernel.shape[0] // 2
    width = ny + 2 * rad
    flat = _padded(bel, rad, outside).ravel()
    offsets, values = _tap_offsets(kernel, width)
    out = np.zeros((nx, ny))
    for i in range(nx):
        base = i * width
        for j in range(0, ny, 4):
            n = min(4, ny - j)
            wanted = False
            for jj in range(j, j + n):
                wanted = wanted or at[i, jj]
            if not wanted:
                continue
            if n < 4:
                for jj in range(j, ny):
                    s0 = 0.0
                    for t in range(values.size):
                        s0 += values[t] * flat[base + jj + offsets[t]]
                    out[i, jj] = min(max(s0, 0.0), 1.0)
                continue
            s0 = s1 = s2 = s3 = 0.0
            for t in range(values.size):
                k, o = values[t], base + j + offsets[t]
                s0 += k * flat[o]
                s1 += k * flat[o + 1]
                s2 += k * flat[o + 2]
                s3 += k * flat[o + 3]
            out[i, j], out[i, j + 1] = min(max(s0, 0.0), 1.0), min(max(s1, 0.0), 1.0)
            out[i, j + 2], out[i, j + 3] = min(max(s2, 0.0), 1.0), min(max(s3, 0.0), 1.0)
    return out


@jit
def _bilinear_tap(flat: NDArray[np.float64], u: float, v: float, nx: int, ny: int, width: int) -> float:
    """The bilinear value at fractional cell ``(u, v)`` of a grid ``(nx, ny)`` padded by 2 cells and flattened
    (``flat``, rows of ``width = ny + 4``), the indices clamped into the pad: the warps' one tap, scipy's order
    (taps (0, 0), (0, 1), (1, 0), (1, 1), each times the x then the y weight)."""
    fi, fj = np.floor(u), np.floor(v)
    fu, fv = u - fi, v - fj
    # an unsigned index: no wrap-around test for negative indices
    t = np.uint64((min(max(fi, -2.0), float(nx)) + 2.0) * width + min(max(fj, -2.0), float(ny)) + 2.0)
    one, below = np.uint64(1), np.uint64(width)
    val = flat[t] * (1.0 - fu) * (1.0 - fv)
    val += flat[t + one] * (1.0 - fu) * fv
    val += flat[t + below] * fu * (1.0 - fv)
    val += flat[t + below + one] * fu * fv
    return float(val)


@jit
def _row_taps(
    au: float,
    av: float,
    sn: float,
    c: float,
    py: NDArray[np.float64],
    grid: tuple[float, float, float],
    shape: tuple[int, int],
    taps: tuple[NDArray[np.uint64], NDArray[np.float64], NDArray[np.float64]],
) -> None:
    """One pose's source coordinates along a grid row (``au = t_x + c p_x``, ``av = t_y + s p_x``): each cell's
    tap (0, 0) into the padded belief and its fractions ``(fu, fv)`` written into ``taps``, computed as in
    :func:`_bilinear_tap`."""
    x0, y0, res = grid
    inv = 1.0 / res
    nx, ny = shape
    width = ny + 4
    tap, fu, fv = taps
    for j in range(ny):
        u = (au - sn * py[j] - x0) * inv - 0.5
        v = (av + c * py[j] - y0) * inv - 0.5
        fi, fj = np.floor(u), np.floor(v)
        fu[j], fv[j] = u - fi, v - fj
        tap[j] = np.uint64((min(max(fi, -2.0), float(nx)) + 2.0) * width + min(max(fj, -2.0), float(ny)) + 2.0)


@jit
def _add_row_taps(
    row: NDArray[np.float64],
    flat: NDArray[np.float64],
    ws: float,
    width: int,
    taps: tuple[NDArray[np.uint64], NDArray[np.float64], NDArray[np.float64]],
) -> None:
    """``row[j] += ws * tap`` of the bilinear taps :func:`_row_taps` placed (:func:`_bilinear_tap`'s sum)."""
    tap, fu, fv = taps
    one, below = np.uint64(1), np.uint64(width)
    for j in range(row.size):
        t, a, b = tap[j], fu[j], fv[j]
        val = flat[t] * (1.0 - a) * (1.0 - b)
        val += flat[t + one] * (1.0 - a) * b
        val += flat[t + below] * a * (1.0 - b)
        val += flat[t + below + one] * a * b
        row[j] += ws * val


@jit
def warp_bilinear(
    bel: NDArray[np.float64],
    grid: tuple[float, float, float],
    poses: NDArray[np.float64],
    weights: NDArray[np.float64],
    outside: float,
) -> NDArray[np.float64]:
    """The sensor-motion prediction (eqs. 10-11): weighted bilinear backward warps of ``bel``, clipped to [0, 1].

    Parameters
    ----------
    bel : ndarray, shape (nx, ny)
        Belief in the old sensor frame.
    grid : tuple
        ``(x0, y0, resolution)`` (m).
    poses : ndarray, shape (S, 3)
        Displacements ``(dx, dy, dtheta)`` of the new sensor frame in the old one (m, m, rad).
    weights : ndarray, shape (S,)
        Normalised weights.
    outside : float
        Belief read beyond the border (bilinear taps outside the grid read it).

    Returns
    -------
    ndarray, shape (nx, ny)
        ``sum_s w_s bel_old(R(dtheta_s) p + t_s)`` at every new cell centre p: each cell's sum over the poses in
        their order from 0.0 (pose by pose over the grid, as :func:`warp_at`); a row's taps are placed first
        (:func:`_row_taps`), then read (:func:`_add_row_taps`).
    """
    x0, y0, res = grid
    nx, ny = bel.shape
    flat = _padded(bel, 2, outside).ravel()  # taps beyond the border read ``outside``; indices clamped into the pad
    py = np.empty(ny)
    for j in range(ny):
        py[j] = y0 + (j + 0.5) * res
    taps = (np.empty(ny, dtype=np.uint64), np.empty(ny), np.empty(ny))
    out = np.zeros((nx, ny))
    for s in range(poses.shape[0]):
        tx, ty, c, sn, ws = poses[s, 0], poses[s, 1], math.cos(poses[s, 2]), math.sin(poses[s, 2]), weights[s]
        for i in range(nx):
            px = x0 + (i + 0.5) * res
            _row_taps(tx + c * px, ty + sn * px, sn, c, py, grid, (nx, ny), taps)
            _add_row_taps(out[i], flat, ws, ny + 4, taps)
    for i in range(nx):
        for j in range(ny):
            out[i, j] = min(max(out[i, j], 0.0), 1.0)
    return out


@jit
def independent_terms(
    q: NDArray[np.float64],
    fov: NDArray[np.bool_],
    odds: tuple[float, float],
    covered: NDArray[np.bool_],
    per_det: NDArray[np.float64],
) -> NDArray[np.float64]:
    """One detector's terms of :class:`gridbridge.likelihoods.IndependentLikelihood` in one pass, bit for bit:
    ``covered = fov | (q > 0)``, the likelihood ratio ``lr = q lr_fire + (1 - q) miss`` and ``per_det = lr / (1 +
    lr)`` where covered (else left as it is, 0.5).

    ``q`` and ``fov`` are the detector's map and field of view ``(nx, ny)``, ``odds = (lr_fire, miss)``;
    ``covered`` and ``per_det`` (its rows of the likelihood) are written. Returns ``lr`` (every cell), whose
    logarithm is numpy's to take (numpy's ``log`` is not the C library's).
    """
    lr_fire, miss = odds
    nx, ny = q.shape
    lr = np.empty((nx, ny))
    for i in range(nx):
        for j in range(ny):
            qq = q[i, j]
            r = qq * lr_fire + (1.0 - qq) * miss
            lr[i, j] = r
            if fov[i, j] or qq > 0.0:
                covered[i, j] = True
                per_det[i, j] = r / (1.0 + r)
    return lr


@jit
def add_where(acc: NDArray[np.float64], values: NDArray[np.float64], mask: NDArray[np.bool_]) -> None:
    """``acc += np.where(mask, values, 0.0)`` in place (the same sums: adding 0.0 leaves a sum that is not -0.0
    as it is, and these sums of logarithms start at +0.0)."""
    nx, ny = acc.shape
    for i in range(nx):
        for j in range(ny):
            if mask[i, j]:
                acc[i, j] += values[i, j]


@jit
def _interior_run(a: float, k: float, lo: float, hi: float, n: int) -> tuple[int, int]:
    """The indices ``j`` in ``[0, n)`` with ``lo <= a + k j <= hi`` shrunk by one at each end (a run that rounding
    cannot leave), as ``(first, last + 1)``; empty as ``(0, 0)``."""
    if k == 0.0:
        return (0, n) if lo <= a <= hi else (0, 0)
    j0, j1 = (lo - a) / k, (hi - a) / k
    if k < 0.0:
        j0, j1 = j1, j0
    first = max(math.ceil(j0) + 1, 0)
    last = min(math.floor(j1) - 1, n - 1)
    return (first, last + 1) if first <= last else (0, 0)


@jit
def warp_outside(
    shape: tuple[int, int],
    grid: tuple[float, float, float],
    poses: NDArray[np.float64],
    weights: NDArray[np.float64],
    outside: float,
) -> NDArray[np.float64]:
    """:func:`warp_bilinear` of an all-zero belief (what enters each cell from beyond the border), bit for bit,
    computing only the cells some of whose taps may lie outside the grid.

    Every tap inside reads 0.0, so a cell whose four taps lie inside adds ``w_s * 0.0 = +0.0`` to its sum, which
    leaves it as it is: such cells are skipped. Along a row the source coordinates are affine in ``j``; the
    cells whose coordinates lie 1e-3 cells inside ``[0, n - 1)`` on both axes, less one at each end of the run,
    are skipped (rounding moves a coordinate by some 1e-15 cells).
    """
    x0, y0, res = grid
    inv = 1.0 / res
    nx, ny = shape
    width = ny + 4
    flat = _padded(np.zeros((nx, ny)), 2, outside).ravel()
    out = np.zeros((nx, ny))
    margin = 1e-3
    for s in range(poses.shape[0]):
        tx, ty, c, sn, ws = poses[s, 0], poses[s, 1], math.cos(poses[s, 2]), math.sin(poses[s, 2]), weights[s]
        py0 = y0 + 0.5 * res
        for i in range(nx):
            px = x0 + (i + 0.5) * res
            row = out[i]
            # u(j) = au - sn j, v(j) = av + c j (to rounding)
            au = (tx + c * px - sn * py0 - x0) * inv - 0.5
            av = (ty + sn * px + c * py0 - y0) * inv - 0.5
            u0, u1 = _interior_run(au, -sn * res * inv, margin, nx - 1.0 - margin, ny)
            v0, v1 = _interior_run(av, c * res * inv, margin, ny - 1.0 - margin, ny)
            skip0, skip1 = max(u0, v0), min(u1, v1)
            for j in range(ny):
                if skip0 <= j < skip1:
                    continue
                py = y0 + (j + 0.5) * res
                u = (tx + c * px - sn * py - x0) * inv - 0.5
                v = (ty + sn * px + c * py - y0) * inv - 0.5
                row[j] += ws * _bilinear_tap(flat, u, v, nx, ny, width)
    for i in range(nx):
        for j in range(ny):
            out[i, j] = min(max(out[i, j], 0.0), 1.0)
    return out


@jit
def warp_at(
    bel: NDArray[np.float64],
    grid: tuple[float, float, float],
    poses: NDArray[np.float64],
    weights: NDArray[np.float64],
    outside: float,
    cells: NDArray[np.intp],
) -> NDArray[np.float64]:
    """``warp_bilinear(bel, grid, poses, weights, outside).ravel()[cells]`` (``cells`` flat, row-major), bit for
    bit, computing only those cells: each cell's sum over the poses, its four taps and their weights are
    :func:`warp_bilinear`'s."""
    x0, y0, res = grid
    inv = 1.0 / res
    nx, ny = bel.shape
    flat = _padded(bel, 2, outside).ravel()
    width = ny + 4
    out = np.zeros(cells.size)
    for s in range(poses.shape[0]):
        tx, ty, c, sn, ws = poses[s, 0], poses[s, 1], math.cos(poses[s, 2]), math.sin(poses[s, 2]), weights[s]
        for m in range(cells.size):
            i, j = cells[m] // ny, cells[m] % ny
            px = x0 + (i + 0.5) * res
            py = y0 + (j + 0.5) * res
            u = (tx + c * px - sn * py - x0) * inv - 0.5
            v = (ty + sn * px + c * py - y0) * inv - 0.5
            out[m] += ws * _bilinear_tap(flat, u, v, nx, ny, width)
    for m in range(cells.size):
        out[m] = min(max(out[m], 0.0), 1.0)
    return out


@jit
def warp_taps(
    shape: tuple[int, int], grid: tuple[float, float, float], poses: NDArray[np.float64], cells: NDArray[np.intp]
) -> NDArray[np.bool_]:
    """The grid cells whose values :func:`warp_at` reads at ``cells``: the four bilinear taps of every pose at
    every cell that lie inside the grid (the others read the border value).

    Parameters
    ----------
    shape : tuple of int
        The grid's ``(nx, ny)``.
    grid : tuple
        ``(x0, y0, resolution)`` (m).
    poses : ndarray, shape (S, 3)
        Displacements ``(dx, dy, dtheta)`` of the new sensor frame in the old one (m, m, rad).
    cells : ndarray of int, shape (C,)
        Flat (row-major) indices of the warped cells.

    Returns
    -------
    ndarray of bool, shape (nx, ny)
        True where a tap reads the cell: :func:`warp_at` gives the same floats for any belief equal to the
        given one there (its source coordinates and clamped tap indices are computed as there).
    """
    x0, y0, res = grid
    inv = 1.0 / res
    nx, ny = shape
    read = np.zeros((nx, ny), dtype=np.bool_)
    for s in range(poses.shape[0]):
        tx, ty, c, sn = poses[s, 0], poses[s, 1], math.cos(poses[s, 2]), math.sin(poses[s, 2])
        for m in range(cells.size):
            i, j = cells[m] // ny, cells[m] % ny
            px = x0 + (i + 0.5) * res
            py = y0 + (j + 0.5) * res
            u = (tx + c * px - sn * py - x0) * inv - 0.5
            v = (ty + sn * px + c * py - y0) * inv - 0.5
            fi = int(min(max(np.floor(u), -2.0), float(nx)))  # _bilinear_tap's tap (0, 0), unpadded
            fj = int(min(max(np.floor(v), -2.0), float(ny)))
            for a in range(max(fi, 0), min(fi + 2, nx)):
                for b in range(max(fj, 0), min(fj + 2, ny)):
                    read[a, b] = True
    return read


@jit
def peak_candidates(grid: NDArray[np.float64], window: NDArray[np.bool_], threshold: float) -> NDArray[np.intp]:
    """The cells ``(K, 2)`` (row-major order) whose belief is above ``threshold`` and the maximum of the cells of
    ``window`` (shape ``(2 half + 1, 2 half + 1)``, centred on them): ``np.argwhere((grid > threshold) & (grid >=
    maximum_filter(grid, footprint=window, mode="constant", cval=0.0)))``, exactly (maxima do not round; the
    window's cells beyond the border read 0.0, which a belief above a threshold >= 0 exceeds anyway)."""
    nx, ny = grid.shape
    half = window.shape[0] // 2
    out = np.empty((nx * ny, 2), dtype=np.intp)
    k = 0
    for i in range(nx):
        i0, i1 = max(i - half, 0), min(i + half + 1, nx)
        for j in range(ny):
            g = grid[i, j]
            if not g > threshold:
                continue
            j0, j1 = max(j - half, 0), min(j + half + 1, ny)
            top = True
            for a in range(i0, i1):
                for b in range(j0, j1):
                    if window[a - i + half, b - j + half] and grid[a, b] > g:
                        top = False
                        break
                if not top:
                    break
            if top:
                out[k, 0], out[k, 1] = i, j
                k += 1
    return out[:k].copy()


@jit
def peak_centroids(
    grid: NDArray[np.float64],
    peaks: NDArray[np.intp],
    di: NDArray[np.intp],
    dj: NDArray[np.intp],
    floor: float,
    mask: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The belief-weighted mean cell ``(ci, cj)`` (P, 2) of each peak ``(i, j)`` over the cells at the offsets
    ``(di, dj)`` inside the grid whose belief is at least ``floor``, and how many there are (P,); those cells set
    in ``mask``: :func:`gridbridge.classifiers._peak_people`'s numpy sums (:func:`pairwise_sum` of the weights
    and of the weights times the indices, in the offsets' order), bit for bit."""
    nx, ny = grid.shape
    w, wi, wj = np.empty(di.size), np.empty(di.size), np.empty(di.size)
    centres = np.empty((peaks.shape[0], 2))
    sizes = np.empty(peaks.shape[0], dtype=np.int64)
    for p in range(peaks.shape[0]):
        n = 0
        for d in range(di.size):
            a, b = peaks[p, 0] + di[d], peaks[p, 1] + dj[d]
            if 0 <= a < nx and 0 <= b < ny and grid[a, b] >= floor:
                g = grid[a, b]
                w[n], wi[n], wj[n] = g, g * a, g * b
                mask[a, b] = True
                n += 1
        total = pairwise_sum(w, 0, n)
        centres[p, 0] = pairwise_sum(wi, 0, n) / total
        centres[p, 1] = pairwise_sum(wj, 0, n) / total
        sizes[p] = n
    return centres, sizes


@jit
def appear(p: NDArray[np.float64], b: float, where: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Appearances in the observed cells (:meth:`gridbridge.components.Appearance.apply`), bit for bit its numpy
    ``np.where(where, p + b (1 - p), p)``.

    Parameters
    ----------
    p : ndarray, shape (nx, ny)
        The prior (probabilities).
    b : float
        The appearance probability of the step.
    where : ndarray of bool, shape (nx, ny)
        The observed cells.

    Returns
    -------
    ndarray, shape (nx, ny)
        ``p + b (1 - p)`` where observed, ``p`` elsewhere.
    """
    nx, ny = p.shape
    out = np.empty((nx, ny))
    for i in range(nx):
        for j in range(ny):
            out[i, j] = p[i, j] + b * (1.0 - p[i, j]) if where[i, j] else p[i, j]
    return out


@jit
def bayes_update(p: NDArray[np.float64], lik: NDArray[np.float64]) -> NDArray[np.float64]:
    """The binary Bayes update of eq. 12 cell by cell, bit for bit
    :func:`gridbridge.measurement.bayes_update_unchecked`.

    Parameters
    ----------
    p, lik : ndarray, any one shape, C-contiguous
        The prior and the fused likelihood P(D | p), probabilities.

    Returns
    -------
    ndarray, the shape of ``p``
        ``lik p / (lik p + (1 - lik)(1 - p))`` where the denominator is above 0, else the prior.
    """
    out = np.empty_like(p)
    pf, lf, of = p.reshape(p.size), lik.reshape(lik.size), out.reshape(out.size)
    for k in range(pf.size):
        num = lf[k] * pf[k]
        den = num + (1.0 - lf[k]) * (1.0 - pf[k])
        of[k] = num / den if den > 0.0 else pf[k]
    return out


@jit
def all_probabilities(a: NDArray[np.float64]) -> bool:
    """Whether every value of ``a`` (any shape, C-contiguous) lies in [0, 1] (False for NaN): the value check of
    :func:`gridbridge.validation.check_grid_array` in one branch-free pass."""
    flat = a.reshape(a.size)
    bad = 0
    for k in range(flat.size):
        v = flat[k]
        bad += (v < 0.0) | (v > 1.0) | (v != v)
    return bad == 0


# The kernels of a filter step on input they check first: ``(result, True)``, or ``(input, False)`` when the input
# holds a value outside [0, 1] (or NaN); the caller then names it (:func:`gridbridge.validation.check_grid_array`).


@jit
def predict_people_checked(
    bel: NDArray[np.float64], kernel: NDArray[np.float64], outside: float, paper: bool
) -> tuple[NDArray[np.float64], bool]:
    """:func:`predict_paper` (``paper``) or :func:`convolve_const` (the linear sum) of a belief checked by
    :func:`all_probabilities`."""
    if not all_probabilities(bel):
        return bel, False
    return (predict_paper(bel, kernel, outside) if paper else convolve_const(bel, kernel, outside)), True


@jit
def warp_bilinear_checked(
    bel: NDArray[np.float64],
    grid: tuple[float, float, float],
    poses: NDArray[np.float64],
    weights: NDArray[np.float64],
    outside: float,
) -> tuple[NDArray[np.float64], bool]:
    """:func:`warp_bilinear` of a belief checked by :func:`all_probabilities`."""
    if not all_probabilities(bel):
        return bel, False
    return warp_bilinear(bel, grid, poses, weights, outside), True


@jit
def bayes_update_checked(p: NDArray[np.float64], lik: NDArray[np.float64]) -> tuple[NDArray[np.float64], bool]:
    """:func:`bayes_update` (the same operations) of a prior and a likelihood checked, in the same pass, as
    :func:`all_probabilities` checks."""
    out = np.empty_like(p)
    pf, lf, of = p.reshape(p.size), lik.reshape(lik.size), out.reshape(out.size)
    bad = 0
    for k in range(pf.size):
        a, b = pf[k], lf[k]
        bad += (a < 0.0) | (a > 1.0) | (a != a) | (b < 0.0) | (b > 1.0) | (b != b)
        num = b * a
        den = num + (1.0 - b) * (1.0 - a)
        of[k] = num / den if den > 0.0 else a
    return out, bad == 0


@jit
def fuse_update(
    fired: NDArray[np.float64],
    covered: NDArray[np.bool_],
    ppv: NDArray[np.float64],
    fnr: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per-detector likelihoods and their De Morgan fusion (eqs. 13-14, soft firing), in one pass.

    Parameters
    ----------
    fired : ndarray, shape (D, nx, ny)
        Firing weights in [0, 1].
    covered : ndarray of bool, shape (D, nx, ny)
        Fields of view.
    ppv, fnr : ndarray, shape (D,)
        Each detector's precision and false-negative rate.

    Returns
    -------
    per_det : ndarray, shape (D, nx, ny)
        P(D_i | p): ``q PPV + (1 - q) FNR`` where covered, 0.5 elsewhere.
    fused : ndarray, shape (nx, ny)
        ``L = 1 - A - N0 (1 - B) + N0 min FNR`` clipped to [0, 1]; 0.5 where no detector covers the cell
        (:func:`gridbridge.measurement.fuse_detectors`).
    """
    d, nx, ny = fired.shape
    per_det = np.empty((d, nx, ny))
    fused = np.empty((nx, ny))
    for i in range(nx):
        for j in range(ny):
            a, n0, b, min_fnr, any_cov = 1.0, 1.0, 1.0, np.inf, False
            for k in range(d):
                q = fired[k, i, j]
                if covered[k, i, j]:
                    per_det[k, i, j] = q * ppv[k] + (1.0 - q) * fnr[k]
                    a *= q * (1.0 - ppv[k]) + (1.0 - q) * (1.0 - fnr[k])
                    n0 *= 1.0 - q
                    b *= 1.0 - fnr[k]
                    min_fnr = min(min_fnr, fnr[k])
                    any_cov = True
                else:  # an uncovered detector's factors are 1
                    per_det[k, i, j] = 0.5
            if any_cov:
                f = (1.0 - a) - n0 * (1.0 - b) + n0 * min_fnr
                fused[i, j] = min(max(f, 0.0), 1.0)
            else:
                fused[i, j] = 0.5
    return per_det, fused


@jit
def point_map(
    fired: NDArray[np.float64],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    grid: tuple[float, float, float],
    radius: float,
) -> None:
    """Point detections (m, sensor frame): their cells and the cells whose centre lies within ``radius`` (m) set
    to 1 in ``fired`` (nx, ny) (:func:`gridbridge.measurement.detection_map`, bit for bit)."""
    x0, y0, res = grid
    nx, ny = fired.shape
    for p in range(x.size):
        fi, fj = math.floor((x[p] - x0) / res), math.floor((y[p] - y0) / res)
        if 0 <= fi < nx and 0 <= fj < ny:
            fired[int(fi), int(fj)] = 1.0
    if radius <= 0.0:
        return
    for p in range(x.size):
        # the cells whose centre lies within radius + 1 cell on both axes: the others fail the test by far
        i0, i1 = _cell_span(x[p], x0, res, radius, nx)
        j0, j1 = _cell_span(y[p], y0, res, radius, ny)
        for i in range(i0, i1):
            dx = x0 + (i + 0.5) * res - x[p]
            for j in range(j0, j1):
                dy = y0 + (j + 0.5) * res - y[p]
                if dx**2 + dy**2 <= radius**2:
                    fired[i, j] = 1.0


@jit
def _cell_span(c: float, c0: float, res: float, radius: float, n: int) -> tuple[int, int]:
    """The cells ``[first, last)`` of an axis (``n`` cells from ``c0``, size ``res``) whose centre may lie within
    ``radius`` of ``c`` (a cell of margin each side; empty when ``c`` is far off the grid or not finite)."""
    lo, hi = (c - radius - c0) / res - 1.5, (c + radius - c0) / res + 0.5
    if not (lo < n and hi > 0.0):
        return 0, 0
    return math.floor(max(lo, 0.0)), math.ceil(min(hi, float(n)))


@jit
def gaussian_args(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    grid: tuple[float, float, float],
    shape: tuple[int, int],
    mount: tuple[float, float],
    sigmas: tuple[float, float],
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The exponents ``-d^T S^-1 d / 2`` of Gaussian detections (m, sensor frame) in the cells within 3 sd.

    As :func:`gridbridge.measurement.detection_map` computes them (window of 3 sd, the same arithmetic), except
    that cells whose exponent is below ``-4.5 - 1e-6`` are left out: their value would fall below the cutoff
    ``exp(-4.5)`` and be set to 0 there anyway. ``mount`` is the detector's ``(x, y)`` (m), ``sigmas`` its
    ``(range, lateral)`` sd (m). Returns the flat cells and the exponents, one pair per (detection, cell).
    """
    x0, y0, res = grid
    nx, ny = shape
    s_range, s_lat = sigmas
    reach = 3.0 * max(s_range, s_lat)
    cells = np.empty(x.size * nx * ny, dtype=np.intp)
    args = np.empty(x.size * nx * ny)
    n = 0
    for p in range(x.size):
        px, py = x[p], y[p]
        i0 = max(math.floor(((px - reach) - x0) / res), 0)
        j0 = max(math.floor(((py - reach) - y0) / res), 0)
        i1 = min(math.floor(((px + reach) - x0) / res), nx - 1)
        j1 = min(math.floor(((py + reach) - y0) / res), ny - 1)
        phi = math.atan2(py - mount[1], px - mount[0])
        c, s = math.cos(phi), math.sin(phi)
        for i in range(i0, i1 + 1):
            xs = x0 + (i + 0.5) * res - px
            for j in range(j0, j1 + 1):
                ys = y0 + (j + 0.5) * res - py
                along = (c * xs + s * ys) / s_range
                across = (-s * xs + c * ys) / s_lat
                arg = -0.5 * (along**2 + across**2)
                if arg >= -4.5 - 1e-6:
                    cells[n] = i * ny + j
                    args[n] = arg
                    n += 1
    return cells[:n], args[:n]


@jit
def scatter_max(
    fired: NDArray[np.float64], cells: NDArray[np.intp], values: NDArray[np.float64], cutoff: float
) -> None:
    """``fired.flat[c] = max(fired.flat[c], v)`` per pair, then values below ``cutoff`` set to 0."""
    flat = fired.ravel()
    for k in range(cells.size):
        if values[k] > flat[cells[k]]:
            flat[cells[k]] = values[k]
    for k in range(flat.size):
        if flat[k] < cutoff:
            flat[k] = 0.0


@jit
def pairwise_sum(a: NDArray[np.float64], lo: int, n: int) -> float:  # pragma: no cover - compiled
    """``a[lo:lo + n]`` summed in the order of numpy's pairwise summation (``pairwise_sum`` of
    ``numpy/_core/src/umath/loops_utils.h.src``: 8 accumulators up to 128 values, halves above).

    Parameters
    ----------
    a : ndarray, shape (N,)
        The values (any unit).
    lo, n : int
        The first index and the number of values (``0 <= lo``, ``lo + n <= N``).

    Returns
    -------
    float
        The sum, bit for bit ``np.add.reduce(a[lo:lo + n])`` of a contiguous float64 slice (``a[lo:lo + n].sum()``).

    Notes
    -----
    numpy halves a block of more than 128 values recursively; here the halves are walked with an explicit stack
    (the same tree, left half first): a recursive kernel cannot be loaded from numba's cache into a cached
    caller of another module.
    """
    if n <= 128:
        return _pairwise_block(a, lo, n)
    f_lo = np.empty(130, dtype=np.intp)  # the frames: a block, and how far it is (0 new, 1 left done, 2 both)
    f_n = np.empty(130, dtype=np.intp)
    f_stage = np.zeros(130, dtype=np.intp)
    vals = np.empty(130)
    f_lo[0], f_n[0], top, nv = lo, n, 1, 0
    while top:
        b_lo, b_n, stage = f_lo[top - 1], f_n[top - 1], f_stage[top - 1]
        if b_n <= 128:
            vals[nv] = _pairwise_block(a, b_lo, b_n)
            nv += 1
            top -= 1
            continue
        n2 = b_n // 2
        n2 -= n2 % 8
        if stage == 2:
            vals[nv - 2] = vals[nv - 2] + vals[nv - 1]
            nv -= 1
            top -= 1
            continue
        f_stage[top - 1] = stage + 1
        f_lo[top], f_n[top], f_stage[top] = (b_lo, n2, 0) if stage == 0 else (b_lo + n2, b_n - n2, 0)
        top += 1
    return vals[0]


@jit
def _pairwise_block(a: NDArray[np.float64], lo: int, n: int) -> float:  # pragma: no cover - compiled
    """:func:`pairwise_sum` of at most 128 values: sequential below 8, else 8 accumulators."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    m = n - n % 8
    for i in range(8, m, 8):
        j = lo + i
        r0 += a[j]
        r1 += a[j + 1]
        r2 += a[j + 2]
        r3 += a[j + 3]
        r4 += a[j + 4]
        r5 += a[j + 5]
        r6 += a[j + 6]
        r7 += a[j + 7]
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(m, n):
        res += a[lo + i]
    return res
