"""The velocity-persistent people motion (:class:`PersistentSampling`): walkers keep heading and speed; its reference
form in numpy and its two compiled forms.

The grid cannot represent this model (it has no velocity state). A walker keeps heading and speed from step to step
with noise,

    heading += N(0, heading_noise^2 dt),
    speed   += speed_reversion (mu - speed) dt + N(0, speed_noise^2 dt)    (reflected into [0, v_max]),

a walker stops with probability ``p_stop`` per second and a standing person starts with probability ``p_start`` per
second (per step ``1 - (1 - p)^dt``); a person who starts draws speed and heading from the paper's prior
(:mod:`pfpeople.particle.predictor.paper`). Standing is ``vx = vy = 0``.

Forms:

* :func:`move_persistent` (reference, numpy);
* :func:`move_persistent_compiled` (:meth:`PersistentSampling.move_compiled`): the kernels :func:`persistent_walk` and
  :func:`persistent_velocities` make the same draws from the filter's ``Generator`` (numba runs numpy's algorithms
  on the same bit generator) and the same arithmetic: the reference form's particles bit for bit;
* :func:`persistent_move_ego_compact` (:meth:`PersistentSampling.drawn_pass`, with ``compiled_draws``): the model drawn
  inside one pass with the sensor motion, from SplitMix64 streams (:mod:`pfpeople.particle.predictor.draws`): the
  same distributions, other draws, and no normal draw for a particle that stands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from gridbridge import PeopleMotion
from gridbridge.jit import jit
from gridbridge.validation import check_positive, check_probability
from pfpeople.particle.predictor import draws
from pfpeople.particle.predictor.paper import check_sampler, sample_speeds, speeds_from_uniform
from pfpeople.particle.predictor.passes import BLOCK, Grid, Rows5, Sums4, fill_drops, move_block
from pfpeople.particle.state import ParticleState

__all__ = [
    "PersistentMotion",
    "PersistentSampling",
    "move_persistent",
    "move_persistent_compiled",
    "persist_params",
    "persistent_move_ego_compact",
    "persistent_velocities",
    "persistent_walk",
]


@dataclass(frozen=True, kw_only=True)
class PersistentMotion:
    """Parameters of the velocity-persistent people motion model (see the module docstring).

    Parameters
    ----------
    heading_noise : float
        Heading random walk intensity (rad / sqrt(s)): heading sd after 1 s of walking.
    speed_noise : float
        Speed noise intensity (m/s / sqrt(s)).
    speed_reversion : float
        Rate (1/s) at which speed relaxes towards ``PeopleMotion.mu``; 0 gives a pure random walk.
    p_stop : float
        Probability per second that a walking person stops.
    p_start : float
        Probability per second that a standing person starts walking.

    Notes
    -----
    ``heading_noise = 1.0`` (57 deg after 1 s, 18 deg per 0.1 s step) and ``p_stop = p_start = 0.5`` (were 0.5,
    0.2, 0.2) were chosen with the recommended particle filter's tracks (``pfpeople run`` with ``[filter] kind =
    "particle"`` on the scan-level scenes, the ETH/UCY replays as the benchmark replays them): MOTA of the tracks,
    mean over the particle filter's seeds 0, 1, 2::

        heading, p_stop = p_start   eth    hotel  zara01  wheelchair  corridor  crowd
        0.5, 0.2                    .753   .524   .640    .542        .827      .716
        1.0, 0.2                    .754   .576   .656    .558        .835      .718
        1.5, 0.2                    .757   .538   .669    .545        .825      .714 (crowd: seeds 0, 1)
        1.0, 0.3 (seed 1)           .789   .556   .672    .548        .846      .711
        **1.0, 0.5**                .799   .612   .666    .573        .844      .729
        1.0, 1.0 (seed 1)           .711   .597   .631    .559        .514      -

    (seed 1 of 1.0, 0.5: .813, .597, .662, .587, .845, .733.) At 1.0 per second the corridor's people found
    fall to a precision of 0.87 (0.99 at 0.5): too many particles change mode every step for a blob to stay
    compact. With the paper's memoryless model instead (a new direction every step), the same filter's tracks
    gave .478, .290, .442, .377, .479, .446 (seed 0).
    """

    heading_noise: float = 1.0
    speed_noise: float = 0.3
    speed_reversion: float = 0.5
    p_stop: float = 0.5
    p_start: float = 0.5

    def __post_init__(self) -> None:
        check_positive(self.heading_noise, "PersistentMotion.heading_noise", allow_zero=True)
        check_positive(self.speed_noise, "PersistentMotion.speed_noise", allow_zero=True)
        check_positive(self.speed_reversion, "PersistentMotion.speed_reversion", allow_zero=True)
        check_probability(self.p_stop, "PersistentMotion.p_stop")
        check_probability(self.p_start, "PersistentMotion.p_start")


@dataclass(frozen=True, kw_only=True)
class PersistentSampling:
    """Velocity-persistent people motion: walkers keep heading and speed with noise, stop and start at rates.

    Reference form :meth:`move`; compiled forms :meth:`move_compiled` (the same draws, bit for bit) and, with
    ``compiled_draws`` and without ``redraw_in_cell``, :meth:`drawn_pass` (the draws inside the kernel).

    Parameters
    ----------
    motion : PeopleMotion
        The paper's prior: the speed a walker relaxes to, ``v_max``, the velocities of those who start.
    persistent : PersistentMotion
        The persistence (heading and speed noise, stop and start rates).
    redraw_in_cell : bool
        Re-draw each particle uniformly in its cell before it moves.
    compiled_draws : bool
        With the compiled kernels (:func:`gridbridge.jit.enabled`, no re-draw in cells), draw the people motion, the
        births and the sensor motion's noise inside them, as for :class:`~pfpeople.particle.predictor.paper.
        PaperSampling` (:meth:`drawn_pass`): the same distributions, other draws than the reference form's, and no
        normal draw for a particle that stands. False (default): the reference form's draws, bit for bit.
    """

    name: ClassVar[str] = "persistent"
    motion: PeopleMotion = field(default_factory=PeopleMotion)
    persistent: PersistentMotion = field(default_factory=PersistentMotion)
    redraw_in_cell: bool = False
    compiled_draws: bool = False

    def __post_init__(self) -> None:
        check_sampler(self.motion, self.redraw_in_cell, "PersistentSampling")
        if not isinstance(self.compiled_draws, bool):
            raise TypeError(
                f"PersistentSampling.compiled_draws must be a bool, got {type(self.compiled_draws).__name__}"
            )
        if not isinstance(self.persistent, PersistentMotion):
            raise TypeError(
                f"PersistentSampling.persistent must be a PersistentMotion, got {type(self.persistent).__name__}"
            )

    @property
    def draws_inside(self) -> bool:
        """Whether the compiled filter runs :meth:`drawn_pass`: ``compiled_draws`` without ``redraw_in_cell``."""
        return self.compiled_draws and not self.redraw_in_cell

    def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """Velocities carried on with noise, then the move over ``dt`` s (fields replaced)."""
        move_persistent(state, self.motion, self.persistent, dt, rng=rng)

    def move_compiled(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """:meth:`move` with the compiled kernels: the same draws and particles, bit for bit."""
        move_persistent_compiled(state, self.motion, self.persistent, dt, rng=rng)

    def drawn_pass(
        self,
        state: ParticleState,
        dt: float,
        rows: NDArray[np.float64],
        ego: bool,
        grid: Grid,
        into: tuple[Rows5, NDArray[np.intp]],
        sums: Sums4,
        *,
        rng: np.random.Generator,
    ) -> tuple[int, int]:
        """The people motion drawn inside :func:`persistent_move_ego_compact` (four 64-bit seeds from ``rng``), then
        the sensor motion; arguments and returns as
        :meth:`pfpeople.particle.predictor.paper.PaperSampling.drawn_pass`."""
        seeds = rng.integers(0, 2**64, size=4, dtype=np.uint64)
        out, cells = into
        walk = draws.walk_of(self.motion)
        src = (state.x, state.y, state.vx, state.vy, state.w)
        persist = persist_params(self.persistent, dt)
        return persistent_move_ego_compact(src, seeds, walk, persist, rows, ego, grid, out, cells, sums)


def persist_params(params: PersistentMotion, dt: float) -> tuple[float, float, float, float, float, float]:
    """The persistent people motion over ``dt`` s as :func:`persistent_move_ego_compact` takes it: ``(p_stop, p_start,
    heading_noise sqrt(dt), speed_reversion, dt, speed_noise sqrt(dt))`` (per-step probabilities)."""
    sqdt = math.sqrt(dt)
    rates = (1.0 - (1.0 - params.p_stop) ** dt, 1.0 - (1.0 - params.p_start) ** dt)
    return (*rates, params.heading_noise * sqdt, params.speed_reversion, float(dt), params.speed_noise * sqdt)


def move_persistent(
    state: ParticleState,
    motion: PeopleMotion,
    params: PersistentMotion,
    dt: float,
    *,
    rng: np.random.Generator,
) -> None:
    """The velocity-persistent people motion in numpy (fields replaced by new arrays; see the module docstring):
    the reference form, drawing from ``rng`` N uniforms, then N heading and N speed normals, then the starters' speed
    and heading uniforms."""
    n = state.size
    speed = np.hypot(state.vx, state.vy)
    heading = np.arctan2(state.vy, state.vx)
    walking = speed > 0.0
    u = rng.random(n)
    p_stop = 1.0 - (1.0 - params.p_stop) ** dt
    p_start = 1.0 - (1.0 - params.p_start) ** dt
    stops = walking & (u < p_stop)
    starts = ~walking & (u < p_start)
    noise = rng.standard_normal((2, n))
    sqdt = math.sqrt(dt)
    heading = heading + params.heading_noise * sqdt * noise[0]
    speed = speed + params.speed_reversion * (motion.mu - speed) * dt + params.speed_noise * sqdt * noise[1]
    speed = np.abs(speed)  # reflect at 0 ...
    speed = np.where(speed > motion.v_max, 2.0 * motion.v_max - speed, speed)  # ... and at v_max
    speed = np.clip(speed, 0.0, motion.v_max)
    new_idx = np.flatnonzero(starts)
    fresh_speed = sample_speeds(motion, new_idx.size, rng=rng)
    fresh_heading = rng.random(new_idx.size) * (2.0 * math.pi)
    speed[new_idx] = fresh_speed
    heading[new_idx] = fresh_heading
    stand = stops | ~(walking | starts)
    state.vx = np.where(stand, 0.0, speed * np.cos(heading))  # +0 where standing (never -0)
    state.vy = np.where(stand, 0.0, speed * np.sin(heading))
    state.x = state.x + state.vx * dt
    state.y = state.y + state.vy * dt


def move_persistent_compiled(
    state: ParticleState,
    motion: PeopleMotion,
    params: PersistentMotion,
    dt: float,
    *,
    rng: np.random.Generator,
) -> None:
    """:func:`move_persistent` with the kernels :func:`persistent_walk` (which makes the draws from ``rng``) and
    :func:`persistent_velocities`: the same draws in the same order and the same particles bit for bit."""
    heading = np.arctan2(state.vy, state.vx)  # numpy's (its SIMD atan2 is not the C library's)
    rates = (1.0 - (1.0 - params.p_stop) ** dt, 1.0 - (1.0 - params.p_start) ** dt)
    sqdt = math.sqrt(dt)
    walk = (
        float(params.heading_noise * sqdt),
        float(params.speed_reversion),
        float(motion.mu),
        float(dt),
        float(params.speed_noise * sqdt),
        float(motion.v_max),
    )
    speed, heading, new_idx, zero, u_speed = persistent_walk(rng, state.vx, state.vy, heading, rates, walk)
    speed[new_idx] = speeds_from_uniform(motion, u_speed)
    out = persistent_velocities(state.x, state.y, speed, heading, zero, float(dt))
    state.x, state.y, state.vx, state.vy = out[0], out[1], out[2], out[3]


# ---------------------------------------------------------------- compiled: the reference form's draws


@jit
def persistent_walk(
    g: np.random.Generator,
    vx: NDArray[np.float64],
    vy: NDArray[np.float64],
    heading: NDArray[np.float64],
    rates: tuple[float, float],
    walk: tuple[float, float, float, float, float, float],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.bool_], NDArray[np.float64]]:
    """:func:`move_persistent`'s walk and its draws from ``g``, bit for bit: numba's
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
        The starters' speed uniforms (:func:`~pfpeople.particle.predictor.paper.speeds_from_uniform`).
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
    """The end of :func:`move_persistent`, bit for bit: the velocities
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


# ---------------------------------------------------------------- compiled: drawn inside one pass


@jit
def _block_persistent(
    keys: NDArray[np.uint64],
    k0: int,
    v: tuple[NDArray[np.float64], NDArray[np.float64]],
    walk: draws.WalkParams,
    persist: tuple[float, float, float, float, float, float],
    state: np.uint64,
    scratch: NDArray[np.float64],
    m: int,
) -> np.uint64:
    """The persistent people motion's velocities (m/s) of particles ``k0, ..., k0 + m - 1`` into
    ``scratch[0:2, :m]``, drawn here (:func:`move_persistent`'s model).

    Particle k's uniform is draw k of the stream ``keys[0]``: a walker (``v`` nonzero) stops below ``p_stop``, else
    turns by ``heading_noise sqrt(dt)`` and its speed relaxes to ``mu`` with ``speed_noise sqrt(dt)`` (two normals
    of the sequential stream ``state``; reflected into [0, v_max]); a standing particle starts below ``p_start``
    with a velocity of the paper's prior (:func:`draws.walker_velocity` on ``state``). Only walkers and
    starters draw normals. ``persist = (p_stop, p_start, heading_noise sqrt(dt), speed_reversion, dt,
    speed_noise sqrt(dt))`` (per-step probabilities). Returns the new state.
    """
    p_stop, p_start, hn, sr, dt, sn = persist
    mu, vmax = walk[1], walk[3]
    vx, vy = scratch[0, :m], scratch[1, :m]
    for i in range(m):
        a, b = v[0][k0 + i], v[1][k0 + i]
        s = math.hypot(a, b)
        u = draws.uniform(draws.hashed(keys[0], k0 + i))
        vx[i], vy[i] = 0.0, 0.0
        if s > 0.0 and u >= p_stop:
            state, z1 = draws.standard_normal(state)
            state, z2 = draws.standard_normal(state)
            s = abs(s + sr * (mu - s) * dt + sn * z2)
            s = min(max(2.0 * vmax - s if s > vmax else s, 0.0), vmax)
            sin_h, cos_h = draws.sincos(math.atan2(b, a) + hn * z1)
            vx[i], vy[i] = s * cos_h, s * sin_h
        elif s == 0.0 and u < p_start:
            state, a, b = draws.walker_velocity(state, walk)
            vx[i], vy[i] = a, b
    return state


@jit
def persistent_move_ego_compact(
    src: Rows5,
    seeds: NDArray[np.uint64],
    walk: draws.WalkParams,
    persist: tuple[float, float, float, float, float, float],
    poses: NDArray[np.float64],
    ego: bool,
    grid: tuple[float, float, float, int, int],
    out: Rows5,
    cells: NDArray[np.intp],
    sums: Sums4,
) -> tuple[int, int]:
    """:func:`~pfpeople.particle.predictor.paper.paper_move_ego_compact` with the persistent people motion drawn
    inside (:func:`_block_persistent`): the same distributions as :func:`move_persistent`, other draws, no normal draw
    for a particle that stands.

    ``src = (x, y, vx, vy, w)`` are the particles (m, m, m/s, m/s, mass); ``seeds`` (4,): stream keys (the first
    used) and the sequential state, from the filter's ``Generator``; ``persist`` as :func:`_block_persistent`'s (its
    ``dt`` the step's, s); the rest and the returns as
    :func:`~pfpeople.particle.predictor.paper.paper_move_ego_compact`'s.
    """
    n, dt = src[0].size, persist[4]
    scratch = np.empty((8, BLOCK))
    drops = np.empty(n, dtype=np.intp)
    state = seeds[3]
    nd = n_inside = 0
    v, xyw = (src[2], src[3]), (src[0], src[1], src[4])
    for b0 in range(0, n, BLOCK):
        m = min(BLOCK, n - b0)
        state = _block_persistent(seeds, b0, v, walk, persist, state, scratch, m)
        nd, n_in = move_block(b0, m, xyw, (poses, ego, dt), grid, scratch, (out, cells), sums, drops, nd)
        n_inside += n_in
    return fill_drops(n, drops, nd, out, cells), n_inside
