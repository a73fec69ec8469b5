"""Synthetic walkers around the robot: standing, walking along, crossing, stop-and-go and pairs.

Walkers are placed relative to the robot's pose at their spawn time (so they meet the robot's local grid,
whatever path the robot drives) and then move in the world frame, independently of the robot:

- ``stand``: stands at one spot ahead of the robot for a random time;
- ``walk``: walks along the robot's heading, towards it from beyond the grid or away from it;
- ``cross``: enters from one side of the grid and walks across it;
- ``stop_and_go``: crosses, stops half-way for a random time, then walks on;
- ``pair``: two people side by side (``pair_spacing`` apart) on a ``walk`` or ``cross`` path.

Walking speeds are drawn from N(speed_mu, speed_sigma) truncated to [speed_min, speed_max]; the defaults are
the paper's people motion model (N(1.46, 0.63) m/s, Daamen & Hoogendoorn 2007). ``initial_people`` walkers are
already under way at t = 0; further walkers arrive as a Poisson process of rate ``spawn_rate`` (1/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from evaluation.scenarios.robot import sensor_to_world
from evaluation.scenarios.tracks import Track
from gridbridge.grid import GridSpec
from gridbridge.validation import check_positive

__all__ = ["BEHAVIOURS", "WalkerConfig", "synthetic_tracks"]

BEHAVIOURS = ("stand", "walk", "cross", "stop_and_go", "pair")


@dataclass(frozen=True, kw_only=True)
class WalkerConfig:
    """Synthetic people.

    Parameters
    ----------
    initial_people : int
        Walkers already in progress at t = 0.
    spawn_rate : float
        Arrival rate of further walkers (1/s).
    p_stand, p_walk, p_cross, p_stop_and_go, p_pair : float
        Relative weights of the behaviours (normalised; at least one positive). A pair counts as one arrival.
    speed_mu, speed_sigma : float
        Walking speed distribution N(mu, sigma) (m/s); default the paper's Table 1.
    speed_min, speed_max : float
        Truncation of the speed distribution (m/s).
    stand_min, stand_max : float
        Standing duration range (s).
    stop_min, stop_max : float
        Duration of a stop-and-go walker's stop (s).
    pair_spacing : float
        Distance between the two people of a pair (m).
    """

    initial_people: int = 4
    spawn_rate: float = 0.2
    p_stand: float = 0.2
    p_walk: float = 0.25
    p_cross: float = 0.25
    p_stop_and_go: float = 0.15
    p_pair: float = 0.15
    speed_mu: float = 1.46
    speed_sigma: float = 0.63
    speed_min: float = 0.3
    speed_max: float = 2.5
    stand_min: float = 5.0
    stand_max: float = 30.0
    stop_min: float = 1.0
    stop_max: float = 4.0
    pair_spacing: float = 0.7

    def __post_init__(self) -> None:
        if isinstance(self.initial_people, bool) or not isinstance(self.initial_people, int | np.integer):
            raise ValueError(f"WalkerConfig.initial_people must be an integer, got {self.initial_people!r}")
        if self.initial_people < 0:
            raise ValueError(f"WalkerConfig.initial_people must be >= 0, got {self.initial_people!r}")
        check_positive(self.spawn_rate, "WalkerConfig.spawn_rate", allow_zero=True)
        weights = self.behaviour_weights()
        for name, w in zip(BEHAVIOURS, weights, strict=True):
            check_positive(w, f"WalkerConfig.p_{name}", allow_zero=True)
        if weights.sum() <= 0:
            raise ValueError("WalkerConfig.p_stand..p_pair: at least one behaviour weight must be positive")
        check_positive(self.speed_mu, "WalkerConfig.speed_mu", allow_zero=True)
        check_positive(self.speed_sigma, "WalkerConfig.speed_sigma", allow_zero=True)
        check_positive(self.speed_min, "WalkerConfig.speed_min")
        check_positive(self.speed_max, "WalkerConfig.speed_max")
        if self.speed_min >= self.speed_max:
            raise ValueError("WalkerConfig.speed_min must be below speed_max")
        if self.speed_sigma == 0 and not self.speed_min <= self.speed_mu <= self.speed_max:
            raise ValueError("WalkerConfig.speed_mu must lie in [speed_min, speed_max] when speed_sigma is 0")
        for lo, hi in (("stand_min", "stand_max"), ("stop_min", "stop_max")):
            check_positive(getattr(self, lo), f"WalkerConfig.{lo}", allow_zero=True)
            check_positive(getattr(self, hi), f"WalkerConfig.{hi}", allow_zero=True)
            if getattr(self, lo) > getattr(self, hi):
                raise ValueError(f"WalkerConfig.{lo} must not exceed {hi}")
        check_positive(self.pair_spacing, "WalkerConfig.pair_spacing")

    def behaviour_weights(self) -> NDArray[np.float64]:
        return np.array([self.p_stand, self.p_walk, self.p_cross, self.p_stop_and_go, self.p_pair], dtype=float)


def walking_speed(mu: float, sigma: float, lo: float, hi: float, rng: np.random.Generator) -> float:
    """One walking speed (m/s) from N(mu, sigma) truncated to [lo, hi] (rejection sampling, bounded tries).

    Shared by the walkers of this module and the scan-level scenes (:mod:`evaluation.scenarios.scan`).
    """
    for _ in range(1000):
        s = rng.normal(mu, sigma)
        if lo <= s <= hi:
            return float(s)
    return float(np.clip(mu, lo, hi))


def _speed(cfg: WalkerConfig, rng: np.random.Generator) -> float:
    return walking_speed(cfg.speed_mu, cfg.speed_sigma, cfg.speed_min, cfg.speed_max, rng)


def polyline_knots(
    t0: float, points: NDArray[np.float64], speed: float, pauses: dict[int, float]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Knot times (s, from ``t0``) and positions for walking the polyline ``points`` (m) at ``speed`` (m/s),
    pausing ``pauses[k]`` seconds at vertex k."""
    times = [t0]
    xy = [points[0]]
    t = t0
    for k in range(1, len(points)):
        t += float(np.hypot(*(points[k] - points[k - 1]))) / speed
        times.append(t)
        xy.append(points[k])
        if k in pauses:
            t += pauses[k]
            times.append(t)
            xy.append(points[k])
    return np.array(times), np.array(xy)


