"""``[filter]``: which filter a run uses, its mode and its options (built by
:func:`pfpeople.pipeline.assembly.build_filter`)."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

from pydantic import Field, model_validator

from pfpeople.config.modes import for_mode
from pfpeople.config.schema import (
    ConfigError,
    Count,
    Flag,
    Metres,
    Number,
    PerSecond,
    Ratio,
    Table,
    fill_defaults,
    table,
)

__all__ = ["FilterConfig"]

#: Particles per grid cell and the least count of ``n_particles = "auto"``.
PARTICLES_PER_CELL = 5
MIN_AUTO_PARTICLES = 5000


@table
class FilterConfig(Table):
    """Which filter a run uses and its options (``[filter]``).

    Parameters
    ----------
    kind : {"grid", "particle"}
        The filter: ``gridbridge.GridFilter`` (the paper's grid filter) or ``pfpeople.ParticleFilter`` (particles
        rasterised into the same grid).
    mode : {"recommended", "paper"}
        ``"recommended"``: the product's configuration, chosen on the benchmark across every scene (linear people
        prediction, an appearance probability, bounded belief, calibrated independent fusion of the detectors, laser
        detections with a person's footprint). ``"paper"``: Batista & Pereira (2015) as written (De Morgan fusion,
        unbounded belief, border belief 0.5). The mode also sets the defaults of the fields left out (the
        reference's paper-mode column).
    form : {"linear", "paper"}
        Grid filter: the people-motion prediction, the integrated kernel (``"linear"``) or the paper's eq. 8
        (``"paper"``). The particle filter always samples the integrated kernel.
    initial : float or "base_rate"
        Initial belief of every cell; ``"base_rate"``: the value of ``base_rate``.
    n_particles : int or "auto"
        Particle filter: the particle count; ``"auto"``: 5 per grid cell, at least 5000.
    seed : int
        Seed (>= 0) of the particle filter's random numbers (same seed, same run).
    motion_model : {"persistent", "paper"}
        Particle filter: the people-motion sampler. ``"persistent"``: walkers keep their heading and speed (compact
        person blobs, better precision and tracks on every scene); ``"paper"``: the paper's memoryless model (what
        the grid filter predicts).
    compiled_draws : bool
        Particle filter with the persistent motion: draw its random numbers inside the compiled step (faster; the
        same distributions as numpy's draws, other draws). The paper's motion always draws there.
    max_overflow : float
        Particle filter: births may push the count this fraction above ``n_particles`` before they trigger a
        resampling (0.1: 29 % of the steps resample instead of all, at the same accuracy; 0: every overflow).
    base_rate : float
        Recommended mode: prior probability of a person in a cell (the appearance floor, the belief outside the
        grid, and the calibration of the detectors' PPV).
    appearance_rate : float
        Recommended mode: rate at which an observed cell gets someone new (:class:`gridbridge.components.Appearance`).
    belief_max : float
        Recommended mode: upper bound of the belief (bounded log-odds); above ``base_rate``.
    laser_footprint : float
        Recommended mode: a laser (point) detection fires every cell whose centre is within this distance.
    """

    TABLE: ClassVar[str] = "[filter]"

    kind: Literal["grid", "particle"] = "grid"
    mode: Literal["recommended", "paper"] = "recommended"
    form: Literal["linear", "paper"] = "linear"
    initial: Annotated[Ratio, Field(ge=0.0, le=1.0)] | Literal["base_rate"] = "base_rate"
    n_particles: Annotated[Count, Field(ge=1)] | Literal["auto"] = "auto"
    seed: Count = Field(default=0, ge=0)
    motion_model: Literal["persistent", "paper"] = "persistent"
    compiled_draws: Flag = True
    max_overflow: Number = Field(default=0.1, ge=0.0, le=10.0)
    base_rate: Ratio = Field(default=0.02, gt=0.0, lt=1.0)
    appearance_rate: PerSecond = Field(default=0.05, ge=0.0)
    belief_max: Ratio = Field(default=0.99, gt=0.0, lt=1.0)
    laser_footprint: Metres = Field(default=0.3, ge=0.0)

    @model_validator(mode="before")
    @classmethod
    def _mode_defaults(cls, data: Any) -> Any:
        return fill_defaults(data, lambda given: for_mode(str(given.get("mode", "recommended")), "filter", given))

    def check(self) -> None:
        """``base_rate`` below ``belief_max`` in the recommended mode."""
        if self.mode == "recommended" and not self.base_rate < self.belief_max:
            raise ConfigError(f"[filter] base_rate ({self.base_rate}) must be below belief_max ({self.belief_max})")

    @property
    def initial_belief(self) -> float:
        """The initial belief of every cell (``initial``, or ``base_rate`` for ``"base_rate"``)."""
        return self.base_rate if self.initial == "base_rate" else float(self.initial)

    def particles_for(self, n_cells: int) -> int:
        """The particle count for a grid of ``n_cells`` cells (``n_particles``, or ``"auto"``'s)."""
        if self.n_particles == "auto":
            return max(MIN_AUTO_PARTICLES, PARTICLES_PER_CELL * n_cells)
        return int(self.n_particles)
