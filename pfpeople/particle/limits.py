"""The particle filter's resource limits, checked before anything large is allocated (the grid's are
:mod:`gridbridge.limits`)."""

from __future__ import annotations

from gridbridge import GridSpec, PeopleMotion
from gridbridge.limits import check_grid_size, check_particles
from gridbridge.validation import check_int
from pfpeople.particle.resampler.policy import Resampler

__all__ = ["check_particle_count"]


def check_particle_count(
    n_particles: int, spec: GridSpec, motion: PeopleMotion, resampler: Resampler, n_detectors: int
) -> int:
    """``n_particles`` checked: a count of at least the grid's cells whose largest count between resamplings
    (``resampler.capacity``) fits the memory limits; the grid's limits too (:func:`gridbridge.limits.check_grid_size`).

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
