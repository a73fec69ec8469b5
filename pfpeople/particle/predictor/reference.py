"""Phases 1-2 of the particle filter step in numpy, on the models' reference forms: the definition of the prediction
that the compiled forms (:mod:`pfpeople.particle.predictor.compiled`) reproduce.

1. **People motion** (eqs. 5-9, sampling form): optionally (the model's ``redraw_in_cell``) each particle is first
   re-drawn uniformly inside its cell, then the model's :meth:`~pfpeople.particle.predictor.protocols.PeopleSampler.
   move`. Particles that leave the grid are dropped; the inflow across the border is born as particles
   (:meth:`~pfpeople.particle.predictor.births.Births.people`).
2. **Sensor motion** (eqs. 10-11): each particle (and each newborn) moves into the new sensor frame by a sampled
   displacement (:meth:`~pfpeople.particle.predictor.protocols.EgoSampler.poses`). Particles that leave are dropped;
   the inflow is born as particles (:meth:`~pfpeople.particle.predictor.births.Births.sensor`).

The cells left without a particle get the grid's linear prior (:mod:`pfpeople.particle.predictor.empty_cells`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gridbridge import GridSpec, Odometry, ego_motion_sigma_points
from pfpeople.particle.predictor.births import Births
from pfpeople.particle.predictor.ego import apply_ego_motion
from pfpeople.particle.predictor.empty_cells import EmptyCells
from pfpeople.particle.predictor.paper import redraw_in_cells
from pfpeople.particle.predictor.protocols import EgoSampler, PeopleSampler, Predicted
from pfpeople.particle.state import ParticleState

__all__ = ["ReferencePredictor"]


class ReferencePredictor:
    """Phases 1-2 in numpy (the module docstring).

    Parameters
    ----------
    spec : GridSpec
        The grid.
    people : PeopleSampler
        The people motion (its reference form :meth:`~PeopleSampler.move`).
    ego : EgoSampler
        The sensor motion (its reference form :meth:`~EgoSampler.poses`).
    births : Births
        The border's newborns.
    n_particles : int
        The filter's particle count (the births fill the slots below it).
    outside : float
        Belief beyond the border (the empty cells' prior).
    """

    def __init__(
        self,
        spec: GridSpec,
        people: PeopleSampler,
        ego: EgoSampler,
        births: Births,
        *,
        n_particles: int,
        outside: float,
    ) -> None:
        self.spec, self.people, self.ego, self.births = spec, people, ego, births
        self.n_particles = n_particles
        self.empty_cells = EmptyCells(spec, people.motion, outside)

    def predict(
        self,
        state: ParticleState,
        odometry: Odometry | None,
        dt: float,
        belief: NDArray[np.float64],
        rng: np.random.Generator,
    ) -> Predicted:
        """Both motions of ``state`` (its fields are not written), the border's births and the empty cells' prior of
        ``belief`` (nx, ny)."""
        st, cells, n_inside = self._people(state.shallow_copy(), dt, rng)
        born, born_cells = self.births.people(dt, n_inside, self.n_particles, rng)
        prior = np.bincount(cells + 1, weights=st.w, minlength=self.spec.n_cells + 1)[1:].astype(np.float64)
        prior += np.bincount(born_cells, weights=born.w, minlength=self.spec.n_cells)
        sigma = ego_motion_sigma_points(odometry, dt, self.ego.noise)
        if np.any(sigma[0] != 0.0):
            st, cells = self._sensor((st, cells, n_inside), (born, born_cells), odometry, dt, sigma, rng)
            mass = np.bincount(cells, weights=st.w, minlength=self.spec.n_cells).astype(np.float64, copy=False)
        else:  # standing: nothing moves, the people prior is the sensor prior
            if n_inside < st.size:
                st, cells = st.take(cells >= 0), cells[cells >= 0]
            st, cells, mass = ParticleState.concatenate([st, born]), np.concatenate((cells, born_cells)), prior.copy()
        empty = np.bincount(cells, minlength=self.spec.n_cells) == 0
        self.empty_cells.fill(mass, empty, belief, dt, sigma)
        return Predicted(st, cells, empty, prior, mass)

    def _people(
        self, st: ParticleState, dt: float, rng: np.random.Generator
    ) -> tuple[ParticleState, NDArray[np.intp], int]:
        """Phase 1 of ``st`` (fields replaced): the particles, their cells (-1 outside; masked, the arrays are
        compressed once per step) and the count inside."""
        if self.people.redraw_in_cell:
            redraw_in_cells(st, self.spec, rng=rng)
        self.people.move(st, dt, rng=rng)
        cells = self.spec.flat_index(st.x, st.y)
        return st, cells, int(np.count_nonzero(cells >= 0))

    def _sensor(
        self,
        moved: tuple[ParticleState, NDArray[np.intp], int],
        newborn: tuple[ParticleState, NDArray[np.intp]],
        odometry: Odometry | None,
        dt: float,
        sigma: tuple[NDArray[np.float64], NDArray[np.float64]],
        rng: np.random.Generator,
    ) -> tuple[ParticleState, NDArray[np.intp]]:
        """Phase 2 of the moved particles ``(state, cells, n_inside)`` and the newborn ``(state, cells)`` (each with
        its own pose draws), the births of the inflow, the particles that left dropped: the particles and their
        cells."""
        (st, cells, n_inside), (born, _) = moved, newborn
        for part in (st, born):
            if part.size:
                apply_ego_motion(part, self.ego.poses(odometry, dt, part.size, rng=rng))
        after = self.spec.flat_index(st.x, st.y)
        inside = (cells >= 0) & (after >= 0)
        born_moved = self.spec.flat_index(born.x, born.y)
        born_in = born_moved >= 0
        n_now = n_inside + int(np.count_nonzero(born_in))
        born2, born2_cells = self.births.sensor(*sigma, self.n_particles - n_now, rng)
        st = ParticleState.concatenate([st.take(inside), born.take(born_in), born2])
        return st, np.concatenate((after[inside], born_moved[born_in], born2_cells))
