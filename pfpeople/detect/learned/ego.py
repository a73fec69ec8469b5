"""The laser's motion between consecutive training scans, as a run would know it.

A temporal model is trained on the ego-motion a run gives it, with its errors: the wheel odometry of a bag that has
one (interpolated to the scan stamps and moved to the laser by its mount: ``motion = L_{k-1}^-1 L_k`` with
``L = odom * mount``), or laser scan matching (:class:`pfpeople.perception.scan_matching.ScanOdometry`, the run's
fallback) where it has none. A failed match is an unknown motion (NaN), as in a run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D, yaw_from_quaternion
from pfpeople.perception.scan_matching import ScanOdometry
from pfpeople.sensors import LaserScan

__all__ = ["odometry_motions", "read_odometry", "scan_matched_motions", "static_mount"]


def read_odometry(bag: str | Path, topic: str) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Header stamps ``(N,)`` (ns) and poses ``(N, 3)`` (x, y, yaw; m, rad, unwrapped) of a ``nav_msgs/Odometry``
    topic of a ROS 1 bag."""
    from rosbags.highlevel import AnyReader

    stamps, poses = [], []
    with AnyReader([Path(bag)]) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:
            raise KeyError(f"topic {topic!r} not in {bag}")
        for conn, _t, raw in reader.messages(connections=conns):
            msg: Any = reader.deserialize(raw, conn.msgtype)
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            stamps.append(int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec))
            poses.append((p.x, p.y, yaw_from_quaternion(q.x, q.y, q.z, q.w)))
    arr = np.asarray(poses, dtype=float).reshape(-1, 3)
    arr[:, 2] = np.unwrap(arr[:, 2])
    return np.asarray(stamps, dtype=np.int64), arr


def odometry_motions(
    scan_stamps: Sequence[int], odom_stamps: NDArray[np.int64], odom_poses: NDArray[np.float64], mount: Pose2D
) -> NDArray[np.float64]:
    """Per scan, the laser frame's motion since the previous scan ``(S, 3)`` (x, y, yaw: the new frame in the
    previous one); NaN for the first scan and where the odometry does not cover both stamps."""
    t = np.asarray(scan_stamps, dtype=np.int64)
    out = np.full((t.size, 3), np.nan)
    if odom_stamps.size < 2:
        return out
    inside = (t >= odom_stamps[0]) & (t <= odom_stamps[-1])
    tf = t.astype(float)
    base = np.column_stack([np.interp(tf, odom_stamps.astype(float), odom_poses[:, j]) for j in range(3)])
    prev: Pose2D | None = None
    for k in range(t.size):
        here = Pose2D(x=base[k, 0], y=base[k, 1], yaw=base[k, 2]).compose(mount) if inside[k] else None
        if prev is not None and here is not None:
            m = prev.inverse().compose(here)
            out[k] = (m.x, m.y, m.yaw)
        prev = here
    return out


def scan_matched_motions(scans: Sequence[LaserScan]) -> NDArray[np.float64]:
    """Per scan, its motion since the previous scan by laser scan matching ``(S, 3)``; NaN for the first scan and
    where the match failed."""
    odo = ScanOdometry()
    out = np.full((len(scans), 3), np.nan)
    for k, scan in enumerate(scans):
        step = odo.update(scan.points())
        if k and step.ok and all(math.isfinite(v) for v in (step.ego.x, step.ego.y, step.ego.yaw)):
            out[k] = (step.ego.x, step.ego.y, step.ego.yaw)
    return out


def static_mount(bag: str | Path, child: str) -> Pose2D:
    """The 2-D pose of frame ``child`` in its parent from a bag's ``/tf_static`` (the laser's mount on the base)."""
    from rosbags.highlevel import AnyReader

    with AnyReader([Path(bag)]) as reader:
        conns = [c for c in reader.connections if c.topic == "/tf_static"]
        for conn, _t, raw in reader.messages(connections=conns):
            tfs: Any = reader.deserialize(raw, conn.msgtype)
            for tf in tfs.transforms:
                if tf.child_frame_id.lstrip("/") == child.lstrip("/"):
                    tr, q = tf.transform.translation, tf.transform.rotation
                    return Pose2D(x=tr.x, y=tr.y, yaw=yaw_from_quaternion(q.x, q.y, q.z, q.w))
    raise KeyError(f"{bag}: no /tf_static transform to frame {child!r}")
