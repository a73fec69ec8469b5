"""New particles: where the people motion's prior puts them, and how many the grid's border lets in.

Particles are born in four places: the filter's start (:meth:`pfpeople.ParticleFilter.reset`), the inflow of the
people motion and of the sensor motion across the grid's border (this module), and the empty cells whose posterior
has mass (:mod:`pfpeople.particle.updater`). A newborn is uniform in its cell and draws its velocity from the paper's
prior (:class:`~gridbridge.PeopleMotion`, as Nuss et al.). :class:`Births` draws them as the reference form does
(:func:`~pfpeople.particle.state.uniform_in_cells`, :func:`~pfpeople.particle.predictor.paper.sample_velocity_prior`);
:class:`DrawnBirths` draws the same distribution inside :func:`born_particles` (SplitMix64), beside a people motion
that draws inside its pass.

Inflow (the grid reads belief ``outside`` beyond its border): over a step of ``dt`` the people motion brings
``outside * sum_{k outside} T(c <- k)`` into cell c (the integrated kernel T convolved with an all-zero grid of
border value ``outside``; :meth:`Births.people_inflow`), the sensor motion the grid's warp of an all-zero grid
(:func:`gridbridge.ego_motion.border_inflow`). That mass is born as particles: one in every cell above
:data:`BIRTH_FLOOR` plus a share of the free slots (particles that left) in proportion to its mass; the people
motion's births take half of the free slots, the sensor motion's the rest.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge import GridSpec, PeopleMotion, people_motion_kernel
from gridbridge.ego_motion import border_inflow
from gridbridge.jit import jit
from gridbridge.people_motion import outside_inflow, quantise_dt
from pfpeople.particle.predictor import draws
from pfpeople.particle.predictor.paper import sample_velocity_prior
from pfpeople.particle.predictor.passes import grid_of
from pfpeople.particle.state import ParticleState, uniform_in_cells

__all__ = ["BIRTH_FLOOR", "Births", "DrawnBirths", "born_particles"]

#: Cells whose posterior (or inflow) mass is at most this get no particles.
BIRTH_FLOOR = 1e-12
#: Births are kept this far (a fraction of a cell) from their cell's edges (as :func:`uniform_in_cells`).
_BIRTH_EDGE = 1e-9

_Born = tuple[ParticleState, NDArray[np.intp]]


class Births:
    """Newborn particles of a filter's grid, motion prior and border belief, drawn as the reference form draws them.

    Parameters
    ----------
    spec : GridSpec
        The grid.
    motion : PeopleMotion
        The prior of the newborns' velocities and of the people motion's inflow.
    outside : float
        Belief beyond the grid's border.
    """

    def __init__(self, spec: GridSpec, motion: PeopleMotion, outside: float) -> None:
        self.spec, self.motion, self.outside = spec, motion, outside
        self._inflow_cache: dict[float, NDArray[np.float64]] = {}
        self._ego_inflow_cache: dict[bytes, NDArray[np.float64]] = {}
        self._inflow_cells_cache: dict[int, tuple[object, NDArray[np.intp], NDArray[np.float64], float]] = {}

    def born(self, cells: NDArray[np.intp], weights: NDArray[np.float64], rng: np.random.Generator) -> ParticleState:
        """Particles in ``cells`` (flat indices, (K,)) carrying ``weights`` (K,): uniform in the cell, velocities from
        the motion prior."""
        x, y = uniform_in_cells(self.spec, cells, rng=rng)
        vx, vy = sample_velocity_prior(self.motion, cells.size, rng=rng)
        return ParticleState(x=x, y=y, vx=vx, vy=vy, w=weights)

    def people(self, dt: float, n_inside: int, n_particles: int, rng: np.random.Generator) -> _Born:
        """The births of the people motion's inflow over ``dt`` s, given the count inside after it (half of the
        free slots of ``n_particles``). Returns the particles and their cells."""
        free = n_particles - n_inside
        return self.from_mass(self.people_inflow(dt).ravel(), free - max(free, 0) // 2, rng)

    def sensor(
        self, poses: NDArray[np.float64], pose_w: NDArray[np.float64], free: int, rng: np.random.Generator
    ) -> _Born:
        """The births of the sensor motion's inflow (sigma points ``poses`` (S, 3), weights ``pose_w`` (S,)) into
        ``free`` slots. Returns the particles and their cells."""
        return self.from_mass(self.ego_inflow(poses, pose_w), free, rng)

    def from_mass(self, mass: NDArray[np.float64], free: int, rng: np.random.Generator) -> _Born:
        """Particles carrying ``mass`` (flat, per cell): one per cell above the floor plus a share of ``free``."""
        cells, m, total = self._inflow_cells(mass)
        if cells.size == 0:
            return ParticleState.empty(), np.zeros(0, dtype=np.intp)
        extra = max(free - cells.size, 0)
        counts = 1 + np.floor(extra * m / total).astype(np.intp)
        rep = np.repeat(cells, counts)
        return self.born(rep, np.repeat(m / counts, counts), rng), rep

    def people_inflow(self, dt: float) -> NDArray[np.float64]:
        """Mass entering each cell from outside over ``dt`` (nx, ny): ``outside * sum_{k out} T(c <- k)``."""
        key = quantise_dt(float(dt))  # the kernel's own dt grid: the cache stays small on jittering clocks
        cached = self._inflow_cache.get(key)
        if cached is None:
            kernel = people_motion_kernel(self.spec, self.motion, dt=dt, form="integrated")
            cached = outside_inflow(self.spec.shape, kernel, self.outside)
            cached.setflags(write=False)
            self._inflow_cache[key] = cached
        return cached

    def ego_inflow(self, poses: NDArray[np.float64], pose_w: NDArray[np.float64]) -> NDArray[np.float64]:
        """Mass entering each cell (flat) across the border in the sensor motion: the grid's warp of an empty
        grid with border value ``outside`` (cached per sigma points: the same odometry gives the same warp)."""
        key = poses.tobytes() + pose_w.tobytes()
        cached = self._ego_inflow_cache.get(key)
        if cached is None:
            cached = border_inflow(self.spec, poses, pose_w, outside=self.outside).ravel()
            cached.setflags(write=False)
            if len(self._ego_inflow_cache) >= 64:
                self._ego_inflow_cache.clear()
            self._ego_inflow_cache[key] = cached
        return cached

    def _inflow_cells(self, mass: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.float64], float]:
        """The cells of ``mass`` above the floor, their masses and the sum of these: kept for the inflow grids the
        births cache (read-only arrays, the same every step of the same dt and odometry), computed for others."""
        owner = mass if mass.base is None else mass.base
        cached = self._inflow_cells_cache.get(id(owner))
        if cached is not None and cached[0] is owner:
            return cached[1], cached[2], cached[3]
        cells = np.flatnonzero(mass > BIRTH_FLOOR)
        m = mass[cells]
        total = float(m.sum())
        if isinstance(owner, np.ndarray) and not owner.flags.writeable:
            if len(self._inflow_cells_cache) >= 64:
                self._inflow_cells_cache.clear()
            self._inflow_cells_cache[id(owner)] = (owner, cells, m, total)
        return cells, m, total


class DrawnBirths(Births):
    """:class:`Births` whose positions and velocities are drawn inside :func:`born_particles` (four 64-bit seeds from
    the filter's ``Generator`` per call): the same distribution, other draws."""

    def born(self, cells: NDArray[np.intp], weights: NDArray[np.float64], rng: np.random.Generator) -> ParticleState:
        """As :meth:`Births.born`, drawn inside the kernel."""
        seeds = rng.integers(0, 2**64, size=4, dtype=np.uint64)
        walk = draws.walk_of(self.motion)
        x, y, vx, vy = born_particles(np.asarray(cells, dtype=np.intp), seeds, walk, grid_of(self.spec))
        return ParticleState.of_checked(x, y, vx, vy, np.asarray(weights, dtype=np.float64))


@jit
def born_particles(
    cells: NDArray[np.intp],
    seeds: NDArray[np.uint64],
    walk: draws.WalkParams,
    grid: tuple[float, float, float, int, int],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """New particles in ``cells`` (flat, in the grid): positions uniform in the cell, velocities from the paper's
    prior, drawn inside (:mod:`~pfpeople.particle.predictor.draws`; ``seeds`` (4,): a stream key for the positions,
    one for whether each walks, a sequential state for the walkers' velocities).

    Returns ``x, y, vx, vy`` (m, m/s), shape (K,) each: :meth:`Births.born`'s distribution
    (:func:`~pfpeople.particle.state.uniform_in_cells`,
    :func:`~pfpeople.particle.predictor.paper.sample_velocity_prior`).
    """
    x0, y0, res, _, ny = grid
    n = cells.size
    x, y, vx, vy = np.empty(n), np.empty(n), np.zeros(n), np.zeros(n)
    thr = math.ceil(walk[0] * 9007199254740992.0)
    state = seeds[3]
    for k in range(n):
        i, j = divmod(cells[k], ny)
        u = min(max(draws.uniform(draws.hashed(seeds[0], 2 * k)), _BIRTH_EDGE), 1.0 - _BIRTH_EDGE)
        v = min(max(draws.uniform(draws.hashed(seeds[0], 2 * k + 1)), _BIRTH_EDGE), 1.0 - _BIRTH_EDGE)
        x[k], y[k] = x0 + (i + u) * res, y0 + (j + v) * res
        if float(draws.hashed(seeds[1], k) >> np.uint64(11)) >= thr:
            state, vx[k], vy[k] = draws.walker_velocity(state, walk)
    return x, y, vx, vy
