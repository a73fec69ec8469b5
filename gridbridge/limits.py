"""Resource limits of a run's grid, checked before anything large is allocated (the particle filter adds its own,
:mod:`pfpeople.particle.limits`).

A grid far beyond what a robot needs (a stamp typed as a cell count, ``resolution = 1e-300``) must fail at once
with a message naming the setting, not after minutes of swapping or with a raw ``_ArrayMemoryError``. The checks
here are estimates with generous margins (a filter that keeps more state than its
grids adds its bytes to the memory check):

- grid cells: ``nx * ny <= MAX_GRID_CELLS`` (4 million, e.g. 2000 x 2000), checked by :class:`gridbridge.GridSpec`
  itself, so a library user and a run get the same message;
- prediction work: the people-motion kernel reaches ``R = ceil(v_max dt / resolution) + 1`` cells, and the grid
  filter's prediction costs ``n_cells * (2 R + 1)^2`` operations per frame (eqs. 8-9 sum over the neighbourhood);
  more than ``MAX_STEP_OPERATIONS`` (1e9, about a second per frame) or a radius beyond ``MAX_KERNEL_RADIUS_CELLS``
  (1000) is refused (:func:`check_motion_step`): by a run's configuration (at 0.1 s), by both filters' constructors
  (at their motion's ``dt``) and whenever a kernel of another step is made (:func:`gridbridge.people_motion_kernel`,
  before anything of the step is allocated);
- time step: ``0 < dt <= MAX_DT_S`` (10 s) in both filters' ``predict`` / ``step`` (:func:`check_dt`), a number
  (not a string, a bool or a complex): a step in milliseconds passed as seconds (``dt = 100``) would ask for a
  people-motion kernel of hundreds of cells radius (minutes and gigabytes per frame for the grid filter, hundreds
  of GiB for a sampling filter). Real frame gaps are a fraction of a second, and the pipeline restarts the
  filter over gaps longer than 2 s (:data:`pfpeople.perception.odometry.MAX_GAP_S`) instead of predicting across them;
- memory: :func:`estimate_run_bytes` (``BYTES_PER_CELL`` per cell and detector, plus the filter's own state)
  must fit in :func:`memory_budget_bytes`: half the physical memory, or ``$PFPEOPLE_MAX_MEMORY_BYTES``.

Within these limits one step's memory is bounded by its inputs: about ``BYTES_PER_CELL * n_cells * (2 + detectors)``
(the grids of the step) ``+ 200 B * particles`` (a particle filter's state and its copies:
:mod:`pfpeople.particle.limits`)
``+ 8 B * (2 R + 1)^2`` per kernel array ``+ 0.3 MB * R`` while an integrated (linear) kernel is computed (its
quadrature, about 3000 points per cell of radius), above the process's own (interpreter, numpy, numba: 150-200 MB).
None of these arrays grows otherwise with ``dt``: the paper kernel's prediction keeps a table of ``q / (1 - q)`` per
distinct tap value only while it is small, the integrated kernel's tents are summed from the two offsets each
covers, and the particle filter's inflow across the border comes from the kernel's summed-area table once the kernel
is larger than the grid
(``python -m evaluation.bench.step_limits`` measures every filter at the limits on the paper's grid).

Limits given in the environment (``PFPEOPLE_MAX_MEMORY_BYTES``, the zip limits of :mod:`pfpeople.io.bag.archive`) are
read by :func:`env_limit`: a positive number of at most :data:`MAX_ENV_LIMIT` (``8e9`` and ``8000000000`` alike);
text, NaN, an infinity, zero, a negative number or a larger one is a ``ValueError`` naming the variable.

Every check raises :class:`ResourceLimitError` (a ``ValueError``) naming the setting, the estimate and the limit
(:func:`check_dt`: ``TypeError`` for a value that is not a real number).
"""

from __future__ import annotations

import math
import numbers
import os

import numpy as np

from gridbridge.validation import InputTypeError

__all__ = [
    "BYTES_PER_CELL",
    "MAX_DT_S",
    "MAX_GRID_CELLS",
    "MAX_KERNEL_RADIUS_CELLS",
    "MAX_SMOOTH_CELLS",
    "MAX_STEP_OPERATIONS",
    "ResourceLimitError",
    "check_dt",
    "check_grid_size",
    "check_memory",
    "check_motion_step",
    "check_smooth",
    "env_limit",
    "estimate_run_bytes",
    "kernel_reach_cells",
    "memory_budget_bytes",
]

#: Largest number of grid cells.
MAX_GRID_CELLS = 4_000_000
#: Largest estimated number of operations of one prediction step (cells x kernel cells).
MAX_STEP_OPERATIONS = 1.0e9
#: Largest radius (cells) of the people-motion neighbourhood of one step: its kernel has at most 2001 x 2001 cells
#: (32 MB), the integrated one's quadrature about 3000 points a cell of radius (250 MB at the limit).
MAX_KERNEL_RADIUS_CELLS = 1000
#: Largest standard deviation (cells) of the Gaussian the peak classifier smooths the belief with: wider spreads one
#: person over hundreds of cells, and ``smooth = 1e9`` asked scipy for a 60 GiB kernel.
MAX_SMOOTH_CELLS = 10.0
#: Largest filter time step (s): well above any real frame gap (the pipeline restarts the filter after 2 s).
MAX_DT_S = 10.0
#: Bytes per grid cell and per detector (float64 belief, priors, likelihood maps, warps, outputs; measured
#: peaks of a GridFilter step are below half of this).
BYTES_PER_CELL = 256
#: Largest value an environment limit may take (:func:`env_limit`): 2**62, far beyond any machine's memory or disk.
MAX_ENV_LIMIT = 2**62


