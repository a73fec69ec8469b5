"""Compiled kernels of the particle-filter step (:mod:`gridbridge.jit`): the paper's people motion drawn inside and the
systematic resampling without a sort (same distributions as the numpy code, other draws), the rest bit-identical.

Each kernel is one pass over the particles doing the work of several numpy calls. Two kinds:

* **Drawing inside** (:func:`paper_move_ego_compact`, :func:`persistent_move_ego_compact`, :func:`born_particles`,
  :func:`ego_rows_drawn`) and **resampling without a sort** (:func:`cell_systematic_ancestors` with
  :func:`gather_ancestors`, after :func:`scale_sums`): the people motion of
  :class:`~pfpeople.particle.components.PaperSampling` (stay or walk, truncated-normal speed, uniform heading) and of
  ``PersistentSampling(compiled_draws=True)``, the births' positions and velocities and the sensor motion's noise
  make their draws in the kernel from SplitMix64 streams seeded by the filter's ``Generator``
  (:mod:`pfpeople.particle.rng_kernels`); the systematic resampling by cell takes its uniforms from the
  ``Generator`` as the numpy code does but finds each cell's forced ancestor on the running sums in particle order,
  not in the particles sorted by cell. The distributions are the numpy path's, the draws are not: a seeded filter
  is deterministic on either path but the two paths give different particles
  (``tests/pfpeople/particle/test_compiled_draws.py`` tests the distributions and the filter's belief).
* **Bit-identical** to the numpy code (the other people-motion samplers, the sensor motion's poses, the other
  resampling schemes), the random draws made with numpy's ``Generator`` in the same order, by the caller or in the
  kernel (numba runs the ``Generator``'s own algorithms: :func:`persistent_walk`, :func:`ego_rows_from`): every kernel
  does the same IEEE operations in the same order as the numpy code it replaces: cell sums accumulate
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
from pfpeople.particle import rng_kernels as rng

#: Five particle arrays x, y, vx, vy, w (m, m, m/s, m/s, mass), each of shape (C,) (numba: a UniTuple).
Rows5 = tuple[NDArray[np.float64], ...]
#: Per-cell sums of a prediction, shape (n_cells,) each: people prior, mass, count and squared mass.
_Sums4 = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.float64]]

__all__ = [
    "accumulate",
    "born_particles",
    "cell",
    "cell_mass",
    "cell_systematic_ancestors",
    "ego_compact",
    "ego_rows",
    "ego_rows_drawn",
    "ego_rows_from",
    "forced_ancestors",
    "gather_ancestors",
    "gather_resampled",
    "move_ego_compact",
    "paper_move_ego_compact",
    "people_prior",
    "persistent_move_ego_compact",
    "persistent_velocities",
    "persistent_walk",
    "scale_sums",
    "systematic_into",
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
def _ego_row(
    e: tuple[float, float, float],
    sd: NDArray[np.float64],
    control: tuple[float, float, float],
    dt: float,
    eps: float,
    libm: bool,
) -> tuple[float, float, float, float]:
    """One sampled sensor displacement (eqs. 10-11) from its three standard normal draws ``e``: ``(dx, dy,
    cos(dtheta), sin(dtheta))`` (:func:`pfpeople.particle.propagation.sample_ego_poses`'s arithmetic; arguments as
    :func:`ego_rows`), with the C library's sine and cosine (``libm``, numpy's) or :func:`rng_kernels.sincos`."""
    v0, w0, vy = control
    v = v0 + e[0] * sd[0]
    w = w0 + e[1] * sd[1]
    gamma = e[2] * sd[2]
    if abs(w) > eps:
        sw, cw = (math.sin(w * dt), math.cos(w * dt)) if libm else rng.sincos(w * dt)
        dx, dy = v / w * sw, v / w * (1.0 - cw)
        if vy != 0.0:
            dx, dy = dx - vy / w * (1.0 - cw), dy + vy / w * sw
    else:
        dx, dy = v * dt, 0.0
        if vy != 0.0:
            dx, dy = dx - 0.0, dy + vy * dt
    th = (w + gamma) * dt
    st, ct = (math.sin(th), math.cos(th)) if libm else rng.sincos(th)
    return dx, dy, ct, st


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
    n = e.shape[1]
    out = np.empty((4, n))
    for k in range(n):
        out[0, k], out[1, k], out[2, k], out[3, k] = _ego_row((e[0, k], e[1, k], e[2, k]), sd, control, dt, eps, True)
    return out


@jit
def ego_rows_from(
    g: np.random.Generator, n: int, sd: NDArray[np.float64], control: tuple[float, float, float], dt: float, eps: float
) -> NDArray[np.float64]:
    """:func:`ego_rows` of ``n`` displacements whose draws ``g.standard_normal((3, n))`` are made here, bit for bit
    numpy's (numba's ``Generator`` runs numpy's algorithms on the same bit generator), shape (4, n)."""
    return ego_rows(g.standard_normal((3, n)), sd, control, dt, eps)


