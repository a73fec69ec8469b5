"""The compiled prediction's shared passes (:mod:`gridbridge.jit`): the particles that left dropped, the sensor motion,
the survivors compacted into a buffer and summed per cell, in one pass over the particles.

Every people-motion model's compiled form ends in these passes (:mod:`pfpeople.particle.predictor.compiled`):

* after a move drawn as the reference form draws it (:meth:`PeopleSampler.move`, or its compiled twin
  ``move_compiled``): :func:`count_inside` (the people prior and the count inside, which the births at the border
  need before the sensor motion draws anything), then :func:`ego_compact` with ``check_first`` (the sensor motion of
  the particles still inside). They do the numpy code's IEEE operations in the same order (cell sums in particle
  order, as ``np.bincount``; ``math.cos`` / ``math.sin`` are the C library's, as numpy's float64 ufuncs on this
  platform): the reference form's particles bit for bit.
* inside a model's drawing pass (``drawn_pass`` of :class:`~pfpeople.particle.predictor.paper.PaperSampling` and
  :class:`~pfpeople.particle.predictor.persistent.PersistentSampling`): :func:`move_block` moves a block of
  :data:`BLOCK` particles whose velocities the model has just drawn into the scratch rows, then the sensor motion,
  the cells (by a multiplication, re-checked near an edge) and the sums; :func:`fill_drops` compacts the survivors
  at the end (their order is not kept).

Cells are row-major flat indices ``i * ny + j`` of :meth:`gridbridge.GridSpec.flat_index` (``-1`` outside);
``grid = (x0, y0, resolution, nx, ny)`` (m, m, m, cells, cells). The sensor motion's sampled displacements are rows
``(dx, dy, cos(dtheta), sin(dtheta))`` of shape (4, S); particle k uses pose ``k mod S``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.grid import GridSpec
from gridbridge.jit import jit

__all__ = [
    "BLOCK",
    "Grid",
    "Rows4",
    "Rows5",
    "Sums4",
    "accumulate",
    "cell",
    "count_inside",
    "ego_compact",
    "fill_drops",
    "grid_of",
    "move_block",
]

#: The grid as the kernels take it: ``(x0, y0, resolution, nx, ny)`` (m, m, m, cells, cells).
Grid = tuple[float, float, float, int, int]
#: Four particle arrays x, y, vx, vy (m, m, m/s, m/s), each of shape (K,) (numba: a UniTuple).
Rows4 = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
#: Five particle arrays x, y, vx, vy, w (m, m, m/s, m/s, mass), each of shape (C,) (numba: a UniTuple).
Rows5 = tuple[NDArray[np.float64], ...]
#: Per-cell sums of a prediction, shape (n_cells,) each: people prior, mass, count and squared mass.
Sums4 = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.float64]]


def grid_of(spec: GridSpec) -> Grid:
    """The kernels' :data:`Grid` of ``spec``."""
    return (float(spec.x0), float(spec.y0), float(spec.resolution), int(spec.nx), int(spec.ny))


#: Particles per block of :func:`move_block` (its scratch rows stay in the first-level cache).
BLOCK = 512
#: Within this distance (in cells) of a cell edge a multiplied cell coordinate is re-checked with the division.
_EDGE_EPS = 2.0**-26


@jit
def cell(x: float, y: float, grid: tuple[float, float, float, int, int]) -> int:
    """Flat cell of the point ``(x, y)`` (m), ``-1`` outside: :meth:`GridSpec.flat_index` for one point.

    ``grid = (x0, y0, resolution, nx, ny)``.
    """
    x0, y0, res, nx, ny = grid
    fi = math.floor((x - x0) / res)  # a division, as numpy's: bit-identical cells
    fj = math.floor((y - y0) / res)
    if fi >= 0.0 and fi < nx and fj >= 0.0 and fj < ny:
        return int(fi) * ny + int(fj)
    return -1


@jit
def _into_pose(
    x: float, y: float, vx: float, vy: float, poses: NDArray[np.float64], p: int
) -> tuple[float, float, float, float]:
    """A particle's position and velocity in the frame of sampled pose ``p`` (``poses``: rows x, y, cos, sin)."""
    c, s = poses[2, p], poses[3, p]
    xr = x - poses[0, p]
    yr = y - poses[1, p]
    return c * xr + s * yr, c * yr - s * xr, c * vx + s * vy, c * vy - s * vx


