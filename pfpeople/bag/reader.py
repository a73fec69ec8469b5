"""Streaming bag input with ``rosbags`` and conversion of ROS messages to :mod:`pfpeople.sensors` types.

:class:`BagSource` opens a ROS1 ``.bag`` file (or several), a ROS2 bag folder (sqlite3 or mcap storage) or a
``.zip`` holding either (extracted once into a cache folder), checks that the wanted topics exist (the error
lists the topics the bag has) and iterates messages in bag-time order without loading the bag: memory does
not grow with the bag's length. Message types come from the bag's own definitions (ROS1 bags and ROS2 bags
of format 8+ carry them, so types defined only inside the bag, such as ``leg_tracker/Person``, work); for
bags without definitions the ROS2 Humble / ROS1 Noetic standard types are used.

Conversions (all errors name the topic and the message type):

- ``sensor_msgs/LaserScan`` -> :class:`pfpeople.sensors.LaserScan`. NaN, inf and out-of-interval ranges are
  kept and marked invalid by ``LaserScan.valid`` (they are "no return", not points).
- ``sensor_msgs/Image`` (mono8, bgr8, rgb8, bgra8, rgba8, 8UC1, 8UC3) and ``sensor_msgs/CompressedImage``
  (decoded with ``cv2.imdecode``) -> :class:`pfpeople.sensors.CameraImage` (BGR or mono).
- ``nav_msgs/Odometry`` -> :class:`pfpeople.sensors.Pose2D` of its child frame in its parent (odom) frame.
- ``geometry_msgs/PoseArray``, ``Pose``, ``PoseStamped``, ``Point``, and any message with a ``pose``,
  ``poses``, ``position``, ``people`` or ``points`` field (e.g. ``leg_tracker/Person``) -> ``(M, 2)``
  positions (m) in the message's frame.
"""

from __future__ import annotations

import hashlib
import logging
import os
import zipfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from pfpeople.sensors import CameraImage, LaserScan, Pose2D

from .tf import yaw_from_quaternion

__all__ = [
    "BagMessage",
    "BagReadError",
    "BagSource",
    "image_from_msg",
    "laser_from_msg",
    "odometry_pose_from_msg",
    "open_bag_paths",
    "positions_from_msg",
]

log = logging.getLogger(__name__)

LASER_TYPES = ("sensor_msgs/msg/LaserScan",)
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
ODOMETRY_TYPES = ("nav_msgs/msg/Odometry",)
TF_TYPES = ("tf2_msgs/msg/TFMessage",)


class BagReadError(RuntimeError):
    """A bag could not be opened or read (corrupt, truncated, unknown format or type)."""