@jit
def ego_rows_drawn(
    seed: np.uint64, n: int, sd: NDArray[np.float64], control: tuple[float, float, float], dt: float, eps: float
) -> NDArray[np.float64]:
    """:func:`ego_rows` of ``n`` displacements whose standard normal draws are made here (the ziggurat of
    :func:`rng_kernels.standard_normal` on the SplitMix64 stream ``seed``) and whose sines and cosines are
    :func:`rng_kernels.sincos`'s, shape (4, n)."""
    out = np.empty((4, n))
    state = seed
    for k in range(n):
        state, e0 = rng.standard_normal(state)
        state, e1 = rng.standard_normal(state)
        state, e2 = rng.standard_normal(state)
        out[0, k], out[1, k], out[2, k], out[3, k] = _ego_row((e0, e1, e2), sd, control, dt, eps, False)
    return out


@jit
def persistent_walk(
    g: np.random.Generator,
    vx: NDArray[np.float64],
    vy: NDArray[np.float64],
    heading: NDArray[np.float64],
    rates: tuple[float, float],
    walk: tuple[float, float, float, float, float, float],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.bool_], NDArray[np.float64]]:
    """:func:`pfpeople.particle.propagation.move_persistent`'s walk and its draws from ``g``, bit for bit: numba's
    ``Generator`` runs numpy's algorithms, so ``g`` gives the numpy path's draws in its order (N uniforms, N heading
    and N speed normals, the K starters' speed and heading uniforms) and ends where numpy leaves it.

    Parameters
    ----------
    g : numpy.random.Generator
        The filter's generator (advanced).
    vx, vy, heading : ndarray, shape (N,)
        Velocities (m/s) before the step and ``np.arctan2(vy, vx)`` (numpy's, not always the C library's).
    rates, walk : tuple of float
        ``(p_stop, p_start)`` per step; ``(heading_noise sqrt(dt), speed_reversion, mu, dt, speed_noise sqrt(dt),
        v_max)``.

    Returns
    -------
    speed, heading : ndarray, shape (N,)
        Walked speed (m/s) and heading (rad); the starters' headings drawn, their speeds the caller's.
    starts : ndarray of intp, shape (K,)
        Indices (ascending) of the standing particles that start walking.
    zero : ndarray of bool, shape (N,)
        The particles that stand after the step.
    u_speed : ndarray, shape (K,)
        The starters' speed uniforms (:func:`pfpeople.particle.propagation.speeds_from_uniform`).
    """
    (p_stop, p_start), (hn, sr, mu, dt, sn, vmax), n = rates, walk, vx.size
    u = g.random(n)
    head, speed = np.empty(n), np.empty(n)
    for k in range(n):  # the heading normals (row 0 of the numpy path's (2, N) draw) ...
        head[k] = heading[k] + hn * g.standard_normal()
    zero, starts, n_start = np.zeros(n, dtype=np.bool_), np.empty(n, dtype=np.intp), 0
    for k in range(n):  # ... then the speed normals (row 1)
        s = math.hypot(vx[k], vy[k])
        if s > 0.0:
            zero[k] = u[k] < p_stop
        elif u[k] < p_start:
            starts[n_start] = k
            n_start += 1
        else:
            zero[k] = True
        s = abs(s + sr * (mu - s) * dt + sn * g.standard_normal())
        if s > vmax:
            s = 2.0 * vmax - s
        s = s if s > 0.0 else 0.0  # np.clip(s, 0, v_max)
        speed[k] = s if s < vmax else vmax
    u_speed = g.random(n_start)
    for i in range(n_start):
        head[starts[i]] = g.random() * (2.0 * math.pi)
    return speed, head, starts[:n_start], zero, u_speed


