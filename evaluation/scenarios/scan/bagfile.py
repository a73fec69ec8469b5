"""Write a simulated scene as a ROS1 ``.bag`` or a ROS2 bag folder (sqlite3 or mcap) with ``rosbags``.

Topics (header stamps = the simulated times from ``SceneConfig.start_ns``; record times a few ms later, as a
driver's bag would have them):

- ``<laser.topic>`` (``/scan``) ``sensor_msgs/LaserScan``: frame_id = the laser frame, stamp = the first beam's
  time, ``time_increment`` the time between beams (0 without ``sweep``), ``scan_time`` = 1 / rate;
  no-return beams per ``LaserConfig.no_return``, too-close beams ``-inf``;
- ``/odom`` ``nav_msgs/Odometry``: frame ``odom``, child ``base_link``, the drifting odometry pose and the
  reported velocities, at the odometry rate;
- ``/tf`` ``tf2_msgs/TFMessage``: ``odom -> base_link`` (the odometry pose) at the odometry rate;
- ``/tf_static``: ``base_link -> <laser frame>`` (the mount, z = 0.3 m) once at the start;
- ``/ground_truth_people`` ``geometry_msgs/PoseArray``: the people of the first laser's ground truth, in its
  frame, header = the scan's stamp (person ids are in the CSV).

Beside the bag: ``<name>_gt.csv`` (scan_index, stamp_ns, person_id, x_<frame>_m, y_<frame>_m, hit_beams, speed_mps; see
:mod:`pfpeople.io.ground_truth`) and ``<name>.toml``, a ``pfpeople run`` configuration (driver and detectors on the
first laser, odometry ``/odom``, the laser's field of view and range in each detector's model).
"""

from __future__ import annotations

import csv
import math
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from evaluation.scenarios.scan.scene import SceneConfig, load_scene
from evaluation.scenarios.scan.simulate import SceneSim, simulate_scene
from gridbridge.geometry import quaternion_from_yaw
from pfpeople.io.bag.inspect import LASER_DETECTORS

__all__ = ["GT_TOPIC", "ODOM_TOPIC", "SceneBag", "run_config_text", "write_gt_csv", "write_scene_bag", "write_sim_bag"]

GT_TOPIC = "/ground_truth_people"
ODOM_TOPIC = "/odom"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
#: Record-time delays after the header stamp (ns): odometry/TF, scans, ground truth.
_DELAY_ODOM_NS = 1_000_000
_DELAY_SCAN_NS = 3_000_000
_DELAY_GT_NS = 4_000_000
_MOUNT_Z = 0.3


@dataclass(frozen=True)
class SceneBag:
    """What :func:`write_scene_bag` wrote, and figures of the scene.

    Attributes
    ----------
    bag : Path
        ``<name>.bag`` (ROS1) or the ROS2 bag folder ``<name>``.
    gt_csv, run_toml : Path
        Ground truth CSV and ``pfpeople run`` configuration.
    frames : int
        Scans of the first laser.
    people_per_scan : float
        Mean ground-truth people (in the first laser's field of view) per scan.
    seen_per_scan : float
        Mean people per scan with at least 3 beams on their legs.
    ms_per_scan : float
        Simulation time per scan (ms, wall clock).
    size_bytes : int
        Size of the bag on disk.
    """

    bag: Path
    gt_csv: Path
    run_toml: Path
    frames: int
    people_per_scan: float
    seen_per_scan: float
    ms_per_scan: float
    size_bytes: int


def _typestore(ros2: bool) -> Any:
    ts = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    if "tf2_msgs/msg/TFMessage" not in ts.types:  # not in rosbags' ROS1 Noetic store
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms\n", "tf2_msgs/msg/TFMessage"))
    return ts


class _Msgs:
    """Message builders for one typestore."""

    def __init__(self, ts: Any, ros2: bool) -> None:
        self.T, self.ros2 = ts.types, ros2
        self._seq: dict[str, int] = {}

    def header(self, stamp_ns: int, frame: str, topic: str) -> Any:
        stamp = self.T["builtin_interfaces/msg/Time"](sec=int(stamp_ns // 10**9), nanosec=int(stamp_ns % 10**9))
        if self.ros2:
            return self.T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)
        seq = self._seq.get(topic, 0)
        self._seq[topic] = seq + 1
        return self.T["std_msgs/msg/Header"](seq=seq, stamp=stamp, frame_id=frame)

    def quat(self, yaw: float) -> Any:
        qx, qy, qz, qw = quaternion_from_yaw(yaw)
        return self.T["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw)

    def pose(self, x: float, y: float, yaw: float = 0.0) -> Any:
        point = self.T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0)
        return self.T["geometry_msgs/msg/Pose"](position=point, orientation=self.quat(yaw))

    def transform(
        self, stamp_ns: int, parent: str, child: str, x: float, y: float, z: float, yaw: float, topic: str
    ) -> Any:
        T = self.T
        tr = T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z), rotation=self.quat(yaw)
        )
        return T["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp_ns, parent, topic), child_frame_id=child, transform=tr
        )


