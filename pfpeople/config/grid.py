"""``[grid]``: the local grid, its cells' size and its extent (by default, the lasers' fields of view)."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field

from gridbridge.grid import GridSpec
from pfpeople.config.schema import Count, Metres, Table, table

__all__ = ["EXTENT_FIELDS", "PAPER_GRID", "GridConfig"]

#: The fields of the grid's extent; ``"auto"`` for each one the lasers' fields of view give.
EXTENT_FIELDS = ("nx", "ny", "x0", "y0")

Auto = Literal["auto"]
#: The paper's grid (30 x 30 cells of 0.3 m, the laser at the middle of its x = 0 edge): the cell size's one source.
PAPER_GRID = GridSpec()


@table
class GridConfig(Table):
    """The local grid in the grid frame (``[grid]``; :class:`gridbridge.grid.GridSpec`).

    Parameters
    ----------
    resolution : float
        Side of a cell.
    nx, ny : int or "auto"
        Cells along x (forward) and y (left); ``"auto"``: as many as the lasers' fields of view need.
    x0, y0 : float or "auto"
        The grid's corner (lowest x and y, grid frame); ``"auto"``: the corner of the box that holds every laser's
        field of view. The boxes of the driving laser and of every laser with a detector, each out to
        ``min(range_max, max_range)`` from the laser at its mount, are joined and snapped outwards to whole cells; a
        run without a LaserScan gets the paper's 30 x 30 grid (x0 = 0, y0 = -4.5 at 0.3 m cells). Each field that is
        given replaces the automatic one.
    max_range : float
        The automatic extent reaches this far from each laser (or to its ``range_max`` where that is nearer).
    """

    TABLE: ClassVar[str] = "[grid]"

    resolution: Metres = Field(default=PAPER_GRID.resolution, gt=0.0)
    nx: Annotated[Count, Field(ge=1)] | Auto = "auto"
    ny: Annotated[Count, Field(ge=1)] | Auto = "auto"
    x0: Metres | Auto = "auto"
    y0: Metres | Auto = "auto"
    max_range: Metres = Field(default=10.0, gt=0.0)

    @classmethod
    def of(cls, spec: GridSpec) -> GridConfig:
        """The configuration of a fixed grid ``spec``."""
        return cls(resolution=spec.resolution, nx=spec.nx, ny=spec.ny, x0=spec.x0, y0=spec.y0)

    @property
    def fixed(self) -> GridSpec | None:
        """The grid when every extent field is given, else None (the lasers' fields of view complete it)."""
        if any(getattr(self, k) == "auto" for k in EXTENT_FIELDS):
            return None
        return self.completed(GridSpec(resolution=self.resolution))

    def completed(self, auto: GridSpec) -> GridSpec:
        """The grid: ``auto`` (the automatic grid, at :attr:`resolution`) with every given extent field in place of
        its own."""
        extent = {k: getattr(self, k) if getattr(self, k) != "auto" else getattr(auto, k) for k in EXTENT_FIELDS}
        return GridSpec(**extent, resolution=self.resolution)

    def check(self) -> None:
        """A fully given grid must be a valid :class:`~gridbridge.grid.GridSpec`."""
        _ = self.fixed
