"""Resource limits of pfpeople's own filters, on top of :mod:`gridbridge.limits` (the grid's).

A particle count far beyond what a robot needs (``n_particles = 1e9``) must fail at once with a message naming the
setting: at most :data:`MAX_PARTICLES`, and the run's memory estimate (:func:`gridbridge.limits.estimate_run_bytes`
with :data:`BYTES_PER_PARTICLE` per particle) within the budget (:func:`gridbridge.limits.memory_budget_bytes`).
Every check raises :class:`gridbridge.limits.ResourceLimitError` (a ``ValueError``) naming the setting, the estimate
and the limit.
"""

from __future__ import annotations

from gridbridge.limits import ResourceLimitError, check_memory

__all__ = ["BYTES_PER_PARTICLE", "MAX_PARTICLES", "check_particles"]

#: Largest number of particles.
MAX_PARTICLES = 200_000_000
#: Bytes per particle (five float64 arrays, and copies during prediction and resampling).
BYTES_PER_PARTICLE = 200


def check_particles(n_particles: int, *, n_cells: int, n_detectors: int = 1, where: str = "n_particles") -> None:
    """Refuse a particle count beyond :data:`MAX_PARTICLES` or the memory budget."""
    if n_particles > MAX_PARTICLES:
        raise ResourceLimitError(
            f"{where} = {n_particles} is more than the limit of {MAX_PARTICLES} particles "
            f"(about 5 per cell, {5 * n_cells} here, is usually enough)"
        )
    check_memory(
        n_cells,
        n_detectors=n_detectors,
        extra_bytes=BYTES_PER_PARTICLE * n_particles,
        extra=f"{n_particles} particles",
        where=where,
    )