@jit
def persistent_velocities(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    speed: NDArray[np.float64],
    heading: NDArray[np.float64],
    zero: NDArray[np.bool_],
    dt: float,
) -> NDArray[np.float64]:
    """The end of :func:`pfpeople.particle.propagation.move_persistent`, bit for bit: the velocities
    ``speed (cos, sin)(heading)``, ``(+0, +0)`` where ``zero`` (no trigonometry there), and the moved positions.

    ``speed`` and ``heading`` (N,) hold the new walkers' draws already. Returns rows x, y, vx, vy, shape (4, N).
    """
    n = x.size
    out = np.empty((4, n))
    for k in range(n):
        vx, vy = 0.0, 0.0
        if not zero[k]:
            vx = speed[k] * math.cos(heading[k])
            vy = speed[k] * math.sin(heading[k])
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


# ---------------------------------------------------------------- the paper's people motion, drawn inside


#: Particles per block of :func:`paper_move_ego_compact` (its scratch rows stay in the first-level cache).
_BLOCK = 512
#: Within this distance (in cells) of a cell edge a multiplied cell coordinate is re-checked with the division.
_EDGE_EPS = 2.0**-26


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
def _block_walkers(
    keys: NDArray[np.uint64],
    k0: int,
    w0: int,
    walk: rng.WalkParams,
    state: np.uint64,
    scratch: NDArray[np.float64],
    m: int,
    widx: NDArray[np.intp],
) -> tuple[np.uint64, int]:
    """The people-motion velocities (m/s) of particles ``k0, ..., k0 + m - 1`` (one block) into ``scratch[0:2, :m]``.

    Particle k walks when draw k of the stream ``keys[0]`` (:func:`rng_kernels.hashed`) is at least
    ``p_stationary`` as a uniform. Walker q (counted over the whole pass; ``w0`` before this block) tries draw q
    of ``keys[1]`` as the first normal of its speed and takes draw q of ``keys[2]`` as its direction, in a loop
    without branches (it vectorises); the few speeds that need more words (the ziggurat's slow path, the
    truncation) take them from the sequential stream ``state``. The others get 0. ``widx`` (>= m + 1) is scratch
    space. Returns the new state and walker count.
    """
    thr = math.ceil(walk[0] * 9007199254740992.0)  # u >= p  <=>  top 53 bits >= ceil(p 2^53)
    vx, vy, flag = scratch[0, :m], scratch[1, :m], scratch[2, :m]
    for i in range(m):  # the hashed draws are independent: vectorised
        flag[i] = float(rng.hashed(keys[0], k0 + i) >> np.uint64(11)) >= thr
        vx[i] = 0.0
        vy[i] = 0.0
    nw = 0
    for i in range(m):  # branch-free: every index is written, the walkers' are kept
        widx[nw] = i
        nw += flag[i] != 0.0
    _, mu, sigma, _, z_lo, z_hi = walk
    sp, co, si, ok = scratch[3, :nw], scratch[4, :nw], scratch[5, :nw], scratch[6, :nw]
    for q in range(nw):
        fast, z, _, _ = rng.ziggurat_fast(rng.hashed(keys[1], w0 + q))
        ok[q] = fast and z_lo <= z <= z_hi
        sp[q] = min(max(mu + sigma * z, 0.0), walk[3])
        co[q], si[q] = rng.direction(rng.hashed(keys[2], w0 + q))
    for q in range(nw):
        if ok[q] == 0.0:
            state, sp[q] = rng.speed_from(state, rng.hashed(keys[1], w0 + q), walk)
        vx[widx[q]] = sp[q] * co[q]
        vy[widx[q]] = sp[q] * si[q]
    return state, w0 + nw


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

    ``src = (x, y, w)`` are the particles (m, m, mass), ``poses`` (4, S) :func:`move_ego_compact`'s. The scratch
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
    sums: _Sums4,
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
def _fill_drops(n: int, drops: NDArray[np.intp], nd: int, out: Rows5, cells: NDArray[np.intp]) -> int:
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
def paper_move_ego_compact(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    seeds: NDArray[np.uint64],
    walk: rng.WalkParams,
    dt: float,
    poses: NDArray[np.float64],
    ego: bool,
    grid: tuple[float, float, float, int, int],
    out: Rows5,
    cells: NDArray[np.intp],
    sums: _Sums4,
) -> tuple[int, int]:
    """:func:`move_ego_compact` with the paper's people motion drawn inside (SplitMix64, :mod:`rng_kernels`).

    Particle k stays with probability ``p_stationary``, else walks at a truncated-normal speed in a uniform
    direction (:func:`_block_walkers`; ``seeds`` (4,): three stream keys and a sequential state, from the filter's
    ``Generator``): the same seeds give the same result. Blocks of ``_BLOCK`` particles: the draws, a vectorised
    pass of both motions and the cells written in place, the sums; then the particles that left are replaced by the
    last ones (the order of the survivors is not kept). ``poses`` (4, S), ``ego``, ``grid``, ``out`` and ``cells``
    as there (``out`` and ``cells`` of at least N entries); ``sums = (prior, mass, counts, sq)``, shape (n_cells,)
    each, accumulate the people prior and the survivors' mass, count and squared mass per cell (the last for the
    effective sample size after the update).

    Returns
    -------
    n : int
        The number of survivors (written to ``out[r][:n]``, ``cells[:n]``).
    n_inside : int
        The number inside the grid after the people motion.
    """
    n = x.size
    scratch = np.empty((8, _BLOCK))
    widx = np.empty(_BLOCK + 1, dtype=np.intp)
    drops = np.empty(n, dtype=np.intp)
    state = seeds[3]
    nd = n_inside = n_walk = 0
    for b0 in range(0, n, _BLOCK):
        m = min(_BLOCK, n - b0)
        state, n_walk = _block_walkers(seeds, b0, n_walk, walk, state, scratch, m, widx)
        nd, n_in = _move_block(b0, m, (x, y, w), (poses, ego, dt), grid, scratch, (out, cells), sums, drops, nd)
        n_inside += n_in
    return _fill_drops(n, drops, nd, out, cells), n_inside


