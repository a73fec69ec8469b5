"""Results as a ROS 1 bag or a rosbag2 (MCAP or sqlite3) that opens in RViz, RViz2, Foxglove or ``ros2 bag``.

Written with rosbags' writers (``rosbags.rosbag1.Writer``, ``rosbags.rosbag2.Writer`` with the MCAP or
sqlite3 storage plugin, metadata version 8); no ROS installation is needed. The format follows the path
(:func:`bag_format_for`): ``*.bag`` is ROS 1, anything else a rosbag2 folder, MCAP unless ``sqlite3`` is asked
for. ROS 1 messages use the Noetic definitions, ROS 2 messages the Humble ones (CDR).

Safety: the bag is written under a temporary folder beside it (``.OUT.bag.XXXX.tmp/OUT.bag``) and renamed into
place when it is closed (an old bag replaced with ``overwrite`` stays whole until then), and the path is locked
while it is written (``OUT.bag.lock`` beside it, :mod:`pfpeople.locks`): a second writer is refused
(:class:`BagLockedError`), not interleaved. :func:`pfpeople.output.check_output_paths` refuses an output that
is, holds or lies inside an input.

Topics (header frame: the grid frame; header stamps: the frame stamps; record time: the driver's bag time):

- ``/pfpeople/belief`` ``nav_msgs/OccupancyGrid``: belief * 100 rounded to int8 (0..100). OccupancyGrid data
  are row-major with ``width`` along x: ``data[j * nx + i] = belief[i, j]``; the origin is the grid's
  lower corner ``(x0, y0)`` with identity orientation.
- ``/pfpeople/people`` ``geometry_msgs/PoseArray``: classified people (identity orientation).
- ``/pfpeople/detections/<detector>`` ``geometry_msgs/PoseArray``: each detector's detections (none written
  in a frame where the detector had no data; characters other than ``[A-Za-z0-9_]`` in the name become ``_``).
- ``/pfpeople/tracks`` ``geometry_msgs/PoseArray`` (frames given ``tracks`` only): one pose per track, its
  orientation the velocity heading ``atan2(vy, vx)`` about z (identity for a track at rest).
- ``/pfpeople/track_markers`` ``visualization_msgs/MarkerArray`` (frames given ``tracks`` only): first a
  ``DELETEALL`` marker (so tracks that ended vanish), then per track a ``TEXT_VIEW_FACING`` marker
  (namespace ``pfpeople/track_ids``, marker id = track id, text = the id, ``TEXT_Z_M`` above the track) and
  an ``ARROW`` (namespace ``pfpeople/track_velocities``, marker id = track id) from the track's position to
  ``position + velocity * arrow_time_s``: its length is the distance walked in ``arrow_time_s`` (1 s).
- ``/tf_static`` ``tf2_msgs/TFMessage`` (once, at the first frame; latched in ROS 1, ``transient_local`` in
  ROS 2): the grid frame -> ``pfpeople_grid_origin``, a child frame at the grid's lower corner ``(x0, y0)``.
  It makes the grid frame exist in the TF tree, so a viewer shows the result bag alone with the grid frame as
  fixed/display frame. Played together with the source bag (which holds the sensor's own TF, e.g.
  ``odom -> base_link -> laser``), nothing conflicts: the grid frame keeps its parent from the source and the
  results follow the robot in ``odom``. No transform with the grid frame as child is written for that reason.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import tempfile
from collections.abc import Sequence
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
from pfpeople import locks

__all__ = [
    "BAG_FORMATS",
    "GRID_ORIGIN_FRAME",
    "TOPIC_BELIEF",
    "TOPIC_PEOPLE",
    "TOPIC_TF_STATIC",
    "TOPIC_TRACKS",
    "TOPIC_TRACK_MARKERS",
    "BagLockedError",
    "ResultBagWriter",
    "bag_format_for",
    "check_bag_out",
    "detection_topic",
    "lock_path",
]

#: The output formats: ROS 1 ``.bag`` file, rosbag2 folder with MCAP or sqlite3 storage.
BAG_FORMATS: tuple[str, ...] = ("ros1", "mcap", "sqlite3")

TOPIC_BELIEF = "/pfpeople/belief"
TOPIC_PEOPLE = "/pfpeople/people"
TOPIC_TRACKS = "/pfpeople/tracks"
TOPIC_TRACK_MARKERS = "/pfpeople/track_markers"
TOPIC_TF_STATIC = "/tf_static"
#: Child frame of the grid frame at the grid's lower corner, written on /tf_static.
GRID_ORIGIN_FRAME = "pfpeople_grid_origin"
#: Height (m) of the track-id text above the track (grid frame z).
TEXT_Z_M = 0.5

# visualization_msgs/Marker constants.
MARKER_ARROW = 0
MARKER_TEXT_VIEW_FACING = 9
MARKER_ADD = 0
MARKER_DELETEALL = 3

_ROSBAG2_VERSION: Literal[8] = 8
_TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"


class BagLockedError(locks.PathLockedError):
    """The result bag is being written by another process (its lock ``OUT.lock`` is held)."""


def lock_path(path: str | Path) -> Path:
    """The lock file of the result bag ``path``: ``OUT.bag.lock`` (``OUT.lock`` for a rosbag2 folder), beside it."""
    p = Path(path)
    return p.parent / f"{p.name}.lock"


def detection_topic(name: str) -> str:
    """The PoseArray topic of detector ``name``."""
    return f"/pfpeople/detections/{re.sub(r'[^A-Za-z0-9_]', '_', name)}"


def bag_format_for(path: str | Path, bag_format: str | None = None) -> str:
    """The output format: ``bag_format`` if given (checked), else ``ros1`` for ``*.bag`` and ``mcap`` otherwise.

    Raises
    ------
    ValueError
        Unknown format, or a format that does not fit the path (ROS 1 needs ``.bag``; a rosbag2 is a folder,
        whose name must not end in ``.bag``).
    """
    p = Path(path)
    if bag_format is None:
        return "ros1" if p.suffix == ".bag" else "mcap"
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
        format (a folder without ``metadata.yaml`` is never deleted, nor a directory in place of a ``.bag``).
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


def _check_tracks(tracks: Any) -> NDArray[np.float64]:
    if not isinstance(tracks, np.ndarray) and all(
        hasattr(t, a) for t in tracks for a in ("id", "x", "y", "vx", "vy")
    ):  # track objects (e.g. pfpeople.mot Track snapshots)
        tracks = [[t.id, t.x, t.y, t.vx, t.vy] for t in tracks] if len(tracks) else np.zeros((0, 5))
    arr = np.asarray(tracks, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 5:
        raise ValueError(f"tracks must have shape (K, 5) [id, x, y, vx, vy], got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("tracks must be finite")
    ids = arr[:, 0]
    if np.any(ids != np.rint(ids)) or np.any(ids < 0) or np.any(ids > np.iinfo(np.int32).max):
        raise ValueError(f"tracks: ids (column 0) must be integers in [0, 2**31 - 1], got {ids.tolist()}")
    if len(np.unique(ids)) != len(ids):
        raise ValueError(f"tracks: ids (column 0) must be unique in a frame, got {ids.tolist()}")
    return arr


class ResultBagWriter:
    """Write the belief, people, detections and tracks of each frame into a ROS 1 bag or a rosbag2.

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
        Detector names (one PoseArray topic each).
    bag_format : {"ros1", "mcap", "sqlite3"}, optional
        Default from the path: ``.bag`` -> ``ros1``, otherwise ``mcap``.
    overwrite : bool
        Replace an existing bag at ``path``.
    arrow_time_s : float
        The velocity arrow of a track spans the distance walked in this time (s).
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
    ) -> None:
        if not isinstance(frame_id, str) or not frame_id:
            raise ValueError(f"frame_id must be a non-empty string, got {frame_id!r}")
        if not (isinstance(arrow_time_s, int | float) and math.isfinite(arrow_time_s) and arrow_time_s > 0):
            raise ValueError(f"arrow_time_s must be a positive number, got {arrow_time_s!r}")
        self._det_topics = [detection_topic(n) for n in detector_names]
        if len(set(self._det_topics)) != len(self._det_topics):
            raise ValueError(f"detector names {list(detector_names)} map to the same topic")
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
        self.spec = spec
        self.frame_id = frame_id
        self.arrow_time_s = float(arrow_time_s)
        self._closed = False
        self._conns: dict[str, Any] = {}
        self._add(TOPIC_TF_STATIC, "tf2_msgs/msg/TFMessage", static=True)
        self._add(TOPIC_BELIEF, "nav_msgs/msg/OccupancyGrid")
        self._add(TOPIC_PEOPLE, "geometry_msgs/msg/PoseArray")
        for topic in self._det_topics:
            self._add(topic, "geometry_msgs/msg/PoseArray")
        self._add(TOPIC_TRACKS, "geometry_msgs/msg/PoseArray")
        self._add(TOPIC_TRACK_MARKERS, "visualization_msgs/msg/MarkerArray")
        self._seq = 0

    # -- plumbing ------------------------------------------------------------------------------------------------

    def _open_writer(self, target: Path) -> Any:
        """The rosbags writer, writing ``target`` (in the temporary folder, under the final name)."""
        self.ros2 = self.bag_format != "ros1"
        self.ts = get_typestore(Stores.ROS2_HUMBLE if self.ros2 else Stores.ROS1_NOETIC)
        if "tf2_msgs/msg/TFMessage" not in self.ts.types:  # not in rosbags' ROS 1 Noetic store
            self.ts.register(get_types_from_msg(_TF_MSG, "tf2_msgs/msg/TFMessage"))
        writer: Any
        if self.ros2:
            plugin = StoragePlugin.MCAP if self.bag_format == "mcap" else StoragePlugin.SQLITE3
            writer = Writer2(target, version=_ROSBAG2_VERSION, storage_plugin=plugin)
        else:
            writer = Writer1(target)
        writer.open()
        return writer

    def _publish(self) -> None:
        """Rename the finished bag into place (replacing an old one, checked at the start), then unlock."""
        assert self._tmp_dir is not None
        try:
            if self.path.is_symlink():  # the link is replaced, not what it points to
                self.path.unlink()
            elif self.path.is_dir():  # an old rosbag2: moved aside, then removed with the temporary folder
                os.rename(self.path, self._tmp_dir / ".replaced")
            os.replace(self._tmp_dir / self.path.name, self.path)
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
            qos: tuple[Qos, ...] = ()
            if static:
                zero = QosTime(sec=0, nsec=0)
                qos = (
                    Qos(
                        history=QosHistory.KEEP_LAST,
                        depth=1,
                        reliability=QosReliability.RELIABLE,
                        durability=QosDurability.TRANSIENT_LOCAL,
                        deadline=zero,
                        lifespan=zero,
                        liveliness=QosLiveliness.AUTOMATIC,
                        liveliness_lease_duration=zero,
                        avoid_ros_namespace_conventions=False,
                    ),
                )
            conn = self._writer.add_connection(topic, msgtype, typestore=self.ts, offered_qos_profiles=qos)
        else:
            conn = self._writer.add_connection(topic, msgtype, typestore=self.ts, latching=1 if static else None)
        self._conns[topic] = (conn, msgtype)

    def _put(self, topic: str, bag_time_ns: int, msg: Any) -> None:
        conn, msgtype = self._conns[topic]
        data = self.ts.serialize_cdr(msg, msgtype) if self.ros2 else self.ts.serialize_ros1(msg, msgtype)
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

    def _tf_static(self, stamp_ns: int) -> Any:
        s = self.spec
        tr = self._m(
            "geometry_msgs/msg/Transform",
            translation=self._m("geometry_msgs/msg/Vector3", x=float(s.x0), y=float(s.y0), z=0.0),
            rotation=self._m("geometry_msgs/msg/Quaternion", w=1.0),
        )
        t = self._m(
            "geometry_msgs/msg/TransformStamped",
            header=self._header(stamp_ns),
            child_frame_id=GRID_ORIGIN_FRAME,
            transform=tr,
        )
        return self._m("tf2_msgs/msg/TFMessage", transforms=[t])

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

    def _markers(self, stamp_ns: int, tracks: NDArray[np.float64]) -> Any:
        header = self._header(stamp_ns)
        markers = [self._m("visualization_msgs/msg/Marker", header=header, action=MARKER_DELETEALL)]
        for tid, x, y, vx, vy in tracks:
            markers.append(
                self._m(
                    "visualization_msgs/msg/Marker",
                    header=header,
                    ns="pfpeople/track_ids",
                    id=int(tid),
                    type=MARKER_TEXT_VIEW_FACING,
                    action=MARKER_ADD,
                    pose=self._pose(x, y, z=TEXT_Z_M),
                    scale=self._m("geometry_msgs/msg/Vector3", z=0.3),
                    color=self._color(1.0, 1.0, 1.0),
                    text=str(int(tid)),
                )
            )
            t = self.arrow_time_s
            markers.append(
                self._m(
                    "visualization_msgs/msg/Marker",
                    header=header,
                    ns="pfpeople/track_velocities",
                    id=int(tid),
                    type=MARKER_ARROW,
                    action=MARKER_ADD,
                    pose=self._pose(0.0, 0.0),
                    scale=self._m("geometry_msgs/msg/Vector3", x=0.05, y=0.1, z=0.1),
                    color=self._color(0.1, 0.9, 0.2),
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
        people: NDArray[np.float64],
        detections: Sequence[NDArray[np.float64] | None],
        tracks: NDArray[np.float64] | Sequence[Any] | None = None,
    ) -> None:
        """Write one frame.

        Parameters
        ----------
        bag_time_ns, stamp_ns : int
            Record time and header stamp (ns).
        belief : ndarray (nx, ny)
            Belief grid (probability of a person per cell, grid frame).
        people : ndarray (P, 2)
            Classified people (m, grid frame).
        detections : sequence of ndarray (D_i, 2) or None
            Each detector's detections (m, grid frame); None: no data (nothing written on its topic).
        tracks : ndarray (K, 5) or sequence of track objects, optional
            ``[id, x, y, vx, vy]`` (id a non-negative integer; m and m/s in the grid frame), or objects with
            those attributes (``id``, ``x``, ``y``, ``vx``, ``vy``). None: no track topics in this frame; an
            empty (0, 5) array writes an empty PoseArray and a lone DELETEALL.
        """
        if self._closed:
            raise ValueError(f"bag output {str(self.path)!r} is closed")
        belief = self.spec.check_grid(belief, "belief")
        if len(detections) != len(self._det_topics):
            raise ValueError(f"detections: expected {len(self._det_topics)} entries, got {len(detections)}")
        trk = None if tracks is None else _check_tracks(tracks)
        if self._seq == 0:
            self._put(TOPIC_TF_STATIC, bag_time_ns, self._tf_static(stamp_ns))
        self._put(TOPIC_BELIEF, bag_time_ns, self._grid(stamp_ns, belief))
        self._put(TOPIC_PEOPLE, bag_time_ns, self._pose_array(stamp_ns, people))
        for topic, det in zip(self._det_topics, detections, strict=True):
            if det is not None:
                self._put(topic, bag_time_ns, self._pose_array(stamp_ns, det))
        if trk is not None:
            yaws = [math.atan2(vy, vx) if (vx or vy) else 0.0 for vx, vy in trk[:, 3:5]]
            self._put(TOPIC_TRACKS, bag_time_ns, self._pose_array(stamp_ns, trk[:, 1:3], yaws))
            self._put(TOPIC_TRACK_MARKERS, bag_time_ns, self._markers(stamp_ns, trk))
        self._seq += 1

    def close(self) -> None:
        """Finish the bag (index / metadata.yaml); idempotent."""
        if not self._closed:
            self._closed = True
            try:
                self._writer.close()
            except BaseException:
                self._discard()
                raise
            self._publish()

    def __enter__(self) -> ResultBagWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