def _cache_root() -> Path:
    env = os.environ.get("PFPEOPLE_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "pfpeople"


def _extract_zip(path: Path, cache_dir: Path | None) -> Path:
    """Extract a zipped bag once; returns the extracted ``.bag`` file or ROS2 folder."""
    stat = path.stat()
    key = hashlib.sha1(f"{path.resolve()}:{stat.st_size}:{stat.st_mtime_ns}".encode()).hexdigest()[:12]
    dest = (cache_dir or _cache_root() / "bags") / f"{path.stem}-{key}"
    done = dest / ".complete"
    if not done.exists():
        try:
            with zipfile.ZipFile(path) as zf:
                dest.mkdir(parents=True, exist_ok=True)
                zf.extractall(dest)
        except zipfile.BadZipFile as exc:
            raise BagReadError(f"bag archive {str(path)!r} is not a valid zip file: {exc}") from None
        done.touch()
    bags = sorted(p for p in dest.rglob("*.bag"))
    if bags:
        return bags[0]
    metas = sorted(p.parent for p in dest.rglob("metadata.yaml"))
    if metas:
        return metas[0]
    raise BagReadError(f"bag archive {str(path)!r} holds no .bag file and no ROS2 bag folder")


def open_bag_paths(path: str | Path | Sequence[str | Path], *, cache_dir: Path | None = None) -> list[Path]:
    """Resolve a bag argument to the paths ``AnyReader`` takes.

    Parameters
    ----------
    path : path or sequence of paths
        ROS1 ``.bag`` file(s), one ROS2 bag folder, or a ``.zip`` of either.
    cache_dir : Path, optional
        Where zips are extracted (default ``$PFPEOPLE_CACHE/bags`` or ``~/.cache/pfpeople/bags``).
    """
    items = [path] if isinstance(path, str | Path) else list(path)
    if not items:
        raise ValueError("bag: no path given")
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if not p.exists():
            raise FileNotFoundError(f"bag {str(p)!r} does not exist")
        if p.suffix == ".zip":
            p = _extract_zip(p, cache_dir)
        out.append(p)
    return out


@dataclass(frozen=True, slots=True)
class BagMessage:
    """One deserialised message: ``stamp_ns`` is the header stamp (bag time when it has none or it is 0)."""

    topic: str
    msgtype: str
    index: int
    bag_time_ns: int
    stamp_ns: int
    frame_id: str
    msg: Any


def header_stamp_ns(msg: object) -> int | None:
    """Header stamp (ns) of a message, or None when it has no header or the stamp is zero."""
    header = getattr(msg, "header", None)
    if header is None:
        return None
    stamp = header.stamp
    ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
    return ns or None


class BagSource:
    """An open bag: topics, checks, and streaming iteration.

    Parameters
    ----------
    path : path or sequence of paths
        See :func:`open_bag_paths`.
    cache_dir : Path, optional
        Where zipped bags are extracted.

    Use as a context manager::

        with BagSource("run.bag") as bag:
            bag.require(["/scan"])
            for m in bag.messages(["/scan"]):
                ...
    """

    def __init__(self, path: str | Path | Sequence[str | Path], *, cache_dir: Path | None = None) -> None:
        self.paths = open_bag_paths(path, cache_dir=cache_dir)
        self.name = ", ".join(str(p) for p in self.paths)
        store = Stores.ROS2_HUMBLE if any(p.suffix != ".bag" for p in self.paths) else Stores.ROS1_NOETIC
        try:
            self._reader = AnyReader(self.paths, default_typestore=get_typestore(store))
            self._reader.open()
        except Exception as exc:  # rosbags raises several error types for damaged files
            raise BagReadError(f"cannot open bag {self.name!r}: {type(exc).__name__}: {exc}") from None

    def __enter__(self) -> BagSource:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def close(self) -> None:
        if self._reader.stack is not None:
            self._reader.close()

    @property
    def topics(self) -> dict[str, str]:
        """Topic -> message type (``pkg/msg/Name``) of every connection."""
        return {c.topic: c.msgtype for c in self._reader.connections}

    @property
    def message_counts(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        for c in self._reader.connections:
            counts[c.topic] = counts.get(c.topic, 0) + c.msgcount
        return counts

    @property
    def start_time_ns(self) -> int:
        return int(self._reader.start_time)

    @property
    def end_time_ns(self) -> int:
        return int(self._reader.end_time)

    def require(self, topics: Iterable[str], *, types: dict[str, Sequence[str]] | None = None) -> None:
        """Check that ``topics`` exist (and have one of ``types[topic]``); errors list what the bag has."""
        have = self.topics
        missing = [t for t in topics if t not in have]
        if missing:
            listing = ", ".join(f"{t} ({m})" for t, m in sorted(have.items())) or "none"
            raise ValueError(f"topic(s) {missing} not in bag {self.name!r}; the bag has: {listing}")
        for topic, allowed in (types or {}).items():
            if have[topic] not in allowed:
                raise ValueError(
                    f"topic {topic!r} in bag {self.name!r} has message type {have[topic]!r}; "
                    f"expected one of {list(allowed)}"
                )

    def messages(self, topics: Iterable[str]) -> Iterator[BagMessage]:
        """Deserialised messages of ``topics`` in bag-time order, one at a time.

        Raises
        ------
        BagReadError
            When the bag cannot be read further (truncated or corrupt data); the message says after which
            message it failed, and everything yielded before stays valid.
        """
        wanted = set(topics)
        self.require(wanted)
        conns = [c for c in self._reader.connections if c.topic in wanted]
        counters: dict[str, int] = {}
        last = "the start"
        it = self._reader.messages(connections=conns)
        while True:
            try:
                item = next(it)
            except StopIteration:
                return
            except Exception as exc:
                raise BagReadError(
                    f"bag {self.name!r} is truncated or corrupt after {last}: {type(exc).__name__}: {exc}"
                ) from None
            conn, bag_time, raw = item
            try:
                msg = self._reader.deserialize(raw, conn.msgtype)
            except Exception as exc:
                raise BagReadError(
                    f"cannot decode a {conn.msgtype} message on topic {conn.topic!r} at bag time {bag_time} ns "
                    f"in {self.name!r}: {type(exc).__name__}: {exc}"
                ) from None
            index = counters.get(conn.topic, 0)
            counters[conn.topic] = index + 1
            stamp = header_stamp_ns(msg)
            header = getattr(msg, "header", None)
            frame_id = str(header.frame_id).lstrip("/") if header is not None else ""
            last = f"message {index} of {conn.topic!r} at bag time {bag_time} ns"
            yield BagMessage(
                conn.topic, conn.msgtype, index, int(bag_time), int(bag_time if stamp is None else stamp), frame_id, msg
            )


def laser_from_msg(msg: Any, *, stamp_ns: int, frame_id: str, topic: str = "") -> LaserScan:
    """``sensor_msgs/LaserScan`` -> :class:`LaserScan` (invalid ranges kept and marked by ``valid``)."""
    try:
        ranges = np.asarray(msg.ranges, dtype=float)
        return LaserScan(
            ranges=ranges,
            angle_min=float(msg.angle_min),
            angle_increment=float(msg.angle_increment),
            range_min=float(msg.range_min),
            range_max=float(msg.range_max),
            stamp_ns=stamp_ns,
            frame_id=frame_id,
        )
    except AttributeError:
        raise ValueError(f"topic {topic!r}: {type(msg).__name__} is not a sensor_msgs/LaserScan") from None
    except ValueError as exc:
        raise ValueError(f"topic {topic!r}: bad LaserScan at stamp {stamp_ns} ns: {exc}") from None


_ENCODINGS = {
    "mono8": (1, None),
    "8uc1": (1, None),
    "bgr8": (3, None),
    "8uc3": (3, None),
    "rgb8": (3, cv2.COLOR_RGB2BGR),
    "bgra8": (4, cv2.COLOR_BGRA2BGR),
    "rgba8": (4, cv2.COLOR_RGBA2BGR),
}


def image_from_msg(msg: Any, msgtype: str, *, stamp_ns: int, frame_id: str, topic: str = "") -> CameraImage:
    """``sensor_msgs/Image`` or ``CompressedImage`` -> :class:`CameraImage` (BGR uint8 or mono8)."""
    if msgtype.endswith("CompressedImage"):
        data = np.frombuffer(bytes(msg.data), dtype=np.uint8)
        pixels = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
        if pixels is None:
            raise ValueError(
                f"topic {topic!r}: CompressedImage at stamp {stamp_ns} ns (format {msg.format!r}) cannot be decoded"
            )
        if pixels.dtype != np.uint8:
            raise ValueError(f"topic {topic!r}: CompressedImage decodes to {pixels.dtype}, expected 8-bit")
        if pixels.ndim == 3 and pixels.shape[2] == 4:
            pixels = cv2.cvtColor(pixels, cv2.COLOR_BGRA2BGR)
        return CameraImage(pixels=np.asarray(pixels, dtype=np.uint8), stamp_ns=stamp_ns, frame_id=frame_id)
    enc = str(msg.encoding).lower()
    if enc not in _ENCODINGS:
        raise ValueError(f"topic {topic!r}: image encoding {msg.encoding!r} not supported; use {sorted(_ENCODINGS)}")
    channels, conversion = _ENCODINGS[enc]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    buf = np.frombuffer(bytes(msg.data), dtype=np.uint8)
    if step < w * channels or buf.size < h * step:
        raise ValueError(
            f"topic {topic!r}: Image {w}x{h} {enc} with step {step} needs {h * step} bytes, has {buf.size}"
        )
    rows = buf[: h * step].reshape(h, step)[:, : w * channels]
    pixels = rows.reshape(h, w) if channels == 1 else rows.reshape(h, w, channels)
    if conversion is not None:
        pixels = cv2.cvtColor(pixels, conversion)
    return CameraImage(pixels=np.ascontiguousarray(pixels), stamp_ns=stamp_ns, frame_id=frame_id)


def odometry_pose_from_msg(msg: Any, *, topic: str = "") -> tuple[Pose2D, str]:
    """``nav_msgs/Odometry`` -> (pose of the child frame in the odom frame, child frame id)."""
    try:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        pose = Pose2D(x=float(p.x), y=float(p.y), yaw=yaw_from_quaternion(q.x, q.y, q.z, q.w))
        child = str(msg.child_frame_id).lstrip("/")
    except AttributeError:
        raise ValueError(f"topic {topic!r}: {type(msg).__name__} is not a nav_msgs/Odometry") from None
    if not all(np.isfinite([pose.x, pose.y, pose.yaw])):
        raise ValueError(f"topic {topic!r}: odometry pose has NaN or infinite values")
    return pose, child


def _collect_positions(obj: Any, out: list[tuple[float, float]], depth: int = 0) -> bool:
    """Append the (x, y) of every position in ``obj``; False when nothing position-like was found."""
    if depth > 4:
        return False
    if all(hasattr(obj, a) for a in ("x", "y", "z")) and not hasattr(obj, "w"):
        out.append((float(obj.x), float(obj.y)))
        return True
    for attr in ("position", "pose", "point"):
        if hasattr(obj, attr):
            return _collect_positions(getattr(obj, attr), out, depth + 1)
    for attr in ("poses", "people", "points", "persons", "detections"):
        seq = getattr(obj, attr, None)
        if isinstance(seq, list | tuple):
            for item in seq:
                if not _collect_positions(item, out, depth + 1):
                    return False
            return True
    return False


def positions_from_msg(msg: Any, *, topic: str = "", msgtype: str = "") -> NDArray[np.float64]:
    """Person positions ``(M, 2)`` (m, the message's frame) from a detection message (see module docstring)."""
    out: list[tuple[float, float]] = []
    if not _collect_positions(msg, out):
        raise ValueError(
            f"topic {topic!r}: message type {msgtype or type(msg).__name__!r} holds no positions; expected "
            "PoseArray, Pose(Stamped), Point(Stamped) or a message with pose/poses/position/people/points"
        )
    arr = np.asarray(out, dtype=float).reshape(-1, 2)
    bad = ~np.all(np.isfinite(arr), axis=1)
    if bad.any():
        log.warning("topic %s: dropped %d detection(s) with NaN/inf coordinates", topic, int(bad.sum()))
        arr = arr[~bad]
    return arr
