"""Phases 1-2 of the particle filter step compiled (:mod:`gridbridge.jit`): the prediction of
:mod:`pfpeople.particle.predictor.reference` in a few passes over the particles, compacted into a buffer from the
filter's pool (:class:`~pfpeople.particle.buffers.PassBuffer`), summed per cell on the way.

Two forms, by where the people-motion model draws:

:class:`CompiledPredictor`
    The draws of the reference form, in its order: the model's ``move_compiled`` (or its reference ``move``), then a
    pass that sums the people prior and counts the particles inside (the border's births need the count before the
    sensor motion draws), the births, the sensor motion's displacements (the ego model's ``rows``), and one pass of
    the sensor motion that drops the particles that left and compacts the rest
    (:mod:`pfpeople.particle.predictor.passes`). The reference form's particles bit for bit.
:class:`DrawingPredictor`
    For a model with ``draws_inside`` (:class:`~pfpeople.particle.predictor.paper.PaperSampling`,
    ``PersistentSampling(compiled_draws=True)``): the sensor motion's displacements drawn in a kernel (``rows_drawn``),
    then the model's ``drawn_pass``, one pass that draws the people motion block by block and applies both motions;
    the births drawn in a kernel too (:class:`~pfpeople.particle.predictor.births.DrawnBirths`). Other draws than the
    reference form's, the same distributions; it also sums the squared masses per cell, from which the update knows
    its effective sample size without another pass.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from gridbridge import GridSpec, Odometry, ego_motion_sigma_points
from pfpeople.particle.buffers import BufferPool, PassBuffer, arrays_of
from pfpeople.particle.predictor.births import Births
from pfpeople.particle.predictor.empty_cells import EmptyCells
from pfpeople.particle.predictor.paper import redraw_in_cells
from pfpeople.particle.predictor.passes import accumulate, count_inside, ego_compact, grid_of
from pfpeople.particle.predictor.protocols import EgoSampler, PeopleSampler, Predicted
from pfpeople.particle.state import ParticleState

__all__ = ["CompiledPredictor", "DrawingPredictor", "Move", "rows_of_poses"]

#: A people model's move (``move_compiled`` or ``move``): ``f(state, dt, *, rng)``, fields replaced.
Move = Callable[..., None]
#: The sensor displacement rows of a standing robot (the passes then leave the particles where they are).
_NO_POSES = np.zeros((4, 1))
_Moved = tuple[int, ParticleState, NDArray[np.intp], NDArray[np.float64]]


def rows_of_poses(poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """Displacements ``(dx, dy, dtheta)`` (S, 3) as the passes take them: rows dx, dy, cos(dtheta), sin(dtheta),
    shape (4, S) (for an ego model without a compiled ``rows``)."""
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    return np.stack((p[:, 0], p[:, 1], np.cos(p[:, 2]), np.sin(p[:, 2])))


class CompiledPredictor:
    """Phases 1-2 compiled with the reference form's draws (the module docstring).

    Parameters
    ----------
    spec, people, ego, births
        As :class:`~pfpeople.particle.predictor.reference.ReferencePredictor`.
    move : callable
        The people model's move (``move_compiled``, or ``move`` for a model without one).
    n_particles, outside
        As :class:`~pfpeople.particle.predictor.reference.ReferencePredictor`.
    n_birth : int
        Particles born per empty cell (room for them in the buffer).
    pool : BufferPool
        The filter's arrays for reuse.
    """

    #: Whether the buffer sums the squared masses per cell.
    squares = False

    def __init__(
        self,
        spec: GridSpec,
        people: PeopleSampler,
        ego: EgoSampler,
        births: Births,
        *,
        move: Move,
        n_particles: int,
        outside: float,
        n_birth: int,
        pool: BufferPool,
    ) -> None:
        self.spec, self.people, self.ego, self.births, self.move = spec, people, ego, births, move
        self.n_particles, self.n_birth, self.pool = n_particles, n_birth, pool
        self.grid = grid_of(spec)
        self.empty_cells = EmptyCells(spec, people.motion, outside)
        #: The ego model's compiled rows (None: its reference poses, turned into rows).
        self.rows: Callable[..., NDArray[np.float64]] | None = getattr(ego, "rows", None)
        #: Its rows drawn inside the kernel (:class:`DrawingPredictor`; None: drawn from the ``Generator``).
        self.rows_drawn: Callable[..., NDArray[np.float64]] | None = getattr(ego, "rows_drawn", None)

    def predict(
        self,
        state: ParticleState,
        odometry: Odometry | None,
        dt: float,
        belief: NDArray[np.float64],
        rng: np.random.Generator,
    ) -> Predicted:
        """Both motions of ``state`` (its arrays go back to the pool), the border's births and the empty cells'
        prior of ``belief`` (nx, ny)."""
        n_cells = self.spec.n_cells
        sigma = ego_motion_sigma_points(odometry, dt, self.ego.noise)
        moves = bool(np.any(sigma[0] != 0.0))
        cap = max(state.size, self.n_particles) + (3 + self.n_birth) * n_cells + 8
        buf = PassBuffer(self.pool, cap, n_cells, squares=self.squares)
        n_inside, born, born_cells, born_rows = self._people(state, odometry, dt, moves, buf, rng)
        buf.prior += np.bincount(born_cells, weights=born.w, minlength=n_cells)
        start = buf.used
        args = (born_rows, moves, False, self.grid, buf.out, buf.cells, start, buf.mass, buf.counts)
        buf.used = ego_compact((born.x, born.y, born.vx, born.vy), born.w, *args)
        if moves:
            born2, born2_cells = self.births.sensor(*sigma, self.n_particles - (n_inside + buf.used - start), rng)
            buf.append(born2, born2_cells)
            accumulate(born2_cells, born2.w, buf.mass, buf.counts)
        else:  # standing: the people prior is the sensor prior
            buf.mass = buf.prior.copy()
        if buf.sq is not None and buf.used > start:  # the births' squared masses
            new = slice(start, buf.used)
            buf.sq += np.bincount(buf.cells[new], weights=np.square(buf.out[4][new]), minlength=n_cells)
        self.pool.give(*arrays_of(state))  # the old state: reused once no step record holds it
        st, cells = buf.state()
        empty = buf.counts == 0
        self.empty_cells.fill(buf.mass, empty, belief, dt, sigma)
        return Predicted(st, cells, empty, buf.prior, buf.mass, buf.sq, buf)

    def _people(
        self,
        state: ParticleState,
        odometry: Odometry | None,
        dt: float,
        moves: bool,
        buf: PassBuffer,
        rng: np.random.Generator,
    ) -> _Moved:
        """Phase 1 with the reference form's draws, and the sensor motion of the moved particles into ``buf``.
        Returns the count inside after the people motion, the border's newborns, their cells and displacements."""
        moved = state.shallow_copy()
        if self.people.redraw_in_cell:
            redraw_in_cells(moved, self.spec, rng=rng)
        self.move(moved, dt, rng=rng)
        n_inside = count_inside(moved.x, moved.y, moved.w, self.grid, buf.prior)
        born, born_cells = self.births.people(dt, n_inside, self.n_particles, rng)
        rows, born_rows = (self._rows_for(odometry, dt, part.size, moves, rng) for part in (moved, born))
        src = (moved.x, moved.y, moved.vx, moved.vy)
        args = (rows, moves, True, self.grid, buf.out, buf.cells, 0, buf.mass, buf.counts)
        buf.used = ego_compact(src, moved.w, *args)
        return n_inside, born, born_cells, born_rows

    def _rows_for(
        self, odometry: Odometry | None, dt: float, n: int, moves: bool, rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """The sensor displacements of ``n`` particles as rows (4, S), drawn from ``rng`` as the reference form
        draws them; none for a standing robot."""
        if not (moves and n):
            return _NO_POSES
        if self.rows is None:
            return rows_of_poses(self.ego.poses(odometry, dt, n, rng=rng))
        return self.rows(odometry, dt, n, rng=rng)


class DrawingPredictor(CompiledPredictor):
    """Phases 1-2 compiled with the people motion, the births and the sensor noise drawn inside the kernels (the
    module docstring); ``people`` has a ``drawn_pass``, ``births`` are
    :class:`~pfpeople.particle.predictor.births.DrawnBirths`."""

    squares = True

    def _people(
        self,
        state: ParticleState,
        odometry: Odometry | None,
        dt: float,
        moves: bool,
        buf: PassBuffer,
        rng: np.random.Generator,
    ) -> _Moved:
        """Phase 1 drawn inside the model's pass, with the sensor motion; returns as
        :meth:`CompiledPredictor._people`."""
        rows = self._rows_for(odometry, dt, state.size, moves, rng)
        drawn_pass = self.people.drawn_pass  # type: ignore[attr-defined]
        buf.used, n_inside = drawn_pass(state, dt, rows, moves, self.grid, (buf.out, buf.cells), buf.sums, rng=rng)
        born, born_cells = self.births.people(dt, n_inside, self.n_particles, rng)
        return n_inside, born, born_cells, self._rows_for(odometry, dt, born.size, moves, rng)

    def _rows_for(
        self, odometry: Odometry | None, dt: float, n: int, moves: bool, rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """The sensor displacements of ``n`` particles drawn inside the kernel (one 64-bit seed from ``rng``), or
        as :meth:`CompiledPredictor._rows_for` for an ego model without ``rows_drawn``."""
        if not (moves and n) or self.rows_drawn is None:
            return super()._rows_for(odometry, dt, n, moves, rng)
        return self.rows_drawn(odometry, dt, n, seed=rng.integers(0, 2**64, dtype=np.uint64))
