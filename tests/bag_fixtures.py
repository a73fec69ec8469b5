"""Bags the tests write: a moving robot with people and odometry (``write_bag``), a laser in a room with two
standing people (``write_scan_bag``), a robot with three lasers (``write_lasers_bag``), and sync-test messages; with
the configurations that read them."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pfpeople.config import BagConfig, DetectorConfig
from pfpeople.detect.synthetic import render_scan
from pfpeople.io.bag.reader import BagMessage
from pfpeople.io.bag.sync import FrameAssembler
from pfpeople.sensors import Pose2D

T0_NS = 1_000 * 1_000_000_000  # the bags' first stamp (ns)
V, W = 0.5, 0.15  # the robot's speed (m/s) and turn rate (rad/s) in write_bag

MS = 1_000_000


def msg(topic: str, stamp_ms: float, index: int = 0) -> BagMessage:
    t = round(stamp_ms * MS)
    return BagMessage(topic, "x/msg/Y", index, t, t, "f", None)


def run_sync(asm: FrameAssembler, stream: list[BagMessage]) -> list:
    frames = []
    for m in stream:
        frames += asm.push(m)
    return frames + asm.finish()


INC = math.radians(0.5)


# Two people (legs 0.3 m apart) at 2 m and 3 m: what every scan of ``write_scan_bag`` shows.
PEOPLE = np.array([[2.0, 0.8], [3.0, -1.0]])


def legs(xy: np.ndarray) -> list[tuple[float, float, float]]:
    out = []
    for x, y in xy:
        b = math.atan2(y, x)
        px, py = -math.sin(b) * 0.15, math.cos(b) * 0.15
        out += [(x + px, y + py, 0.06), (x - px, y - py, 0.06)]
    return out


def write_scan_bag(
    path: Path,
    n: int,
    *,
    reverse: bool = False,
    range_min: float = 0.05,
    range_max: float = 10.0,
    topics: tuple[str, ...] = ("/scan",),
    tf_mount: Any = None,
    frame_of: Any = None,
    static_mounts: dict[str, Pose2D] | None = None,
    angle_increment: float = INC,
    beams_of: Any = None,
) -> None:
    """A ROS1 bag of ``n`` identical scans at 10 Hz (the people of ``PEOPLE``) on ``/scan``, ``angle_increment`` apart.

    ``reverse``: the same beams listed clockwise (negative ``angle_increment``): the same points. Topics
    after the first get a connection and no message. ``tf_mount(k) -> Pose2D``: the pose of ``laser`` in
    ``base_link`` published on ``/tf`` with each scan ``k``. ``frame_of(k)``: scan ``k``'s frame_id (default
    ``laser``); ``static_mounts``: frame -> its pose in ``base_link`` on ``/tf_static``. ``beams_of(k)``: the slice of
    the beams scan ``k`` keeps (a narrower scan with consistent angles; default all).
    """
    ts = typestore(False)
    m = Msgs(ts, False)
    scan = render_scan(circles=legs(PEOPLE), angle_increment=angle_increment)
    ranges = np.asarray(scan.ranges, dtype=np.float32)
    a0, inc = scan.angle_min, scan.angle_increment
    if reverse:
        ranges, a0, inc = ranges[::-1].copy(), a0 + inc * (ranges.size - 1), -inc
    T = m.T
    w = Writer1(path)
    w.open()
    conn = w.add_connection(topics[0], "sensor_msgs/msg/LaserScan", typestore=ts)
    for extra in topics[1:]:
        w.add_connection(extra, "sensor_msgs/msg/LaserScan", typestore=ts)
    tf_conn = None if tf_mount is None else w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=ts)
    if static_mounts:
        st_conn = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts)
        for child, pose in static_mounts.items():
            w.write(st_conn, T0_NS - 1, ts.serialize_ros1(m.tf(T0_NS, "base_link", child, pose), st_conn.msgtype))
    for k in range(n):
        stamp = T0_NS + k * 100_000_000
        if tf_conn is not None:
            tf = m.tf(stamp, "base_link", "laser", tf_mount(k))
            w.write(tf_conn, stamp + 1_000_000, ts.serialize_ros1(tf, "tf2_msgs/msg/TFMessage"))
        keep = np.arange(ranges.size)[beams_of(k) if beams_of is not None else slice(None)]
        msg = T["sensor_msgs/msg/LaserScan"](
            header=m.header(stamp, "laser" if frame_of is None else frame_of(k)),
            angle_min=a0 + inc * keep[0],
            angle_max=a0 + inc * keep[-1],
            angle_increment=inc,
            time_increment=0.0,
            scan_time=0.1,
            range_min=range_min,
            range_max=range_max,
            ranges=np.ascontiguousarray(ranges[keep]),
            intensities=np.zeros(0, dtype=np.float32),
        )
        w.write(conn, stamp + 3_000_000, ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan"))
    w.close()


def legs_only(**changes: Any) -> BagConfig:
    return replace(
        BagConfig(driver="/scan", detectors=(DetectorConfig(name="legs", kind="leg", topic="/scan"),)), **changes
    )


MOUNT = Pose2D(x=0.2, y=0.1, yaw=0.3)


PEOPLE_ODOM = np.array([[3.5, 1.0], [3.0, -1.0]])


PERSON_MSG = "geometry_msgs/Pose pose\nuint32 id\n"


PERSON_ARRAY_MSG = "std_msgs/Header header\ntest_msgs/Person[] people\n"


def base_pose(t: float) -> Pose2D:
    """Pose of base_link in odom at t s (constant twist from the origin)."""
    return Pose2D(x=V / W * math.sin(W * t), y=V / W * (1 - math.cos(W * t)), yaw=W * t)


def laser_pose(t: float) -> Pose2D:
    return base_pose(t).compose(MOUNT)


def people_in(pose: Pose2D) -> np.ndarray:
    return pose.inverse().apply(PEOPLE_ODOM)


@dataclass
class Truth:
    stamps_ns: list[int]
    people_laser: list[np.ndarray]


def typestore(ros2: bool) -> Any:
    ts = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    types = get_types_from_msg(PERSON_MSG, "test_msgs/msg/Person")
    types.update(get_types_from_msg(PERSON_ARRAY_MSG, "test_msgs/msg/PersonArray"))
    if "tf2_msgs/msg/TFMessage" not in ts.types:  # not in rosbags' ROS1 Noetic store
        types.update(get_types_from_msg("geometry_msgs/TransformStamped[] transforms\n", "tf2_msgs/msg/TFMessage"))
    ts.register(types)
    return ts


class Msgs:
    def __init__(self, ts: Any, ros2: bool) -> None:
        self.ts, self.T, self.ros2 = ts, ts.types, ros2

    def header(self, stamp_ns: int, frame: str) -> Any:
        stamp = self.T["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
        if self.ros2:
            return self.T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)
        return self.T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)

    def quat(self, yaw: float) -> Any:
        return self.T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))

    def pose(self, x: float, y: float, yaw: float = 0.0) -> Any:
        point = self.T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0)
        return self.T["geometry_msgs/msg/Pose"](position=point, orientation=self.quat(yaw))

    def scan(self, stamp_ns: int, ranges: np.ndarray, angle_min: float, inc: float) -> Any:
        r = np.asarray(ranges, dtype=np.float32)
        return self.T["sensor_msgs/msg/LaserScan"](
            header=self.header(stamp_ns, "laser"),
            angle_min=angle_min,
            angle_max=angle_min + inc * max(len(r) - 1, 0),
            angle_increment=inc,
            time_increment=0.0,
            scan_time=0.1,
            range_min=0.05,
            range_max=10.0,
            ranges=r,
            intensities=np.zeros(0, dtype=np.float32),
        )

    def odom(self, stamp_ns: int, p: Pose2D) -> Any:
        T = self.T
        vec = T["geometry_msgs/msg/Vector3"]
        twist = T["geometry_msgs/msg/Twist"](linear=vec(x=V, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=W))
        return T["nav_msgs/msg/Odometry"](
            header=self.header(stamp_ns, "odom"),
            child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(p.x, p.y, p.yaw), covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
        )

    def tf(self, stamp_ns: int, parent: str, child: str, p: Pose2D) -> Any:
        T = self.T
        tr = T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=p.x, y=p.y, z=0.3), rotation=self.quat(p.yaw)
        )
        ts = T["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp_ns, parent), child_frame_id=child, transform=tr
        )
        return T["tf2_msgs/msg/TFMessage"](transforms=[ts])

    def person(self, x: float, y: float, pid: int) -> Any:
        return self.T["test_msgs/msg/Person"](pose=self.pose(x, y), id=pid)

    def person_array(self, stamp_ns: int, frame: str, xy: np.ndarray) -> Any:
        people = [self.person(x, y, k) for k, (x, y) in enumerate(xy)]
        return self.T["test_msgs/msg/PersonArray"](header=self.header(stamp_ns, frame), people=people)


def write_bag(
    path: Path,
    *,
    ros2: bool = False,
    storage: str = "sqlite3",
    n_scans: int = 20,
    odometry: bool = True,
    scan_hook: Any = None,
    chunk_threshold: int | None = None,
    n_images: int = 0,
    odom_gap_s: tuple[float, float] | None = None,
    odom_latency_s: float = 0.0,
) -> Truth:
    """Write the synthetic scene (see the module docstring); returns the true people in the laser frame.

    ROS1: the custom detections are headerless ``test_msgs/Person`` messages (one per person, in the laser
    frame, written 20 ms after their scan, like leg_tracker's ground truth). ROS2: a stamped
    ``test_msgs/PersonArray`` in base_link. ``scan_hook(k, stamp_ns, ranges) -> (stamp_ns, ranges)`` alters scans;
    no odometry is written strictly inside ``odom_gap_s`` (s from the first scan); odometry is recorded
    ``odom_latency_s`` after its stamps (1 ms by default).
    """
    ts = typestore(ros2)
    m = Msgs(ts, ros2)
    ser = ts.serialize_cdr if ros2 else ts.serialize_ros1
    items: list[tuple[int, str, str, Any]] = []  # (bag time, topic, type, msg)
    items.append(
        (T0_NS - 200_000_000, "/tf_static", "tf2_msgs/msg/TFMessage", m.tf(T0_NS, "base_link", "laser", MOUNT))
    )
    if odometry:
        for k in range(-5, 5 * n_scans + 6):
            t_ns = T0_NS + k * 20_000_000
            if odom_gap_s is not None and odom_gap_s[0] < k * 0.02 - 1e-9 and k * 0.02 + 1e-9 < odom_gap_s[1]:
                continue
            bag_ns = t_ns + 1_000_000 + round(odom_latency_s * 1e9)
            items.append((bag_ns, "/odom", "nav_msgs/msg/Odometry", m.odom(t_ns, base_pose(k * 0.02))))
    truth = Truth([], [])
    inc = math.radians(0.5)
    for k in range(n_scans):
        t = 0.1 * k
        stamp = T0_NS + k * 100_000_000
        lp = laser_pose(t)
        xy = people_in(lp)
        circles = []
        for x, y in xy:
            b = math.atan2(y, x)
            px, py = -math.sin(b) * 0.15, math.cos(b) * 0.15
            circles += [(x + px, y + py, 0.06), (x - px, y - py, 0.06)]
        ranges = render_scan(circles=circles, angle_increment=inc).ranges
        if scan_hook is not None:
            stamp, ranges = scan_hook(k, stamp, ranges)
        items.append(
            (
                T0_NS + k * 100_000_000 + 3_000_000,
                "/scan",
                "sensor_msgs/msg/LaserScan",
                m.scan(stamp, ranges, -math.pi / 2, inc),
            )
        )
        truth.stamps_ns.append(stamp)
        truth.people_laser.append(xy)
        if ros2:
            base_xy = MOUNT.apply(xy)
            items.append(
                (
                    stamp + 10_000_000,
                    "/people",
                    "test_msgs/msg/PersonArray",
                    m.person_array(stamp, "base_link", base_xy),
                )
            )
        else:
            for pid, (x, y) in enumerate(xy):
                items.append(
                    (T0_NS + k * 100_000_000 + 20_000_000, "/people", "test_msgs/msg/Person", m.person(x, y, pid))
                )
    for k in range(n_images):
        stamp = T0_NS + 37_000_000 + k * 250_000_000
        pixels = np.full(480 * 640, 90, dtype=np.uint8)
        img = m.T["sensor_msgs/msg/Image"](
            header=m.header(stamp, "laser"),
            height=480,
            width=640,
            encoding="mono8",
            is_bigendian=0,
            step=640,
            data=pixels,
        )
        items.append((stamp + 30_000_000, "/image", "sensor_msgs/msg/Image", img))
    items.sort(key=lambda it: it[0])
    if ros2:
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        w2 = Writer2(path, version=9, storage_plugin=plugin)
        w2.open()
        conns2: dict[str, Any] = {}
        for bt, topic, typ, msg in items:
            if topic not in conns2:
                conns2[topic] = w2.add_connection(topic, typ, typestore=ts)
            w2.write(conns2[topic], bt, ser(msg, typ))
        w2.close()
    else:
        w1 = Writer1(path)
        if chunk_threshold is not None:
            w1.chunk_threshold = chunk_threshold
        w1.open()
        conns1: dict[str, Any] = {}
        for bt, topic, typ, msg in items:
            if topic not in conns1:
                conns1[topic] = w1.add_connection(topic, typ, typestore=ts)
            w1.write(conns1[topic], bt, ser(msg, typ))
        w1.close()
    return truth


def config(*, ros2: bool = False, odometry: bool = True, **changes: Any) -> BagConfig:
    people = (
        DetectorConfig(name="bag-people", kind="topic", topic="/people", model={"ppv": 0.9, "fnr": 0.2})
        if ros2
        else DetectorConfig(
            name="bag-people",
            kind="topic",
            topic="/people",
            frame="laser",
            assign="preceding",
            model={"ppv": 0.9, "fnr": 0.2},
        )
    )
    cfg = BagConfig(
        driver="/scan",
        odometry="/odom" if odometry else "",
        detectors=(DetectorConfig(name="laser_legs", kind="leg", topic="/scan"), people),
    )
    return replace(cfg, **changes)


#: topic -> (frame, mount in base_link, stamp offset from the front laser's in ns)
LASERS: dict[str, tuple[str, Pose2D, int]] = {
    "/front_scan": ("front_laser", Pose2D(x=0.3, y=0.0, yaw=0.0), 0),
    "/rear_scan": ("rear_laser", Pose2D(x=-0.3, y=0.0, yaw=math.pi), 10_000_000),
    "/side_scan": ("side_laser", Pose2D(x=0.0, y=0.2, yaw=math.pi / 2), 30_000_000),
}
PEOPLE_BASE = np.array([[2.5, 0.3], [-2.5, -0.4], [0.8, 2.5]])


def write_lasers_bag(path: Path, *, n_scans: int = 8, tf_for: tuple[str, ...] = tuple(LASERS)) -> None:
    """A ROS 1 bag of a standing robot with three lasers (no odometry): ``n_scans`` scans at 10 Hz on each of
    :data:`LASERS`, 361 beams of 0.5 deg over 180 deg, each in its own frame: /front_scan (front_laser at 0.3 m,
    0, yaw 0), /rear_scan (rear_laser at -0.3 m, 0, yaw 180 deg; stamps 10 ms after the front's) and /side_scan
    (side_laser at 0, 0.2 m, yaw 90 deg; 30 ms after); each message recorded 3 ms after its stamp. Three people
    stand around the robot (:data:`PEOPLE_BASE`, base_link): in front (2.5 m, 0.3 m), behind (-2.5 m, -0.4 m:
    only the rear laser sees them) and on its left (0.8 m, 2.5 m). /tf_static gives the mounts (in base_link)
    of the lasers in ``tf_for`` only."""
    ts = typestore(False)
    m = Msgs(ts, False)
    items: list[tuple[int, str, str, Any]] = []
    for topic in tf_for:
        frame, mount, _ = LASERS[topic]
        items.append(
            (T0_NS - 200_000_000, "/tf_static", "tf2_msgs/msg/TFMessage", m.tf(T0_NS, "base_link", frame, mount))
        )
    inc = math.radians(0.5)
    for topic, (frame, mount, offset) in LASERS.items():
        circles = []
        for x, y in mount.inverse().apply(PEOPLE_BASE):
            b = math.atan2(y, x)
            px, py = -math.sin(b) * 0.15, math.cos(b) * 0.15
            circles += [(x + px, y + py, 0.06), (x - px, y - py, 0.06)]
        ranges = render_scan(circles=circles, angle_increment=inc).ranges
        for k in range(n_scans):
            stamp = T0_NS + k * 100_000_000 + offset
            msg = m.scan(stamp, ranges, -math.pi / 2, inc)
            msg = replace(msg, header=m.header(stamp, frame))
            items.append((stamp + 3_000_000, topic, "sensor_msgs/msg/LaserScan", msg))
    items.sort(key=lambda it: it[0])
    with Writer1(path) as w:
        conns: dict[str, Any] = {}
        for t_ns, topic, msgtype, msg in items:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=ts)
            w.write(conns[topic], t_ns, ts.serialize_ros1(msg, msgtype))