def write_gt_csv(sim: SceneSim, path: Path) -> None:
    """The first laser's ground truth as CSV (see the module docstring)."""
    las = sim.lasers[0]
    f = las.laser.frame_id
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scan_index", "stamp_ns", "person_id", f"x_{f}_m", f"y_{f}_m", "hit_beams", "speed_mps"])
        rows = zip(sim.gt_scan, sim.gt_person, sim.gt_xy, sim.gt_beams, sim.gt_speed, strict=True)
        for k, pid, (x, y), b, v in rows:
            w.writerow([int(k), int(las.stamps_ns[k]), int(pid), f"{x:.4f}", f"{y:.4f}", int(b), f"{v:.3f}"])


def run_config_text(cfg: SceneConfig) -> str:
    """A ``pfpeople run`` TOML for the scene (see :mod:`pfpeople.config`): first laser, /odom, leg and
    boosted detectors with the laser's field of view and range."""
    las = cfg.lasers[0]
    lines = [
        f"# pfpeople run configuration of the simulated scene {cfg.name!r} (evaluation.scenarios.scan).",
        f"# Laser {las.frame_id!r}: {las.n_beams} beams, {math.degrees(las.angle_max - las.angle_min):.0f} deg, "
        f"{las.rate_hz:g} Hz, mounted at x={las.mount[0]:g} m, y={las.mount[1]:g} m, "
        f"yaw={math.degrees(las.mount[2]):.1f} deg in {cfg.base_frame} (from /tf_static).",
        "",
        "[frames]",
        f'driver = "{las.topic}"',
        f'base_frame = "{cfg.base_frame}"',
        "",
        "[odometry]",
        f'topic = "{ODOM_TOPIC}"',
        "",
    ]
    for name, kind, _ in LASER_DETECTORS:
        lines += [
            "[[detectors]]",
            f'name = "{name}"',
            f'kind = "{kind}"',
            f'topic = "{las.topic}"',
            "[detectors.model]  # the laser's field of view and range (rad, m)",
            f"fov_min = {las.angle_min!r}",
            f"fov_max = {las.angle_max!r}",
            f"max_range = {las.range_max!r}",
            "",
        ]
    return "\n".join(lines)


def _messages(sim: SceneSim, m: _Msgs) -> list[tuple[int, str, str, Any]]:
    """Every message as (record time ns, topic, type, message), unsorted."""
    cfg = sim.config
    T = m.T
    items: list[tuple[int, str, str, Any]] = []
    t0 = cfg.start_ns
    statics = [
        m.transform(
            t0,
            cfg.base_frame,
            r.laser.frame_id,
            r.laser.mount[0],
            r.laser.mount[1],
            _MOUNT_Z,
            r.laser.mount[2],
            TF_STATIC_TOPIC,
        )
        for r in sim.lasers
    ]
    items.append((t0, TF_STATIC_TOPIC, "tf2_msgs/msg/TFMessage", T["tf2_msgs/msg/TFMessage"](transforms=statics)))
    vec = T["geometry_msgs/msg/Vector3"]
    cov = np.diag([1e-3, 1e-3, 1e6, 1e6, 1e6, 1e-3]).ravel()
    lag_ns = round(cfg.odometry.latency_s * 1e9)
    for stamp, (x, y, yaw), vo, wo in zip(sim.step_stamps_ns, sim.odom, sim.v_odom, sim.omega_odom, strict=True):
        s = int(stamp) + lag_ns
        odom = T["nav_msgs/msg/Odometry"](
            header=m.header(s, cfg.odom_frame, ODOM_TOPIC),
            child_frame_id=cfg.base_frame,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=m.pose(x, y, yaw), covariance=cov),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](
                    linear=vec(x=float(vo), y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=float(wo))
                ),
                covariance=cov,
            ),
        )
        items.append((s + _DELAY_ODOM_NS, ODOM_TOPIC, "nav_msgs/msg/Odometry", odom))
        tf = m.transform(s, cfg.odom_frame, cfg.base_frame, float(x), float(y), 0.0, float(yaw), TF_TOPIC)
        items.append(
            (s + _DELAY_ODOM_NS, TF_TOPIC, "tf2_msgs/msg/TFMessage", T["tf2_msgs/msg/TFMessage"](transforms=[tf]))
        )
    empty = np.zeros(0, dtype=np.float32)
    for rec in sim.lasers:
        las = rec.laser
        for stamp, ranges in zip(rec.stamps_ns, rec.ranges, strict=True):
            s = int(stamp)
            scan = T["sensor_msgs/msg/LaserScan"](
                header=m.header(s, las.frame_id, las.topic),
                angle_min=las.angle_min,
                angle_max=las.angle_max,
                angle_increment=las.angle_increment,
                time_increment=las.time_increment,
                scan_time=1.0 / las.rate_hz,
                range_min=las.range_min,
                range_max=las.range_max,
                ranges=np.ascontiguousarray(ranges, dtype=np.float32),
                intensities=empty,
            )
            items.append((s + _DELAY_SCAN_NS, las.topic, "sensor_msgs/msg/LaserScan", scan))
    rec0 = sim.lasers[0]
    bounds = np.searchsorted(sim.gt_scan, np.arange(rec0.times.size + 1))
    for k, stamp in enumerate(rec0.stamps_ns):
        s = int(stamp)
        xy = sim.gt_xy[bounds[k] : bounds[k + 1]]
        msg = T["geometry_msgs/msg/PoseArray"](
            header=m.header(s, rec0.laser.frame_id, GT_TOPIC), poses=[m.pose(x, y) for x, y in xy]
        )
        items.append((s + _DELAY_GT_NS, GT_TOPIC, "geometry_msgs/msg/PoseArray", msg))
    return items


