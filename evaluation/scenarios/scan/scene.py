"""Scene configuration of the scan-level simulator, read from TOML.

A scene (``evaluation/scenarios/scan/scenes/*.toml``) is a static world (walls, furniture, poles), a robot
driving a waypoint route, its odometry, one or more lasers mounted on ``base_link`` and the people::

    name = "wheelchair"
    seed = 0
    duration_s = 90.0          # default length; the first laser's scan count can be overridden (frames)
    room = [10.0, 8.0]         # optional: walls of a room [0, W] x [0, H] (m, world frame)
    segments = [[x0, y0, x1, y1], ...]     # more walls / furniture edges (m)
    boxes = [[cx, cy, length, width, yaw], ...]   # rectangular furniture outlines (4 segments)
    poles = [[x, y, radius], ...]
    chairs = [[x, y, yaw], ...]            # 4 legs on a chair_size square
    tables = [[x, y, yaw], ...]            # 4 legs on table_size (length along the table's x)

    [robot]       # RobotRoute fields: waypoints, loop, speeds, turn rate, accelerations
    [odometry]    # OdometryNoise fields
    [[lasers]]    # LaserConfig fields; the first laser drives the ground truth and the run config
    [people]      # PeopleConfig fields; [people.gait] GaitParams fields

Units: metres, seconds, radians (REP-103: x forward, y left, yaw counter-clockwise).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evaluation.scenarios.scan.gait import GaitParams
from evaluation.scenarios.scan.raycast import NO_RETURN_KINDS
from gridbridge.geometry import from_frame
from gridbridge.validation import check_number, check_positive

__all__ = [
    "PEOPLE_SOURCES",
    "LaserConfig",
    "OdometryNoise",
    "PeopleConfig",
    "RobotRoute",
    "SceneConfig",
    "builtin_scan_scenes",
    "load_scene",
    "scene_from_mapping",
]

PEOPLE_SOURCES = ("walkers", "corridor", "eth_ucy", "none")
_SCENES_DIR = Path(__file__).with_name("scenes")


def _int(value: object, name: str, *, minimum: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)


def _rows(value: object, width: int, name: str) -> tuple[tuple[float, ...], ...]:
    arr = np.asarray(value, dtype=float)
    if arr.size == 0:
        return ()
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must be a list of [{width} numbers] rows, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return tuple(tuple(float(v) for v in row) for row in arr)


@dataclass(frozen=True, kw_only=True)
class LaserConfig:
    """A planar laser on the robot.

    Parameters
    ----------
    topic, frame_id : str
        ROS topic of its ``sensor_msgs/LaserScan`` and its frame.
    mount : (x, y, yaw)
        Pose of the laser frame in ``base_link`` (m, m, rad).
    n_beams : int
        Beams per scan; the angle increment is ``(angle_max - angle_min) / (n_beams - 1)``.
    angle_min, angle_max : float
        Bearings of the first and last beam (rad, laser frame).
    rate_hz : float
        Scan rate (Hz); scans are stamped at ``k / rate_hz`` s from the scene start (no per-beam time).
    range_min, range_max : float
        Measurable interval (m).
    noise_sd : float
        Gaussian range noise (m); 2 cm by default, as common 2-D lasers are specified (1-3 cm).
    dropout : float
        Probability that a beam returns nothing.
    mixed_pixel : float
        Probability that a beam at a depth edge returns a range between the two surfaces (mixed pixels, see
        :mod:`evaluation.scenarios.scan.raycast`).
    no_return : {"inf", "nan", "above_max", "at_max"}
        Value of beams without a return (see :mod:`evaluation.scenarios.scan.raycast`).
    sweep : bool
        Beams are taken one after the other during a mirror revolution of ``1 / rate_hz`` s (beam ``i`` at
        ``(angle_i - angle_min) / (2 pi rate_hz)`` s after the stamp; the message's ``time_increment`` says
        so) instead of all at the stamp.
    sweep_blocks : int
        Angular blocks a swept scan is simulated in (each at its mean time).
    range_at_10pct : float
        Range (m) at which a 10 %-reflectance surface at normal incidence returns half the beams (the data sheet's
        "range at 10 % reflectivity"): whether a hit returns depends on the surface's reflectivity, the range and
        the angle of incidence (:mod:`evaluation.scenarios.scan.returns`). 0 (default): every hit returns.
    """

    topic: str = "/scan"
    frame_id: str = "laser"
    mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
    n_beams: int = 720
    angle_min: float = -math.pi / 2
    angle_max: float = math.pi / 2
    rate_hz: float = 15.0
    range_min: float = 0.05
    range_max: float = 25.0
    noise_sd: float = 0.02
    dropout: float = 0.002
    mixed_pixel: float = 0.3
    no_return: str = "inf"
    sweep: bool = False
    sweep_blocks: int = 16
    range_at_10pct: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.topic, str) or not self.topic.startswith("/"):
            raise ValueError(f"LaserConfig.topic must be a topic name starting with '/', got {self.topic!r}")
        if not isinstance(self.frame_id, str) or not self.frame_id or self.frame_id == "base_link":
            raise ValueError(
                f"LaserConfig.frame_id must be a non-empty frame other than base_link, got {self.frame_id!r}"
            )
        if len(self.mount) != 3:
            raise ValueError(f"LaserConfig.mount must be [x, y, yaw], got {self.mount!r}")
        object.__setattr__(self, "mount", tuple(check_number(v, "LaserConfig.mount") for v in self.mount))
        _int(self.n_beams, "LaserConfig.n_beams", minimum=2)
        lo, hi = (
            check_number(self.angle_min, "LaserConfig.angle_min"),
            check_number(self.angle_max, "LaserConfig.angle_max"),
        )
        if not -math.pi - 1e-9 <= lo < hi <= math.pi + 1e-9:
            raise ValueError(f"LaserConfig.angle_min/angle_max must satisfy -pi <= min < max <= pi, got {lo}, {hi}")
        check_positive(self.rate_hz, "LaserConfig.rate_hz")
        check_positive(self.range_min, "LaserConfig.range_min", allow_zero=True)
        check_positive(self.range_max, "LaserConfig.range_max")
        if self.range_min >= self.range_max:
            raise ValueError("LaserConfig.range_min must be below range_max")
        check_positive(self.noise_sd, "LaserConfig.noise_sd", allow_zero=True)
        if not 0.0 <= check_number(self.dropout, "LaserConfig.dropout") < 1.0:
            raise ValueError(f"LaserConfig.dropout must be in [0, 1), got {self.dropout!r}")
        if not 0.0 <= check_number(self.mixed_pixel, "LaserConfig.mixed_pixel") <= 1.0:
            raise ValueError(f"LaserConfig.mixed_pixel must be in [0, 1], got {self.mixed_pixel!r}")
        if self.no_return not in NO_RETURN_KINDS:
            raise ValueError(f"LaserConfig.no_return must be one of {NO_RETURN_KINDS}, got {self.no_return!r}")
        if not isinstance(self.sweep, bool):
            raise TypeError(f"LaserConfig.sweep must be a boolean, got {self.sweep!r}")
        if _int(self.sweep_blocks, "LaserConfig.sweep_blocks", minimum=1) > self.n_beams:
            raise ValueError("LaserConfig.sweep_blocks must not exceed n_beams")
        check_positive(self.range_at_10pct, "LaserConfig.range_at_10pct", allow_zero=True)

    @property
    def angle_increment(self) -> float:
        return (self.angle_max - self.angle_min) / (self.n_beams - 1)

    @property
    def time_increment(self) -> float:
        """Time between two beams (s): ``angle_increment / (2 pi rate_hz)`` when swept, else 0."""
        return self.angle_increment / (2.0 * math.pi * self.rate_hz) if self.sweep else 0.0

    def beam_time_offsets(self) -> NDArray[np.float64]:
        """Acquisition time of each beam after the stamp (s), shape (n_beams,)."""
        return np.arange(self.n_beams, dtype=np.float64) * self.time_increment


@dataclass(frozen=True, kw_only=True)
class RobotRoute:
    """The robot drives through ``waypoints`` (world frame) with a heading controller.

    Each step the robot turns towards the current waypoint, ``omega = clip(turn_gain * alpha, +-omega_max)``
    with ``alpha`` the bearing error, and drives at ``v = v_target * max(cos alpha, 0)^2`` (it slows down
    for sharp turns and turns on the spot when the waypoint is behind it); ``v_target`` is redrawn uniformly
    in ``[v_min, v_max]`` every ``speed_change_s`` seconds; ``accel`` / ``yaw_accel`` limit the changes.
    A waypoint is reached within ``reach_m``. With ``loop`` the route repeats, else the robot stops at the
    last waypoint. ``start`` is ``[x, y, yaw]``; default the first waypoint facing the second.
    """

    waypoints: tuple[tuple[float, float], ...] = ((0.0, 0.0), (5.0, 0.0))
    loop: bool = True
    start: tuple[float, ...] = ()
    v_min: float = 0.3
    v_max: float = 0.8
    omega_max: float = 0.8
    accel: float = 0.5
    yaw_accel: float = 1.5
    turn_gain: float = 1.5
    speed_change_s: float = 5.0
    reach_m: float = 0.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "waypoints", _rows(self.waypoints, 2, "RobotRoute.waypoints"))
        if len(self.waypoints) < 1:
            raise ValueError("RobotRoute.waypoints must hold at least one point")
        if not isinstance(self.loop, bool):
            raise TypeError(f"RobotRoute.loop must be a boolean, got {self.loop!r}")
        if len(self.start) not in (0, 3):
            raise ValueError(f"RobotRoute.start must be [] or [x, y, yaw], got {self.start!r}")
        object.__setattr__(self, "start", tuple(check_number(v, "RobotRoute.start") for v in self.start))
        check_positive(self.v_min, "RobotRoute.v_min", allow_zero=True)
        check_positive(self.v_max, "RobotRoute.v_max", allow_zero=True)
        if self.v_min > self.v_max:
            raise ValueError("RobotRoute.v_min must not exceed v_max")
        for name in ("omega_max", "accel", "yaw_accel", "turn_gain", "speed_change_s", "reach_m"):
            check_positive(getattr(self, name), f"RobotRoute.{name}")


@dataclass(frozen=True, kw_only=True)
class OdometryNoise:
    """Wheel odometry: integrated noisy velocities, published at ``rate_hz`` (also the simulation step).

    Reported controls per step: ``v_o = v (1 + e_v) + N(0, alpha1 v^2 + alpha2 w^2)`` and
    ``w_o = w (1 + e_w) + N(0, alpha3 v^2 + alpha4 w^2)`` (the velocity-model variances of
    :class:`gridbridge.params.SensorMotionNoise`, drawn independently every step) with systematic scale errors
    ``e_v ~ N(0, scale_sd_v^2)``, ``e_w ~ N(0, scale_sd_w^2)`` drawn once per run (wheel radius and track
    width errors). Two more errors of real wheel odometry: a yaw-rate bias ``b ~ N(0, yaw_bias_sd^2)`` (rad/s,
    drawn once per run: ``w_o += b``, a heading drift while driving straight), and slip in turns, which wheels
    report as rotation they did not make (``w_o *= 1 + slip min(|w| / 1 rad/s, 1)``). The odometry messages and
    the ``odom -> base_link`` TF are stamped ``latency_s`` after the pose they carry (a driver that stamps at
    publication). The odometry pose integrates ``(v_o, w_o)``, so its error grows with the distance driven.
    """

    rate_hz: float = 50.0
    alpha1: float = 0.0025
    alpha2: float = 0.0005
    alpha3: float = 0.0005
    alpha4: float = 0.0025
    scale_sd_v: float = 0.02
    scale_sd_w: float = 0.03
    yaw_bias_sd: float = 0.005
    slip: float = 0.05
    latency_s: float = 0.02

    def __post_init__(self) -> None:
        check_positive(self.rate_hz, "OdometryNoise.rate_hz")
        for name in (
            "alpha1",
            "alpha2",
            "alpha3",
            "alpha4",
            "scale_sd_v",
            "scale_sd_w",
            "yaw_bias_sd",
            "slip",
            "latency_s",
        ):
            check_positive(getattr(self, name), f"OdometryNoise.{name}", allow_zero=True)


@dataclass(frozen=True, kw_only=True)
class PeopleConfig:
    """Where people come from and how they walk.

    Parameters
    ----------
    source : {"walkers", "corridor", "eth_ucy", "none"}
        ``walkers``: synthetic walkers placed relative to the robot (towards and past it, crossing, stop-and-go,
        pairs, standing), cut to ``region``; ``corridor``: people entering at both ends of ``region`` (a
        corridor along x) and walking to the other end, keeping right, some in pairs; ``eth_ucy``: real tracks
        of ``sequence`` from ``t_offset_s`` on, moved by ``offset`` (m).
    region : (x_min, x_max, y_min, y_max)
        Walkable area (m, world); synthetic tracks are cut to their longest part inside it.
    initial_people : int
        Synthetic people under way at t = 0.
    spawn_rate : float
        Arrivals per second of further synthetic people (a pair counts once).
    p_towards, p_cross, p_stop_and_go, p_pair, p_stand : float
        Relative weights of the walker behaviours (``walkers``; ``corridor`` uses ``p_pair`` only).
    speed_mu, speed_sigma, speed_min, speed_max : float
        Walking speed N(mu, sigma) truncated to [min, max] (m/s).
    pair_spacing : float
        Distance between the two people of a pair (m).
    lane_min, lane_max : float
        ``corridor``: distance of a person's lane from the corridor's centre line (m), on their right.
    stand_min, stand_max, stop_min, stop_max : float
        Standing and stop durations (s).
    wander_min, wander_max : int
        ``walkers``: after its behaviour's path (cut to ``region``), a walker walks to this many random points
        of ``region`` (uniform count), pausing ``0 .. stop_max`` s at each, then leaves through the nearest
        border of ``region`` (people stay in a room instead of crossing it in seconds).
    sequence : str
        ``eth_ucy`` sequence (``seq_eth``, ``seq_hotel``, ``zara01``).
    t_offset_s : float
        ``eth_ucy``: dataset time of the scene start (s).
    offset : (x, y)
        ``eth_ucy``: added to the dataset's positions (m).
    groups : rows (x, y, n, t_start, t_end)
        People standing in groups (world, m, s), besides ``source``'s people (see
        :mod:`evaluation.scenarios.scan.standing`).
    queues : rows (x, y, yaw, n, t_start, t_end)
        People standing in a line (a queue, people waiting at a door).
    reflectivity : (low, high)
        Reflectivity of a person's trousers at the laser's height, drawn per person log-uniformly in ``[low,
        high]`` (black cloth about 0.03-0.08, jeans 0.1-0.2, light trousers 0.3-0.5); it matters only to a laser
        with ``range_at_10pct`` (:mod:`evaluation.scenarios.scan.returns`).
    shuffle_sd, shuffle_rate : float
        Standing people sway around their spot (sd, m) and shift it by 0.1-0.4 m ``shuffle_rate`` times a second.
    gait : GaitParams
        Legs and gait.
    """

    source: str = "walkers"
    region: tuple[float, float, float, float] = (-1e3, 1e3, -1e3, 1e3)
    initial_people: int = 4
    spawn_rate: float = 0.1
    p_towards: float = 0.45
    p_cross: float = 0.2
    p_stop_and_go: float = 0.1
    p_pair: float = 0.15
    p_stand: float = 0.1
    speed_mu: float = 1.3
    speed_sigma: float = 0.25
    speed_min: float = 0.5
    speed_max: float = 2.0
    pair_spacing: float = 0.65
    lane_min: float = 0.45
    lane_max: float = 1.2
    stand_min: float = 5.0
    stand_max: float = 20.0
    stop_min: float = 1.0
    stop_max: float = 4.0
    wander_min: int = 0
    wander_max: int = 0
    sequence: str = "seq_eth"
    t_offset_s: float = 0.0
    offset: tuple[float, float] = (0.0, 0.0)
    groups: tuple[tuple[float, ...], ...] = ()
    queues: tuple[tuple[float, ...], ...] = ()
    shuffle_sd: float = 0.08
    shuffle_rate: float = 0.25
    reflectivity: tuple[float, float] = (0.03, 0.5)
    gait: GaitParams = field(default_factory=GaitParams)

    def __post_init__(self) -> None:
        if self.source not in PEOPLE_SOURCES:
            raise ValueError(f"PeopleConfig.source must be one of {PEOPLE_SOURCES}, got {self.source!r}")
        if len(self.region) != 4:
            raise ValueError("PeopleConfig.region must be [x_min, x_max, y_min, y_max]")
        region = tuple(check_number(v, "PeopleConfig.region") for v in self.region)
        if region[0] >= region[1] or region[2] >= region[3]:
            raise ValueError(f"PeopleConfig.region must have x_min < x_max and y_min < y_max, got {region}")
        object.__setattr__(self, "region", region)
        _int(self.initial_people, "PeopleConfig.initial_people")
        _int(self.wander_min, "PeopleConfig.wander_min")
        if _int(self.wander_max, "PeopleConfig.wander_max") < self.wander_min:
            raise ValueError("PeopleConfig.wander_min must not exceed wander_max")
        check_positive(self.spawn_rate, "PeopleConfig.spawn_rate", allow_zero=True)
        weights = self.behaviour_weights()
        for name, w in zip(("p_towards", "p_cross", "p_stop_and_go", "p_pair", "p_stand"), weights, strict=True):
            check_positive(w, f"PeopleConfig.{name}", allow_zero=True)
        if self.source == "walkers" and weights.sum() <= 0:
            raise ValueError("PeopleConfig.p_towards..p_stand: at least one weight must be positive")
        for name in ("speed_mu", "speed_min", "speed_max", "pair_spacing", "lane_max"):
            check_positive(getattr(self, name), f"PeopleConfig.{name}")
        for name in ("speed_sigma", "lane_min", "stand_min", "stand_max", "stop_min", "stop_max", "t_offset_s"):
            check_positive(getattr(self, name), f"PeopleConfig.{name}", allow_zero=True)
        for lo, hi in (
            ("speed_min", "speed_max"),
            ("lane_min", "lane_max"),
            ("stand_min", "stand_max"),
            ("stop_min", "stop_max"),
        ):
            if getattr(self, lo) > getattr(self, hi):
                raise ValueError(f"PeopleConfig.{lo} must not exceed {hi}")
        if len(self.offset) != 2:
            raise ValueError("PeopleConfig.offset must be [x, y]")
        object.__setattr__(self, "offset", tuple(check_number(v, "PeopleConfig.offset") for v in self.offset))
        if not isinstance(self.gait, GaitParams):
            raise TypeError("PeopleConfig.gait must be a GaitParams")
        if len(self.reflectivity) != 2:
            raise ValueError("PeopleConfig.reflectivity must be [low, high]")
        lo_r, hi_r = (check_number(v, "PeopleConfig.reflectivity") for v in self.reflectivity)
        if not 0.0 < lo_r <= hi_r <= 1.0:
            raise ValueError(f"PeopleConfig.reflectivity must satisfy 0 < low <= high <= 1, got {self.reflectivity}")
        object.__setattr__(self, "reflectivity", (lo_r, hi_r))
        object.__setattr__(self, "groups", _rows(self.groups, 5, "PeopleConfig.groups"))
        object.__setattr__(self, "queues", _rows(self.queues, 6, "PeopleConfig.queues"))
        for name, rows, n_col in (("groups", self.groups, 2), ("queues", self.queues, 3)):
            for row in rows:
                if row[n_col] < 1 or row[n_col] != int(row[n_col]):
                    raise ValueError(
                        f"PeopleConfig.{name}: the number of people must be a whole number >= 1, got {row}"
                    )
                if row[-1] <= row[-2]:
                    raise ValueError(f"PeopleConfig.{name}: t_end must exceed t_start, got {row}")
        check_positive(self.shuffle_sd, "PeopleConfig.shuffle_sd", allow_zero=True)
        check_positive(self.shuffle_rate, "PeopleConfig.shuffle_rate", allow_zero=True)

    def behaviour_weights(self) -> NDArray[np.float64]:
        return np.array([self.p_towards, self.p_cross, self.p_stop_and_go, self.p_pair, self.p_stand], dtype=float)


@dataclass(frozen=True, kw_only=True)
class SceneConfig:
    """A scan-level scene (see the module docstring for the TOML form).

    Parameters
    ----------
    name : str
    seed : int
        Default seed of the scene's ``numpy.random.Generator``.
    duration_s : float
        Default length (s); the first laser makes ``round(duration_s * rate_hz)`` scans unless ``frames``.
    frames : int or None
        Number of scans of the first laser (overrides ``duration_s``).
    room : (W, H) or ()
        Walls of the rectangle [0, W] x [0, H] (m).
    segments : rows (x0, y0, x1, y1)
        More wall / furniture segments (m, world).
    boxes : rows (cx, cy, length, width, yaw)
        Rectangular outlines (m, rad).
    poles, chairs, tables : rows (x, y, radius) / (x, y, yaw)
        Round obstacles; 4-legged chairs and tables.
    chair_size, chair_leg_radius : float
        Side of a chair's leg square and its legs' radius (m).
    table_size : (length, width)
        Table leg rectangle (m); ``table_leg_radius`` its legs' radius (m).
    robot, odometry, lasers, people
        See :class:`RobotRoute`, :class:`OdometryNoise`, :class:`LaserConfig`, :class:`PeopleConfig`.
    static_reflectivity : float
        Reflectivity of the walls and furniture (0-1; :mod:`evaluation.scenarios.scan.returns`).
    base_frame, odom_frame : str
        Frame names of the robot body and the odometry origin.
    start_ns : int
        Stamp of the scene start (ns).
    """

    name: str
    seed: int = 0
    duration_s: float = 60.0
    frames: int | None = None
    room: tuple[float, ...] = ()
    segments: tuple[tuple[float, ...], ...] = ()
    boxes: tuple[tuple[float, ...], ...] = ()
    poles: tuple[tuple[float, ...], ...] = ()
    chairs: tuple[tuple[float, ...], ...] = ()
    tables: tuple[tuple[float, ...], ...] = ()
    chair_size: float = 0.4
    chair_leg_radius: float = 0.018
    table_size: tuple[float, float] = (1.2, 0.8)
    table_leg_radius: float = 0.03
    robot: RobotRoute = field(default_factory=RobotRoute)
    odometry: OdometryNoise = field(default_factory=OdometryNoise)
    lasers: tuple[LaserConfig, ...] = (LaserConfig(),)
    people: PeopleConfig = field(default_factory=PeopleConfig)
    static_reflectivity: float = 0.5
    base_frame: str = "base_link"
    odom_frame: str = "odom"
    start_ns: int = 1_600_000_000 * 10**9

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"SceneConfig.name must be a non-empty string, got {self.name!r}")
        _int(self.seed, "SceneConfig.seed")
        check_positive(self.duration_s, "SceneConfig.duration_s")
        if self.frames is not None:
            _int(self.frames, "SceneConfig.frames", minimum=1)
        if len(self.room) not in (0, 2):
            raise ValueError(f"SceneConfig.room must be [] or [width, height], got {self.room!r}")
        for v in self.room:
            check_positive(v, "SceneConfig.room")
        object.__setattr__(self, "segments", _rows(self.segments, 4, "SceneConfig.segments"))
        object.__setattr__(self, "boxes", _rows(self.boxes, 5, "SceneConfig.boxes"))
        object.__setattr__(self, "poles", _rows(self.poles, 3, "SceneConfig.poles"))
        object.__setattr__(self, "chairs", _rows(self.chairs, 3, "SceneConfig.chairs"))
        object.__setattr__(self, "tables", _rows(self.tables, 3, "SceneConfig.tables"))
        for name in ("chair_size", "chair_leg_radius", "table_leg_radius"):
            check_positive(getattr(self, name), f"SceneConfig.{name}")
        if len(self.table_size) != 2:
            raise ValueError("SceneConfig.table_size must be [length, width]")
        for v in self.table_size:
            check_positive(v, "SceneConfig.table_size")
        if not 0.0 < check_number(self.static_reflectivity, "SceneConfig.static_reflectivity") <= 1.0:
            raise ValueError(f"SceneConfig.static_reflectivity must be in (0, 1], got {self.static_reflectivity!r}")
        if not self.lasers:
            raise ValueError("SceneConfig.lasers must hold at least one laser")
        for name, cls in (("robot", RobotRoute), ("odometry", OdometryNoise), ("people", PeopleConfig)):
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"SceneConfig.{name} must be a {cls.__name__}")
        if not all(isinstance(las, LaserConfig) for las in self.lasers):
            raise TypeError("SceneConfig.lasers must be LaserConfig objects")
        topics = [las.topic for las in self.lasers]
        frames = [las.frame_id for las in self.lasers]
        if len(set(topics)) != len(topics) or len(set(frames)) != len(frames):
            raise ValueError(f"SceneConfig.lasers: topics and frames must be unique, got {topics}, {frames}")
        _int(self.start_ns, "SceneConfig.start_ns")

    @property
    def n_frames(self) -> int:
        """Scans of the first laser."""
        if self.frames is not None:
            return int(self.frames)
        return max(1, round(self.duration_s * self.lasers[0].rate_hz))

    def static_circles(self) -> NDArray[np.float64]:
        """Poles, chair and table legs as ``(C, 3)`` circles ``(x, y, radius)`` (m, world)."""
        rows: list[tuple[float, float, float]] = [(p[0], p[1], p[2]) for p in self.poles]
        half_c = 0.5 * self.chair_size
        tl, tw = 0.5 * self.table_size[0], 0.5 * self.table_size[1]
        for items, (hx, hy), rad in (
            (self.chairs, (half_c, half_c), self.chair_leg_radius),
            (self.tables, (tl, tw), self.table_leg_radius),
        ):
            legs = [(sx * (hx - rad), sy * (hy - rad)) for sx, sy in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
            for x, y, yaw in items:
                rows += [(float(lx), float(ly), rad) for lx, ly in from_frame(legs, (x, y, yaw))]
        return np.array(rows, dtype=float).reshape(-1, 3)

    def static_segments(self) -> NDArray[np.float64]:
        """Walls, segments and box outlines as ``(S, 4)`` rows ``(x0, y0, x1, y1)`` (m, world)."""
        rows: list[tuple[float, ...]] = list(self.segments)
        if self.room:
            w, h = self.room
            rows += [(0.0, 0.0, w, 0.0), (w, 0.0, w, h), (w, h, 0.0, h), (0.0, h, 0.0, 0.0)]
        for cx, cy, length, width, yaw in self.boxes:
            hl, hw = length / 2, width / 2
            corners = from_frame([(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)], (cx, cy, yaw))
            for k in range(4):
                (x0, y0), (x1, y1) = corners[k], corners[(k + 1) % 4]
                rows.append((float(x0), float(y0), float(x1), float(y1)))
        return np.array(rows, dtype=float).reshape(-1, 4)


def _build(cls: type, table: Mapping[str, Any], where: str) -> Any:
    if not isinstance(table, Mapping):
        raise ValueError(f"scene: [{where}] must be a table")
    allowed = {f.name for f in fields(cls)}
    unknown = set(table) - allowed
    if unknown:
        raise ValueError(f"scene: unknown keys {sorted(unknown)} in [{where}]; allowed: {sorted(allowed)}")
    kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in table.items()}
    return cls(**kwargs)


def scene_from_mapping(data: Mapping[str, Any]) -> SceneConfig:
    """Build a :class:`SceneConfig` from a parsed TOML document (see the module docstring)."""
    data = dict(data)
    robot = _build(RobotRoute, data.pop("robot", {}), "robot")
    odometry = _build(OdometryNoise, data.pop("odometry", {}), "odometry")
    lasers_t = data.pop("lasers", [{}])
    if not isinstance(lasers_t, list):
        raise ValueError("scene: lasers must be an array of tables ([[lasers]])")
    lasers = tuple(_build(LaserConfig, t, f"lasers[{k}]") for k, t in enumerate(lasers_t))
    people_t = dict(data.pop("people", {}))
    gait = _build(GaitParams, people_t.pop("gait", {}), "people.gait")
    people = _build(PeopleConfig, {**people_t}, "people")
    people = replace(people, gait=gait)
    return _build(
        SceneConfig, {**data, "robot": robot, "odometry": odometry, "lasers": lasers, "people": people}, "top level"
    )


def builtin_scan_scenes() -> list[str]:
    """Names of the built-in scenes (``scenes/*.toml``)."""
    return sorted(p.stem for p in _SCENES_DIR.glob("*.toml"))


def load_scene(scene: str | Path | SceneConfig) -> SceneConfig:
    """A scene from a built-in name, a TOML path or a ready :class:`SceneConfig`; errors name the file."""
    if isinstance(scene, SceneConfig):
        return scene
    path = Path(scene)
    if not path.suffix and not path.exists():
        path = _SCENES_DIR / f"{scene}.toml"
        if not path.is_file():
            raise ValueError(f"no built-in scan scene {str(scene)!r}; available: {builtin_scan_scenes()}")
    if not path.is_file():
        raise FileNotFoundError(f"scene file {str(path)!r} does not exist")
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"scene file {str(path)!r} is not valid TOML: {exc}") from None
    try:
        return scene_from_mapping(data)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"scene file {str(path)!r}: {exc}") from None
