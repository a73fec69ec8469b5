"""Scenarios: a robot driving through people, with ground truth and simulated detectors, frame by frame.

A :class:`ScenarioConfig` (frozen, keyword-only, TOML-loadable) says how long, how the robot drives, where
the people come from (synthetic walkers or a replayed ETH/UCY sequence) and how each detector fails. A
:class:`Scenario` builds the world once (robot path and people tracks, cheap) and yields :class:`Frame` s
lazily; the detector noise of frame ``k`` comes from its own random stream, so iterating twice or asking
:meth:`Scenario.frame` for one frame gives the same result (same seed, same frames).

Per frame ``k`` (``stamp = k dt`` s):

- ``v, omega``: the controls (m/s, rad/s) that moved the robot from frame ``k - 1`` to ``k`` under the
  velocity motion model (constant over ``dt``; see :mod:`evaluation.scenarios.robot`); ``v_odom, omega_odom``
  the reported, optionally noisy, odometry;
- ``person_ids`` / ``people``: every person existing at that time, positions (m) in the grid's sensor frame
  (REP-103), including people outside the grid (they can occlude and be seen by the detectors);
- ``truth_grid``: (nx, ny) bool, the cells a person's disc (radius ``person_radius``) overlaps: a cell counts
  when the distance from the person's centre to the closed cell square is below the radius
  (:func:`occupancy_grid`);
- ``outputs``: one :class:`~evaluation.scenarios.simulated_detectors.DetectorOutput` per detector; ``detections`` is the
  list of (M_i, 2) arrays ``GridFilter.step(detections, odometry, dt)`` takes.

Built-in scenarios are TOML files next to this module: ``default`` (synthetic, short), ``corridor`` (robot
driving with turns; walkers crossing, standing, pairs), ``complementary`` (detectors with complementary
misses and laser occlusion: the fused filter should beat every single detector in recall) and ``eth``
(the real seq_eth crowd, needs ``../shared/data``).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evaluation.scenarios.eth_ucy import load_tracks
from evaluation.scenarios.robot import (
    RobotProfile,
    integrate_path,
    noisy_odometry,
    robot_controls,
    world_to_sensor,
)
from evaluation.scenarios.simulated_detectors import (
    DetectorOutput,
    SimulatedDetector,
    paper_simulated_detectors,
    simulate_detections,
)
from evaluation.scenarios.tracks import Track, sample_tracks
from evaluation.scenarios.walkers import WalkerConfig, synthetic_tracks
from gridbridge.ego_motion import Odometry
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel, SensorMotionNoise
from gridbridge.validation import check_positive

__all__ = [
    "EthReplay",
    "Frame",
    "Scenario",
    "ScenarioConfig",
    "builtin_scenarios",
    "load_scenario_config",
    "occupancy_grid",
]

# Random streams of one seed (SeedSequence spawn keys): independent and stable when one part changes.
_STREAM_ROBOT, _STREAM_PEOPLE, _STREAM_ODOMETRY, _STREAM_DETECTORS = 0, 1, 2, 3


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(entropy=seed, spawn_key=key)))


def occupancy_grid(spec: GridSpec, positions: ArrayLike, *, radius: float = 0.25) -> NDArray[np.bool_]:
    """True occupancy: cells overlapped by a person's disc.

    A cell ``[i, j]`` is occupied when, for some person at ``p``, the distance from ``p`` to the closed
    square of the cell is strictly below ``radius``. With ``radius = 0`` a person marks only the cell that
    contains it (half-open cells, as :meth:`GridSpec.flat_index`).

    Parameters
    ----------
    spec : GridSpec
        The grid.
    positions : array_like, shape (P, 2)
        People positions (m), grid sensor frame; people outside the grid may overlap border cells.
    radius : float
        Person disc radius (m), >= 0.

    Returns
    -------
    ndarray of bool, shape (nx, ny)
    """
    pts = np.asarray(positions, dtype=float).reshape(-1, 2)
    radius = check_positive(radius, "radius", allow_zero=True)
    if not np.all(np.isfinite(pts)):
        raise ValueError("positions contains NaN or infinite values")
    grid = np.zeros(spec.shape, dtype=bool)
    if pts.shape[0] == 0:
        return grid
    if radius == 0.0:
        flat = spec.flat_index(pts[:, 0], pts[:, 1])
        grid.reshape(-1)[flat[flat >= 0]] = True
        return grid
    cx, cy = spec.cell_centres()
    half = 0.5 * spec.resolution
    for px, py in pts:
        dx = np.maximum(np.abs(px - cx) - half, 0.0)
        dy = np.maximum(np.abs(py - cy) - half, 0.0)
        grid |= dx * dx + dy * dy < radius * radius
    return grid


@dataclass(frozen=True, kw_only=True)
class EthReplay:
    """Replay of an ETH/UCY sequence (:mod:`evaluation.scenarios.eth_ucy`).

    Parameters
    ----------
    sequence : str
        ``seq_eth``, ``seq_hotel`` or ``zara01``.
    start_s : float
        Scenario time 0 is this many seconds after the sequence's first annotation.
    data_root : str, optional
        Folder holding ``eth_ucy/``; default ``../shared/data`` (or ``$PFPEOPLE_DATA``).
    start_pose : tuple of 3 floats, optional
        Robot start pose (x, y, yaw) in the dataset's world frame (m, m, rad). Default: 3 m behind the
        median position of the people in the time window, heading along the main walking direction, against
        the mean flow (so the robot meets people).
    """

    sequence: str = "seq_eth"
    start_s: float = 0.0
    data_root: str | None = None
    start_pose: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.sequence, str) or not self.sequence:
            raise ValueError(f"EthReplay.sequence must be a non-empty string, got {self.sequence!r}")
        check_positive(self.start_s, "EthReplay.start_s", allow_zero=True)
        if self.start_pose is not None:
            pose = tuple(float(c) for c in self.start_pose)
            if len(pose) != 3 or not all(math.isfinite(c) for c in pose):
                raise ValueError(f"EthReplay.start_pose must be 3 finite numbers (x, y, yaw), got {self.start_pose!r}")
            object.__setattr__(self, "start_pose", pose)


@dataclass(frozen=True, kw_only=True)
class ScenarioConfig:
    """Everything that defines a scenario; same config and seed, same frames.

    Parameters
    ----------
    name : str
        Scenario name.
    n_frames : int
        Number of frames.
    dt : float
        Frame period (s); 0.1 s as the paper's Table 1.
    seed : int
        Seed of every random stream (robot path, people, odometry noise, detectors).
    grid : GridSpec
        The local grid in the robot's sensor frame.
    person_radius : float
        Person disc radius (m) for the truth grid and occlusion.
    people : {"synthetic", "eth_ucy"}
        Where people come from.
    walkers : WalkerConfig
        Synthetic people (``people = "synthetic"``).
    eth : EthReplay
        Real people (``people = "eth_ucy"``).
    robot : RobotProfile
        How the robot drives.
    odometry_noise : SensorMotionNoise or None
        Noise of the reported odometry; None reports the true controls.
    detectors : tuple of SimulatedDetector
        The simulated detectors, in filter order. Default: the paper's three.
    """

    name: str = "default"
    n_frames: int = 300
    dt: float = 0.1
    seed: int = 0
    grid: GridSpec = field(default_factory=GridSpec)
    person_radius: float = 0.25
    people: Literal["synthetic", "eth_ucy"] = "synthetic"
    walkers: WalkerConfig = field(default_factory=WalkerConfig)
    eth: EthReplay = field(default_factory=EthReplay)
    robot: RobotProfile = field(default_factory=RobotProfile)
    odometry_noise: SensorMotionNoise | None = field(default_factory=SensorMotionNoise)
    detectors: tuple[SimulatedDetector, ...] = field(default_factory=paper_simulated_detectors)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"ScenarioConfig.name must be a non-empty string, got {self.name!r}")
        for name in ("n_frames", "seed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise ValueError(f"ScenarioConfig.{name} must be an integer, got {value!r}")
        if self.n_frames < 1:
            raise ValueError(f"ScenarioConfig.n_frames must be >= 1, got {self.n_frames!r}")
        if self.seed < 0:
            raise ValueError(f"ScenarioConfig.seed must be >= 0, got {self.seed!r}")
        check_positive(self.dt, "ScenarioConfig.dt")
        check_positive(self.person_radius, "ScenarioConfig.person_radius", allow_zero=True)
        if self.people not in ("synthetic", "eth_ucy"):
            raise ValueError(f"ScenarioConfig.people must be 'synthetic' or 'eth_ucy', got {self.people!r}")
        checks: tuple[tuple[str, type], ...] = (
            ("grid", GridSpec),
            ("walkers", WalkerConfig),
            ("eth", EthReplay),
            ("robot", RobotProfile),
        )
        for name, kind in checks:
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"ScenarioConfig.{name} must be a {kind.__name__}")
        if self.odometry_noise is not None and not isinstance(self.odometry_noise, SensorMotionNoise):
            raise ValueError("ScenarioConfig.odometry_noise must be a SensorMotionNoise or None")
        dets = tuple(self.detectors)
        if not dets or not all(isinstance(d, SimulatedDetector) for d in dets):
            raise ValueError("ScenarioConfig.detectors must be a non-empty sequence of SimulatedDetector")
        names = [d.name for d in dets]
        if len(set(names)) != len(names):
            raise ValueError(f"ScenarioConfig.detectors: detector names must be unique, got {names}")
        object.__setattr__(self, "detectors", dets)

    @property
    def detector_models(self) -> tuple[DetectorModel, ...]:
        """The detectors' models, for ``GridFilter(detectors=...)``."""
        return tuple(d.model for d in self.detectors)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ScenarioConfig:
        """Build from a parsed TOML document (see the built-in ``*.toml`` files for the layout).

        Top-level keys are the scalar fields; tables ``[grid]``, ``[robot]``, ``[walkers]``, ``[eth]``,
        ``[odometry_noise]`` (or ``odometry_noise = false`` for exact odometry) and ``[[detectors]]``
        (see :meth:`SimulatedDetector.from_dict`). Unknown keys raise ``ValueError`` naming them.
        """
        data = dict(data)
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise ValueError(f"unknown scenario field(s) {sorted(unknown)}; known: {sorted(known)}")
        kwargs: dict[str, Any] = {}
        tables: dict[str, type] = {
            "grid": GridSpec,
            "robot": RobotProfile,
            "walkers": WalkerConfig,
            "eth": EthReplay,
        }
        for key, value in data.items():
            if key in tables:
                if not isinstance(value, Mapping):
                    raise ValueError(f"scenario field {key!r} must be a table")
                kwargs[key] = _build(tables[key], value, key)
            elif key == "odometry_noise":
                if value is False:
                    kwargs[key] = None
                elif isinstance(value, Mapping):
                    kwargs[key] = _build(SensorMotionNoise, value, key)
                else:
                    raise ValueError("scenario field 'odometry_noise' must be a table or false")
            elif key == "detectors":
                if not isinstance(value, list):
                    raise ValueError("scenario field 'detectors' must be an array of tables ([[detectors]])")
                kwargs[key] = tuple(SimulatedDetector.from_dict(d) for d in value)
            else:
                kwargs[key] = value
        return cls(**kwargs)

    @classmethod
    def from_toml(cls, path: str | os.PathLike[str]) -> ScenarioConfig:
        """Read a scenario TOML file (errors name the file)."""
        return _config_from_file(Path(path), {})