@jit
def _keep(
    out: tuple[NDArray[np.float64], ...],
    cells: NDArray[np.intp],
    mass: NDArray[np.float64],
    counts: NDArray[np.intp],
    j: int,
    x: float,
    y: float,
    vx: float,
    vy: float,
    w: float,
    c: int,
) -> None:
    """Write particle ``j`` (position, velocity, weight) into ``out`` in cell ``c``, counted in ``mass`` and
    ``counts``."""
    out[0][j], out[1][j], out[2][j], out[3][j], out[4][j] = x, y, vx, vy, w
    cells[j] = c
    mass[c] += w
    counts[c] += 1


@jit
def _next_pose(p: int, n_pose: int) -> int:
    """The pose of the next particle: ``p + 1`` wrapped to 0 at ``n_pose`` (``k mod S`` without a division)."""
    p += 1
    return 0 if p == n_pose else p


@jit
def count_inside(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    grid: Grid,
    prior: NDArray[np.float64],
) -> int:
    """The people prior (eqs. 5-9, sampling form) of particles that have moved (read only).

    Parameters
    ----------
    x, y, w : ndarray, shape (N,)
        Positions after the people motion (m, old sensor frame) and masses.
    grid : tuple
        ``(x0, y0, resolution, nx, ny)``.
    prior : ndarray, shape (n_cells,)
        Zeros; receives the mass per cell (``np.bincount`` order).

    Returns
    -------
    int
        Number of particles inside the grid.
    """
    n_inside = 0
    for k in range(x.size):
        c = cell(x[k], y[k], grid)
        if c >= 0:
            prior[c] += w[k]
            n_inside += 1
    return n_inside


@jit
def ego_compact(
    src: Rows4,
    w: NDArray[np.float64],
    poses: NDArray[np.float64],
    ego: bool,
    check_first: bool,
    grid: Grid,
    out: Rows5,
    cells: NDArray[np.intp],
    start: int,
    mass: NDArray[np.float64],
    counts: NDArray[np.intp],
) -> int:
    """Sensor motion (eqs. 10-11) of particles, the ones outside dropped, written compacted from ``start``.

    Particle k uses pose ``k mod S`` (as :func:`pfpeople.particle.predictor.ego.apply_ego_motion`):
    ``p' = R(-dtheta)(p - t)``, ``v' = R(-dtheta) v``.

    Parameters
    ----------
    src : tuple of 4 ndarrays, shape (K,) each
        x, y, vx, vy of the K = ``w.size`` particles (m, m/s; old sensor frame).
    w : ndarray, shape (K,)
        Their masses.
    poses : ndarray, shape (4, S)
        Rows dx, dy, cos(dtheta), sin(dtheta) of the sampled displacements.
    ego : bool
        Apply the poses (False: a standing robot; only the compaction).
    check_first : bool
        Also drop particles already outside before the sensor motion (those that left in the people motion).
    grid : tuple
        ``(x0, y0, resolution, nx, ny)``.
    out, cells : tuple of 5 ndarrays (x, y, vx, vy, w) and ndarray of intp, shape (C,) each
        The kept particles and their cells, written to entries ``start, start + 1, ...``.
    start : int
        First column written.
    mass, counts : ndarray, shape (n_cells,)
        Accumulate the kept particles' mass and number per cell.

    Returns
    -------
    int
        One past the last column written.
    """
    n_pose = poses.shape[1]
    j, p = start, -1
    for k in range(w.size):
        p = _next_pose(p, n_pose)
        xk, yk, vxk, vyk = src[0][k], src[1][k], src[2][k], src[3][k]
        if check_first and cell(xk, yk, grid) < 0:
            continue
        if ego:
            xk, yk, vxk, vyk = _into_pose(xk, yk, vxk, vyk, poses, p)
        ck = cell(xk, yk, grid)
        if ck < 0:
            continue
        _keep(out, cells, mass, counts, j, xk, yk, vxk, vyk, w[k], ck)
        j += 1
    return j


