"""Particle state of the people particle filter: one array per quantity (structure of arrays).

A particle is a hypothesis "a person is here, moving like this" carrying *occupancy mass*:

* ``x, y`` : position (m) in the **current** sensor frame (REP-103: x forward, y left);
* ``vx, vy`` : the person's velocity over the last step (m/s), expressed in the current sensor frame;
* ``w`` : non-negative weight. The sum of ``w`` over the particles in a grid cell is that cell's probability
  of holding a person, so rasterising the weights (:func:`gridbridge.rasterise`) gives exactly the quantity the
  grid filter's belief holds. The weights are *not* normalised to one.

All arrays are float64 of shape ``(N,)``; there are no per-particle Python objects.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import GridSpec, rasterise

__all__ = ["ParticleState", "uniform_in_cells"]

_FIELDS = ("x", "y", "vx", "vy", "w")
_EDGE = 1e-9


@dataclass(eq=False, slots=True)
class ParticleState:
    """Positions, velocities and occupancy masses of N particles (structure of arrays).

    Parameters
    ----------
    x, y : ndarray, shape (N,)
        Positions (m), current sensor frame.
    vx, vy : ndarray, shape (N,)
        Velocities (m/s), current sensor frame.
    w : ndarray, shape (N,)
        Occupancy mass per particle, >= 0 (a cell's mass is the sum over its particles).
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    vx: NDArray[np.float64]
    vy: NDArray[np.float64]
    w: NDArray[np.float64]

    def __post_init__(self) -> None:
        for name in _FIELDS:
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            if arr.ndim != 1:
                raise ValueError(f"ParticleState.{name} must be 1-D, got shape {arr.shape}")
            object.__setattr__(self, name, arr)
        n = self.x.shape[0]
        for name in _FIELDS[1:]:
            if getattr(self, name).shape[0] != n:
                raise ValueError(
                    f"ParticleState.{name} has {getattr(self, name).shape[0]} entries, x has {n}: lengths differ"
                )

    @classmethod
    def of_checked(
        cls,
        x: NDArray[np.float64],
        y: NDArray[np.float64],
        vx: NDArray[np.float64],
        vy: NDArray[np.float64],
        w: NDArray[np.float64],
    ) -> ParticleState:
        """A state of arrays already known to be 1-D float64 of one length (the filter's own), without the
        constructor's checks (a few microseconds each, several times per filter step)."""
        st = object.__new__(cls)
        for name, arr in zip(_FIELDS, (x, y, vx, vy, w), strict=True):
            object.__setattr__(st, name, arr)
        return st

    @classmethod
    def empty(cls) -> ParticleState:
        """A state with no particles."""
        z = np.zeros(0)
        return cls(x=z, y=z.copy(), vx=z.copy(), vy=z.copy(), w=z.copy())

    @property
    def size(self) -> int:
        """Number of particles N."""
        return int(self.x.shape[0])

    def __len__(self) -> int:
        return self.size

    @property
    def positions(self) -> NDArray[np.float64]:
        """``(N, 2)`` positions (x, y) in metres (a new array)."""
        return np.column_stack((self.x, self.y))

    @property
    def velocities(self) -> NDArray[np.float64]:
        """``(N, 2)`` velocities (vx, vy) in m/s (a new array)."""
        return np.column_stack((self.vx, self.vy))

    def total_mass(self) -> float:
        """Sum of weights: the expected number of people in the particles' cells."""
        return float(self.w.sum())

    def copy(self) -> ParticleState:
        return ParticleState(x=self.x.copy(), y=self.y.copy(), vx=self.vx.copy(), vy=self.vy.copy(), w=self.w.copy())

    def shallow_copy(self) -> ParticleState:
        """A new state object sharing the arrays (assigning a field of the copy leaves this one alone)."""
        return ParticleState.of_checked(self.x, self.y, self.vx, self.vy, self.w)

    def take(self, index: ArrayLike) -> ParticleState:
        """The particles selected by an integer index array or a boolean mask (new arrays)."""
        idx = np.asarray(index)
        return ParticleState(x=self.x[idx], y=self.y[idx], vx=self.vx[idx], vy=self.vy[idx], w=self.w[idx])

    @staticmethod
    def concatenate(states: Sequence[ParticleState]) -> ParticleState:
        """All particles of ``states``, in order."""
        if not states:
            return ParticleState.empty()
        if len(states) == 1:
            return states[0]
        return ParticleState(
            x=np.concatenate([s.x for s in states]),
            y=np.concatenate([s.y for s in states]),
            vx=np.concatenate([s.vx for s in states]),
            vy=np.concatenate([s.vy for s in states]),
            w=np.concatenate([s.w for s in states]),
        )

    def validate(self) -> None:
        """Raise ValueError (naming the array) on NaN / infinite values or negative weights."""
        for name in _FIELDS:
            if not np.all(np.isfinite(getattr(self, name))):
                raise ValueError(f"ParticleState.{name} contains NaN or infinite values")
        if self.size and self.w.min() < 0.0:
            raise ValueError("ParticleState.w must be non-negative (occupancy mass)")

    def rasterise(self, spec: GridSpec) -> NDArray[np.float64]:
        """Mass per cell ``(nx, ny)``: the belief these particles represent (particles outside are ignored)."""
        return rasterise(spec, self.positions, self.w)


def uniform_in_cells(
    spec: GridSpec, flat_cells: ArrayLike, *, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions drawn uniformly inside the given cells.

    Parameters
    ----------
    spec : GridSpec
    flat_cells : array_like of int, shape (K,)
        Row-major flat cell indices ``i * ny + j`` (as :meth:`GridSpec.flat_index`), one per point.
    rng : numpy.random.Generator

    Returns
    -------
    x, y : ndarray, shape (K,)
        Positions (m) in the grid's sensor frame, uniform in each cell (half-open cells).
    """
    flat = np.asarray(flat_cells, dtype=np.intp).ravel()
    if flat.size and (flat.min() < 0 or flat.max() >= spec.n_cells):
        raise ValueError(f"flat_cells must be cell indices in [0, {spec.n_cells}), got [{flat.min()}, {flat.max()}]")
    i, j = np.divmod(flat, spec.ny)
    # Kept 1e-9 of a cell away from the edges, so that round-off never puts a point in a neighbour cell.
    u = np.clip(rng.random((2, flat.size)), _EDGE, 1.0 - _EDGE)
    # cell_centre(i + u - 0.5) = x0 + (i + u) r: uniform over the cell.
    x, y = spec.cell_centre(i + u[0] - 0.5, j + u[1] - 0.5)
    return x, y