def _config_from_file(path: Path, overrides: Mapping[str, Any]) -> ScenarioConfig:
    """A scenario TOML file with top-level ``overrides``; any error is a ``ValueError`` naming the file."""
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: invalid TOML ({exc})") from exc
    data.update(overrides)
    try:
        return ScenarioConfig.from_dict(data)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from exc


def _build(kind: type, table: Mapping[str, Any], where: str) -> Any:
    known = {f.name for f in fields(kind)}
    unknown = set(table) - known
    if unknown:
        raise ValueError(f"unknown field(s) {sorted(unknown)} in [{where}]; known: {sorted(known)}")
    return kind(**table)


def builtin_scenarios() -> list[str]:
    """Names of the built-in scenarios (TOML files shipped in this package)."""
    root = resources.files("evaluation.scenarios")
    return sorted(p.name[: -len(".toml")] for p in root.iterdir() if p.name.endswith(".toml"))


def load_scenario_config(name_or_path: str | os.PathLike[str], **overrides: Any) -> ScenarioConfig:
    """A built-in scenario by name, or a TOML file by path; ``overrides`` replace top-level fields.

    Raises
    ------
    ValueError
        Unknown name (listing the built-in ones) or a bad file.
    """
    text = os.fspath(name_or_path)
    given = {k: v for k, v in overrides.items() if v is not None}
    if text in builtin_scenarios():
        res = resources.files("evaluation.scenarios") / f"{text}.toml"
        data = tomllib.loads(res.read_text(encoding="utf-8"))
        data.update(given)
        return ScenarioConfig.from_dict(data)
    path = Path(text)
    if not path.is_file():
        raise ValueError(
            f"scenario {text!r} is neither a built-in scenario ({', '.join(builtin_scenarios())}) nor a file"
        )
    return _config_from_file(path, given)


