"""The paper's people motion in sampling form (Batista & Pereira 2015, Sect. 3.1.1, eqs. 5-9): :class:`PaperSampling`,
its reference form in numpy and its compiled pass.

Over a step of ``dt`` a person stays put with probability ``p_stationary``; otherwise they walk at a speed ``s`` ~
N(mu, sigma) truncated to [0, v_max] in a uniform direction (the same :class:`~gridbridge.PeopleMotion` the grid turns
into a kernel). The velocity is memoryless (drawn afresh every step). The reference form samples the truncated
normal exactly by inverse CDF,

    s = mu + sigma * Phi^-1( Phi(a) + U (Phi(b) - Phi(a)) ),   a = -mu / sigma,  b = (v_max - mu) / sigma,

which is the density :func:`gridbridge.truncated_speed_pdf`. A particle drawn uniformly in cell k and moved this way
lands in cell c with probability ``T(c <- k)``, the integrated kernel of :func:`gridbridge.people_motion_kernel`
(``form="integrated"``).

The compiled form (:meth:`PaperSampling.drawn_pass`, :func:`paper_move_ego_compact`) draws the same model inside one
pass over the particles from SplitMix64 streams (:mod:`pfpeople.particle.predictor.draws`): the truncated normal by
rejection of ziggurat normals, the direction from a table (same distributions, other draws;
``tests/pfpeople/particle/test_compiled_draws.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy import special

from gridbridge import GridSpec, PeopleMotion
from gridbridge.jit import jit
from pfpeople.particle.predictor import draws
from pfpeople.particle.predictor.passes import BLOCK, Grid, Rows5, Sums4, fill_drops, move_block
from pfpeople.particle.state import ParticleState

__all__ = [
    "PaperSampling",
    "check_sampler",
    "move_paper",
    "paper_move_ego_compact",
    "redraw_in_cells",
    "sample_speeds",
    "sample_velocity_prior",
    "speeds_from_uniform",
]


def check_sampler(motion: object, redraw_in_cell: object, where: str) -> None:
    """``TypeError`` naming ``where`` unless ``motion`` is a :class:`~gridbridge.PeopleMotion` and ``redraw_in_cell``
    a bool (the fields every built-in people sampler has)."""
    if not isinstance(motion, PeopleMotion):
        raise TypeError(f"{where}.motion must be a PeopleMotion, got {type(motion).__name__}")
    if not isinstance(redraw_in_cell, bool):
        raise TypeError(f"{where}.redraw_in_cell must be a bool, got {type(redraw_in_cell).__name__}")


@dataclass(frozen=True, kw_only=True)
class PaperSampling:
    """The paper's people motion sampled per particle: stay with ``p_stationary``, else walk at a truncated-normal
    speed in a uniform direction, drawn afresh every step.

    Reference form :meth:`move` (:func:`move_paper`); compiled form :meth:`drawn_pass` (the draws inside the
    kernel), used unless ``redraw_in_cell``.

    Parameters
    ----------
    motion : PeopleMotion
        Table 1 model.
    redraw_in_cell : bool
        Re-draw each particle uniformly in its cell before it moves: the prediction is then an unbiased estimate
        of the linear grid prediction (:class:`gridbridge.components.LinearPrediction`).
    """

    name: ClassVar[str] = "paper"
    motion: PeopleMotion = field(default_factory=PeopleMotion)
    redraw_in_cell: bool = False

    def __post_init__(self) -> None:
        check_sampler(self.motion, self.redraw_in_cell, "PaperSampling")

    @property
    def draws_inside(self) -> bool:
        """Whether the compiled filter runs :meth:`drawn_pass` (not with ``redraw_in_cell``, whose uniforms the
        reference form draws)."""
        return not self.redraw_in_cell

    def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """New memoryless velocities, then the move over ``dt`` s (fields replaced)."""
        move_paper(state, self.motion, dt, rng=rng)

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
        """The people motion of ``state`` over ``dt`` s drawn inside :func:`paper_move_ego_compact` (four 64-bit
        seeds from ``rng``), then the sensor motion of displacement rows ``rows`` (4, S) when ``ego``; the survivors
        written to ``into = (out, cells)``, ``sums = (prior, mass, counts, sq)`` accumulated. Returns the survivors'
        count and the count inside after the people motion."""
        seeds = rng.integers(0, 2**64, size=4, dtype=np.uint64)
        out, cells = into
        walk = draws.walk_of(self.motion)
        return paper_move_ego_compact(state.x, state.y, state.w, seeds, walk, dt, rows, ego, grid, out, cells, sums)


def sample_speeds(motion: PeopleMotion, n: int, *, rng: np.random.Generator) -> NDArray[np.float64]:
    """``n`` walking speeds (m/s) from N(mu, sigma) truncated to [0, v_max], sampled exactly (inverse CDF)."""
    return speeds_from_uniform(motion, rng.random(n))


def speeds_from_uniform(motion: PeopleMotion, u: NDArray[np.float64]) -> NDArray[np.float64]:
    """Walking speeds (m/s) of the truncated normal by inverse CDF from uniforms ``u`` in [0, 1), any shape."""
    lo = special.ndtr(-motion.mu / motion.sigma)
    hi = special.ndtr((motion.v_max - motion.mu) / motion.sigma)
    s = motion.mu + motion.sigma * special.ndtri(lo + u * (hi - lo))
    return np.clip(s, 0.0, motion.v_max, out=s)


def sample_velocity_prior(
    motion: PeopleMotion, n: int, *, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Velocities ``(vx, vy)`` (m/s), each ``(n,)``, from the paper's motion prior.

    Zero with probability ``p_stationary``, else a truncated-normal speed in a uniform direction.
    """
    u = rng.random(n)
    vx = np.zeros(n)
    vy = np.zeros(n)
    p_stat = motion.p_stationary
    if p_stat >= 1.0:
        return vx, vy
    moving = np.flatnonzero(u >= p_stat)
    # Given u >= p_stat, (u - p_stat) / (1 - p_stat) is uniform on [0, 1): it serves as the speed's uniform.
    speed = speeds_from_uniform(motion, (u[moving] - p_stat) / (1.0 - p_stat))
    heading = rng.random(moving.size) * (2.0 * math.pi)
    vx[moving] = speed * np.cos(heading)
    vy[moving] = speed * np.sin(heading)
    return vx, vy