class ResourceLimitError(ValueError):
    """A requested run would exceed a resource limit (see the module docstring)."""


def _human(nbytes: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(nbytes) < 1024 or unit == "PiB":
            return f"{nbytes:.3g} {unit}"
        nbytes /= 1024
    return f"{nbytes:.3g} PiB"  # pragma: no cover


def env_limit(name: str, default: int) -> int:
    """The limit the environment variable ``name`` gives (a number of bytes or of items), else ``default``.

    Raises
    ------
    ValueError
        Naming the variable, when its value is not a finite number in ``[1, MAX_ENV_LIMIT]`` (text, NaN, ``inf``,
        ``1e400``, zero, a negative number).
    """
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 1 <= value <= MAX_ENV_LIMIT):
        raise ValueError(
            f"environment variable {name}={text!r} must be a finite number from 1 to {MAX_ENV_LIMIT:.3g} "
            "(e.g. 8e9); unset it for the default"
        )
    return int(value)


def memory_budget_bytes() -> int:
    """Memory a run may use (bytes): ``$PFPEOPLE_MAX_MEMORY_BYTES`` (:func:`env_limit`) or half the physical memory
    (8 GiB if unknown)."""
    if os.environ.get("PFPEOPLE_MAX_MEMORY_BYTES", "").strip():
        return env_limit("PFPEOPLE_MAX_MEMORY_BYTES", 0)
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
    of its own state."""
    return int(BYTES_PER_CELL * n_cells * (2 + max(n_detectors, 1)) + extra_bytes)


def check_smooth(value: object, where: str = "smooth") -> float:
    """Check the peak classifier's smoothing (cells): a real number in ``[0, MAX_SMOOTH_CELLS]``; returns it.

    Raises
    ------
    InputTypeError
        Not a real number (a string, a bool): a ``TypeError`` and a ``ValueError``.
    ValueError
        Negative or not finite; :class:`ResourceLimitError` above :data:`MAX_SMOOTH_CELLS`.
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise InputTypeError(f"{where} must be a number of cells, got {type(value).__name__} {value!r}")
    v = float(value)
    if not math.isfinite(v) or v < 0.0:
        raise ValueError(f"{where} must be a finite number of cells >= 0, got {value!r}")
    if v > MAX_SMOOTH_CELLS:
        raise ResourceLimitError(
            f"{where} = {v:g} cells is more than the limit of {MAX_SMOOTH_CELLS:g} cells (the standard deviation of "
            "the Gaussian the belief is smoothed with; 1 is typical)"
        )
    return v


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
    """Refuse a grid with too many cells or (given ``v_max``) a prediction step too expensive
    (:func:`check_motion_step`)."""
    n_cells = int(nx) * int(ny)
    if n_cells > MAX_GRID_CELLS:
        raise ResourceLimitError(
            f"{where}: {nx} x {ny} = {n_cells} cells is more than the limit of {MAX_GRID_CELLS} cells; "
            "use fewer, larger cells"
        )
    if v_max is not None:
        check_motion_step(n_cells, resolution, v_max=v_max, dt=dt, where=where)


def check_motion_step(n_cells: int, resolution: float, *, v_max: float, dt: float, where: str = "grid") -> None:
    """Refuse a people-motion step whose neighbourhood (``R = ceil(v_max dt / resolution) + 1`` cells) is wider than
    :data:`MAX_KERNEL_RADIUS_CELLS` or costs more than :data:`MAX_STEP_OPERATIONS` over ``n_cells`` cells
    (``n_cells (2 R + 1)^2``): checked before a kernel is computed, by both filters
    (:func:`gridbridge.people_motion.people_motion_kernel`) and for a run's grid.

    Raises
    ------
    ResourceLimitError
        Naming ``where``, the resolution, the speed, the step, the radius and the cost.
    """
    reach = kernel_reach_cells(resolution, v_max=v_max, dt=dt)
    ops = n_cells * (2.0 * reach + 1.0) ** 2
    if reach > MAX_KERNEL_RADIUS_CELLS or ops > MAX_STEP_OPERATIONS:
        raise ResourceLimitError(
            f"{where}: resolution {resolution!r} m with people walking up to {v_max:.3g} m/s in {dt:g} s "
            f"gives a motion neighbourhood of {reach:.3g} cells radius (limit {MAX_KERNEL_RADIUS_CELLS}): about "
            f"{ops:.3g} operations per frame over {n_cells} cells (limit {MAX_STEP_OPERATIONS:.0e}); use a coarser "
            "resolution (the paper uses 0.3 m) or a shorter step"
        )


def check_memory(
    n_cells: int, *, n_detectors: int = 1, extra_bytes: int = 0, extra: str = "", where: str = "run"
) -> None:
    """Refuse a run whose estimated memory (:func:`estimate_run_bytes`) exceeds :func:`memory_budget_bytes`.

    ``extra_bytes``: the filter's own state besides the grids, described by ``extra`` in the error (e.g.
    ``"1000000 samples"``).
    """
    need = estimate_run_bytes(n_cells, n_detectors=n_detectors, extra_bytes=extra_bytes)
    budget = memory_budget_bytes()
    if need > budget:
        more = f", {extra}" if extra else ""
        raise ResourceLimitError(
            f"{where}: the requested run needs about {_human(need)} ({n_cells} cells, {n_detectors} detector(s)"
            f"{more}), more than the budget of {_human(budget)} (half the physical memory, or "
            "PFPEOPLE_MAX_MEMORY_BYTES)"
        )