@jit
def accumulate(
    cells: NDArray[np.intp], w: NDArray[np.float64], mass: NDArray[np.float64], counts: NDArray[np.intp]
) -> None:
    """``mass[c] += w``, ``counts[c] += 1`` per particle, in order (continues an ``np.bincount``)."""
    for k in range(cells.size):
        mass[cells[k]] += w[k]
        counts[cells[k]] += 1


# ---------------------------------------------------------------- blocks of a drawing pass


@jit
def _cell_mul(x: float, y: float, x0: float, y0: float, inv: float, nx: int, ny: int) -> np.intp:
    """:func:`cell` by a multiplication with ``inv = 1 / resolution``; ``-2`` where it may differ from it.

    ``(x - x0) inv`` differs from ``(x - x0) / resolution`` by at most 3 |q| 2^-53, below ``_EDGE_EPS`` for
    ``|q| <= 2^24`` (grids have at most 4e6 cells a side): away from an edge both have the same floor. Further out
    both are outside the grid. Near an edge the result is ``-2``: the caller takes :func:`cell`. Branch-free, so
    a loop of it vectorises.
    """
    u = (x - x0) * inv
    v = (y - y0) * inv
    fu, fv = np.floor(u), np.floor(v)
    near = (u - fu < _EDGE_EPS) | (fu + 1.0 - u < _EDGE_EPS) | (v - fv < _EDGE_EPS) | (fv + 1.0 - v < _EDGE_EPS)
    inside = (fu >= 0.0) & (fu < nx) & (fv >= 0.0) & (fv < ny)
    c = np.intp(fu) * ny + np.intp(fv) if inside else np.intp(-1)
    return np.intp(-2) if near else c


@jit
def _move_segment(
    k0: int,
    k1: int,
    src: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    poses: NDArray[np.float64],
    p0: int,
    dt: float,
    ego: bool,
    grid: tuple[float, float, float, int, int],
    scratch: NDArray[np.float64],
    out: Rows5,
    cells: NDArray[np.intp],
) -> None:
    """People motion then sensor motion of particles ``k0, ..., k1 - 1`` (poses ``p0, p0 + 1, ...``), written in
    place: ``out[r][k]``, ``cells[k]`` (vectorised: contiguous rows, no branches).

    ``src = (x, y, w)`` are the particles (m, m, mass), ``poses`` (4, S) the sampled displacements. The scratch
    columns ``0, ..., k1 - k0 - 1`` (``scratch`` (8, B)) hold the people-motion velocities in rows 0-1 and receive
    the positions after the people motion in rows 2-3 and their cells in row 4. Cells are :func:`_cell_mul`'s
    (``-2``: to be re-checked).
    """
    x0, y0, res, nx, ny = grid
    inv, m = 1.0 / res, k1 - k0
    xs, ys, ws = src[0][k0:k1], src[1][k0:k1], src[2][k0:k1]
    vx, vy, xk, yk, c1 = scratch[0, :m], scratch[1, :m], scratch[2, :m], scratch[3, :m], scratch[4, :m]
    ox, oy, ovx, ovy, ow, oc = out[0][k0:k1], out[1][k0:k1], out[2][k0:k1], out[3][k0:k1], out[4][k0:k1], cells[k0:k1]
    for i in range(m):
        a = xs[i] + vx[i] * dt
        b = ys[i] + vy[i] * dt
        xk[i], yk[i], ow[i] = a, b, ws[i]
        c1[i] = _cell_mul(a, b, x0, y0, inv, nx, ny)
    if not ego:
        for i in range(m):
            ox[i], oy[i], ovx[i], ovy[i], oc[i] = xk[i], yk[i], vx[i], vy[i], np.intp(c1[i])
        return
    dx, dy, co, si = poses[0, p0 : p0 + m], poses[1, p0 : p0 + m], poses[2, p0 : p0 + m], poses[3, p0 : p0 + m]
    for i in range(m):
        xr = xk[i] - dx[i]
        yr = yk[i] - dy[i]
        a = co[i] * xr + si[i] * yr
        b = co[i] * yr - si[i] * xr
        ox[i], oy[i] = a, b
        ovx[i] = co[i] * vx[i] + si[i] * vy[i]
        ovy[i] = co[i] * vy[i] - si[i] * vx[i]
        oc[i] = _cell_mul(a, b, x0, y0, inv, nx, ny)


