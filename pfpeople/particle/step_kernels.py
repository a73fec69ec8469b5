"""Compiled kernels of the particle-filter step (:mod:`gridbridge.jit`), bit-identical to the numpy code.

Each kernel is one pass over the particles doing the deterministic arithmetic of several numpy calls; the random
draws stay with the caller (numpy's ``Generator``, in the same order as the numpy path), so a seeded filter gives
the same particles bit for bit on either path (``tests/test_kernels.py``). Bit identity holds because every
kernel does the same IEEE operations in the same order as the numpy code it replaces: cell sums accumulate
sequentially in particle order (as ``np.bincount``), running sums are sequential (as ``np.cumsum``), and
``math.cos`` / ``math.sin`` are the C library's, as numpy's float64 ufuncs on this platform (the tests check).

The numpy twins are the code in :mod:`pfpeople.particle.propagation`, :mod:`pfpeople.particle.resampling` and
:class:`pfpeople.ParticleFilter`'s numpy path; these kernels are called only when :func:`gridbridge.jit.enabled`.

Cells are row-major flat indices ``i * ny + j`` of :meth:`gridbridge.GridSpec.flat_index` (``-1`` outside);
``grid = (x0, y0, resolution, nx, ny)`` (m, m, m, cells, cells).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit

#: Five particle arrays x, y, vx, vy, w (m, m, m/s, m/s, mass), each of shape (C,) (numba: a UniTuple).
Rows5 = tuple[NDArray[np.float64], ...]

__all__ = [
    "accumulate",
    "cell",
    "cell_mass",
    "ego_compact",
    "ego_rows",
    "forced_ancestors",
    "gather_resampled",
    "move_ego_compact",
    "people_prior",
    "persistent_velocities",
    "persistent_walk",
    "scale_weights",
    "select_moving",
    "systematic_gather",
    "systematic_into",
    "walker_velocities",
]


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
def select_moving(u: NDArray[np.float64], p_stat: float) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The walkers of the paper's motion prior: indices with ``u >= p_stat`` and their speed uniforms
    ``(u - p_stat) / (1 - p_stat)`` (:func:`pfpeople.particle.propagation.sample_velocity_prior`'s arithmetic)."""
    n = 0
    for k in range(u.size):
        n += u[k] >= p_stat
    moving = np.empty(n + 1, dtype=np.intp)
    m = 0
    for k in range(u.size):  # branch-free: every index is written, the walkers' are kept
        moving[m] = k
        m += u[k] >= p_stat
    moving = moving[:n]
    z = np.empty(n)
    for m in range(n):
        z[m] = (u[moving[m]] - p_stat) / (1.0 - p_stat)
    return moving, z


