"""What a people-motion or ego-motion model of the particle filter is: two small protocols.

A model is one class that owns both of its forms:

* its **reference form**, in numpy (required): the definition of the model, what :class:`pfpeople.ParticleFilter`
  runs without numba (``PFPEOPLE_NUMBA=0``);
* its **compiled form** (optional): the same model with numba kernels (:mod:`gridbridge.jit`), which the filter runs
  when the compiled kernels are on. Without one, the compiled filter runs the reference form inside its compiled
  step and says so once in the log (:mod:`pfpeople.particle.forms`).

People motion (:class:`PeopleSampler`; eqs. 5-9 or a variant). Compiled forms, the first that applies:

``drawn_pass(state, dt, rows, ego, grid, into, sums, *, rng)`` with ``draws_inside`` true
    The people motion drawn inside one compiled pass that also applies the sensor motion and sums the particles per
    cell (:mod:`pfpeople.particle.predictor.passes`); the births and the sensor noise are then drawn inside kernels
    too. Other draws than the reference form's, the same distributions: the built-in models' fastest form
    (:class:`~pfpeople.particle.predictor.paper.PaperSampling`,
    ``PersistentSampling(compiled_draws=True)``).
``move_compiled(state, dt, *, rng)``
    :meth:`PeopleSampler.move` with numba kernels that draw from ``rng`` (numba runs numpy's ``Generator``
    algorithms): the reference form's particles bit for bit, faster.

Ego-motion (:class:`EgoSampler`; eqs. 10-11). Compiled forms: ``rows(odometry, dt, n, *, rng)``, the displacements
as the compiled passes take them, drawn as :meth:`EgoSampler.poses` draws them; ``rows_drawn(odometry, dt, n, *,
seed)``, the same with the draws inside the kernel (used beside a people model's ``drawn_pass``).
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from gridbridge import Odometry, PeopleMotion, SensorMotionNoise
from pfpeople.particle.buffers import PassBuffer
from pfpeople.particle.state import ParticleState

__all__ = ["EgoSampler", "PeopleSampler", "Predicted", "Predictor"]


@runtime_checkable
class PeopleSampler(Protocol):
    """People motion in sampling form (eqs. 5-9 or a variant): moves particles over one step.

    Attributes
    ----------
    motion : PeopleMotion
        The paper's prior (Table 1): newborn particles draw their velocities from it, and its integrated kernel
        gives the inflow across the grid's border.
    redraw_in_cell : bool
        Each particle is first re-drawn uniformly inside its cell (the grid's assumption; the filter does it).
    """

    @property
    def motion(self) -> PeopleMotion: ...

    @property
    def redraw_in_cell(self) -> bool: ...

    def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """Reference form: replace the state's fields (never write into them) with the velocities (m/s) and the
        positions (m, old sensor frame) after ``dt`` s; the weights stay."""
        ...


@runtime_checkable
class EgoSampler(Protocol):
    """Sensor motion in sampling form (eqs. 10-11): sampled displacements of the sensor frame over one step.

    Attributes
    ----------
    noise : SensorMotionNoise
        The odometry noise; the grid's sigma points of it give the inflow across the border and the empty cells'
        prior.
    """

    @property
    def noise(self) -> SensorMotionNoise: ...

    def poses(self, odometry: Odometry | None, dt: float, n: int, *, rng: np.random.Generator) -> NDArray[np.float64]:
        """Reference form: at most ``n`` displacements ``(dx, dy, dtheta)`` of the new sensor frame in the old one
        (m, m, rad), shape (S, 3); particle k takes displacement ``k mod S``."""
        ...


class Predicted(NamedTuple):
    """The particles after both predictions (eqs. 5-11) and the grids they rasterise to; flat ``(n_cells,)`` grids.

    Attributes
    ----------
    state : ParticleState
        The particles in the new sensor frame (those that left dropped, the border's births added).
    cells : ndarray of intp, shape (K,)
        The flat cell of each particle.
    empty : ndarray of bool
        The cells without a particle.
    people_prior : ndarray
        The mass per cell after the people motion (Fig. 6d).
    sensor_prior : ndarray
        The mass per cell after the sensor motion, the empty cells' prior filled in (Fig. 6e).
    sq : ndarray or None
        The particles' squared masses summed per cell (a drawing pass's; the update's effective sample size).
    buffer : PassBuffer or None
        The compiled prediction's buffer, whose first columns ``state`` views (the update appends births there).
    """

    state: ParticleState
    cells: NDArray[np.intp]
    empty: NDArray[np.bool_]
    people_prior: NDArray[np.float64]
    sensor_prior: NDArray[np.float64]
    sq: NDArray[np.float64] | None = None
    buffer: PassBuffer | None = None


class Predictor(Protocol):
    """Phases 1-2 of the filter step in one form (:mod:`pfpeople.particle.predictor.reference`,
    :mod:`pfpeople.particle.predictor.compiled`): both motions of the particles, the births at the border and the
    empty cells' prior (of the previous posterior ``belief``, (nx, ny))."""

    def predict(
        self,
        state: ParticleState,
        odometry: Odometry | None,
        dt: float,
        belief: NDArray[np.float64],
        rng: np.random.Generator,
    ) -> Predicted: ...
