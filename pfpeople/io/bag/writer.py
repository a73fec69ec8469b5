"""Results as a ROS 1 bag or a rosbag2 (sqlite3 or MCAP) that opens in RViz, RViz2, Foxglove or ``ros2 bag``.

Written with rosbags' writers (``rosbags.rosbag1.Writer``, ``rosbags.rosbag2.Writer`` with the sqlite3 or MCAP
storage plugin); no ROS installation is needed. The format follows the path (:func:`bag_format_for`): ``*.bag``
is ROS 1, anything else a rosbag2 folder, sqlite3 unless ``mcap`` is asked for (sqlite3 is the storage every
ROS 2 distribution reads out of the box; Humble needs the extra ``rosbag2_storage_mcap`` package for MCAP).
ROS 1 messages use the Noetic definitions, ROS 2 messages the Humble ones (CDR).

rosbag2 metadata: ``metadata.yaml`` is written as **version 5** (:data:`ROSBAG2_METADATA_VERSION`), the
version of ROS 2 Humble's ``rosbag2_storage::BagMetadata``; later distributions read every older version.
rosbags' writer only writes versions 8 and 9, so the bag is written as version 8 and its ``metadata.yaml``
rewritten as version 5 (:func:`humble_metadata`): the fields of versions 6-8 (``custom_data``, ``ros_distro``,
``type_description_hash``) are dropped and every topic has an explicit QoS profile (the integer encoding that
Humble decodes).

Safety: the bag is written under a temporary folder beside it (``.OUT.bag.XXXX.tmp/OUT.bag``) and renamed into
place when it is closed (an old bag replaced with ``overwrite`` stays whole until then), and the path is locked
while it is written (``OUT.bag.lock`` beside it, :mod:`pfpeople.io.locks`): a second writer is refused
(:class:`BagLockedError`), not interleaved. :func:`pfpeople.io.run_dir.check_output_paths` refuses an output that
is, holds or lies inside an input. A Foxglove layout (:mod:`pfpeople.io.bag.foxglove`) is written beside the bag
when it is closed: ``OUT.foxglove-layout.json``.

Topics (header frame: the grid frame, or for people, tracks and their markers the results frame given as
``results_frame_id``, e.g. ``odom`` (``[output] frame``); header stamps: the stamps given to
:meth:`ResultBagWriter.write`, the source scan's header stamp in a run; record time: the driver's bag time):

- ``/pfpeople/belief`` ``nav_msgs/OccupancyGrid``: belief * 100 rounded to int8 (0..100). OccupancyGrid data
  are row-major with ``width`` along x: ``data[j * nx + i] = belief[i, j]``; the origin is the grid's
  lower corner ``(x0, y0)`` with identity orientation.
- ``/pfpeople/people`` ``people_msgs/People``: classified people (``name`` empty: they have no identity;
  ``velocity`` zero; ``reliability`` their mean belief when given, else 1).
- ``/pfpeople/people_markers`` ``visualization_msgs/MarkerArray``: ``DELETEALL``, then a ``SPHERE`` per person
  (namespace ``pfpeople/people``, marker id = index in the frame).
- ``/pfpeople/detections/<detector>`` ``geometry_msgs/PoseArray``: each detector's detections (none written
  in a frame where the detector had no data). The topic is the detector's name when it is a valid ROS name
  token; otherwise characters other than ``[A-Za-z0-9_]`` become ``_`` (and a leading digit gets a ``_``):
  the rename is logged (a warning) and listed in ``run.json`` (``result_bag.renamed_topics``), see
  :func:`detector_topics`.
- ``/pfpeople/tracks`` ``people_msgs/People`` (frames given ``tracks`` only): one ``Person`` per confirmed
  track: ``name`` = the track id (decimal), ``position``, ``velocity`` (m/s, grid frame), ``reliability`` =
  the track score (1 when not given), ``tagnames`` / ``tags`` = ``cov_xx``, ``cov_xy``, ``cov_yy`` (the
  position covariance, m^2, ``repr`` of the float) when given, for readers of earlier bags.
- ``/pfpeople/tracked_persons`` ``spencer_tracking_msgs/TrackedPersons`` (frames given ``tracks`` only): the
  same tracks with their covariance in the message: per track ``track_id``, ``is_matched`` (a detection
  updated it in this frame), ``is_occluded`` (not matched), ``detection_id``, ``age``, the position and its
  covariance (``PoseWithCovariance``) and the velocity and its covariance (``TwistWithCovariance``), see
  :mod:`pfpeople.io.bag.track_messages`.
- ``/pfpeople/track_markers`` ``visualization_msgs/MarkerArray`` (frames given ``tracks`` only): first a
  ``DELETEALL`` marker (so tracks that ended vanish), then per track a ``SPHERE`` (namespace
  ``pfpeople/tracks``), a ``TEXT_VIEW_FACING`` id label (namespace ``pfpeople/track_ids``, text = the id,
  ``TEXT_Z_M`` above the track) and an ``ARROW`` (namespace ``pfpeople/track_velocities``) from the track's
  position to ``position + velocity * arrow_time_s`` (the distance walked in ``arrow_time_s``, 1 s); marker
  id = track id in every namespace; sphere and arrow in the track's own colour
  (:func:`pfpeople.io.bag.track_messages.track_colour`), the label white.
- ``/tf_static`` ``tf2_msgs/TFMessage`` (latched in ROS 1, ``transient_local`` in ROS 2): at the first frame,
  the grid frame -> ``pfpeople_grid_origin``, a child frame at the grid's lower corner ``(x0, y0)``, so the
  grid frame exists in the TF tree even without the input's TF, and the ``static_transforms`` given (in a run:
  the ``[mounts]`` it used for frames the bag has no TF for, base frame -> laser frame, so every laser is
  placed); plus the input's ``/tf_static`` messages when they are copied. No other transform with the grid frame
  as child is written, so nothing conflicts with the source's TF (e.g. ``odom -> base_link -> laser``).
- Input topics (``input_topics``, written with :meth:`ResultBagWriter.write_input`): the LaserScan topics
  the run read and ``/tf``, ``/tf_static``, under their own names, with their own record times and header
  stamps, so one bag shows the input and the results.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import math
import os
import re
import shutil
import sqlite3
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, Any, Literal

import numpy as np
from numpy.typing import NDArray
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from gridbridge.geometry import quaternion_from_yaw
from gridbridge.grid import GridSpec
from pfpeople.io import locks
from pfpeople.io.bag.foxglove import write_layout
from pfpeople.io.bag.replace import check_replaceable, move_in
from pfpeople.io.bag.rosbag2_meta import ROSBAG2_METADATA_VERSION, humble_metadata
from pfpeople.io.bag.tf import TfLink
from pfpeople.io.bag.track_messages import (
    SPENCER_MSG_DEFINITIONS,
    SPENCER_MSG_DEFINITIONS_ROS2,
    TRACKED_PERSON_TYPE,
    TRACKED_PERSONS_TYPE,
    TrackTable,
    duration,
    pose_covariance,
    track_colour,
    track_table,
    twist_covariance,
)
from pfpeople.io.files import named_os_error

__all__ = [
    "BAG_FORMATS",
    "GRID_ORIGIN_FRAME",
    "PEOPLE_MSG_DEFINITIONS",
    "ROSBAG2_METADATA_VERSION",
    "TOPIC_BELIEF",
    "TOPIC_PEOPLE",
    "TOPIC_PEOPLE_MARKERS",
    "TOPIC_TF",
    "TOPIC_TF_STATIC",
    "TOPIC_TRACKED_PERSONS",
    "TOPIC_TRACKS",
    "TOPIC_TRACK_MARKERS",
    "BagLockedError",
    "ResultBagWriter",
    "bag_format_for",
    "check_bag_out",
    "detection_topic",
    "detector_topics",
    "lock_path",
    "output_topics",
]

log = logging.getLogger(__name__)

#: The output formats: ROS 1 ``.bag`` file, rosbag2 folder with MCAP or sqlite3 storage.
BAG_FORMATS: tuple[str, ...] = ("ros1", "mcap", "sqlite3")

TOPIC_BELIEF = "/pfpeople/belief"
TOPIC_PEOPLE = "/pfpeople/people"
TOPIC_PEOPLE_MARKERS = "/pfpeople/people_markers"
TOPIC_TRACKS = "/pfpeople/tracks"
TOPIC_TRACK_MARKERS = "/pfpeople/track_markers"
TOPIC_TRACKED_PERSONS = "/pfpeople/tracked_persons"
TOPIC_TF = "/tf"
TOPIC_TF_STATIC = "/tf_static"
#: Child frame of the grid frame at the grid's lower corner, written on /tf_static.
GRID_ORIGIN_FRAME = "pfpeople_grid_origin"
#: Height (m) of the track-id text above the track (grid frame z).
TEXT_Z_M = 0.5
#: Diameter (m) of the sphere markers of people and tracks.
SPHERE_M = 0.4

# visualization_msgs/Marker constants.
MARKER_ARROW = 0
MARKER_SPHERE = 2
MARKER_TEXT_VIEW_FACING = 9
MARKER_ADD = 0
MARKER_DELETEALL = 3

PEOPLE_TYPE = "people_msgs/msg/People"
PERSON_TYPE = "people_msgs/msg/Person"
#: ``people_msgs`` (ROS 1 ``people`` stack, also its ROS 2 port): registered in the type store of both writers.
PEOPLE_MSG_DEFINITIONS: dict[str, str] = {
    PERSON_TYPE: (
        "string name\n"
        "geometry_msgs/Point position\n"
        "geometry_msgs/Point velocity\n"
        "float64 reliability\n"
        "string[] tagnames\n"
        "string[] tags\n"
    ),
    PEOPLE_TYPE: "std_msgs/Header header\npeople_msgs/Person[] people\n",
}
#: Position covariance entries written as Person tags (when the tracks carry them).
TRACK_TAGS = ("cov_xx", "cov_xy", "cov_yy")

_ROSBAG2_WRITE_VERSION: Literal[8] = 8  # what rosbags writes; metadata.yaml is then rewritten as version 5
_TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@contextlib.contextmanager
def naming_errors(path: Path) -> Iterator[None]:
    """Within the block, an ``OSError`` without a file name (``ENOSPC`` from rosbags' writer) or an sqlite3 error
    ("database or disk is full") is raised as an ``OSError`` naming the bag output ``path``."""
    try:
        yield
    except OSError as exc:
        raise named_os_error(exc, path) from exc
    except sqlite3.Error as exc:
        code = errno.ENOSPC if "full" in str(exc) else errno.EIO
        raise OSError(code, f"{os.strerror(code)} ({exc})", str(path)) from exc


class BagLockedError(locks.PathLockedError):
    """The result bag is being written by another process (its lock ``OUT.lock`` is held)."""


def lock_path(path: str | Path) -> Path:
    """The lock file of the result bag ``path``: ``OUT.bag.lock`` (``OUT.lock`` for a rosbag2 folder), beside it."""
    p = Path(path)
    return p.parent / f"{p.name}.lock"


def detection_topic(name: str) -> str:
    """The PoseArray topic of detector ``name``: ``/pfpeople/detections/<name>``, the name made a ROS name token.

    A ROS name token has only ``[A-Za-z0-9_]`` and does not start with a digit: other characters become ``_``
    and a leading digit (or an empty name) gets a ``_`` in front.
    """
    token = re.sub(r"[^A-Za-z0-9_]", "_", name)
    if not _TOKEN.fullmatch(token):
        token = f"_{token}"
    return f"/pfpeople/detections/{token}"


def detector_topics(detector_names: Sequence[str]) -> tuple[dict[str, str], dict[str, str]]:
    """``(topics, renamed)``: the detection topic of every detector, and of those whose name had to change.

    Raises
    ------
    ValueError
        Two detectors map to the same topic.
    """
    topics = {n: detection_topic(n) for n in detector_names}
    if len(set(topics.values())) != len(detector_names):
        raise ValueError(f"detector names {list(detector_names)} map to the same topic")
    renamed = {n: t for n, t in topics.items() if t != f"/pfpeople/detections/{n}"}
    return topics, renamed


def output_topics(detector_names: Sequence[str], input_topics: Mapping[str, str] | None = None) -> dict[str, str]:
    """Topic -> message type (``pkg/msg/Name``) of every topic of a result bag, input topics included."""
    out = {TOPIC_TF_STATIC: "tf2_msgs/msg/TFMessage", **dict(input_topics or {})}
    out.update({TOPIC_BELIEF: "nav_msgs/msg/OccupancyGrid", TOPIC_PEOPLE: PEOPLE_TYPE})
    out[TOPIC_PEOPLE_MARKERS] = "visualization_msgs/msg/MarkerArray"
    out.update(dict.fromkeys(detector_topics(detector_names)[0].values(), "geometry_msgs/msg/PoseArray"))
    out.update({TOPIC_TRACKS: PEOPLE_TYPE, TOPIC_TRACK_MARKERS: "visualization_msgs/msg/MarkerArray"})
    out[TOPIC_TRACKED_PERSONS] = TRACKED_PERSONS_TYPE
    return out


def bag_format_for(path: str | Path, bag_format: str | None = None) -> str:
    """The output format: ``bag_format`` if given (checked), else ``ros1`` for ``*.bag`` and ``sqlite3`` otherwise.

    Raises
    ------
    ValueError
        Unknown format, or a format that does not fit the path (ROS 1 needs ``.bag``; a rosbag2 is a folder,
        whose name must not end in ``.bag``).
    """
    p = Path(path)
    if bag_format is None:
        return "ros1" if p.suffix == ".bag" else "sqlite3"
    if bag_format not in BAG_FORMATS:
        raise ValueError(f"bag output {str(p)!r}: unknown format {bag_format!r}; choose one of {list(BAG_FORMATS)}")
    if bag_format == "ros1" and p.suffix != ".bag":
        raise ValueError(f"bag output {str(p)!r}: a ROS 1 bag must end in .bag")
    if bag_format != "ros1" and p.suffix == ".bag":
        raise ValueError(f"bag output {str(p)!r}: a rosbag2 ({bag_format}) is a folder; give a name not ending in .bag")
    return bag_format


def check_bag_out(
    path: str | Path, bag_format: str | None = None, *, overwrite: bool = False, check_lock: bool = True
) -> tuple[Path, str]:
    """Check a result-bag path before a run starts; returns ``(path, format)``.

    ``check_lock``: also refuse a bag another process is writing (false: the caller holds the lock).

    Raises
    ------
    ValueError
        Bad format (see :func:`bag_format_for`), or ``overwrite`` asked for a path that is not a bag of the
        format (a folder without ``metadata.yaml`` is never deleted, nor a directory in place of a ``.bag``), or
        a rosbag2 folder where the new bag would write a file the old one does not list
        (:func:`pfpeople.io.bag.replace.check_replaceable`).
    FileNotFoundError
        The parent folder does not exist.
    FileExistsError
        The path exists and ``overwrite`` is false.
    BagLockedError
        Another live process is writing the bag (its lock, :func:`lock_path`, is held).
    """
    p = Path(path)
    fmt = bag_format_for(p, bag_format)
    parent = p.absolute().parent
    if not parent.is_dir():
        raise FileNotFoundError(f"bag output {str(p)!r}: parent folder {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise PermissionError(f"bag output {str(p)!r}: parent folder {str(parent)!r} is not writable")
    if check_lock:
        locks.check_free(lock_path(p), f"bag output {str(p)!r}", BagLockedError)
    if p.exists() or p.is_symlink():
        if not overwrite:
            raise FileExistsError(f"bag output {str(p)!r} already exists (use --overwrite to replace it)")
        if fmt == "ros1" and not p.is_file():
            raise ValueError(f"bag output {str(p)!r} exists and is not a file: not replaced")
        if fmt != "ros1" and not (p.is_dir() and ((p / "metadata.yaml").is_file() or not any(p.iterdir()))):
            raise ValueError(f"bag output {str(p)!r} exists and is not a rosbag2 folder (metadata.yaml): not replaced")
        if fmt != "ros1" and not p.is_symlink():
            check_replaceable(p, fmt, f"bag output {str(p)!r}")
    return p, fmt


def _default(ts: Any, node: tuple[Any, Any]) -> Any:
    """The zero value of a field node of a rosbags typestore (numbers 0, strings '', nested messages)."""
    kind, spec = node
    kind = int(kind)
    if kind == 1:  # BASE
        name = spec[0]
        if name == "string":
            return ""
        if name == "bool":
            return False
        return 0.0 if name.startswith("float") else 0
    if kind == 2:  # NAME
        return _message(ts, spec)
    sub, length = spec
    if kind == 3:  # ARRAY (fixed length)
        if int(sub[0]) == 1 and sub[1][0] not in ("string", "bool"):
            return np.zeros(length, dtype=_dtype(sub[1][0]))
        return [_default(ts, sub) for _ in range(length)]
    if int(sub[0]) == 1 and sub[1][0] not in ("string",):  # SEQUENCE of numbers: an empty array
        return np.zeros(0, dtype=_dtype(sub[1][0]))
    return []


def _dtype(name: str) -> Any:
    return {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "octet": np.uint8}.get(name, np.dtype(name))


def _message(ts: Any, typename: str, **given: Any) -> Any:
    """A message of ``typename`` with ``given`` fields and every other field zero (works across distros)."""
    fields = ts.fielddefs[typename][1]
    names = {n for n, _ in fields}
    unknown = set(given) - names
    if unknown:  # pragma: no cover - a programming error
        raise TypeError(f"{typename} has no field(s) {sorted(unknown)}")
    values = {n: given[n] if n in given else _default(ts, node) for n, node in fields}
    return ts.types[typename](**values)


def _convert(ts: Any, typename: str, src: Any) -> Any:
    """``src`` (a message of any rosbags type store, e.g. a reader's) as a ``typename`` message of ``ts``.

    Fields are copied by name, recursively; a field ``src`` lacks (e.g. ``seq`` of a ROS 1 header from a ROS 2
    message) gets its zero value.
    """
    values = {}
    for name, node in ts.fielddefs[typename][1]:
        if not hasattr(src, name):
            values[name] = _default(ts, node)
            continue
        values[name] = _convert_field(ts, node, getattr(src, name))
    return ts.types[typename](**values)


def _convert_field(ts: Any, node: tuple[Any, Any], value: Any) -> Any:
    kind, spec = node
    kind = int(kind)
    if kind == 1:  # BASE
        return value
    if kind == 2:  # NAME
        return _convert(ts, spec, value)
    sub = spec[0]
    if int(sub[0]) == 1 and sub[1][0] != "string":
        return np.asarray(value, dtype=_dtype(sub[1][0]))
    return [_convert_field(ts, sub, v) for v in value]


class ResultBagWriter:
    """Write the belief, people, detections and tracks of each frame (and the input) into a ROS 1 bag or rosbag2.

    See the module docstring for topics, types, frames and the TF written. Use as a context manager or call
    :meth:`close` (a bag that is not closed has no index / metadata).

    Parameters
    ----------
    path : path
        Output: a ``.bag`` file (ROS 1) or a rosbag2 folder (created). Checked by :func:`check_bag_out`.
    spec : GridSpec
        The grid.
    frame_id : str
        The grid frame (non-empty).
    detector_names : sequence of str
        Detector names (one PoseArray topic each, :func:`detector_topics`; a rename is logged).
    bag_format : {"ros1", "mcap", "sqlite3"}, optional
        Default from the path: ``.bag`` -> ``ros1``, otherwise ``sqlite3``.
    overwrite : bool
        Replace an existing bag at ``path``.
    arrow_time_s : float
        The velocity arrow of a track spans the distance walked in this time (s).
    input_topics : mapping of str to str, optional
        Input topics to copy (topic -> message type, e.g. ``sensor_msgs/msg/LaserScan``,
        ``tf2_msgs/msg/TFMessage``), written with :meth:`write_input` under the same names.
    layout : bool
        Write the Foxglove layout ``OUT.foxglove-layout.json`` beside the bag when it is closed.
    static_transforms : sequence of TfLink
        Transforms written on ``/tf_static`` with the grid origin's (``parent -> child``, the planar ``pose``):
        in a run, the ``[mounts]`` used for frames without TF (:attr:`pfpeople.pipeline.sinks.RunInfo.mount_links`).
    results_frame_id : str, optional
        The frame of the people, the tracks and their markers (positions given in it to :meth:`write`); default
        ``frame_id``. The grid and the detections stay in ``frame_id``.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        spec: GridSpec,
        frame_id: str,
        detector_names: Sequence[str],
        bag_format: str | None = None,
        overwrite: bool = False,
        arrow_time_s: float = 1.0,
        input_topics: Mapping[str, str] | None = None,
        layout: bool = True,
        static_transforms: Sequence[TfLink] = (),
        results_frame_id: str | None = None,
    ) -> None:
        if not isinstance(frame_id, str) or not frame_id:
            raise ValueError(f"frame_id must be a non-empty string, got {frame_id!r}")
        if not (isinstance(arrow_time_s, int | float) and math.isfinite(arrow_time_s) and arrow_time_s > 0):
            raise ValueError(f"arrow_time_s must be a positive number, got {arrow_time_s!r}")
        topics, renamed = detector_topics(detector_names)
        self._det_topics = list(topics.values())
        self.topics = output_topics(detector_names, input_topics)
        self._check_inputs(dict(input_topics or {}), detector_names)
        self._input_topics = set(input_topics or {})
        self.path, self.bag_format = Path(path), bag_format_for(path, bag_format)
        self._tmp_dir: Path | None = None
        self._lock_path = lock_path(self.path)
        self._lock: IO[str] | None = locks.acquire(self._lock_path, f"bag output {str(self.path)!r}", BagLockedError)
        try:
            check_bag_out(self.path, self.bag_format, overwrite=overwrite, check_lock=False)
            self._tmp_dir = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".tmp", dir=self.path.parent))
            self._writer: Any = self._open_writer(self._tmp_dir / self.path.name)
        except BaseException:
            self._discard()
            raise
        for name, topic in renamed.items():
            log.warning(
                "detector %r: its detections go to %s (a ROS topic name token allows [A-Za-z0-9_])", name, topic
            )
        self.spec = spec
        self.frame_id = frame_id
        self.results_frame_id = results_frame_id or frame_id
        self.arrow_time_s = float(arrow_time_s)
        self.layout = layout
        self.static_transforms = tuple(static_transforms)
        self._closed = False
        self._conns: dict[str, Any] = {}
        for topic, msgtype in self.topics.items():
            self._add(topic, msgtype, static=topic == TOPIC_TF_STATIC)
        self._seq = 0

    def _check_inputs(self, input_topics: dict[str, str], detector_names: Sequence[str]) -> None:
        """Refuse input topics that are result topics (``/tf_static`` is shared), and a non-TFMessage ``/tf_static``."""
        clash = set(input_topics) & set(output_topics(detector_names)) - {TOPIC_TF_STATIC}
        if clash:
            raise ValueError(f"input topic(s) {sorted(clash)} are result topics of the bag; not copied over them")
        if input_topics.get(TOPIC_TF_STATIC, "tf2_msgs/msg/TFMessage") != "tf2_msgs/msg/TFMessage":
            raise ValueError(f"input topic /tf_static has type {input_topics[TOPIC_TF_STATIC]!r}, not a TFMessage")

    # -- plumbing ------------------------------------------------------------------------------------------------

    def _open_writer(self, target: Path) -> Any:
        """The rosbags writer, writing ``target`` (in the temporary folder, under the final name)."""
        self.ros2 = self.bag_format != "ros1"
        self.ts = get_typestore(Stores.ROS2_HUMBLE if self.ros2 else Stores.ROS1_NOETIC)
        types: dict[str, Any] = {}
        if "tf2_msgs/msg/TFMessage" not in self.ts.types:  # not in rosbags' ROS 1 Noetic store
            types.update(get_types_from_msg(_TF_MSG, "tf2_msgs/msg/TFMessage"))
        spencer = SPENCER_MSG_DEFINITIONS_ROS2 if self.ros2 else SPENCER_MSG_DEFINITIONS
        for name, text in {**PEOPLE_MSG_DEFINITIONS, **spencer}.items():
            types.update(get_types_from_msg(text, name))
        self.ts.register(types)
        unknown = sorted(t for t in self.topics.values() if t not in self.ts.types)
        if unknown:
            raise ValueError(f"bag output: message type(s) {unknown} are not in the type store; not copied")
        writer: Any
        if self.ros2:
            plugin = StoragePlugin.MCAP if self.bag_format == "mcap" else StoragePlugin.SQLITE3
            writer = Writer2(target, version=_ROSBAG2_WRITE_VERSION, storage_plugin=plugin)
        else:
            writer = Writer1(target)
        writer.open()
        return writer

    def _publish(self) -> None:
        """Rename the finished bag into place (replacing an old one, checked at the start), then unlock.

        An old rosbag2 folder keeps every file but the old bag's own (:func:`pfpeople.io.bag.replace.move_in`);
        a symbolic link at the path is replaced, not what it points to."""
        assert self._tmp_dir is not None
        try:
            new = self._tmp_dir / self.path.name
            if self.path.is_symlink():
                self.path.unlink()
            elif self.path.is_dir():
                move_in(new, self.path, self._tmp_dir / ".replaced", f"bag output {str(self.path)!r}")
                return
            os.replace(new, self.path)
        finally:
            self._discard()

    def _discard(self) -> None:
        """Remove the temporary folder (whatever it still holds) and release the lock (idempotent)."""
        if self._tmp_dir is not None:
            shutil.rmtree(self._tmp_dir, ignore_errors=True)
            self._tmp_dir = None
        if self._lock is not None:
            locks.release(self._lock, remove=self._lock_path)
            self._lock = None

    def _add(self, topic: str, msgtype: str, *, static: bool = False) -> None:
        if self.ros2:
            zero = QosTime(sec=0, nsec=0)
            qos = Qos(  # explicit for every topic: Humble's player reads the offered profile
                history=QosHistory.KEEP_LAST,
                depth=1 if static else 10,
                reliability=QosReliability.RELIABLE,
                durability=QosDurability.TRANSIENT_LOCAL if static else QosDurability.VOLATILE,
                deadline=zero,
                lifespan=zero,
                liveliness=QosLiveliness.AUTOMATIC,
                liveliness_lease_duration=zero,
                avoid_ros_namespace_conventions=False,
            )
            conn = self._writer.add_connection(topic, msgtype, typestore=self.ts, offered_qos_profiles=(qos,))
        else:
            conn = self._writer.add_connection(topic, msgtype, typestore=self.ts, latching=1 if static else None)
        self._conns[topic] = (conn, msgtype)

    def _put(self, topic: str, bag_time_ns: int, msg: Any) -> None:
        conn, msgtype = self._conns[topic]
        data = self.ts.serialize_cdr(msg, msgtype) if self.ros2 else self.ts.serialize_ros1(msg, msgtype)
        with naming_errors(self.path):
            self._writer.write(conn, bag_time_ns, data)

    def _m(self, typename: str, **given: Any) -> Any:
        return _message(self.ts, typename, **given)

    def _stamp(self, stamp_ns: int) -> Any:
        return self._m("builtin_interfaces/msg/Time", sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)

    def _header(self, stamp_ns: int, frame_id: str | None = None) -> Any:
        given: dict[str, Any] = {"stamp": self._stamp(stamp_ns), "frame_id": frame_id or self.frame_id}
        if not self.ros2:
            given["seq"] = self._seq
        return self._m("std_msgs/msg/Header", **given)

    def _point(self, x: float, y: float, z: float = 0.0) -> Any:
        return self._m("geometry_msgs/msg/Point", x=float(x), y=float(y), z=float(z))

    def _pose(self, x: float, y: float, yaw: float = 0.0, z: float = 0.0) -> Any:
        qx, qy, qz, qw = quaternion_from_yaw(yaw)
        q = self._m("geometry_msgs/msg/Quaternion", x=qx, y=qy, z=qz, w=qw)
        return self._m("geometry_msgs/msg/Pose", position=self._point(x, y, z), orientation=q)

    def _pose_array(self, stamp_ns: int, points: NDArray[np.float64], yaws: Sequence[float] | None = None) -> Any:
        xy = np.asarray(points, dtype=float).reshape(-1, 2)
        yaw = [0.0] * len(xy) if yaws is None else list(yaws)
        poses = [self._pose(x, y, a) for (x, y), a in zip(xy, yaw, strict=True)]
        return self._m("geometry_msgs/msg/PoseArray", header=self._header(stamp_ns), poses=poses)

    def _color(self, r: float, g: float, b: float) -> Any:
        return self._m("std_msgs/msg/ColorRGBA", r=r, g=g, b=b, a=1.0)

    # -- messages ------------------------------------------------------------------------------------------------

    def _transform(self, stamp_ns: int, parent: str, child: str, x: float, y: float, yaw: float) -> Any:
        """A ``TransformStamped``: ``child``'s planar pose ``(x, y, yaw)`` in ``parent`` (m, rad)."""
        qx, qy, qz, qw = quaternion_from_yaw(yaw)
        tr = self._m(
            "geometry_msgs/msg/Transform",
            translation=self._m("geometry_msgs/msg/Vector3", x=float(x), y=float(y), z=0.0),
            rotation=self._m("geometry_msgs/msg/Quaternion", x=qx, y=qy, z=qz, w=qw),
        )
        header = self._header(stamp_ns, parent)
        return self._m("geometry_msgs/msg/TransformStamped", header=header, child_frame_id=child, transform=tr)

    def _tf_static(self, stamp_ns: int) -> Any:
        """The grid frame -> :data:`GRID_ORIGIN_FRAME`, then :attr:`static_transforms`."""
        s = self.spec
        transforms = [self._transform(stamp_ns, self.frame_id, GRID_ORIGIN_FRAME, s.x0, s.y0, 0.0)]
        for link in self.static_transforms:
            p = link.pose
            transforms.append(self._transform(stamp_ns, link.parent, link.child, p.x, p.y, p.yaw))
        return self._m("tf2_msgs/msg/TFMessage", transforms=transforms)

    def _grid(self, stamp_ns: int, belief: NDArray[np.float64]) -> Any:
        s = self.spec
        header = self._header(stamp_ns)
        info = self._m(
            "nav_msgs/msg/MapMetaData",
            map_load_time=header.stamp,
            resolution=float(s.resolution),
            width=s.nx,
            height=s.ny,
            origin=self._pose(s.x0, s.y0),
        )
        data = np.rint(belief.T * 100.0).astype(np.int8).ravel()
        return self._m("nav_msgs/msg/OccupancyGrid", header=header, info=info, data=data)

    def _marker(self, header: Any, ns: str, mid: int, mtype: int, **given: Any) -> Any:
        return self._m("visualization_msgs/msg/Marker", header=header, ns=ns, id=mid, type=mtype, **given)

    def _sphere(self, header: Any, ns: str, mid: int, x: float, y: float, rgb: tuple[float, float, float]) -> Any:
        d = SPHERE_M
        return self._marker(
            header,
            ns,
            mid,
            MARKER_SPHERE,
            action=MARKER_ADD,
            pose=self._pose(x, y, z=d / 2),
            scale=self._m("geometry_msgs/msg/Vector3", x=d, y=d, z=d),
            color=self._color(*rgb),
        )

    def _people(self, stamp_ns: int, people: NDArray[np.float64], reliability: Sequence[float] | None) -> Any:
        xy = np.asarray(people, dtype=float).reshape(-1, 2)
        rel = [1.0] * len(xy) if reliability is None else [float(r) for r in reliability]
        if len(rel) != len(xy):
            raise ValueError(f"people_reliability: expected {len(xy)} values, got {len(rel)}")
        persons = [
            self._m(PERSON_TYPE, position=self._point(x, y), velocity=self._point(0.0, 0.0), reliability=r)
            for (x, y), r in zip(xy, rel, strict=True)
        ]
        return self._m(PEOPLE_TYPE, header=self._header(stamp_ns, self.results_frame_id), people=persons)

    def _people_markers(self, stamp_ns: int, people: NDArray[np.float64]) -> Any:
        header = self._header(stamp_ns, self.results_frame_id)
        markers = [self._m("visualization_msgs/msg/Marker", header=header, action=MARKER_DELETEALL)]
        xy = np.asarray(people, dtype=float).reshape(-1, 2)
        markers += [self._sphere(header, "pfpeople/people", k, x, y, (1.0, 0.6, 0.0)) for k, (x, y) in enumerate(xy)]
        return self._m("visualization_msgs/msg/MarkerArray", markers=markers)

    def _tracks(self, stamp_ns: int, table: TrackTable) -> Any:
        persons = []
        for tid, x, y, vx, vy, cxx, cxy, cyy, score in table.rows:
            cov = [(n, repr(float(v))) for n, v in zip(TRACK_TAGS, (cxx, cxy, cyy), strict=True) if math.isfinite(v)]
            persons.append(
                self._m(
                    PERSON_TYPE,
                    name=str(int(tid)),
                    position=self._point(x, y),
                    velocity=self._point(vx, vy),
                    reliability=float(score) if math.isfinite(score) else 1.0,
                    tagnames=[n for n, _ in cov],
                    tags=[v for _, v in cov],
                )
            )
        return self._m(PEOPLE_TYPE, header=self._header(stamp_ns, self.results_frame_id), people=persons)

    def _tracked_persons(self, stamp_ns: int, table: TrackTable) -> Any:
        """SPENCER's ``TrackedPersons`` of the tracks (:mod:`pfpeople.io.bag.track_messages`)."""
        tracks = []
        for k, (tid, x, y, vx, vy) in enumerate(table.rows[:, :5]):
            sec, nanosec = duration(float(table.age_s[k]))
            cov = table.covariance[k]
            pcov = pose_covariance(cov)
            pose = self._m("geometry_msgs/msg/PoseWithCovariance", pose=self._pose(x, y), covariance=pcov)
            linear = self._m("geometry_msgs/msg/Vector3", x=float(vx), y=float(vy), z=0.0)
            twist = self._m("geometry_msgs/msg/Twist", linear=linear)
            tracks.append(
                self._m(
                    TRACKED_PERSON_TYPE,
                    track_id=int(tid),
                    is_occluded=not bool(table.matched[k]),
                    is_matched=bool(table.matched[k]),
                    detection_id=int(table.detection[k]),
                    age=self._m("builtin_interfaces/msg/Duration", sec=sec, nanosec=nanosec),
                    pose=pose,
                    twist=self._m(
                        "geometry_msgs/msg/TwistWithCovariance", twist=twist, covariance=twist_covariance(cov)
                    ),
                )
            )
        return self._m(TRACKED_PERSONS_TYPE, header=self._header(stamp_ns, self.results_frame_id), tracks=tracks)

    def _markers(self, stamp_ns: int, table: TrackTable) -> Any:
        """``DELETEALL``, then per track its sphere and arrow in its colour and its id (white)."""
        header = self._header(stamp_ns, self.results_frame_id)
        markers = [self._m("visualization_msgs/msg/Marker", header=header, action=MARKER_DELETEALL)]
        t = self.arrow_time_s
        for tid, x, y, vx, vy in table.rows[:, :5]:
            i = int(tid)
            colour = track_colour(i)
            markers.append(self._sphere(header, "pfpeople/tracks", i, x, y, colour))
            markers.append(
                self._marker(
                    header,
                    "pfpeople/track_ids",
                    i,
                    MARKER_TEXT_VIEW_FACING,
                    action=MARKER_ADD,
                    pose=self._pose(x, y, z=TEXT_Z_M),
                    scale=self._m("geometry_msgs/msg/Vector3", z=0.3),
                    color=self._color(1.0, 1.0, 1.0),
                    text=str(i),
                )
            )
            markers.append(
                self._marker(
                    header,
                    "pfpeople/track_velocities",
                    i,
                    MARKER_ARROW,
                    action=MARKER_ADD,
                    pose=self._pose(0.0, 0.0),
                    scale=self._m("geometry_msgs/msg/Vector3", x=0.05, y=0.1, z=0.1),
                    color=self._color(*colour),
                    points=[self._point(x, y), self._point(x + vx * t, y + vy * t)],
                )
            )
        return self._m("visualization_msgs/msg/MarkerArray", markers=markers)

    # -- public --------------------------------------------------------------------------------------------------

    def write(
        self,
        bag_time_ns: int,
        stamp_ns: int,
        belief: NDArray[np.float64],
        people: NDArray[np.float64] | None,
        detections: Sequence[NDArray[np.float64] | None],
        tracks: NDArray[np.float64] | Sequence[Any] | None = None,
        *,
        people_reliability: Sequence[float] | None = None,
    ) -> None:
        """Write one frame.

        Parameters
        ----------
        bag_time_ns, stamp_ns : int
            Record time and header stamp (ns); in a run the header stamp is the source scan's header stamp.
        belief : ndarray (nx, ny)
            Belief grid (probability of a person per cell, grid frame).
        people : ndarray (P, 2) or None
            Classified people (m, results frame); None: no people topics in this frame (their results-frame
            positions are unknown).
        detections : sequence of ndarray (D_i, 2) or None
            Each detector's detections (m, grid frame); None: no data (nothing written on its topic).
        tracks : ndarray (K, 5) or (K, 9), or sequence of track objects, optional
            ``[id, x, y, vx, vy]`` (id a non-negative integer; m and m/s in the grid frame), optionally followed
            by ``cov_xx, cov_xy, cov_yy, score`` (NaN: not known), or objects with those attributes (``id``,
            ``x``, ``y``, ``vx``, ``vy``, optionally ``covariance`` (2, 2) and ``score``). None: no track topics
            in this frame; an empty array writes an empty People and a lone DELETEALL.
        people_reliability : sequence of float, optional
            Per person, the ``reliability`` of its Person (e.g. its mean belief); default 1.
        """
        if self._closed:
            raise ValueError(f"bag output {str(self.path)!r} is closed")
        belief = self.spec.check_grid(belief, "belief")
        if len(detections) != len(self._det_topics):
            raise ValueError(f"detections: expected {len(self._det_topics)} entries, got {len(detections)}")
        trk = None if tracks is None else track_table(tracks)
        people_msg = None if people is None else self._people(stamp_ns, people, people_reliability)
        if self._seq == 0:
            self._put(TOPIC_TF_STATIC, bag_time_ns, self._tf_static(stamp_ns))
        self._put(TOPIC_BELIEF, bag_time_ns, self._grid(stamp_ns, belief))
        if people is not None:
            self._put(TOPIC_PEOPLE, bag_time_ns, people_msg)
            self._put(TOPIC_PEOPLE_MARKERS, bag_time_ns, self._people_markers(stamp_ns, people))
        for topic, det in zip(self._det_topics, detections, strict=True):
            if det is not None:
                self._put(topic, bag_time_ns, self._pose_array(stamp_ns, det))
        if trk is not None:
            self._put(TOPIC_TRACKS, bag_time_ns, self._tracks(stamp_ns, trk))
            self._put(TOPIC_TRACKED_PERSONS, bag_time_ns, self._tracked_persons(stamp_ns, trk))
            self._put(TOPIC_TRACK_MARKERS, bag_time_ns, self._markers(stamp_ns, trk))
        self._seq += 1

    def write_input(self, bag_time_ns: int, topic: str, msg: Any) -> None:
        """Copy one input message (of any rosbags type store) to ``topic``, one of ``input_topics``.

        The message keeps its fields (its header stamp included) and is written at ``bag_time_ns``, its record
        time in the input.
        """
        if self._closed:
            raise ValueError(f"bag output {str(self.path)!r} is closed")
        if topic not in self._input_topics:
            raise ValueError(f"topic {topic!r} is not an input topic of this bag")
        self._put(topic, bag_time_ns, _convert(self.ts, self._conns[topic][1], msg))

    def close(self) -> None:
        """Finish the bag (index / metadata.yaml as version 5), rename it into place, write the layout; idempotent.

        Errors (a full disk) name the bag output; the temporary folder is removed and an old bag stays."""
        if not self._closed:
            self._closed = True
            try:
                with naming_errors(self.path):
                    self._writer.close()
                    if self.ros2:
                        humble_metadata(self._tmp_dir_path() / self.path.name / "metadata.yaml")
                    if self.layout:  # beside the bag, written while the lock is held
                        write_layout(self.path, self.topics, self.frame_id)
            except BaseException:
                self._discard()
                raise
            with naming_errors(self.path):
                self._publish()

    def _tmp_dir_path(self) -> Path:
        assert self._tmp_dir is not None
        return self._tmp_dir

    def __enter__(self) -> ResultBagWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