def _local_path(
    kind: str, spec: GridSpec, cfg: WalkerConfig, rng: np.random.Generator
) -> tuple[NDArray[np.float64], dict[int, float], float]:
    """A path in the robot's sensor frame at spawn time: vertices, pauses (s at vertex), speed (m/s)."""
    x0, x1, y0, y1 = spec.extent
    if kind == "stand":
        p = np.array([rng.uniform(x0 + 1.0, x1 + 2.0), rng.uniform(y0 + 0.5, y1 - 0.5)])
        return np.array([p, p]), {1: rng.uniform(cfg.stand_min, cfg.stand_max)}, 1.0
    speed = _speed(cfg, rng)
    if kind == "walk":
        lane = rng.uniform(y0 + 1.0, y1 - 1.0)
        drift = rng.uniform(-0.2, 0.2)
        length = (x1 - x0) + 8.0
        if rng.random() < 0.5:  # towards the robot, from beyond the grid
            start = np.array([rng.uniform(x1 - 1.0, x1 + 2.0), lane])
            heading = math.pi + drift
        else:  # away from the robot, starting in the near part of the grid
            start = np.array([rng.uniform(x0 + 0.5, x0 + 3.0), lane])
            heading = drift
        end = start + length * np.array([math.cos(heading), math.sin(heading)])
        return np.array([start, end]), {}, speed
    # cross / stop_and_go: from one side of the grid to the other
    side = 1.0 if rng.random() < 0.5 else -1.0
    x_start = rng.uniform(x0 + 1.5, x1 - 1.0)
    start = np.array([x_start, (y1 + 0.5) if side > 0 else (y0 - 0.5)])
    angle = rng.uniform(-0.35, 0.35)
    width = (y1 - y0) + 1.0
    direction = np.array([math.sin(angle), -side * math.cos(angle)])
    end = start + width * direction
    if kind == "stop_and_go":
        mid = start + rng.uniform(0.3, 0.7) * width * direction
        return np.array([start, mid, end]), {1: rng.uniform(cfg.stop_min, cfg.stop_max)}, speed
    return np.array([start, end]), {}, speed


def synthetic_tracks(
    robot_poses: NDArray[np.float64],
    dt: float,
    *,
    spec: GridSpec,
    config: WalkerConfig,
    rng: np.random.Generator,
    first_id: int = 0,
) -> tuple[list[Track], list[str]]:
    """Walkers for a robot path.

    Parameters
    ----------
    robot_poses : ndarray, shape (T, 3)
        Robot (sensor-frame) world pose per frame ``(x, y, yaw)`` (m, m, rad).
    dt : float
        Frame period (s); frame ``k`` is at ``t = k dt``.
    spec : GridSpec
        The local grid; walkers are placed relative to it.
    config : WalkerConfig
        Behaviours and speeds.
    rng : numpy.random.Generator
        Source of randomness.
    first_id : int
        Id of the first person.

    Returns
    -------
    tracks : list of Track
        World trajectories.
    behaviours : list of str
        The behaviour of each track (a pair contributes two ``"pair"`` entries).
    """
    n_frames = robot_poses.shape[0]
    duration = n_frames * dt
    arrivals: list[tuple[float, bool]] = [(0.0, True)] * config.initial_people
    if config.spawn_rate > 0:
        t = rng.exponential(1.0 / config.spawn_rate)
        while t < duration:
            arrivals.append((float(t), False))
            t += rng.exponential(1.0 / config.spawn_rate)
    weights = config.behaviour_weights()
    weights = weights / weights.sum()
    tracks: list[Track] = []
    behaviours: list[str] = []
    next_id = first_id
    for t_spawn, initial in arrivals:
        kind = BEHAVIOURS[int(rng.choice(len(BEHAVIOURS), p=weights))]
        base = kind
        if kind == "pair":
            base = "walk" if rng.random() < 0.5 else "cross"
        path, pauses, speed = _local_path(base, spec, config, rng)
        knots_t, knots_xy = polyline_knots(0.0, path, speed, pauses)
        t0 = t_spawn
        if initial:  # already under way: start somewhere along the track
            t0 = -rng.uniform(0.0, 0.6) * float(knots_t[-1])
        pose = robot_poses[min(n_frames - 1, max(0, round(t_spawn / dt)))]
        offsets = [np.zeros(2)]
        if kind == "pair":
            d = knots_xy[-1] - knots_xy[0]
            normal = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
            offsets = [0.5 * config.pair_spacing * normal, -0.5 * config.pair_spacing * normal]
        for off in offsets:
            world = sensor_to_world(knots_xy + off, pose)
            tracks.append(Track(next_id, knots_t + t0, world))
            behaviours.append(kind)
            next_id += 1
    return tracks, behaviours