def redraw_in_cells(state: ParticleState, spec: GridSpec, *, rng: np.random.Generator) -> None:
    """Move every particle to a uniform position inside the cell that holds it (fields replaced by new arrays).

    With this, the paper-model prediction of the particles is an unbiased estimate of the linear grid
    prediction with the integrated kernel (the grid forgets where in a cell a person is).
    """
    u, v = spec.to_fractional(state.x, state.y)
    r = rng.random((2, state.size))
    state.x, state.y = spec.cell_centre(np.floor(u) + r[0] - 0.5, np.floor(v) + r[1] - 0.5)


def move_paper(state: ParticleState, motion: PeopleMotion, dt: float, *, rng: np.random.Generator) -> None:
    """The paper's people motion, sampled per particle: new memoryless velocity, then move.

    The state's fields are replaced by new arrays (the old arrays are not written to).
    """
    vx, vy = sample_velocity_prior(motion, state.size, rng=rng)
    state.vx, state.vy = vx, vy
    state.x = state.x + vx * dt
    state.y = state.y + vy * dt


# ---------------------------------------------------------------- the compiled form: drawn inside one pass


@jit
def _block_walkers(
    keys: NDArray[np.uint64],
    k0: int,
    w0: int,
    walk: draws.WalkParams,
    state: np.uint64,
    scratch: NDArray[np.float64],
    m: int,
    widx: NDArray[np.intp],
) -> tuple[np.uint64, int]:
    """The people-motion velocities (m/s) of particles ``k0, ..., k0 + m - 1`` (one block) into ``scratch[0:2, :m]``.

    Particle k walks when draw k of the stream ``keys[0]`` (:func:`draws.hashed`) is at least
    ``p_stationary`` as a uniform. Walker q (counted over the whole pass; ``w0`` before this block) tries draw q
    of ``keys[1]`` as the first normal of its speed and takes draw q of ``keys[2]`` as its direction, in a loop
    without branches (it vectorises); the few speeds that need more words (the ziggurat's slow path, the
    truncation) take them from the sequential stream ``state``. The others get 0. ``widx`` (>= m + 1) is scratch
    space. Returns the new state and walker count.
    """
    thr = math.ceil(walk[0] * 9007199254740992.0)  # u >= p  <=>  top 53 bits >= ceil(p 2^53)
    vx, vy, flag = scratch[0, :m], scratch[1, :m], scratch[2, :m]
    for i in range(m):  # the hashed draws are independent: vectorised
        flag[i] = float(draws.hashed(keys[0], k0 + i) >> np.uint64(11)) >= thr
        vx[i] = 0.0
        vy[i] = 0.0
    nw = 0
    for i in range(m):  # branch-free: every index is written, the walkers' are kept
        widx[nw] = i
        nw += flag[i] != 0.0
    _, mu, sigma, _, z_lo, z_hi = walk
    sp, co, si, ok = scratch[3, :nw], scratch[4, :nw], scratch[5, :nw], scratch[6, :nw]
    for q in range(nw):
        fast, z, _, _ = draws.ziggurat_fast(draws.hashed(keys[1], w0 + q))
        ok[q] = fast and z_lo <= z <= z_hi
        sp[q] = min(max(mu + sigma * z, 0.0), walk[3])
        co[q], si[q] = draws.direction(draws.hashed(keys[2], w0 + q))
    for q in range(nw):
        if ok[q] == 0.0:
            state, sp[q] = draws.speed_from(state, draws.hashed(keys[1], w0 + q), walk)
        vx[widx[q]] = sp[q] * co[q]
        vy[widx[q]] = sp[q] * si[q]
    return state, w0 + nw