def write_sim_bag(
    sim: SceneSim,
    path: Path,
    *,
    fmt: str = "ros1",
    storage: str = "sqlite3",
    progress: Callable[[int], object] | None = None,
) -> None:
    """Write ``sim`` as a bag at ``path`` (a ``.bag`` file for ROS1, a folder for ROS2; must not exist)."""
    if fmt not in ("ros1", "ros2"):
        raise ValueError(f"fmt must be 'ros1' or 'ros2', got {fmt!r}")
    if storage not in ("sqlite3", "mcap"):
        raise ValueError(f"storage must be 'sqlite3' or 'mcap', got {storage!r}")
    ros2 = fmt == "ros2"
    ts = _typestore(ros2)
    items = _messages(sim, _Msgs(ts, ros2))
    items.sort(key=lambda it: it[0])
    ser = ts.serialize_cdr if ros2 else ts.serialize_ros1
    conns: dict[str, Any] = {}
    writer: Any
    if ros2:
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    else:
        writer = Writer1(path)
    writer.open()
    try:
        for n, (bt, topic, typ, msg) in enumerate(items):
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, typ, typestore=ts)
            writer.write(conns[topic], bt, ser(msg, typ))
            if progress is not None and (n + 1) % 1000 == 0:
                progress(1000)
    finally:
        writer.close()
    if progress is not None:
        progress(len(items) % 1000)


def _size(path: Path) -> int:
    if path.is_dir():
        return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())
    return path.stat().st_size


def write_scene_bag(
    scene: str | Path | SceneConfig,
    out_dir: str | Path,
    *,
    seed: int | None = None,
    frames: int | None = None,
    fmt: str = "ros1",
    storage: str = "sqlite3",
    name: str | None = None,
    overwrite: bool = False,
    progress: Callable[[str, int], object] | None = None,
) -> SceneBag:
    """Simulate a scene and write its bag, ground-truth CSV and run configuration into ``out_dir``.

    Parameters
    ----------
    scene : str, path or SceneConfig
        Built-in scene name, scene TOML or config.
    out_dir : path
        Output folder (created).
    seed : int, optional
        Seed (default the scene's).
    frames : int, optional
        Scans of the first laser (default the scene's length).
    fmt : {"ros1", "ros2"}
        ``<name>.bag`` or a ROS2 bag folder ``<name>``.
    storage : {"sqlite3", "mcap"}
        ROS2 storage plugin.
    name : str, optional
        File stem (default the scene's name).
    overwrite : bool
        Replace existing outputs (else FileExistsError).
    progress : callable, optional
        ``progress(stage, n)``: stage ``"simulate"`` (n scans done) or ``"write"`` (n messages written).

    Returns
    -------
    SceneBag
    """
    if fmt not in ("ros1", "ros2"):
        raise ValueError(f"fmt must be 'ros1' or 'ros2', got {fmt!r}")
    if storage not in ("sqlite3", "mcap"):
        raise ValueError(f"storage must be 'sqlite3' or 'mcap', got {storage!r}")
    cfg = load_scene(scene)
    out = Path(out_dir)
    stem = name or cfg.name
    bag = out / (f"{stem}.bag" if fmt == "ros1" else stem)
    gt_csv = out / f"{stem}_gt.csv"
    run_toml = out / f"{stem}.toml"
    for p in (bag, gt_csv, run_toml):
        if p.exists() and not overwrite:
            raise FileExistsError(f"{str(p)!r} already exists (pass overwrite / --overwrite)")
    sim = simulate_scene(
        cfg, seed=seed, frames=frames, progress=(lambda n: progress("simulate", n)) if progress else None
    )
    out.mkdir(parents=True, exist_ok=True)
    for p in (bag, gt_csv, run_toml):
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()
    write_sim_bag(sim, bag, fmt=fmt, storage=storage, progress=(lambda n: progress("write", n)) if progress else None)
    write_gt_csv(sim, gt_csv)
    run_toml.write_text(run_config_text(sim.config))
    n = sim.n_frames
    return SceneBag(
        bag=bag,
        gt_csv=gt_csv,
        run_toml=run_toml,
        frames=n,
        people_per_scan=sim.gt_scan.size / n,
        seen_per_scan=float(np.count_nonzero(sim.gt_beams >= 3)) / n,
        ms_per_scan=sim.ms_per_scan,
        size_bytes=_size(bag),
    )