@jit
def walker_velocities(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    moving: NDArray[np.intp],
    speed: NDArray[np.float64],
    heading_u: NDArray[np.float64],
    dt: float,
    grid: tuple[float, float, float, int, int],
) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Velocities ``speed (cos h, sin h)``, ``h = 2 pi u`` (m/s) of the walkers and how many of them are inside
    the grid after moving ``dt`` (the others, standing, stay where they are)."""
    n = moving.size
    vx, vy = np.empty(n), np.empty(n)
    two_pi = 2.0 * math.pi
    n_in = 0
    for m in range(n):
        h = heading_u[m] * two_pi
        vx[m] = speed[m] * math.cos(h)
        vy[m] = speed[m] * math.sin(h)
        k = moving[m]
        if cell(x[k] + vx[m] * dt, y[k] + vy[m] * dt, grid) >= 0:
            n_in += 1
    return vx, vy, n_in


@jit
def ego_rows(
    e: NDArray[np.float64], sd: NDArray[np.float64], control: tuple[float, float, float], dt: float, eps: float
) -> NDArray[np.float64]:
    """Sampled sensor displacements (eqs. 10-11) as rows dx, dy, cos(dtheta), sin(dtheta):
    :func:`pfpeople.particle.propagation.sample_ego_poses` from its standard normal draws ``e`` (3, S), bit for bit.

    ``sd`` are the noise sd of ``v``, ``omega`` and ``gamma``, ``control = (v, omega, vy)`` the odometry
    (m/s, rad/s, m/s), ``eps`` the yaw rate below which the motion is a straight line
    (:func:`gridbridge.velocity_displacement`).
    """
    v0, w0, vy = control
    n = e.shape[1]
    out = np.empty((4, n))
    for k in range(n):
        v = v0 + e[0, k] * sd[0]
        w = w0 + e[1, k] * sd[1]
        gamma = e[2, k] * sd[2]
        if abs(w) > eps:
            sw, cw = math.sin(w * dt), math.cos(w * dt)
            dx, dy = v / w * sw, v / w * (1.0 - cw)
            if vy != 0.0:
                dx, dy = dx - vy / w * (1.0 - cw), dy + vy / w * sw
        else:
            dx, dy = v * dt, 0.0
            if vy != 0.0:
                dx, dy = dx - 0.0, dy + vy * dt
        th = (w + gamma) * dt
        out[0, k], out[1, k], out[2, k], out[3, k] = dx, dy, math.cos(th), math.sin(th)
    return out


@jit
def persistent_walk(
    vx: NDArray[np.float64],
    vy: NDArray[np.float64],
    heading: NDArray[np.float64],
    u: NDArray[np.float64],
    noise: NDArray[np.float64],
    rates: tuple[float, float],
    walk: tuple[float, float, float, float, float, float],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.bool_]]:
    """:func:`pfpeople.particle.propagation.move_persistent`'s walk before the new walkers' draws, bit for bit.

    Parameters
    ----------
    vx, vy : ndarray, shape (N,)
        Velocities (m/s) before the step.
    heading : ndarray, shape (N,)
        ``np.arctan2(vy, vx)`` (numpy's, which the C library's ``atan2`` does not always equal).
    u, noise : ndarray, shapes (N,) and (2, N)
        The step's uniform and standard normal draws.
    rates : tuple of float
        The per-step probabilities ``(p_stop, p_start)``.
    walk : tuple of float
        ``(heading_noise * sqrt(dt), speed_reversion, mu, dt, speed_noise * sqrt(dt), v_max)``.

    Returns
    -------
    speed, heading : ndarray, shape (N,)
        The walked speed (m/s) and heading (rad) of every particle.
    starts : ndarray of intp
        Indices (ascending) of the standing particles that start walking (their draws are the caller's).
    zero : ndarray of bool, shape (N,)
        The particles that stand after the step (walkers that stop, standing ones that do not start).
    """
    p_stop, p_start = rates
    hn, sr, mu, dt, sn, vmax = walk
    two_vmax = 2.0 * vmax
    n = vx.size
    speed, head = np.empty(n), np.empty(n)
    zero = np.zeros(n, dtype=np.bool_)
    starts = np.empty(n, dtype=np.intp)
    n_start = 0
    for k in range(n):
        s = math.hypot(vx[k], vy[k])
        walking = s > 0.0
        if walking:
            zero[k] = u[k] < p_stop
        elif u[k] < p_start:
            starts[n_start] = k
            n_start += 1
        else:
            zero[k] = True
        head[k] = heading[k] + hn * noise[0, k]
        s = s + sr * (mu - s) * dt + sn * noise[1, k]
        s = abs(s)
        if s > vmax:
            s = two_vmax - s
        s = s if s > 0.0 else 0.0  # np.clip(s, 0, v_max)
        speed[k] = s if s < vmax else vmax
    return speed, head, starts[:n_start], zero


@jit
def persistent_velocities(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    speed: NDArray[np.float64],
    heading: NDArray[np.float64],
    zero: NDArray[np.bool_],
    dt: float,
) -> NDArray[np.float64]:
    """The end of :func:`pfpeople.particle.propagation.move_persistent`, bit for bit: ``speed`` zeroed where
    ``zero``, the velocities ``speed (cos, sin)(heading)`` and the moved positions.

    ``speed`` and ``heading`` (N,) hold the new walkers' draws already. Returns rows x, y, vx, vy, shape (4, N).
    """
    n = x.size
    out = np.empty((4, n))
    for k in range(n):
        s = 0.0 if zero[k] else speed[k]
        vx = s * math.cos(heading[k])
        vy = s * math.sin(heading[k])
        out[0, k] = x[k] + vx * dt
        out[1, k] = y[k] + vy * dt
        out[2, k] = vx
        out[3, k] = vy
    return out


@jit
def people_prior(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    moving: NDArray[np.intp],
    vx_m: NDArray[np.float64],
    vy_m: NDArray[np.float64],
    dt: float,
    grid: tuple[float, float, float, int, int],
    prior: NDArray[np.float64],
) -> int:
    """The people prior of the people motion (eqs. 5-9, sampling form) without moving anything (read only).

    Parameters
    ----------
    x, y, w : ndarray, shape (N,)
        Positions (m, sensor frame) and masses before the motion.
    moving : ndarray of intp, shape (M,)
        Sorted indices of the particles with a velocity (the others stand: velocity 0).
    vx_m, vy_m : ndarray, shape (M,)
        Their velocities (m/s); particle ``moving[m]`` moves to ``x + vx_m[m] dt``.
    dt : float
        Step (s).
    grid : tuple
        ``(x0, y0, resolution, nx, ny)``.
    prior : ndarray, shape (n_cells,)
        Zeros; receives the moved mass per cell (``np.bincount`` order).

    Returns
    -------
    int
        Number of particles inside the grid after the motion.
    """
    m = 0
    nxt = moving[0] if moving.size else x.size
    n_inside = 0
    for k in range(x.size):
        vx = 0.0
        vy = 0.0
        if k == nxt:
            vx, vy = vx_m[m], vy_m[m]
            m += 1
            nxt = moving[m] if m < moving.size else x.size
        c = cell(x[k] + vx * dt, y[k] + vy * dt, grid)
        if c >= 0:
            prior[c] += w[k]
            n_inside += 1
    return n_inside


@jit
def move_ego_compact(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    moving: NDArray[np.intp],
    vx_m: NDArray[np.float64],
    vy_m: NDArray[np.float64],
    dt: float,
    poses: NDArray[np.float64],
    ego: bool,
    grid: tuple[float, float, float, int, int],
    out: Rows5,
    cells: NDArray[np.intp],
    mass: NDArray[np.float64],
    counts: NDArray[np.intp],
    prior: NDArray[np.float64],
) -> tuple[int, int]:
    """People motion, then sensor motion, of N particles in one pass; the ones that leave are dropped.

    The people motion is :func:`people_prior`'s (its mass per cell accumulated into ``prior``); a particle
    outside after it is dropped (whatever the sensor motion does), the others move into the new sensor frame as
    in :func:`ego_compact` (pose ``k mod S``). Arguments as there; the survivors go to ``out[r][:n]``
    (x, y, vx, vy, w) and ``cells[:n]``.

    Returns
    -------
    n : int
        The number of survivors.
    n_inside : int
        The number inside the grid after the people motion.
    """
    n_pose = poses.shape[1]
    m = 0
    nxt = moving[0] if moving.size else x.size
    j = n_inside = 0
    p = -1
    for k in range(x.size):
        p = _next_pose(p, n_pose)
        vxk = 0.0
        vyk = 0.0
        if k == nxt:
            vxk, vyk = vx_m[m], vy_m[m]
            m += 1
            nxt = moving[m] if m < moving.size else x.size
        xk = x[k] + vxk * dt
        yk = y[k] + vyk * dt
        c1 = cell(xk, yk, grid)
        if c1 < 0:
            continue
        prior[c1] += w[k]
        n_inside += 1
        if ego:
            xk, yk, vxk, vyk = _into_pose(xk, yk, vxk, vyk, poses, p)
        ck = cell(xk, yk, grid)
        if ck < 0:
            continue
        _keep(out, cells, mass, counts, j, xk, yk, vxk, vyk, w[k], ck)
        j += 1
    return j, n_inside


@jit
def ego_compact(
    src: NDArray[np.float64],
    w: NDArray[np.float64],
    poses: NDArray[np.float64],
    ego: bool,
    check_first: bool,
    grid: tuple[float, float, float, int, int],
    out: Rows5,
    cells: NDArray[np.intp],
    start: int,
    mass: NDArray[np.float64],
    counts: NDArray[np.intp],
) -> int:
    """Sensor motion (eqs. 10-11) of particles, the ones outside dropped, written compacted from ``start``.

    Particle k uses pose ``k mod S`` (as :func:`pfpeople.particle.propagation.apply_ego_motion`):
    ``p' = R(-dtheta)(p - t)``, ``v' = R(-dtheta) v``.

    Parameters
    ----------
    src : ndarray, shape (4, >= K)
        Rows x, y, vx, vy of the K = ``w.size`` particles (m, m/s; old sensor frame).
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
        xk, yk, vxk, vyk = src[0, k], src[1, k], src[2, k], src[3, k]
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


@jit
def scale_weights(
    w: NDArray[np.float64], cells: NDArray[np.intp], factor: NDArray[np.float64], out: NDArray[np.float64]
) -> None:
    """``out[:N] = w * factor[cells]`` in one pass: the particles' share of their cell's posterior (eq. 12)."""
    for k in range(w.size):
        out[k] = w[k] * factor[cells[k]]


@jit
def cell_mass(
    cells: NDArray[np.intp], w: NDArray[np.float64], n_cells: int
) -> tuple[NDArray[np.float64], NDArray[np.intp], float, int]:
    """Mass and particle count per cell (``np.bincount`` order), the total mass and a status.

    Returns ``(mass, counts, total, status)``: ``total`` is the running sum in particle order (``np.cumsum``'s
    last value); status 0 ok, 1 a weight negative or not finite, 2 a cell outside ``[0, n_cells)`` (the sums
    are then incomplete).
    """
    mass = np.zeros(n_cells)
    counts = np.zeros(n_cells, dtype=np.intp)
    total = 0.0
    status = 0
    for k in range(cells.size):
        wk = w[k]
        if not (wk >= 0.0 and wk < np.inf):
            return mass, counts, total, 1
        c = cells[k]
        total += wk
        if c < 0 or c >= n_cells:
            status = 2  # reported after the weights are all checked, as the numpy code orders its errors
            continue
        mass[c] += wk
        counts[c] += 1
    return mass, counts, total, status


@jit
def forced_ancestors(
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    counts: NDArray[np.intp],
    mass: NDArray[np.float64],
    occupied: NDArray[np.intp],
    u: NDArray[np.float64],
    out: NDArray[np.intp],
    order: NDArray[np.intp],
) -> None:
    """One ancestor per occupied cell, by weight within the cell (the first stage of
    :func:`pfpeople.particle.resampling.resample_by_cell`), written to ``out[:K]``.

    The particles are ordered by cell (a stable counting sort: ``np.argsort(kind="stable")``'s order), their
    weights summed in that order; the ancestor of cell c is the first in c whose running sum exceeds
    ``before_c + u_c M_c``, else the cell's last (``np.searchsorted`` clipped to the cell). ``order`` (N,) is
    scratch space for the sort.
    """
    n, n_cells = cells.size, counts.size
    start = np.empty(n_cells, dtype=np.intp)
    acc_i = 0
    for c in range(n_cells):
        start[c] = acc_i
        acc_i += counts[c]
    fill = start.copy()
    for k in range(n):
        c = cells[k]
        order[fill[c]] = k
        fill[c] += 1
    acc = 0.0  # the running sum over the particles in cell order (np.cumsum of the sorted weights)
    q = 0
    for c in range(n_cells):
        lo, end = start[c], start[c] + counts[c]
        if q < occupied.size and occupied[q] == c:
            target = acc + u[q] * mass[c]
            found = end - 1
            for t in range(lo, end):
                acc += w[order[t]]
                if found == end - 1 and t < end - 1 and acc > target:
                    found = t
            out[q] = order[found]
            q += 1
        else:
            for t in range(lo, end):
                acc += w[order[t]]


@jit
def systematic_into(w: NDArray[np.float64], m: int, off: float, out: NDArray[np.intp], start: int) -> None:
    """Systematic resampling of ``m`` ancestors (positions ``(k + off) / m``) into ``out[start:start + m]``:
    :func:`pfpeople.particle.resampling.systematic` with its offset given, for weights with a positive sum."""
    n = w.size
    total = 0.0
    for i in range(n):
        total += w[i]
    acc = 0.0
    prev = 0
    j = start
    for i in range(n):
        acc += w[i]
        below = _systematic_count(acc, total, m, off, i == n - 1)
        for _ in range(below - prev):
            out[j] = i
            j += 1
        prev = below


@jit
def gather_resampled(
    anc: NDArray[np.intp],
    cells: NDArray[np.intp],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    vx: NDArray[np.float64],
    vy: NDArray[np.float64],
    mass: NDArray[np.float64],
    n_cells: int,
    out: Rows5,
) -> NDArray[np.intp]:
    """The resampled particles: ``x[anc], y[anc], vx[anc], vy[anc]`` and the new weights ``M_c / n_c``.

    They are written to ``out`` (5 arrays x, y, vx, vy, w, shape (n,) each); returns ``new_cells = cells[anc]``.
    """
    n = anc.size
    n_new = np.zeros(n_cells, dtype=np.intp)
    new_cells = np.empty(n, dtype=np.intp)
    for t in range(n):
        c = cells[anc[t]]
        new_cells[t] = c
        n_new[c] += 1
    share = np.zeros(n_cells)
    for c in range(n_cells):
        if n_new[c] > 0:
            share[c] = mass[c] / n_new[c]
    ox, oy, ovx, ovy, ow = out
    for t in range(n):
        a = anc[t]
        ox[t], oy[t], ovx[t], ovy[t], ow[t] = x[a], y[a], vx[a], vy[a], share[new_cells[t]]
    return new_cells


@jit
def _systematic_count(acc: float, total: float, m: int, off: float, last: bool) -> int:
    """Positions ``(k + off) / m`` below the normalised running sum ``acc / total`` (``m`` for the last)."""
    if last:
        return m
    b = math.ceil(m * (acc / total) - off)
    return 0 if b < 0.0 else (m if b > m else int(b))


@jit
def systematic_gather(
    forced: NDArray[np.intp],
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    src: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    mass: NDArray[np.float64],
    total: float,
    m: int,
    off: float,
    out: Rows5,
) -> None:
    """The resampled particles of :func:`pfpeople.particle.resampling.resample_by_cell` with the systematic resampler,
    without an ancestor array: the ``forced`` ancestors, then ``m`` systematic ones (offset ``off``, weights
    ``w`` of sum ``total``), each carrying ``M_c / n_c``.

    Two passes over the particles: the first counts each particle's copies and the new particles per cell, the
    second copies them.

    The new particles are written to ``out``: 5 arrays of shape (K + m,), x, y, vx, vy (of ``src``) and the
    new weights.
    """
    n, n_cells = w.size, mass.size
    n_new = np.zeros(n_cells, dtype=np.intp)
    copies = np.empty(n, dtype=np.int32)  # each particle's systematic copies, for the second pass
    for f in forced:
        n_new[cells[f]] += 1
    acc, prev = 0.0, 0
    for i in range(n):
        acc += w[i]
        below = _systematic_count(acc, total, m, off, i == n - 1)
        copies[i] = below - prev
        n_new[cells[i]] += below - prev
        prev = below
    share = np.zeros(n_cells)
    for c in range(n_cells):
        if n_new[c] > 0:
            share[c] = mass[c] / n_new[c]
    x, y, vx, vy = src
    ox, oy, ovx, ovy, ow = out
    for t in range(forced.size):
        a = forced[t]
        ox[t], oy[t], ovx[t], ovy[t], ow[t] = x[a], y[a], vx[a], vy[a], share[cells[a]]
    j = forced.size
    for i in range(n):
        if copies[i] == 0:
            continue
        xi, yi, vxi, vyi, wi = x[i], y[i], vx[i], vy[i], share[cells[i]]
        for _ in range(copies[i]):
            ox[j], oy[j], ovx[j], ovy[j], ow[j] = xi, yi, vxi, vyi, wi
            j += 1
