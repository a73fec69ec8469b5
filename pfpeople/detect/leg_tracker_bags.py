"""Small ROS1 bag loaders for the leg_tracker training recordings (``rosbags``, no ROS install needed).

The positive bags of Leigh et al. (2015) hold, per scan, a ``geometry_msgs/PoseArray`` on
``/leg_cluster_positions`` written just BEFORE its ``sensor_msgs/LaserScan`` on ``/training_scan`` (the
PoseArray has a zero stamp); a scan is paired with the most recent PoseArray, as leg_tracker's own trainer does.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfpeople.sensors import LaserScan

__all__ = ["LabelledScan", "iter_scans", "load_labelled_scans", "load_scans"]


@dataclass(frozen=True, kw_only=True, eq=False)
class LabelledScan:
    """A scan with the labelled leg positions ``legs`` (K, 2) in the scan frame (m)."""

    scan: LaserScan
    legs: NDArray[np.float64]


def _reader(path: Path) -> Any:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    if not path.is_file():
        raise FileNotFoundError(f"bag file not found: {path}")
    return AnyReader([path], default_typestore=get_typestore(Stores.ROS1_NOETIC))


def _to_scan(msg: Any) -> LaserScan:
    stamp = msg.header.stamp
    return LaserScan(
        ranges=np.asarray(msg.ranges, dtype=np.float64),
        angle_min=float(msg.angle_min),
        angle_increment=float(msg.angle_increment),
        range_min=float(msg.range_min),
        range_max=float(msg.range_max),
        stamp_ns=int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec),
        frame_id=str(msg.header.frame_id),
    )


def iter_scans(path: str | Path, topics: Sequence[str]) -> Iterator[tuple[str, LaserScan]]:
    """Yield ``(topic, scan)`` for every LaserScan on ``topics`` in bag order.

    Raises
    ------
    FileNotFoundError
        If the bag does not exist.
    KeyError
        If a topic is not in the bag (the message names the topic and the bag).
    """
    path = Path(path)
    with _reader(path) as reader:
        present = {c.topic for c in reader.connections}
        missing = [t for t in topics if t not in present]
        if missing:
            raise KeyError(f"topic(s) {missing} not in {path} (has {sorted(present)})")
        conns = [c for c in reader.connections if c.topic in topics]
        for conn, _t, raw in reader.messages(connections=conns):
            yield conn.topic, _to_scan(reader.deserialize(raw, conn.msgtype))


def load_scans(path: str | Path, topics: Sequence[str]) -> dict[str, list[LaserScan]]:
    """All scans of ``topics`` in a bag, per topic, in bag order."""
    out: dict[str, list[LaserScan]] = {t: [] for t in topics}
    for topic, scan in iter_scans(path, topics):
        out[topic].append(scan)
    return out


def load_labelled_scans(
    path: str | Path,
    *,
    scan_topic: str = "/training_scan",
    label_topic: str = "/leg_cluster_positions",
) -> list[LabelledScan]:
    """Scans with their labelled leg positions from a leg_tracker ``positive_*_extracted.bag``.

    Each scan takes the most recent PoseArray before it; a scan with no preceding PoseArray raises
    ``ValueError`` (nothing is silently dropped).
    """
    path = Path(path)
    out: list[LabelledScan] = []
    with _reader(path) as reader:
        present = {c.topic for c in reader.connections}
        for t in (scan_topic, label_topic):
            if t not in present:
                raise KeyError(f"topic {t!r} not in {path} (has {sorted(present)})")
        conns = [c for c in reader.connections if c.topic in (scan_topic, label_topic)]
        legs: NDArray[np.float64] | None = None
        for conn, _t, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic == label_topic:
                legs = np.array([(p.position.x, p.position.y) for p in msg.poses], dtype=float).reshape(-1, 2)
            else:
                if legs is None:
                    raise ValueError(f"{path}: scan on {scan_topic!r} before any {label_topic!r} message")
                out.append(LabelledScan(scan=_to_scan(msg), legs=legs))
    return out