@dataclass(frozen=True, eq=False)
class Frame:
    """One simulated frame (see the module docstring for the meaning of each field).

    Attributes
    ----------
    index : int
        Frame number from 0.
    stamp : float
        Time (s) since the start of the scenario.
    v, omega : float
        True controls (m/s, rad/s) that moved the robot from the previous frame.
    v_odom, omega_odom : float
        Reported odometry (m/s, rad/s).
    robot_pose : ndarray, shape (3,)
        World pose (x, y, yaw) of the sensor frame (m, m, rad).
    person_ids : ndarray, shape (P,)
        Ids of the people existing in this frame.
    people : ndarray, shape (P, 2)
        Their positions (m), grid sensor frame.
    truth_grid : ndarray of bool, shape (nx, ny)
        Cells overlapped by a person.
    outputs : tuple of DetectorOutput
        One per detector, with true/false flags and sources.
    """

    index: int
    stamp: float
    v: float
    omega: float
    v_odom: float
    omega_odom: float
    robot_pose: NDArray[np.float64]
    person_ids: NDArray[np.int64]
    people: NDArray[np.float64]
    truth_grid: NDArray[np.bool_]
    outputs: tuple[DetectorOutput, ...]

    @property
    def detections(self) -> list[NDArray[np.float64]]:
        """Per detector, the (M_i, 2) detected positions (m, sensor frame): ``GridFilter.step``'s input."""
        return [o.positions for o in self.outputs]

    def odometry(self, *, noisy: bool = True) -> Odometry:
        """The odometry for ``GridFilter.step``: reported (``noisy``) or true controls."""
        if noisy:
            return Odometry(v=self.v_odom, omega=self.omega_odom)
        return Odometry(v=self.v, omega=self.omega)


