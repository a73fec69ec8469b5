"""Resource limits of a run's grid, checked before anything large is allocated (the particle filter adds its own,
:mod:`pfpeople.particle.limits`).

A grid far beyond what a robot needs (a stamp typed as a cell count, ``resolution = 1e-300``) must fail at once with a
message naming the setting, not after minutes of swapping or with a raw ``_ArrayMemoryError``. The checks here are
estimates with generous margins:

- grid cells: ``nx * ny <= MAX_GRID_CELLS`` (4 million, e.g. 2000 x 2000);
- prediction work: the people-motion kernel reaches ``v_max dt / resolution`` cells, and the grid filter's
  prediction costs ``n_cells * (2 R + 1)^2`` operations per frame (eqs. 8-9 sum over the neighbourhood); more
  than ``MAX_STEP_OPERATIONS`` (1e9, about a second per frame) is refused;
- time step: ``0 < dt <= MAX_DT_S`` (10 s) in both filters' ``predict`` / ``step`` (:func:`check_dt`), a number
  (not a string, a bool or a complex): a step in milliseconds passed as seconds (``dt = 100``) would ask for a
  people-motion kernel of hundreds of cells radius (minutes and gigabytes per frame for the grid filter, hundreds
  of GiB for a particle filter). Real frame gaps are a fraction of a second, and the pipeline restarts the
  filter over gaps longer than 2 s (:data:`pfpeople.perception.odometry.MAX_GAP_S`) instead of predicting across them;
- memory: :func:`estimate_run_bytes` (``BYTES_PER_CELL`` per cell and detector, plus what the filter adds, e.g. its
  particles) must fit in :func:`memory_budget_bytes`: half the physical memory, or ``$PFPEOPLE_MAX_MEMORY_BYTES``.

Every check raises :class:`ResourceLimitError` (a ``ValueError``) naming the setting, the estimate and the limit
(:func:`check_dt`: ``TypeError`` for a value that is not a real number).
"""

from __future__ import annotations

import math
import numbers
import os

import numpy as np

__all__ = [
    "BYTES_PER_CELL",
    "MAX_DT_S",
    "MAX_GRID_CELLS",
    "MAX_STEP_OPERATIONS",
    "ResourceLimitError",
    "check_dt",
    "check_grid_size",
    "check_memory",
    "estimate_run_bytes",
    "kernel_reach_cells",
    "memory_budget_bytes",
]

#: Largest number of grid cells.
MAX_GRID_CELLS = 4_000_000
#: Largest estimated number of operations of one prediction step (cells x kernel cells).
MAX_STEP_OPERATIONS = 1.0e9
#: Largest filter time step (s): well above any real frame gap (the pipeline restarts the filter after 2 s).
MAX_DT_S = 10.0
#: Bytes per grid cell and per detector (float64 belief, priors, likelihood maps, warps, outputs; measured
#: peaks of a GridFilter step are below half of this).
BYTES_PER_CELL = 256


class ResourceLimitError(ValueError):
    """A requested run would exceed a resource limit (see the module docstring)."""


def _human(nbytes: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(nbytes) < 1024 or unit == "PiB":
            return f"{nbytes:.3g} {unit}"
        nbytes /= 1024
    return f"{nbytes:.3g} PiB"  # pragma: no cover


def memory_budget_bytes() -> int:
    """Memory a run may use (bytes): ``$PFPEOPLE_MAX_MEMORY_BYTES`` or half the physical memory (8 GiB if
    unknown)."""
    env = os.environ.get("PFPEOPLE_MAX_MEMORY_BYTES")
    if env:
        try:
            return int(float(env))
        except ValueError:
            raise ValueError(f"PFPEOPLE_MAX_MEMORY_BYTES={env!r} is not a number of bytes") from None
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        total = 16 * 2**30
    return int(total // 2)


def kernel_reach_cells(resolution: float, *, v_max: float, dt: float) -> float:
    """Radius (cells) of the people-motion neighbourhood, capped at 1e100 (a float: it may be astronomical)."""
    reach = min(v_max * dt / resolution, 1e100)
    return float(math.ceil(reach) + 1) if reach < 1e15 else reach


def estimate_run_bytes(n_cells: int, *, n_detectors: int = 1, extra_bytes: int = 0) -> int:
    """Estimated peak memory (bytes) of a filter over ``n_cells`` cells with ``n_detectors``, plus ``extra_bytes``
    (what the filter holds besides its grids, e.g. particles)."""
    return int(BYTES_PER_CELL * n_cells * (2 + max(n_detectors, 1)) + extra_bytes)


def check_dt(dt: object, where: str = "dt") -> float:
    """Check a filter time step: a real number (not a bool), finite, in ``(0, MAX_DT_S]``; returns it as a float.

    Raises
    ------
    TypeError
        ``dt`` is not a real number (a string, a complex, a bool, None).
    ValueError
        ``dt`` is not finite or not positive; :class:`ResourceLimitError` when above :data:`MAX_DT_S`.
    """
    if type(dt) is not float and (isinstance(dt, bool | np.bool_) or not isinstance(dt, numbers.Real)):
        raise TypeError(f"{where} must be a real number of seconds, got {type(dt).__name__} {dt!r}")
    v = float(dt)
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{where} must be a finite positive number of seconds, got {dt!r}")
    if v > MAX_DT_S:
        raise ResourceLimitError(
            f"{where} = {v:g} s is more than the limit of {MAX_DT_S:g} s (a time in ms given as seconds?); "
            "a longer gap between frames restarts the filter instead"
        )
    return v


def check_grid_size(
    nx: int, ny: int, resolution: float, *, v_max: float | None = None, dt: float = 0.1, where: str = "grid"
) -> None:
    """Refuse a grid with too many cells or (given ``v_max``) a prediction step too expensive."""
    n_cells = int(nx) * int(ny)
    if n_cells > MAX_GRID_CELLS:
        raise ResourceLimitError(
            f"{where}: {nx} x {ny} = {n_cells} cells is more than the limit of {MAX_GRID_CELLS} cells; "
            "use fewer, larger cells"
        )
    if v_max is not None:
        reach = kernel_reach_cells(resolution, v_max=v_max, dt=dt)
        ops = n_cells * (2.0 * reach + 1.0) ** 2
        if ops > MAX_STEP_OPERATIONS:
            raise ResourceLimitError(
                f"{where}: resolution {resolution!r} m with people walking up to {v_max:.3g} m/s in {dt:g} s "
                f"gives a motion neighbourhood of {reach:.3g} cells radius: about {ops:.3g} operations per frame "
                f"over {n_cells} cells (limit {MAX_STEP_OPERATIONS:.0e}); use a coarser resolution "
                "(the paper uses 0.3 m)"
            )


def check_memory(
    n_cells: int, *, n_detectors: int = 1, extra_bytes: int = 0, extra: str = "", where: str = "run"
) -> None:
    """Refuse a run whose estimated memory (:func:`estimate_run_bytes`) exceeds :func:`memory_budget_bytes`;
    ``extra`` says what ``extra_bytes`` are (e.g. ``", 1000000 particles"``) in the message."""
    need = estimate_run_bytes(n_cells, n_detectors=n_detectors, extra_bytes=extra_bytes)
    budget = memory_budget_bytes()
    if need > budget:
        raise ResourceLimitError(
            f"{where}: the requested run needs about {_human(need)} ({n_cells} cells, {n_detectors} detector(s)"
            f"{extra}), more than the budget of {_human(budget)} (half the physical memory, or "
            "PFPEOPLE_MAX_MEMORY_BYTES)"
        )
