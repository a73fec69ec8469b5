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
  (PNG or JPEG, its size read from its header and checked before ``cv2.imdecode`` decodes it:
  :mod:`pfpeople.io.bag.image_size`) -> :class:`pfpeople.sensors.CameraImage` (BGR or mono).
- ``nav_msgs/Odometry`` -> :class:`pfpeople.sensors.Pose2D` of its child frame in its parent (odom) frame.
- ``geometry_msgs/PoseArray``, ``Pose``, ``PoseStamped``, ``Point``, and any message with a ``pose``,
  ``poses``, ``position``, ``people`` or ``points`` field (e.g. ``leg_tracker/Person``) -> ``(M, 2)``
  positions (m) in the message's frame.

Damaged input (every error names the file, member or topic):

- A file that is not a ROS1 bag (no ``#ROSBAG V2.0`` magic), a folder without ``metadata.yaml``: refused
  before ``rosbags`` reads it. A ROS1 bag that cannot be opened or read to its end (an interrupted
  recording) gets the hint to repair it with ``rosbag reindex``.
- A ROS2 folder whose ``metadata.yaml`` is not YAML or lists no storage file: refused in one line naming the
  file, the line and the problem (:func:`pfpeople.io.bag.rosbag2_meta.parse_metadata`).
- Zips (:mod:`pfpeople.io.bag.archive`): members are read by their validated names only (an absolute name or one
  with ``..`` is refused), only the bag's members are unpacked, and the archive's member count and the bag's
  unpacked size are bounded before anything is written; more than one bag in the archive is refused (naming
  the members).
- A required sensor topic (LaserScan, Image) without messages is an error at :meth:`BagSource.require`.
- LaserScans with ``range_min > range_max``, a NaN ``range_max``, or every range NaN (the sensor measured
  nothing: REP 117 NaN is an erroneous measurement, unlike +inf "no return") and odometry with implausible
  coordinates (beyond :data:`MAX_ODOMETRY_COORD_M`) raise ``ValueError`` naming the topic: the pipeline counts
  such messages and treats the detector as having no data (not as "saw nobody").
- LaserScans whose beams contradict their angles raise :class:`BadScanError` (a ``MessageDataError``, with a
  ``reason``), handled the same way (also counted per reason in ``run.json`` ``stats.bad_scans``):
  ``beam_count``: ``len(ranges)`` differs by more than :data:`MAX_BEAM_MISMATCH` beam from
  ``(angle_max - angle_min) / angle_increment + 1`` (drivers differ by one on whether ``angle_max`` is the last
  beam's bearing or one step past it; more is a wrong increment or a truncated message, whose missing sector
  would otherwise count as seen empty); ``span``: the beams span more than a full turn,
  ``|angle_increment| (n - 1) > 2 pi`` plus one beam (a wrong increment; one repeated bearing is accepted);
  ``no_return``: no beam is usable, every range NaN or below ``range_min`` (negative included) and none a
  "no return" (``+inf`` or ``range_max`` and beyond): the sensor gave nothing to see free space or people with.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore

from gridbridge.geometry import Pose2D, yaw_from_orientation
from pfpeople.io.bag.archive import BagReadError, extract_zip
from pfpeople.io.bag.image_size import check_encoded_size
from pfpeople.io.bag.ros1_decoders import Decoder, ros1_decoder
from pfpeople.io.bag.rosbag2_meta import parse_metadata
from pfpeople.sensors import CameraImage, LaserScan

__all__ = [
    "BadScanError",
    "BagMessage",
    "BagReadError",
    "BagSource",
    "MessageDataError",
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


class MessageDataError(ValueError):
    """One message holds data that cannot be used (not the expected type, undecodable, NaN, inconsistent).

    Raised by the message converters (:func:`laser_from_msg`, :func:`image_from_msg`,
    :func:`odometry_pose_from_msg`, :func:`positions_from_msg`). A run counts such a message and treats its
    detector as having no data in the frame; any other exception is a bug and ends the run.
    """


class BadScanError(MessageDataError):
    """A LaserScan whose beams contradict its angles or hold no usable range (see the module docstring).

    Parameters
    ----------
    message : str
        What is wrong, naming the topic.
    reason : {"beam_count", "span", "no_return"}
        Which check failed (the key of its count in ``stats.bad_scans``).
    """

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason

    def __reduce__(self) -> tuple[type[BadScanError], tuple[str, str]]:
        return type(self), (str(self), self.reason)


#: Beams by which ``len(ranges)`` may differ from ``(angle_max - angle_min) / angle_increment + 1``.
MAX_BEAM_MISMATCH = 1.0
#: Odometry coordinates beyond this (m) are not a robot's pose.
MAX_ODOMETRY_COORD_M = 1.0e7
ROS1_MAGIC = b"#ROSBAG V2.0"
#: Bytes of a bag folder's ``metadata.yaml`` read to check it (a real one is a few kB).
MAX_METADATA_READ = 16 * 2**20
REINDEX_HINT = (
    "a ROS1 bag whose recording was interrupted can often be repaired with `rosbag reindex FILE` "
    "(ROS1 tools; keeps a .orig.bag backup)"
)


def _check_bag_path(p: Path) -> None:
    """Refuse what is clearly not a bag before ``rosbags`` reads it (its errors there are cryptic)."""
    if p.is_dir():
        if not (p / "metadata.yaml").is_file():
            inside = sorted(x.name for x in p.iterdir())[:6]
            hint = ""
            bags = sorted(x.name for x in p.glob("*.bag"))
            if bags:
                hint = f"; it holds ROS1 bag(s) {bags}: give the .bag file"
            elif any(x.name.endswith((".db3", ".mcap")) for x in p.iterdir()):
                hint = "; it holds ROS2 storage files but no metadata.yaml (`ros2 bag reindex FOLDER` recreates it)"
            raise BagReadError(f"folder {str(p)!r} is not a ROS2 bag (no metadata.yaml; it holds {inside}){hint}")
        meta = p / "metadata.yaml"
        try:
            with meta.open("rb") as fh:
                parse_metadata(fh.read(MAX_METADATA_READ), f"bag metadata {str(meta)!r}")
        except ValueError as exc:
            raise BagReadError(str(exc)) from None
        return
    if p.suffix == ".bag":
        with p.open("rb") as fh:
            head = fh.read(len(ROS1_MAGIC))
        if head != ROS1_MAGIC:
            raise BagReadError(
                f"cannot open bag {str(p)!r}: not a ROS1 bag (it does not start with {ROS1_MAGIC.decode()!r}; "
                f"{'the file is empty' if not head else 'first bytes ' + repr(head[:12])})"
            )
    elif p.suffix not in BAG_FILE_SUFFIXES:
        _refuse_other_file(p)


#: File names a bag argument may have (ROS 1 bag; a ROS 2 bag's storage file, read without its folder).
BAG_FILE_SUFFIXES = (".bag", ".db3", ".mcap")


def _refuse_other_file(p: Path) -> None:
    """A file whose name is no bag's: refused, saying what a bag argument is (and when its first bytes are a ROS 1
    bag's, that it needs the .bag name)."""
    with p.open("rb") as fh:
        head = fh.read(len(ROS1_MAGIC))
    if head == ROS1_MAGIC:
        raise BagReadError(f"cannot open bag {str(p)!r}: a ROS1 bag by its first bytes, but not named *.bag: rename it")
    raise BagReadError(
        f"cannot open bag {str(p)!r}: the file is not a bag (its name does not end in .bag, .db3, .mcap or .zip); "
        "give a ROS1 .bag file, a ROS2 bag folder (holding metadata.yaml) or a .zip of either"
    )


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
            p = extract_zip(p, cache_dir)
        _check_bag_path(p)
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
        self._ros1 = all(p.suffix == ".bag" for p in self.paths)
        store = Stores.ROS1_NOETIC if self._ros1 else Stores.ROS2_HUMBLE
        try:
            self._reader = AnyReader(self.paths, default_typestore=get_typestore(store))
            self._reader.open()
        except Exception as exc:  # rosbags raises several error types for damaged files
            hint = f"; {REINDEX_HINT}" if self._ros1 else ""
            text = " ".join(str(exc).split())  # one line: rosbags' errors may quote a parser's several lines
            raise BagReadError(f"cannot open bag {self.name!r}: {type(exc).__name__}: {text}{hint}") from None

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
    def topic_types(self) -> dict[str, tuple[str, ...]]:
        """Topic -> every message type its connections carry (sorted; two or more: a mixed topic)."""
        out: dict[str, set[str]] = {}
        for c in self._reader.connections:
            out.setdefault(c.topic, set()).add(c.msgtype)
        return {t: tuple(sorted(v)) for t, v in out.items()}

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

    def load_decoders(self, topics: Iterable[str]) -> None:
        """Generate the message decoders of ``topics`` now (rosbags writes each message type's decoder at its
        first message, 1-3 ms a type: without this the first frame of a run waits for them)."""
        wanted = set(topics)
        typestore = self._reader.typestore
        for msgtype in sorted({c.msgtype for c in self._reader.connections if c.topic in wanted}):
            typestore.get_msgdef(msgtype)

    def _decoder(self, conn: Any) -> Decoder | None:
        """The fast decoder of a ROS1 connection of standard TF or odometry messages (:mod:`.ros1_decoders`),
        else None (rosbags decodes)."""
        if not self._ros1:
            return None
        return ros1_decoder(conn.msgtype, str(conn.digest), self._reader.typestore)

    def require(self, topics: Iterable[str], *, types: dict[str, Sequence[str]] | None = None) -> None:
        """Check that ``topics`` exist (and have one of ``types[topic]``); errors list what the bag has."""
        have = self.topics
        missing = [t for t in topics if t not in have]
        if missing:
            listing = ", ".join(f"{t} ({m})" for t, m in sorted(have.items())) or "none"
            raise ValueError(f"topic(s) {missing} not in bag {self.name!r}; the bag has: {listing}")
        mixed = {t: m for t, m in self.topic_types.items() if len(m) > 1 and t in set(topics)}
        if mixed:
            topic, kinds = sorted(mixed.items())[0]
            raise ValueError(
                f"topic {topic!r} in bag {self.name!r} carries {len(kinds)} message types ({', '.join(kinds)}): a run "
                "reads one type per topic; record them on separate topics (or leave this topic out of the config)"
            )
        counts = self.message_counts
        for topic, allowed in (types or {}).items():
            if have[topic] not in allowed:
                raise ValueError(
                    f"topic {topic!r} in bag {self.name!r} has message type {have[topic]!r}; "
                    f"expected one of {list(allowed)}"
                )
            if counts.get(topic, 0) == 0:
                if have[topic] in (*LASER_TYPES, *IMAGE_TYPES):
                    raise ValueError(
                        f"topic {topic!r} ({have[topic]}) in bag {self.name!r} has no messages; "
                        "choose a topic with data (see the message counts of `rosbag info` / `ros2 bag info`)"
                    )
                log.warning("topic %s in bag %s has no messages", topic, self.name)

    def messages(self, topics: Iterable[str]) -> Iterator[BagMessage]:
        """Deserialised messages of ``topics`` in bag-time order, one at a time (none for no topics).

        Raises
        ------
        BagReadError
            When the bag cannot be read further (truncated or corrupt data); the message says after which
            message it failed, and everything yielded before stays valid.
        """
        wanted = set(topics)
        self.require(wanted)
        conns = [c for c in self._reader.connections if c.topic in wanted]
        if not conns:  # rosbags reads every connection when given none
            return
        decoders = {c.id: self._decoder(c) for c in conns}
        counters: dict[str, int] = {}
        last: tuple[int, str, int] | None = None  # (index, topic, bag time) of the latest message; text on error
        it = self._reader.messages(connections=conns)
        while True:
            try:
                item = next(it)
            except StopIteration:
                return
            except Exception as exc:
                hint = f"; {REINDEX_HINT}" if self._ros1 else ""
                after = "the start" if last is None else f"message {last[0]} of {last[1]!r} at bag time {last[2]} ns"
                raise BagReadError(
                    f"bag {self.name!r} is truncated or corrupt after {after}: {type(exc).__name__}: {exc}{hint}"
                ) from None
            conn, bag_time, raw = item
            try:
                decode = decoders[conn.id]
                msg = self._reader.deserialize(raw, conn.msgtype) if decode is None else _decoded(decode, raw)
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
            last = (index, conn.topic, bag_time)
            yield BagMessage(
                conn.topic, conn.msgtype, index, int(bag_time), int(bag_time if stamp is None else stamp), frame_id, msg
            )


def _decoded(decode: Decoder, raw: Any) -> object:
    """``decode(raw)`` raising rosbags' reader error as :meth:`AnyReader.deserialize` does (the same error text)."""
    try:
        return decode(raw)
    except SerdeError as err:
        raise AnyReaderError(*err.args) from None


def laser_from_msg(msg: Any, *, stamp_ns: int, frame_id: str, topic: str = "") -> LaserScan:
    """``sensor_msgs/LaserScan`` -> :class:`LaserScan` (invalid ranges kept and marked by ``valid``)."""
    try:
        ranges = np.asarray(msg.ranges, dtype=float)
        rmin, rmax = float(msg.range_min), float(msg.range_max)
    except AttributeError:
        raise MessageDataError(f"topic {topic!r}: {type(msg).__name__} is not a sensor_msgs/LaserScan") from None
    except ValueError as exc:
        raise MessageDataError(f"topic {topic!r}: LaserScan ranges or bounds are not numbers: {exc}") from None
    where = f"topic {topic!r}: LaserScan at stamp {stamp_ns} ns"
    if math.isnan(rmin) or math.isnan(rmax) or rmin > rmax:
        raise MessageDataError(
            f"{where} has range_min={rmin!r} > range_max={rmax!r} or a NaN bound: every beam would be invalid "
            "(fix the driver's range parameters)"
        )
    if ranges.size:
        _check_scan_beams(msg, ranges, rmin, rmax, where)
    try:
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
        raise MessageDataError(f"topic {topic!r}: {type(msg).__name__} is not a sensor_msgs/LaserScan") from None
    except ValueError as exc:
        raise MessageDataError(f"topic {topic!r}: bad LaserScan at stamp {stamp_ns} ns: {exc}") from None


def _check_scan_beams(msg: Any, ranges: NDArray[np.float64], rmin: float, rmax: float, where: str) -> None:
    """Refuse a non-empty scan whose beam count or span contradicts its angles, or without a usable range.

    Raises
    ------
    BadScanError
        With ``reason`` ``"span"``, ``"beam_count"`` or ``"no_return"`` (see the module docstring).
    MessageDataError
        If the angles are not numbers.
    """
    n = ranges.size
    try:
        a0, a1, inc = float(msg.angle_min), float(msg.angle_max), float(msg.angle_increment)
    except (AttributeError, TypeError, ValueError):
        raise MessageDataError(f"{where}: angle_min, angle_max or angle_increment is missing or not a number") from None
    span = abs(inc) * (n - 1)
    if span > 2 * math.pi + abs(inc) + 1e-6:
        raise BadScanError(
            f"{where}: {n} beams at angle_increment={inc!r} rad span {math.degrees(span):.1f} deg, more than a full "
            "turn (a wrong angle_increment?); message refused",
            "span",
        )
    if n > 1 and inc != 0.0:
        expected = (a1 - a0) / inc + 1.0
        if not abs(n - expected) <= MAX_BEAM_MISMATCH + 1e-6:
            raise BadScanError(
                f"{where}: {n} ranges, but angle_min={a0!r}, angle_max={a1!r}, angle_increment={inc!r} give "
                f"{expected:.1f} beams (more than {MAX_BEAM_MISMATCH:.0f} beam apart: a truncated message or a wrong "
                "increment); message refused",
                "beam_count",
            )
    with np.errstate(invalid="ignore"):
        usable = ranges >= rmin  # a return, or a "no return" (+inf, range_max and beyond): not NaN, not too close
    if not usable.any():
        if np.isnan(ranges).all():
            raise BadScanError(f"{where}: all {n} ranges are NaN (the sensor measured nothing)", "no_return")
        raise BadScanError(
            f"{where}: no usable range: all {n} ranges are NaN or below range_min={rmin!r} (negative included), "
            "none a return or a 'no return' (+inf, range_max and beyond)",
            "no_return",
        )


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
        raw = bytes(msg.data)
        if raw:
            try:
                check_encoded_size(raw, f"topic {topic!r}: CompressedImage at stamp {stamp_ns} ns")
            except ValueError as exc:
                raise MessageDataError(str(exc)) from None
        data = np.frombuffer(raw, dtype=np.uint8)
        pixels = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if data.size else None
        if pixels is None:
            raise MessageDataError(
                f"topic {topic!r}: CompressedImage at stamp {stamp_ns} ns (format {msg.format!r}) cannot be decoded"
            )
        if pixels.dtype != np.uint8:
            raise MessageDataError(f"topic {topic!r}: CompressedImage decodes to {pixels.dtype}, expected 8-bit")
        if pixels.ndim == 3 and pixels.shape[2] == 4:
            pixels = cv2.cvtColor(pixels, cv2.COLOR_BGRA2BGR)
        return CameraImage(pixels=np.asarray(pixels, dtype=np.uint8), stamp_ns=stamp_ns, frame_id=frame_id)
    enc = str(msg.encoding).lower()
    if enc not in _ENCODINGS:
        raise MessageDataError(
            f"topic {topic!r}: image encoding {msg.encoding!r} not supported; use {sorted(_ENCODINGS)}"
        )
    channels, conversion = _ENCODINGS[enc]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    buf = np.frombuffer(bytes(msg.data), dtype=np.uint8)
    if step < w * channels or buf.size < h * step:
        raise MessageDataError(
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
        yaw = yaw_from_orientation(q.x, q.y, q.z, q.w, f"topic {topic!r}: odometry")
        pose = Pose2D(x=float(p.x), y=float(p.y), yaw=yaw)
        child = str(msg.child_frame_id).lstrip("/")
    except AttributeError:
        raise MessageDataError(f"topic {topic!r}: {type(msg).__name__} is not a nav_msgs/Odometry") from None
    except ValueError as exc:  # a zero or non-finite orientation: this message is not used (counted)
        raise MessageDataError(str(exc)) from None
    if not all(np.isfinite([pose.x, pose.y, pose.yaw])):
        raise MessageDataError(f"topic {topic!r}: odometry pose has NaN or infinite values")
    if max(abs(pose.x), abs(pose.y)) > MAX_ODOMETRY_COORD_M:
        raise MessageDataError(
            f"topic {topic!r}: odometry position ({pose.x:.6g}, {pose.y:.6g}) m is beyond "
            f"{MAX_ODOMETRY_COORD_M:.0e} m from the odom origin: not a robot pose"
        )
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
        raise MessageDataError(
            f"topic {topic!r}: message type {msgtype or type(msg).__name__!r} holds no positions; expected "
            "PoseArray, Pose(Stamped), Point(Stamped) or a message with pose/poses/position/people/points"
        )
    arr = np.asarray(out, dtype=float).reshape(-1, 2)
    bad = ~np.all(np.isfinite(arr), axis=1)
    if bad.any():
        log.warning("topic %s: dropped %d detection(s) with NaN/inf coordinates", topic, int(bad.sum()))
        arr = arr[~bad]
    return arr