class Scenario:
    """A scenario built from its config: the robot path and people tracks, and frames on demand.

    Parameters
    ----------
    config : ScenarioConfig
        The scenario; ``Scenario.from_name("corridor")`` loads a built-in one.

    Raises
    ------
    DataNotFoundError
        An ``eth_ucy`` scenario whose data folder is missing (a ``FileNotFoundError``).
    """

    def __init__(self, config: ScenarioConfig) -> None:
        if not isinstance(config, ScenarioConfig):
            raise TypeError(f"config must be a ScenarioConfig, got {type(config).__name__}")
        self.config = config
        n, dt = config.n_frames, config.dt
        self.times = np.arange(n) * dt
        v, w = robot_controls(n, dt, profile=config.robot, rng=_rng(config.seed, _STREAM_ROBOT))
        self.v, self.omega = v, w
        if config.odometry_noise is None:
            self.v_odom, self.omega_odom = v.copy(), w.copy()
        else:
            self.v_odom, self.omega_odom = noisy_odometry(
                v, w, noise=config.odometry_noise, rng=_rng(config.seed, _STREAM_ODOMETRY)
            )
        self.behaviours: list[str] = []
        if config.people == "synthetic":
            self.robot_poses = integrate_path(v, w, dt)
            tracks, self.behaviours = synthetic_tracks(
                self.robot_poses, dt, spec=config.grid, config=config.walkers, rng=_rng(config.seed, _STREAM_PEOPLE)
            )
            self.tracks = tracks
            self.person_ids, self.world_people = sample_tracks(tracks, self.times)
        else:
            all_tracks = load_tracks(config.eth.sequence, data_root=config.eth.data_root)
            t0 = config.eth.start_s
            shifted = [Track(tr.person_id, tr.t - t0, tr.xy) for tr in all_tracks]
            self.tracks = [tr for tr in shifted if tr.t_end >= 0.0 and tr.t_start <= self.times[-1]]
            if not self.tracks:
                raise ValueError(
                    f"EthReplay.start_s = {t0}: no pedestrian of {config.eth.sequence} exists in the window "
                    f"[{t0}, {t0 + self.times[-1]}] s"
                )
            self.person_ids, self.world_people = sample_tracks(self.tracks, self.times)
            start = config.eth.start_pose or _auto_start_pose(self.world_people)
            self.robot_poses = integrate_path(v, w, dt, start=start)

    @classmethod
    def from_name(cls, name_or_path: str | os.PathLike[str], **overrides: Any) -> Scenario:
        """Load a built-in scenario (or TOML file) with optional top-level overrides (``n_frames``, ``seed``)."""
        return cls(load_scenario_config(name_or_path, **overrides))

    def __len__(self) -> int:
        return self.config.n_frames

    def __iter__(self) -> Iterator[Frame]:
        return self.frames()

    @property
    def spec(self) -> GridSpec:
        return self.config.grid

    @property
    def dt(self) -> float:
        return self.config.dt

    def frames(self, start: int = 0, stop: int | None = None) -> Iterator[Frame]:
        """Frames ``start`` to ``stop - 1``, generated lazily."""
        stop = len(self) if stop is None else min(stop, len(self))
        for k in range(start, stop):
            yield self.frame(k)

    def people_at(self, k: int) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Ids ``(P,)`` and sensor-frame positions ``(P, 2)`` (m) of the people existing in frame ``k``."""
        world = self.world_people[k]
        alive = np.isfinite(world[:, 0])
        return self.person_ids[alive], world_to_sensor(world[alive], self.robot_poses[k])

    def frame(self, k: int) -> Frame:
        """Frame ``k`` (0 <= k < len); the same every time it is asked for."""
        if not 0 <= k < len(self):
            raise IndexError(f"frame index {k} out of range [0, {len(self)})")
        cfg = self.config
        ids, people = self.people_at(k)
        outputs = simulate_detections(
            people,
            ids,
            detectors=cfg.detectors,
            spec=cfg.grid,
            rng=_rng(cfg.seed, _STREAM_DETECTORS, k),
            person_radius=cfg.person_radius,
        )
        return Frame(
            index=k,
            stamp=float(self.times[k]),
            v=float(self.v[k]),
            omega=float(self.omega[k]),
            v_odom=float(self.v_odom[k]),
            omega_odom=float(self.omega_odom[k]),
            robot_pose=self.robot_poses[k].copy(),
            person_ids=ids,
            people=people,
            truth_grid=occupancy_grid(cfg.grid, people, radius=cfg.person_radius),
            outputs=tuple(outputs),
        )


def _auto_start_pose(world_people: NDArray[np.float64]) -> tuple[float, float, float]:
    """3 m behind the crowd's median position, heading along the main walking axis against the mean flow."""
    pts = world_people.reshape(-1, 2)
    pts = pts[np.isfinite(pts[:, 0])]
    centre = np.median(pts, axis=0)
    vel = np.diff(world_people, axis=0).reshape(-1, 2)
    vel = vel[np.all(np.isfinite(vel), axis=1)]
    heading = np.array([1.0, 0.0])
    if vel.shape[0] >= 2:
        _, _, vt = np.linalg.svd(vel, full_matrices=False)
        heading = vt[0]
        if float(vel.mean(axis=0) @ heading) > 0:
            heading = -heading
    start = centre - 3.0 * heading
    return float(start[0]), float(start[1]), float(math.atan2(heading[1], heading[0]))