@jit
def _sum_block(
    k0: int,
    w: NDArray[np.float64],
    scratch: NDArray[np.float64],
    grid: tuple[float, float, float, int, int],
    out: Rows5,
    cells: NDArray[np.intp],
    sums: Sums4,
    drops: NDArray[np.intp],
    nd: int,
) -> tuple[int, int]:
    """The sums of one block (particles ``k0, ..., k0 + w.size - 1`` after :func:`_move_segment`) and its particles
    that left: cells near an edge re-checked with the division (:func:`cell`), a particle outside after the people
    motion or after the sensor motion marked ``cells[k] = -1`` and listed in ``drops[nd:]``.

    ``sums = (prior, mass, counts, sq)`` accumulate the people prior and the kept mass, count and squared mass per
    cell. Returns the new ``nd`` and the block's count inside after the people motion.
    """
    prior, mass, counts, sq = sums
    n_in = 0
    for i in range(w.size):
        k, a, c = k0 + i, int(scratch[4, i]), int(cells[k0 + i])
        if a < 0 or c < 0:  # rare: an edge or the border
            a = cell(scratch[2, i], scratch[3, i], grid) if a == -2 else a
            c = cell(out[0][k], out[1][k], grid) if c == -2 else c
            c = c if a >= 0 else -1  # outside after the people motion: gone, whatever the sensor motion does
            cells[k] = c
            if c < 0:
                drops[nd] = k
                nd += 1
            if a < 0:
                continue
        prior[a] += w[i]
        n_in += 1
        if c >= 0:
            mass[c] += w[i]
            counts[c] += 1
            sq[c] += w[i] * w[i]
    return nd, n_in


@jit
def fill_drops(n: int, drops: NDArray[np.intp], nd: int, out: Rows5, cells: NDArray[np.intp]) -> int:
    """Compact particles ``0, ..., n - 1`` whose ``nd`` dropped ones are listed (ascending) in ``drops``: each hole
    below the kept count is filled with a kept particle from the end. Returns the kept count."""
    kept = n - nd
    src = n - 1
    for q in range(nd):
        h = drops[q]
        if h >= kept:
            break
        while cells[src] < 0:
            src -= 1
        for r in range(5):
            out[r][h] = out[r][src]
        cells[h] = cells[src]
        src -= 1
    return kept


@jit
def move_block(
    b0: int,
    m: int,
    src: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    motion: tuple[NDArray[np.float64], bool, float],
    grid: tuple[float, float, float, int, int],
    scratch: NDArray[np.float64],
    into: tuple[Rows5, NDArray[np.intp]],
    sums: Sums4,
    drops: NDArray[np.intp],
    nd: int,
) -> tuple[int, int]:
    """The people motion (velocities in ``scratch[0:2, :m]``), the sensor motion (``motion = (poses, ego, dt)``),
    the cells and the sums of the block of particles ``b0, ..., b0 + m - 1`` (``src = (x, y, w)``), in runs of
    consecutive poses (particle k has pose k mod S; one run without the poses). Returns the dropped count so far
    and the block's count inside after the people motion."""
    poses, ego, dt = motion
    out, cells = into
    n_pose, n_inside = poses.shape[1], 0
    i0, p0 = 0, b0 % n_pose
    while i0 < m:
        i1 = min(m, i0 + n_pose - p0) if ego else m
        if i0 > 0:  # the run's velocities to the scratch's first columns, where _move_segment reads them
            scratch[0:2, : i1 - i0] = scratch[0:2, i0:i1].copy()
        _move_segment(b0 + i0, b0 + i1, src, poses, p0, dt, ego, grid, scratch, out, cells)
        nd, n_in = _sum_block(b0 + i0, src[2][b0 + i0 : b0 + i1], scratch, grid, out, cells, sums, drops, nd)
        n_inside += n_in
        i0, p0 = i1, 0
    return nd, n_inside
