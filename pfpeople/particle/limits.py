"""The particle filter's resource limits, checked before anything large is allocated (the grid's are
:mod:`gridbridge.limits`): at most :data:`MAX_PARTICLES` particles, and their memory (:data:`BYTES_PER_PARTICLE`
each) within the run's budget. Each check raises :class:`~gridbridge.limits.ResourceLimitError` (a ``ValueError``)
naming the setting, the estimate and the limit."""

from __future__ import annotations

from gridbridge import GridSpec, PeopleMotion
from gridbridge.limits import ResourceLimitError, check_grid_size, check_memory
from gridbridge.validation import check_int
from pfpeople.particle.resampler.policy import Resampler

__all__ = ["BYTES_PER_PARTICLE", "MAX_PARTICLES", "check_particle_count", "check_particles"]

#: Largest number of particles.
MAX_PARTICLES = 200_000_000
#: Bytes per particle (five float64 arrays, and copies during prediction and resampling).
BYTES_PER_PARTICLE = 200


def check_particles(n_particles: int, *, n_cells: int, n_detectors: int = 1, where: str = "n_particles") -> None:
    """Refuse a particle count beyond :data:`MAX_PARTICLES` or the memory budget
    (:func:`gridbridge.limits.check_memory`) of a filter over ``n_cells`` cells with ``n_detectors``."""
    if n_particles > MAX_PARTICLES:
        raise ResourceLimitError(
            f"{where} = {n_particles} is more than the limit of {MAX_PARTICLES} particles "
            f"(about 5 per cell, {5 * n_cells} here, is usually enough)"
        )
    extra = BYTES_PER_PARTICLE * n_particles
    check_memory(n_cells, n_detectors=n_detectors, extra_bytes=extra, extra=f"{n_particles} particles", where=where)


def check_particle_count(
    n_particles: int, spec: GridSpec, motion: PeopleMotion, resampler: Resampler, n_detectors: int
) -> int:
    """``n_particles`` checked: a count of at least the grid's cells whose largest count between resamplings
    (``resampler.capacity``) fits the limits (:func:`check_particles`); the grid's limits too
    (:func:`gridbridge.limits.check_grid_size`).

    Raises
    ------
    ValueError
        Not a positive count, or fewer than the grid's cells; :class:`~gridbridge.limits.ResourceLimitError` beyond a
        limit, naming it.
    """
    n = check_int(n_particles, "n_particles", minimum=1)
    check_grid_size(spec.nx, spec.ny, spec.resolution, v_max=motion.v_max, dt=motion.dt)
    most = resampler.capacity(n)
    where = "n_particles" if most == n else "n_particles x (1 + max_overflow)"
    check_particles(most, n_cells=spec.n_cells, n_detectors=n_detectors, where=where)
    if n < spec.n_cells:
        raise ValueError(f"n_particles must be at least the number of grid cells ({spec.n_cells}), got {n}")
    return n
