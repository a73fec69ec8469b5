"""Compiled kernel of the particle filter's update (:mod:`gridbridge.jit`; :mod:`pfpeople.particle.updater.update`):
the particles scaled to their cell's posterior and the sums the resampling needs, in one pass."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit

__all__ = ["scale_sums"]


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