@jit
def paper_move_ego_compact(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    seeds: NDArray[np.uint64],
    walk: draws.WalkParams,
    dt: float,
    poses: NDArray[np.float64],
    ego: bool,
    grid: tuple[float, float, float, int, int],
    out: Rows5,
    cells: NDArray[np.intp],
    sums: Sums4,
) -> tuple[int, int]:
    """People motion drawn inside (SplitMix64, :mod:`~pfpeople.particle.predictor.draws`), then sensor motion, of N
    particles in one pass; the ones that leave are dropped (:mod:`~pfpeople.particle.predictor.passes`).

    ``x, y, w`` (N,) are the particles' positions (m) and masses. Particle k stays with probability
    ``p_stationary``, else walks at a truncated-normal speed in a uniform direction (:func:`_block_walkers`;
    ``seeds`` (4,): three stream keys and a sequential state, from the filter's ``Generator``): the same seeds give
    the same result. Blocks of ``BLOCK`` particles: the draws, a vectorised pass of both motions and the cells
    written in place, the sums; then the particles that left are replaced by the last ones (the order of the
    survivors is not kept). ``poses`` (4, S) are the sensor motion's displacement rows, applied when ``ego``;
    ``grid = (x0, y0, resolution, nx, ny)``; ``out`` (x, y, vx, vy, w) and ``cells`` receive the survivors (at least
    N entries each); ``sums = (prior, mass, counts, sq)``, shape (n_cells,) each, accumulate the people prior and the
    survivors' mass, count and squared mass per cell (the last for the effective sample size after the update).

    Returns
    -------
    n : int
        The number of survivors (written to ``out[r][:n]``, ``cells[:n]``).
    n_inside : int
        The number inside the grid after the people motion.
    """
    n = x.size
    scratch = np.empty((8, BLOCK))
    widx = np.empty(BLOCK + 1, dtype=np.intp)
    drops = np.empty(n, dtype=np.intp)
    state = seeds[3]
    nd = n_inside = n_walk = 0
    for b0 in range(0, n, BLOCK):
        m = min(BLOCK, n - b0)
        state, n_walk = _block_walkers(seeds, b0, n_walk, walk, state, scratch, m, widx)
        nd, n_in = move_block(b0, m, (x, y, w), (poses, ego, dt), grid, scratch, (out, cells), sums, drops, nd)
        n_inside += n_in
    return fill_drops(n, drops, nd, out, cells), n_inside
