"""People as two legs with a walking gait, for the scan-level simulator.

A person's centre (midpoint of the hips, the ground truth) follows a world track ``c(t)``. Seen by a planar
laser at knee height, each leg is a circle of radius ``rho`` (0.05-0.08 m). With walking direction ``h(t)``
(unit vector of the centre's velocity, held while the person stands) and its left normal ``n(t)``:

    leg_left(t)  = c(t) + (A(s)/2) sin(phi(t)) h(t) + (w/2) n(t)
    leg_right(t) = c(t) - (A(s)/2) sin(phi(t)) h(t) - (w/2) n(t)

- ``w``: lateral distance between the leg centres (per person, uniform in [hip_width_min, hip_width_max]);
- ``A(s) = min(stride_per_speed * s, stride_max)``: each leg's swing along the walking direction, peak to
  peak, growing with the speed ``s = |c'(t)|`` (0.35 m at 1.3 m/s by default); the legs' separation along
  the walking direction then oscillates in ``[-A, A]``, so the legs are up to ``sqrt(A^2 + w^2)`` apart
  (0.40 m at 1.3 m/s, the 99th percentile of labelled leg pairs in the leg_tracker bags is 0.43 m);
- ``phi(t) = phi0 + int pi f(s) dt``: the gait phase; ``f(s) = min(f0 + f1 s, f_max)`` is the step frequency
  (two steps per gait cycle; 1.94 Hz at 1.3 m/s by default).

A standing person (``s = 0``) has ``A = 0``: legs side by side, ``w`` apart. The legs' midpoint is exactly
``c(t)``. Legs occlude each other (and other people) through the ray caster, not here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.validation import check_positive

__all__ = ["GaitParams", "leg_positions"]


@dataclass(frozen=True, kw_only=True)
class GaitParams:
    """How people's legs look and move (m, s, Hz).

    Parameters
    ----------
    leg_radius_min, leg_radius_max : float
        Leg radius range at the laser's height (m); drawn once per person.
    hip_width_min, hip_width_max : float
        Lateral distance between the two leg centres (m); drawn once per person.
    stride_per_speed : float
        Peak-to-peak swing of each leg along the walking direction per unit speed (m per m/s).
    stride_max : float
        Largest swing (m).
    step_freq_base, step_freq_per_speed, step_freq_max : float
        Step frequency ``min(base + per_speed * s, max)`` (Hz, Hz per m/s, Hz).
    """

    leg_radius_min: float = 0.05
    leg_radius_max: float = 0.08
    hip_width_min: float = 0.10
    hip_width_max: float = 0.25
    stride_per_speed: float = 0.27
    stride_max: float = 0.5
    step_freq_base: float = 1.35
    step_freq_per_speed: float = 0.45
    step_freq_max: float = 2.4

    def __post_init__(self) -> None:
        for name in (
            "leg_radius_min",
            "leg_radius_max",
            "hip_width_min",
            "hip_width_max",
            "stride_max",
            "step_freq_base",
            "step_freq_max",
        ):
            check_positive(getattr(self, name), f"GaitParams.{name}")
        check_positive(self.stride_per_speed, "GaitParams.stride_per_speed", allow_zero=True)
        check_positive(self.step_freq_per_speed, "GaitParams.step_freq_per_speed", allow_zero=True)
        for lo, hi in (("leg_radius_min", "leg_radius_max"), ("hip_width_min", "hip_width_max")):
            if getattr(self, lo) > getattr(self, hi):
                raise ValueError(f"GaitParams.{lo} must not exceed {hi}")

    def stride(self, speed: ArrayLike) -> NDArray[np.float64]:
        """Peak-to-peak swing ``A(s)`` of each leg (m) at ``speed`` (m/s)."""
        return np.minimum(self.stride_per_speed * np.asarray(speed, dtype=float), self.stride_max)

    def step_frequency(self, speed: ArrayLike) -> NDArray[np.float64]:
        """Step frequency ``f(s)`` (Hz) at ``speed`` (m/s)."""
        return np.minimum(
            self.step_freq_base + self.step_freq_per_speed * np.asarray(speed, dtype=float), self.step_freq_max
        )

    def draw_person(self, rng: np.random.Generator) -> tuple[float, float, float]:
        """One person's ``(leg radius (m), hip width (m), initial phase (rad))``."""
        return (
            float(rng.uniform(self.leg_radius_min, self.leg_radius_max)),
            float(rng.uniform(self.hip_width_min, self.hip_width_max)),
            float(rng.uniform(0.0, 2.0 * math.pi)),
        )


def leg_positions(
    times: ArrayLike,
    centres: ArrayLike,
    *,
    params: GaitParams,
    hip_width: float,
    phase0: float = 0.0,
    heading0: float = 0.0,
    standing_speed: float = 0.05,
) -> NDArray[np.float64]:
    """Both legs' centres along a centre trajectory.

    Parameters
    ----------
    times : array_like, shape (T,)
        Increasing sample times (s).
    centres : array_like, shape (T, 2)
        The person's centre (m, world frame) at ``times``; NaN rows (the person absent) give NaN legs.
        Present rows must be one contiguous run.
    params : GaitParams
        Stride and step frequency laws.
    hip_width : float
        Lateral distance between the leg centres (m).
    phase0 : float
        Gait phase at the first present sample (rad).
    heading0 : float
        Walking direction (rad, world) used until the person first moves faster than ``standing_speed``.
    standing_speed : float
        Below this speed (m/s) the walking direction is held (the velocity's direction is noise).

    Returns
    -------
    ndarray, shape (T, 2, 2)
        ``[:, 0]`` the left leg, ``[:, 1]`` the right leg (m, world frame).
    """
    t = np.asarray(times, dtype=float).reshape(-1)
    c = np.asarray(centres, dtype=float).reshape(t.size, 2)
    out = np.full((t.size, 2, 2), np.nan)
    alive = np.flatnonzero(np.all(np.isfinite(c), axis=1))
    if alive.size == 0:
        return out
    if np.any(np.diff(alive) != 1):
        raise ValueError("leg_positions: the present samples of a person must be contiguous")
    tt, cc = t[alive], c[alive]
    if tt.size >= 2:
        vel = np.gradient(cc, tt, axis=0)
    else:
        vel = np.zeros_like(cc)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    heading = np.arctan2(vel[:, 1], vel[:, 0])
    moving = speed > standing_speed
    # hold the last walking direction while standing (forward fill; heading0 before the first move)
    idx = np.where(moving, np.arange(tt.size), -1)
    idx = np.maximum.accumulate(idx)
    heading = np.where(idx >= 0, heading[np.maximum(idx, 0)], heading0)
    speed = np.where(moving, speed, 0.0)
    dts = np.diff(tt, prepend=tt[0])
    phase = phase0 + np.cumsum(math.pi * params.step_frequency(speed) * dts)
    swing = 0.5 * params.stride(speed) * np.sin(phase)
    h = np.column_stack((np.cos(heading), np.sin(heading)))
    n = np.column_stack((-h[:, 1], h[:, 0]))
    off = swing[:, None] * h + 0.5 * hip_width * n
    out[alive, 0] = cc + off
    out[alive, 1] = cc - off
    return out
