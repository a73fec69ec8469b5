"""Grid geometry: the local semantic grid attached to the sensor frame.

One :class:`GridSpec` owns every world <-> cell conversion. Frames follow ROS REP-103 (x forward,
y left, yaw counter-clockwise). A grid array has shape ``(nx, ny)``; cell ``[i, j]`` has its centre at

    x = x0 + (i + 0.5) * resolution,    y = y0 + (j + 0.5) * resolution.

The default is the paper's grid (Batista & Pereira 2015, Sect. 4): 30 x 30 cells of 0.3 m with the
laser at the middle of one edge, looking into the grid: x in [0, 9] m, y in [-4.5, 4.5] m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.limits import check_grid_size
from gridbridge.validation import check_grid_array, check_int, check_real

__all__ = ["GridSpec"]


@dataclass(frozen=True, kw_only=True)
class GridSpec:
    """Shape, resolution and origin of the local grid in the sensor frame.

    Parameters
    ----------
    nx, ny : int
        Number of cells along x (forward) and y (left).
    resolution : float
        Cell side (m).
    x0, y0 : float
        Sensor-frame coordinates (m) of the grid's lower corner (cell [0, 0]'s outer corner).
    """

    nx: int = 30
    ny: int = 30
    resolution: float = 0.3
    x0: float = 0.0
    y0: float = -4.5

    def __post_init__(self) -> None:
        for name in ("nx", "ny"):
            check_int(getattr(self, name), f"GridSpec.{name}", minimum=1)
        check_grid_size(self.nx, self.ny, 1.0, where="GridSpec")  # before any array of the grid is allocated
        check_real(self.resolution, "GridSpec.resolution", low=0.0, low_open=True)
        for name in ("x0", "y0"):
            check_real(getattr(self, name), f"GridSpec.{name}")

    @classmethod
    def centred_on_edge(cls, nx: int, ny: int, resolution: float) -> GridSpec:
        """A grid with the sensor at the middle of its x = 0 edge, as in the paper."""
        return cls(nx=nx, ny=ny, resolution=resolution, x0=0.0, y0=-0.5 * ny * resolution)

    @property
    def shape(self) -> tuple[int, int]:
        """Array shape ``(nx, ny)``."""
        return (self.nx, self.ny)

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny

    @property
    def x1(self) -> float:
        """Upper x bound of the grid (m)."""
        return self.x0 + self.nx * self.resolution

    @property
    def y1(self) -> float:
        """Upper y bound of the grid (m)."""
        return self.y0 + self.ny * self.resolution

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(x0, x1, y0, y1)`` in metres."""
        return (self.x0, self.x1, self.y0, self.y1)

    def cell_centres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Cell-centre coordinates, two ``(nx, ny)`` arrays ``(x, y)`` in metres, sensor frame."""
        xs = self.x0 + (np.arange(self.nx) + 0.5) * self.resolution
        ys = self.y0 + (np.arange(self.ny) + 0.5) * self.resolution
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        return gx, gy

    def to_fractional(self, x: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Continuous cell coordinates: ``u = (x - x0) / r``, so cell ``i`` spans ``[i, i + 1)``."""
        u = (np.asarray(x, dtype=float) - self.x0) / self.resolution
        v = (np.asarray(y, dtype=float) - self.y0) / self.resolution
        return u, v

    def to_cell(self, x: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Integer cell indices ``(i, j)`` of points; points outside the grid get indices outside range.

        Use :meth:`contains` or :meth:`flat_index` to handle points outside the grid.
        """
        u, v = self.to_fractional(x, y)
        return np.floor(u).astype(np.intp), np.floor(v).astype(np.intp)

    def contains(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
        """True where the point (m, sensor frame) lies inside the grid (half-open cells)."""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        return (x >= self.x0) & (x < self.x1) & (y >= self.y0) & (y < self.y1)

    def flat_index(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.intp]:
        """Row-major flat cell index ``i * ny + j`` of each point, ``-1`` outside the grid."""
        i, j = self.to_cell(x, y)
        inside = (i >= 0) & (i < self.nx) & (j >= 0) & (j < self.ny)
        return np.where(inside, i * self.ny + j, -1)

    def cell_centre(self, i: ArrayLike, j: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centre ``(x, y)`` (m) of cell(s) ``[i, j]``."""
        x = self.x0 + (np.asarray(i, dtype=float) + 0.5) * self.resolution
        y = self.y0 + (np.asarray(j, dtype=float) + 0.5) * self.resolution
        return x, y

    def check_grid(self, array: ArrayLike, name: str, *, probability: bool = True) -> NDArray[np.float64]:
        """Validate a grid array: shape ``(nx, ny)``, finite, and within [0, 1] if ``probability``.

        Raises
        ------
        ValueError
            Naming ``name`` and what is wrong.
        """
        return check_grid_array(array, name, shape=self.shape, probability=probability)