@jit
def _move_block(
    b0: int,
    m: int,
    src: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    motion: tuple[NDArray[np.float64], bool, float],
    grid: tuple[float, float, float, int, int],
    scratch: NDArray[np.float64],
    into: tuple[Rows5, NDArray[np.intp]],
    sums: _Sums4,
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


@jit
def _block_persistent(
    keys: NDArray[np.uint64],
    k0: int,
    v: tuple[NDArray[np.float64], NDArray[np.float64]],
    walk: rng.WalkParams,
    persist: tuple[float, float, float, float, float, float],
    state: np.uint64,
    scratch: NDArray[np.float64],
    m: int,
) -> np.uint64:
    """The persistent people motion's velocities (m/s) of particles ``k0, ..., k0 + m - 1`` into
    ``scratch[0:2, :m]``, drawn here (:func:`pfpeople.particle.propagation.move_persistent`'s model).

    Particle k's uniform is draw k of the stream ``keys[0]``: a walker (``v`` nonzero) stops below ``p_stop``, else
    turns by ``heading_noise sqrt(dt)`` and its speed relaxes to ``mu`` with ``speed_noise sqrt(dt)`` (two normals
    of the sequential stream ``state``; reflected into [0, v_max]); a standing particle starts below ``p_start``
    with a velocity of the paper's prior (:func:`rng_kernels.walker_velocity` on ``state``). Only walkers and
    starters draw normals. ``persist = (p_stop, p_start, heading_noise sqrt(dt), speed_reversion, dt,
    speed_noise sqrt(dt))`` (per-step probabilities). Returns the new state.
    """
    p_stop, p_start, hn, sr, dt, sn = persist
    mu, vmax = walk[1], walk[3]
    vx, vy = scratch[0, :m], scratch[1, :m]
    for i in range(m):
        a, b = v[0][k0 + i], v[1][k0 + i]
        s = math.hypot(a, b)
        u = rng.uniform(rng.hashed(keys[0], k0 + i))
        vx[i], vy[i] = 0.0, 0.0
        if s > 0.0 and u >= p_stop:
            state, z1 = rng.standard_normal(state)
            state, z2 = rng.standard_normal(state)
            s = abs(s + sr * (mu - s) * dt + sn * z2)
            s = min(max(2.0 * vmax - s if s > vmax else s, 0.0), vmax)
            sin_h, cos_h = rng.sincos(math.atan2(b, a) + hn * z1)
            vx[i], vy[i] = s * cos_h, s * sin_h
        elif s == 0.0 and u < p_start:
            state, a, b = rng.walker_velocity(state, walk)
            vx[i], vy[i] = a, b
    return state


@jit
def persistent_move_ego_compact(
    src: Rows5,
    seeds: NDArray[np.uint64],
    walk: rng.WalkParams,
    persist: tuple[float, float, float, float, float, float],
    poses: NDArray[np.float64],
    ego: bool,
    grid: tuple[float, float, float, int, int],
    out: Rows5,
    cells: NDArray[np.intp],
    sums: _Sums4,
) -> tuple[int, int]:
    """:func:`paper_move_ego_compact` with the persistent people motion drawn inside (:func:`_block_persistent`):
    the same distributions as :func:`pfpeople.particle.propagation.move_persistent`, other draws, no normal draw
    for a particle that stands.

    ``src = (x, y, vx, vy, w)`` are the particles (m, m, m/s, m/s, mass); ``seeds`` (4,): stream keys (the first
    used) and the sequential state, from the filter's ``Generator``; ``persist`` as :func:`_block_persistent`'s (its
    ``dt`` the step's, s); the rest and the returns as :func:`paper_move_ego_compact`'s.
    """
    n, dt = src[0].size, persist[4]
    scratch = np.empty((8, _BLOCK))
    drops = np.empty(n, dtype=np.intp)
    state = seeds[3]
    nd = n_inside = 0
    v, xyw = (src[2], src[3]), (src[0], src[1], src[4])
    for b0 in range(0, n, _BLOCK):
        m = min(_BLOCK, n - b0)
        state = _block_persistent(seeds, b0, v, walk, persist, state, scratch, m)
        nd, n_in = _move_block(b0, m, xyw, (poses, ego, dt), grid, scratch, (out, cells), sums, drops, nd)
        n_inside += n_in
    return _fill_drops(n, drops, nd, out, cells), n_inside


# ---------------------------------------------------------------- the filter's update and systematic resampling


@jit
def scale_sums(
    w: NDArray[np.float64],
    cells: NDArray[np.intp],
    factor: NDArray[np.float64],
    out: NDArray[np.float64],
    n_cells: int,
) -> tuple[NDArray[np.float64], float, float, int]:
    """``out = w * factor[cells]`` (the particles' share of their cell's posterior, eq. 12) and the sums the
    resampling needs, in one pass (the cell sums in particle order, as ``np.bincount``).

    Returns
    -------
    mass : ndarray, shape (n_cells,)
        The new weights summed per cell.
    total, sum_sq : float
        Their sum and sum of squares (the effective sample size is ``total^2 / sum_sq``).
    status : int
        0 ok, 1 a weight negative or not finite, 2 a cell outside ``[0, n_cells)`` (the sums are then incomplete).
    """
    mass = np.zeros(n_cells)
    total = sum_sq = 0.0
    for k in range(w.size):
        c = cells[k]
        if c < 0 or c >= n_cells:
            return mass, total, sum_sq, 2
        wk = w[k] * factor[c]
        if not (wk >= 0.0 and wk < np.inf):
            return mass, total, sum_sq, 1
        out[k] = wk
        mass[c] += wk
        total += wk
        sum_sq += wk * wk
    return mass, total, sum_sq, 0


@jit
def cell_systematic_ancestors(
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    factor: NDArray[np.float64],
    draws: tuple[NDArray[np.float64], float, int, float],
    anc: NDArray[np.intp],
    forced: NDArray[np.intp],
    n_new: NDArray[np.intp],
) -> None:
    """The draws of :func:`pfpeople.particle.resampling.resample_by_cell` (systematic) in one pass, without a sort.

    The particles' weights are ``w[i] factor[cells[i]]``; ``draws = (target, total, m, off)``. The forced ancestor of
    cell c is the first particle (in particle order) at which the cell's running sum exceeds ``target[c]``
    (``u_c M_c``; ``inf`` for a cell without mass), else (round-off) the cell's last particle of positive weight:
    particle i of c with probability ``w_i / M_c``, as the numpy code's search in the sorted cell. The ``m``
    systematic ancestors (positions ``(k + off) / m`` on the running sum over all particles, of sum ``total``; the
    last particle takes what round-off leaves) are written, sorted, to ``anc[K:K + m]`` (K = ``anc.size - m - 3``;
    the 3 entries after them are room: each particle is written three times without a branch, the next
    overwriting what it does not own).

    ``forced`` (n_cells,) must hold -1 and receives the forced ancestors, ``n_new`` (n_cells,) must hold the forced
    count per cell (1 or 0) and receives the new particles per cell.
    """
    target, total, m, off = draws
    n, k = w.size, anc.size - m - 3
    rem = target.copy()  # the target less the cell's running sum; inf once the cell has its forced ancestor
    scale = m / total
    acc, prev = 0.0, 0
    for i in range(n):
        c = cells[i]
        wi = w[i] * factor[c]
        acc += wi
        below = min(max(math.ceil(acc * scale - off), 0), m)
        anc[k + prev], anc[k + prev + 1], anc[k + prev + 2] = i, i, i
        for t in range(k + prev + 3, k + below):  # a fourth copy and more: rare
            anc[t] = i
        n_new[c] += below - prev
        prev = below
        r = rem[c] - wi
        rem[c] = r
        if r < 0.0:  # taken once per cell
            forced[c], rem[c] = i, np.inf
    if n and prev < m:  # round-off left positions above the last running sum: the last particle's
        anc[k + prev : k + m] = n - 1
        n_new[cells[n - 1]] += m - prev
    _forced_fallback(cells, w, factor, target, forced)


@jit
def _forced_fallback(
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    factor: NDArray[np.float64],
    target: NDArray[np.float64],
    forced: NDArray[np.intp],
) -> None:
    """The cells with mass (finite ``target``) whose running sum never passed the target (it was computed from sums
    rounded otherwise): their last particle of positive weight as the forced ancestor (one pass from the end,
    only when some cell needs it)."""
    missing = 0
    for c in range(target.size):
        missing += forced[c] < 0 and target[c] < np.inf
    i = cells.size - 1
    while missing > 0 and i >= 0:
        c = cells[i]
        if forced[c] < 0 and target[c] < np.inf and w[i] * factor[c] > 0.0:
            forced[c] = i
            missing -= 1
        i -= 1


@jit
def gather_ancestors(
    anc: NDArray[np.intp],
    cells: NDArray[np.intp],
    src: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    share: NDArray[np.float64],
    out: Rows5,
) -> None:
    """The resampled particles: ``x[anc], y[anc], vx[anc], vy[anc]`` and the weights ``share[cells[anc]]`` (each
    cell's mass over its new count) into ``out`` (x, y, vx, vy, w; ``anc.size`` entries each)."""
    x, y, vx, vy = src
    ox, oy, ovx, ovy, ow = out
    for t in range(anc.size):
        a = anc[t]
        ox[t], oy[t], ovx[t], ovy[t], ow[t] = x[a], y[a], vx[a], vy[a], share[cells[a]]


#: Births are kept this far (a fraction of a cell) from their cell's edges (as
#: :func:`pfpeople.particle.state.uniform_in_cells`).
_BIRTH_EDGE = 1e-9


@jit
def born_particles(
    cells: NDArray[np.intp],
    seeds: NDArray[np.uint64],
    walk: rng.WalkParams,
    grid: tuple[float, float, float, int, int],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """New particles in ``cells`` (flat, in the grid): positions uniform in the cell, velocities from the paper's
    prior, drawn inside (:mod:`rng_kernels`; ``seeds`` (4,) as :func:`paper_move_ego_compact`'s).

    Returns ``x, y, vx, vy`` (m, m/s), shape (K,) each: :meth:`pfpeople.ParticleFilter._born`'s distribution
    (:func:`pfpeople.particle.state.uniform_in_cells`, :func:`pfpeople.particle.propagation.sample_velocity_prior`).
    """
    x0, y0, res, _, ny = grid
    n = cells.size
    x, y, vx, vy = np.empty(n), np.empty(n), np.zeros(n), np.zeros(n)
    thr = math.ceil(walk[0] * 9007199254740992.0)
    state = seeds[3]
    for k in range(n):
        i, j = divmod(cells[k], ny)
        u = min(max(rng.uniform(rng.hashed(seeds[0], 2 * k)), _BIRTH_EDGE), 1.0 - _BIRTH_EDGE)
        v = min(max(rng.uniform(rng.hashed(seeds[0], 2 * k + 1)), _BIRTH_EDGE), 1.0 - _BIRTH_EDGE)
        x[k], y[k] = x0 + (i + u) * res, y0 + (j + v) * res
        if float(rng.hashed(seeds[1], k) >> np.uint64(11)) >= thr:
            state, vx[k], vy[k] = rng.walker_velocity(state, walk)
    return x, y, vx, vy
