"""The bag pipeline: bag -> synchronised frames -> detectors -> filter -> classification -> run directory.

Per frame (driven by the config's ``driver`` topic, see :mod:`pfpeople.bag.sync`):

1. Inputs: each detector's input message is chosen by its sync policy; a detector whose input is missing
   (nothing within the tolerance), empty (a LaserScan with no beams) or undecodable has **no data** in the
   frame: its entry is ``None`` and the filter treats it as covering no cell (counted and logged once). A
   ``topic`` detector with ``assign = "preceding"`` and no message in the frame detected nobody (an empty
   array): such topics typically publish only when someone is detected.
2. Detections: built-in detectors (``leg``, ``boosted``, ``hog``) run on the converted message; ``topic``
   detectors read positions from the messages. Positions are mapped from the detector's frame to the grid
   frame by the 2-D TF mount, which is also written into the detector's ``DetectorModel`` (``mount_x``,
   ``mount_y``, ``mount_yaw``) so its field of view is placed correctly.
3. Ego-motion: the odometry pose of the base frame is interpolated to the frame stamps (linear in x, y and
   the wrapped yaw), composed with the grid frame's mount on the base (``P_grid = P_base * T_base_grid``),
   and the relative motion ``D = P_grid(t_{k-1})^-1 P_grid(t_k)`` is converted to the velocity motion model's
   controls over ``dt = t_k - t_{k-1}``:

       omega = dtheta / dt,   v = (dtheta/2) / sin(dtheta/2) * (dx cos(dtheta/2) + dy sin(dtheta/2)) / dt

   (exact for motion on an arc; the lateral part ``-dx sin(dtheta/2) + dy cos(dtheta/2)``, which a sensor
   mounted off the rotation axis can have, is not representable by (v, omega); its largest magnitude is
   reported in the run statistics). Without odometry the robot is taken as standing (logged once); after a
   frame without odometry, the next frame with odometry moves the grid by the whole displacement since the
   last frame that had it, so no motion is lost.
4. Filter step (``GridFilter`` or ``ParticleFilter``, same ``step`` signature), the paper's blob
   classification of the belief (:func:`gridbridge.classify.classify_blobs`), and one frame of output.

The first frame uses ``dt = 0.1 s`` (the paper's step; the initial belief is uniform, so the prediction has no
effect there). A gap between frames longer than ``MAX_GAP_S`` restarts the filter (counted; a prediction over
a long gap would be meaningless and its kernel very large).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import itertools
import logging
import math
import time
import types
import typing
from collections.abc import Callable, Generator, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol, TypeAlias

import numpy as np
from numpy.typing import NDArray

from gridbridge.classifiers import PeakClassifier
from gridbridge.ego_motion import Odometry
from gridbridge.filter import BeliefFilter
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.bag.config import BagConfig, DetectorConfig, FilterConfig, check_run_limits
from pfpeople.bag.reader import (
    IMAGE_TYPES,
    LASER_TYPES,
    ODOMETRY_TYPES,
    BagMessage,
    BagSource,
    image_from_msg,
    laser_from_msg,
    odometry_pose_from_msg,
    positions_from_msg,
)
from pfpeople.bag.sync import Frame, FrameAssembler
from pfpeople.bag.tf import TfBuffer, TfLookupError
from pfpeople.filters import build_classifier, grid_for_scan
from pfpeople.mot import track_rows, tracker_inputs
from pfpeople.output import RunWriter, deferred_signals, interrupt_signals
from pfpeople.sensors import Pose2D

__all__ = [
    "FIRST_DT_S",
    "MAX_GAP_S",
    "Detector",
    "FrameResult",
    "Pipeline",
    "RunSummary",
    "build_detector",
    "make_filter",
    "odometry_between",
]

log = logging.getLogger(__name__)

#: dt of the first frame (s).
FIRST_DT_S = 0.1
#: A gap between frames longer than this (s) restarts the filter.
MAX_GAP_S = 2.0
#: TF on /tf (not static) read before the run to find sensor mounts: the first this many seconds of the bag.
TF_PRELOAD_S = 1.0

# kind -> class name in pfpeople.detectors (imported lazily).
_BUILTIN = {"leg": "LegDetector", "boosted": "BoostedSegmentDetector", "hog": "HogCameraDetector"}
#: Kinds whose detector maps its positions into the grid frame itself (given ``mounting``).
_SELF_MOUNTED = {"hog"}


class Detector(Protocol):
    """What the pipeline needs of a detector."""

    model: DetectorModel

    def detect(self, data: Any, /) -> NDArray[np.float64]: ...


#: The filter interface the pipeline uses (one Protocol for both filters, :class:`gridbridge.filter.BeliefFilter`).
StepFilter: TypeAlias = BeliefFilter


def _import_builtin(kind: str) -> type:
    cls_name = _BUILTIN[kind]
    try:
        module = importlib.import_module("pfpeople.detectors")
        return getattr(module, cls_name)
    except (ImportError, AttributeError) as exc:
        raise ValueError(
            f"detector kind {kind!r} needs pfpeople.detectors.{cls_name}, which cannot be imported: {exc}"
        ) from None


def _type_name(hint: Any) -> str:
    args = typing.get_args(hint)
    if args:
        return " or ".join(_type_name(a) for a in args)
    if hint is type(None):
        return "None"
    if hint is float:
        return "a number"
    if hint is int:
        return "an integer"
    if hint is bool:
        return "true/false"
    if hint is str:
        return "a string"
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return f"a table ({hint.__name__})"
    return getattr(hint, "__name__", str(hint))


def _matches(value: Any, hint: Any) -> bool:
    """Whether a TOML value fits a constructor annotation (unknown annotations accept anything)."""
    if hint is Any or hint is None:
        return True
    args = typing.get_args(hint)
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, a) for a in args)
    if origin is typing.Literal:
        return value in args
    if hint is type(None):
        return value is None
    if hint is bool:
        return isinstance(value, bool)
    if hint is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if hint is str:
        return isinstance(value, str)
    if hint is Path or (isinstance(hint, type) and issubclass(hint, Path)):
        return isinstance(value, str | Path)
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return isinstance(value, Mapping | hint)
    if isinstance(hint, type):
        return isinstance(value, hint)
    return True


def _dataclass_from_table(cls: type, value: Mapping[str, Any], where: str) -> Any:
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for key, item in value.items():
        if key not in names:
            raise ValueError(f"{where}: {cls.__name__} has no field {key!r}; it has {sorted(names)}")
        hint = hints.get(key)
        if isinstance(item, Mapping):
            options = typing.get_args(hint) or (hint,)
            sub = [t for t in options if isinstance(t, type) and dataclasses.is_dataclass(t)]
            if not sub:
                raise ValueError(f"{where}.{key} does not take a table; expected {_type_name(hint)}")
            item = _dataclass_from_table(sub[0], item, f"{where}.{key}")
        elif not _matches(item, hint):
            raise ValueError(f"{where}.{key} must be {_type_name(hint)}, got {item!r} ({type(item).__name__})")
        kwargs[key] = item
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise ValueError(f"{where}: {exc}") from None


def _kwargs_from_table(cls: type, table: Mapping[str, Any]) -> dict[str, Any]:
    """Constructor keyword arguments from ``[detectors.params]``; tables become the annotated dataclass.

    Values are checked against the constructor's annotations: a wrong type raises ValueError naming
    ``detectors.params.KEY`` and the expected type.
    """
    sig = inspect.signature(cls)
    hints = typing.get_type_hints(cls.__init__)  # type: ignore[misc]
    kwargs: dict[str, Any] = {}
    for key, value in table.items():
        if key not in sig.parameters or key == "model":
            allowed = sorted(k for k in sig.parameters if k != "model")
            raise ValueError(f"{cls.__name__} has no constructor argument {key!r}; it takes {allowed}")
        where = f"detectors.params.{key}"
        hint = hints.get(key)
        if isinstance(value, Mapping):
            options = typing.get_args(hint) or (hint,)
            candidates: list[Any] = [t for t in options if isinstance(t, type) and dataclasses.is_dataclass(t)]
            if not candidates:
                raise ValueError(f"{cls.__name__}.{key} does not take a table ({where} must be {_type_name(hint)})")
            value = _dataclass_from_table(candidates[0], value, where)
        elif not _matches(value, hint):
            raise ValueError(f"{where} must be {_type_name(hint)}, got {value!r} ({type(value).__name__})")
        kwargs[key] = value
    return kwargs


def build_detector(cfg: DetectorConfig, mount: Pose2D) -> Detector | None:
    """The built-in detector of ``cfg`` with its model overridden by ``cfg.model`` and mounted at ``mount``.

    Returns None for ``kind="topic"`` (no detector object: positions come from the bag). Bad
    ``[detectors.params]`` raise ValueError naming the detector and the parameter.
    """
    if cfg.kind == "topic":
        return None
    cls = _import_builtin(cfg.kind)
    try:
        kwargs = _kwargs_from_table(cls, cfg.params)
        if cfg.kind in _SELF_MOUNTED:
            kwargs.setdefault("mounting", mount)
        det: Detector = cls(**kwargs)  # built once: the boosted detector loads its model file here
    except (TypeError, ValueError) as exc:
        raise ValueError(f"detector {cfg.name!r} ({cfg.kind}): {exc}") from None
    det.model = _model_for(cfg, mount, det.model)
    return det


def _model_for(cfg: DetectorConfig, mount: Pose2D, base: DetectorModel | None) -> DetectorModel:
    over = dict(cfg.model)
    over["name"] = cfg.name
    over.setdefault("mount_x", mount.x)
    over.setdefault("mount_y", mount.y)
    over.setdefault("mount_yaw", mount.yaw)
    if base is None:
        return DetectorModel(**over)
    return replace(base, **over)


def make_filter(config: FilterConfig, spec: GridSpec, detectors: Sequence[DetectorModel]) -> StepFilter:
    """The run's filter (:func:`pfpeople.filters.build_filter`)."""
    from pfpeople.filters import build_filter

    return build_filter(config, spec, detectors)


def _scan_bearings(msg: Any) -> tuple[float, float]:
    """``(lowest, highest)`` bearing of a LaserScan message (rad), whatever the sign of its increment."""
    a0, a1 = float(msg.angle_min), float(msg.angle_max)
    lo, hi = min(a0, a1), max(a0, a1)
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi - lo <= 0:
        raise ValueError(f"LaserScan angles angle_min={a0!r}, angle_max={a1!r} give no field of view")
    return lo, min(hi, lo + 2 * math.pi)


def _with_scan_fov(d: DetectorConfig, msg: Any) -> DetectorConfig:
    """``d`` with the field of view and range of its LaserScan where its ``[detectors.model]`` leaves them out."""
    try:
        lo, hi = _scan_bearings(msg)
    except ValueError:
        return d  # the reader reports such scans; the model keeps its own field of view
    model = dict(d.model)
    model.setdefault("fov_min", lo)
    model.setdefault("fov_max", hi)
    rmax = float(msg.range_max)
    if "max_range" not in model and math.isfinite(rmax) and rmax > 0:
        model["max_range"] = rmax
    if model.get("min_range", 0.0) >= model.get("max_range", math.inf):
        model.pop("min_range", None)
    return replace(d, model=model)


def _check_max_frames(max_frames: int | None) -> None:
    if max_frames is not None and (isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 0):
        raise ValueError(f"max_frames must be a non-negative integer or None, got {max_frames!r}")


def _interpolate(a: tuple[int, Pose2D], b: tuple[int, Pose2D], t: int) -> Pose2D:
    (ta, pa), (tb, pb) = a, b
    if tb == ta:
        return pb
    f = (t - ta) / (tb - ta)
    dyaw = math.atan2(math.sin(pb.yaw - pa.yaw), math.cos(pb.yaw - pa.yaw))
    return Pose2D(x=pa.x + f * (pb.x - pa.x), y=pa.y + f * (pb.y - pa.y), yaw=pa.yaw + f * dyaw)


def odometry_between(p0: Pose2D, p1: Pose2D, dt: float) -> tuple[Odometry, float]:
    """Velocity-model controls moving a frame from pose ``p0`` to ``p1`` in ``dt`` s (see module docstring).

    Returns
    -------
    odometry : Odometry
        ``v`` (m/s) and ``omega`` (rad/s) in the moving frame.
    lateral : float
        The lateral displacement (m) the arc model cannot represent.
    """
    d = p0.inverse().compose(p1)
    half = 0.5 * d.yaw
    along = d.x * math.cos(half) + d.y * math.sin(half)
    lateral = -d.x * math.sin(half) + d.y * math.cos(half)
    arc = 1.0 if abs(half) < 1e-9 else half / math.sin(half)
    return Odometry(v=arc * along / dt, omega=d.yaw / dt), lateral


@dataclass(frozen=True, kw_only=True, eq=False)
class FrameResult:
    """One processed frame: detections in the grid frame (None: no data), belief, classified people."""

    frame: Frame
    dt: float
    odometry: Odometry | None
    detections: list[NDArray[np.float64] | None]
    belief: NDArray[np.float64]
    people: NDArray[np.float64]
    people_size: list[int] = field(default_factory=list)
    people_probability: list[float] = field(default_factory=list)
    step: Any = None
    tracks: list[Any] | None = None
    static: list[NDArray[np.bool_] | None] | None = None


@dataclass
class RunSummary:
    """Counts of a run (also written to ``run.json`` as ``stats``)."""

    frames: int = 0
    elapsed_s: float = 0.0
    no_data: dict[str, int] = field(default_factory=dict)
    empty_scans: dict[str, int] = field(default_factory=dict)
    bad_messages: dict[str, int] = field(default_factory=dict)
    frames_without_odometry: int = 0
    filter_restarts: int = 0
    max_lateral_m: float = 0.0
    suppressed: dict[str, int] = field(default_factory=dict)
    laser_odometry_frames: int = 0
    sync: dict[str, dict[str, int]] = field(default_factory=dict)
    error: str | None = None

    @property
    def fps(self) -> float:
        return self.frames / self.elapsed_s if self.elapsed_s > 0 else math.nan

    def as_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["fps"] = self.fps
        return out


class Pipeline:
    """Run a :class:`BagConfig` over a bag.

    Parameters
    ----------
    config : BagConfig
        Topics, frames, detectors, grid and filter.
    detectors : mapping of str to Detector, optional
        Detector objects to use instead of building the built-in ones (by detector name); their ``model``
        is used as given (name and mount included).
    filter_factory : callable, optional
        ``(spec, models) -> filter`` replacing :func:`make_filter`.
    """

    def __init__(
        self,
        config: BagConfig,
        *,
        detectors: Mapping[str, Detector] | None = None,
        filter_factory: Callable[[GridSpec, Sequence[DetectorModel]], StepFilter] | None = None,
    ) -> None:
        self.config = config
        self._given = dict(detectors or {})
        unknown = set(self._given) - {d.name for d in config.detectors}
        if unknown:
            raise ValueError(f"detectors {sorted(unknown)} are not in the config")
        self._filter_factory = filter_factory
        self.summary = RunSummary()
        self.grid_frame = config.grid_frame
        self.models: list[DetectorModel] = []
        self.mounts: list[Pose2D] = []
        self.filter: StepFilter | None = None
        self.spec: GridSpec = config.grid if config.grid is not None else GridSpec()
        self.classifier: Any = None
        self.tracker: Any = None
        self._track_classifier: PeakClassifier | None = None
        self._suppressors: dict[str, Any] = {}
        self._frame_scans: dict[str, Any] = {}
        self._frame_raw: dict[int, NDArray[np.float64]] = {}
        self._last_people = np.zeros((0, 2))
        self._detectors: list[Detector | None] = []
        self._warned: set[str] = set()

    # -- preparation -----------------------------------------------------------------------------------------

    def _topics(self) -> list[str]:
        c = self.config
        topics = {c.driver, *(d.topic for d in c.detectors)}
        if c.odometry:
            topics.add(c.odometry)
        return sorted(topics)

    def _first_messages(self, bag: BagSource, topics: Sequence[str]) -> dict[str, BagMessage]:
        first: dict[str, BagMessage] = {}
        for topic in topics:
            for m in bag.messages([topic]):
                first[topic] = m
                break
        return first

    def prepare(self, bag: BagSource) -> TfBuffer:
        """Check topics and types, read the TF mounts, build the detectors and the filter."""
        c = self.config
        types: dict[str, Sequence[str]] = {c.driver: (*LASER_TYPES, *IMAGE_TYPES)}
        for d in c.detectors:
            if d.kind in ("leg", "boosted"):
                types[d.topic] = LASER_TYPES
            elif d.kind == "hog":
                types[d.topic] = IMAGE_TYPES
        if c.odometry:
            types[c.odometry] = ODOMETRY_TYPES
        bag.require(self._topics(), types=types)
        tf = TfBuffer(fallback_parent=c.base_frame, fallback=c.mounts)
        for topic in (t for t in c.tf_topics if t in bag.topics):
            static = topic.endswith("tf_static")
            for m in bag.messages([topic]):
                if not static and m.bag_time_ns - bag.start_time_ns > TF_PRELOAD_S * 1e9:
                    break
                tf.add_message(m.msg)
        first = self._first_messages(bag, [c.driver, *(d.topic for d in c.detectors)])
        ids = {t: m.frame_id for t, m in first.items()}
        for d in c.detectors:
            if d.kind == "topic" and d.topic in first:  # fails early, naming the type, if it holds no positions
                positions_from_msg(first[d.topic].msg, topic=d.topic, msgtype=first[d.topic].msgtype)
        if not self.grid_frame:
            self.grid_frame = ids.get(c.driver, "")
            if not self.grid_frame:
                raise ValueError(f"driver topic {c.driver!r} has no frame_id; set [frames] grid_frame in the config")
        self.models, self.mounts, self._detectors = [], [], []
        self.frame_mounts: dict[str, Pose2D] = {self.grid_frame: Pose2D()}
        for d in c.detectors:
            if d.kind in ("leg", "boosted") and d.topic in first:
                d = _with_scan_fov(d, first[d.topic].msg)
            src = d.frame or ids.get(d.topic, "") or self.grid_frame
            try:
                mount = tf.lookup(self.grid_frame, src)
            except TfLookupError as exc:
                raise ValueError(f"detector {d.name!r}: {exc}") from None
            if d.name in self._given:
                det: Detector | None = self._given[d.name]
                model = det.model  # type: ignore[union-attr]
            else:
                det = build_detector(d, mount)
                model = det.model if det is not None else _model_for(d, mount, None)
            self._detectors.append(det)
            self.models.append(model)
            self.mounts.append(mount)
            self.frame_mounts[src] = mount
        self._base_to_grid: Pose2D | None = None
        if c.odometry:
            try:
                self._base_to_grid = tf.lookup(c.base_frame, self.grid_frame)
            except TfLookupError as exc:
                raise ValueError(f"odometry needs the grid frame's mount on the base frame: {exc}") from None
        if c.base_frame not in self.frame_mounts:  # so ground truth given in the base frame can be scored
            try:
                self.frame_mounts[c.base_frame] = tf.lookup(self.grid_frame, c.base_frame)
            except TfLookupError:
                pass
        self.spec = c.grid if c.grid is not None else self._default_grid(tf, first, ids)
        if c.grid is None:
            check_run_limits(self.spec, c.filter, len(c.detectors))
            log.info("grid from the driving laser's field of view: %s", self.spec)
        factory = self._filter_factory or (lambda spec, models: make_filter(c.filter, spec, models))
        self.filter = factory(self.spec, self.models)
        self.classifier = build_classifier(c.classifier, c.filter.mode)
        self._suppressors = {}
        self._last_people = np.zeros((0, 2))
        if c.clutter.on(c.filter.mode):
            from pfpeople.clutter import ClutterConfig, ClutterSuppressor

            try:
                ccfg = ClutterConfig(**dict(c.clutter.params))
            except TypeError as exc:
                raise ValueError(f"[clutter.params]: {exc}") from None
            for d in c.detectors:
                if d.kind in ("leg", "boosted") and d.topic not in self._suppressors:
                    self._suppressors[d.topic] = ClutterSuppressor(ccfg)
        self.tracker, self._track_classifier = None, None
        if c.tracking.enabled:
            from pfpeople.mot import MultiPersonTracker, TrackerConfig

            params = dict(c.tracking.params)
            pt = c.tracking.peak_threshold
            if isinstance(self.classifier, PeakClassifier) and pt is not None and pt < self.classifier.threshold:
                self._track_classifier = replace(self.classifier, threshold=pt)  # lower peaks update tracks
                params.setdefault("birth_min_score", self.classifier.threshold)  # people start them
            try:
                self.tracker = MultiPersonTracker(TrackerConfig(**params))
            except TypeError as exc:
                raise ValueError(f"[tracking.params]: {exc}") from None
        return tf

    def _default_grid(self, tf: TfBuffer, first: Mapping[str, BagMessage], ids: Mapping[str, str]) -> GridSpec:
        """The grid covering the driving laser's field of view (:func:`pfpeople.filters.grid_for_scan`), or the first
        laser detector's when the driver is not a LaserScan, or the paper's grid when the run has no laser."""
        c = self.config
        lasers = [c.driver, *(d.topic for d in c.detectors if d.kind in ("leg", "boosted"))]
        topic = next((t for t in lasers if t in first and first[t].msgtype in LASER_TYPES), None)
        if topic is None:
            log.info("no [grid] and no LaserScan to size it: the paper's 30 x 30 grid of 0.3 m")
            return GridSpec()
        m = first[topic]
        try:
            mount = tf.lookup(self.grid_frame, ids.get(topic, "") or self.grid_frame)
        except TfLookupError as exc:
            raise ValueError(f"grid from the laser {topic!r}: {exc}") from None
        lo, hi = _scan_bearings(m.msg)
        return grid_for_scan(lo, hi, float(m.msg.range_max), mount=mount)

    # -- running ---------------------------------------------------------------------------------------------

    def _once(self, key: str, msg: str, *args: object) -> None:
        if key not in self._warned:
            self._warned.add(key)
            log.warning(msg, *args)

    def _count(self, table: dict[str, int], name: str) -> None:
        table[name] = table.get(name, 0) + 1

    def _inputs(self, frame: Frame, d: DetectorConfig) -> list[BagMessage]:
        if d.topic == self.config.driver:
            return [frame.driver]
        return frame.inputs.get(d.topic, [])

    def _detect(self, k: int, d: DetectorConfig, frame: Frame) -> NDArray[np.float64] | None:
        msgs = self._inputs(frame, d)
        s = self.summary
        if not msgs:
            if d.assign == "preceding" and d.kind == "topic":
                return np.zeros((0, 2))
            self._count(s.no_data, d.name)
            self._once(
                f"nodata:{d.name}",
                "detector %s: no %s message within the tolerance of frame %d "
                "(it covers no cell in such frames; counted)",
                d.name,
                d.topic,
                frame.index,
            )
            return None
        det = self._detectors[k]
        try:
            if d.kind == "topic":
                pts = np.concatenate([positions_from_msg(m.msg, topic=m.topic, msgtype=m.msgtype) for m in msgs])
            else:
                m = msgs[0]
                if d.kind == "hog":
                    data: Any = image_from_msg(
                        m.msg, m.msgtype, stamp_ns=m.stamp_ns, frame_id=m.frame_id, topic=m.topic
                    )
                else:
                    data = laser_from_msg(m.msg, stamp_ns=m.stamp_ns, frame_id=m.frame_id, topic=m.topic)
                    self._frame_scans[d.topic] = data
                    if data.ranges.size == 0:
                        self._count(s.empty_scans, d.name)
                        self._count(s.no_data, d.name)
                        self._once(
                            f"empty:{d.name}",
                            "topic %s: empty LaserScan (no beams) at %d ns; detector %s "
                            "has no data in such frames (counted)",
                            m.topic,
                            m.stamp_ns,
                            d.name,
                        )
                        return None
                assert det is not None
                pts = np.asarray(det.detect(data), dtype=float).reshape(-1, 2)
        except ValueError as exc:
            self._count(s.bad_messages, d.name)
            self._count(s.no_data, d.name)
            self._once(
                f"bad:{d.name}", "detector %s: unusable input (%s); no data in such frames (counted)", d.name, exc
            )
            return None
        if not len(pts):
            pts = np.zeros((0, 2))
        self._frame_raw[k] = pts
        if not len(pts):
            return pts
        return pts if d.kind in _SELF_MOUNTED else self.mounts[k].apply(pts)

    def _suppress(
        self,
        dets: list[NDArray[np.float64] | None],
        ego_grid: Pose2D | None,
        dt: float,
        stamp_ns: int,
    ) -> tuple[list[NDArray[np.float64] | None], list[NDArray[np.bool_] | None], Pose2D | None]:
        """Static-clutter suppression of the laser detections (one :class:`pfpeople.clutter.ClutterSuppressor`
        per laser topic, in the laser's frame); returns the detections the filter sees, the static flags per
        detector, and the driving laser's scan-matched ego-motion in the grid frame (None when unknown)."""
        c = self.config
        kept: list[NDArray[np.float64] | None] = list(dets)
        static: list[NDArray[np.bool_] | None] = [None] * len(dets)
        driver_ego: Pose2D | None = None
        for topic, sup in self._suppressors.items():
            scan = self._frame_scans.get(topic)
            idx = [k for k, d in enumerate(c.detectors) if d.topic == topic and dets[k] is not None]
            if scan is None or not idx:
                continue
            mount = self.mounts[idx[0]]  # the laser's pose in the grid frame
            ego = None if ego_grid is None else mount.inverse().compose(ego_grid).compose(mount)
            exclude = self._last_people
            if len(exclude):
                if ego_grid is not None:
                    exclude = ego_grid.inverse().apply(exclude)
                exclude = mount.inverse().apply(exclude)
            st = sup.step(
                scan.points(),
                [self._frame_raw[k] for k in idx],
                ego=ego,
                exclude=exclude,
                stamp_ns=stamp_ns,
                dt=dt,
            )
            for k, keep in zip(idx, st.keep, strict=True):
                static[k] = ~keep
                d = dets[k]
                kept[k] = d[keep] if d is not None and len(d) else d
                self.summary.suppressed[c.detectors[k].name] = self.summary.suppressed.get(
                    c.detectors[k].name, 0
                ) + int(np.count_nonzero(~keep))
            if topic == c.driver and st.ego_ok and ego is None:
                driver_ego = mount.compose(st.ego).compose(mount.inverse())
        return kept, static, driver_ego

    def _odometry_pose(self, frame: Frame) -> Pose2D | None:
        c = self.config
        if not c.odometry:
            return None
        msgs = frame.inputs.get(c.odometry, [])
        poses = []
        for m in msgs:
            try:
                pose, _child = odometry_pose_from_msg(m.msg, topic=m.topic)
            except ValueError as exc:
                self._count(self.summary.bad_messages, c.odometry)
                self._once("bad:odom", "%s (such messages are not used; counted)", exc)
                return None
            poses.append((m.stamp_ns, pose))
        if not poses:
            return None
        base = poses[0][1] if len(poses) == 1 else _interpolate(poses[0], poses[1], frame.stamp_ns)
        assert self._base_to_grid is not None
        return base.compose(self._base_to_grid)

    def frames(self, bag: BagSource, *, max_frames: int | None = None) -> Generator[FrameResult, None, None]:
        """Process the bag frame by frame (call :meth:`prepare` first, or let this call it)."""
        _check_max_frames(max_frames)
        if self.filter is None:
            self.prepare(bag)
        assert self.filter is not None
        c = self.config
        policies: dict[str, str] = {}
        for d in c.detectors:
            if d.topic != c.driver:
                old = policies.setdefault(d.topic, d.assign)
                if old != d.assign:
                    raise ValueError(f"topic {d.topic!r} is given two sync policies ({old!r}, {d.assign!r})")
        if c.odometry:
            if c.odometry in policies or c.odometry == c.driver:
                raise ValueError(f"odometry topic {c.odometry!r} is also a detector or driver topic")
            policies[c.odometry] = "interpolate"
        else:
            log.info("no odometry topic configured: the robot is taken as standing in every frame")
        sync = FrameAssembler(c.driver, policies, tolerance_ns=c.sync_tolerance_ns, max_pending=c.max_pending_frames)
        use_bag_time = c.time_source == "bag"
        prev_stamp: int | None = None
        prev_pose: Pose2D | None = None  # the grid frame's pose in the latest frame that had odometry

        def process(frame: Frame) -> FrameResult:
            nonlocal prev_stamp, prev_pose
            assert self.filter is not None
            s = self.summary
            dt = FIRST_DT_S if prev_stamp is None else (frame.stamp_ns - prev_stamp) * 1e-9
            restarted = False
            if dt > MAX_GAP_S:
                restarted = True
                s.filter_restarts += 1
                log.warning("gap of %.3f s before frame %d: restarting the filter", dt, frame.index)
                self.filter.reset()
                for sup in self._suppressors.values():
                    sup.map.forget()
                dt, prev_pose = FIRST_DT_S, None
            pose = self._odometry_pose(frame)
            odo: Odometry | None = None
            if c.odometry:
                if pose is None:
                    s.frames_without_odometry += 1
                    self._once(
                        "noodo",
                        "frame %d has no odometry within the tolerance: robot taken as standing (counted)",
                        frame.index,
                    )
                elif prev_pose is not None:
                    odo, lateral = odometry_between(prev_pose, pose, dt)
                    s.max_lateral_m = max(s.max_lateral_m, abs(lateral))
            self._frame_scans, self._frame_raw = {}, {}
            raw = [self._detect(k, d, frame) for k, d in enumerate(c.detectors)]
            dets = raw
            static: list[NDArray[np.bool_] | None] = [None] * len(raw)
            laser_ego: Pose2D | None = None
            if self._suppressors:
                ego_grid = None if (pose is None or prev_pose is None) else prev_pose.inverse().compose(pose)
                dets, static, laser_ego = self._suppress(raw, ego_grid, dt, frame.stamp_ns)
                if not c.odometry and c.clutter.laser_odometry and laser_ego is not None and prev_stamp is not None:
                    odo, lateral = odometry_between(Pose2D(), laser_ego, dt)
                    s.laser_odometry_frames += 1
                    s.max_lateral_m = max(s.max_lateral_m, abs(lateral))
            step = self.filter.step(dets, odo, dt)
            belief = np.asarray(step.posterior, dtype=float)
            observed = np.asarray(step.covered).any(axis=0)
            found = self.classifier.classify(belief, self.spec, observed=observed)
            people = found.positions.reshape(-1, 2)
            tracks = None
            if self.tracker is not None:
                ego = None if (pose is None or prev_pose is None) else prev_pose.inverse().compose(pose)
                if ego is None and odo is not None and laser_ego is not None:  # moved by scan matching
                    ego = laser_ego
                if restarted:
                    self.tracker.reset()
                tpos, tsc = people, found.scores
                if self._track_classifier is not None:  # the people + weaker peaks (update, never start tracks)
                    tpos, tsc = tracker_inputs(
                        found,
                        belief,
                        self.spec,
                        low=self._track_classifier,
                        high=self.classifier.threshold,
                        observed=observed,
                    )
                self.tracker.update(tpos, dt, scores=tsc, ego=ego, belief=belief, spec=self.spec)
                tracks = self.tracker.confirmed()
            # people kept out of the clutter map next frame: the confirmed tracks (else the classified people), so
            # that a person standing still is not absorbed into the map. Trade-off measured on the benchmark:
            # keeping out only tracks moving >= 0.3 m/s cut the wheelchair scene's false people by 15 % but lost
            # people who stand still from the first scan (they turn static after static_time).
            self._last_people = np.array([[t.x, t.y] for t in tracks]).reshape(-1, 2) if tracks else people
            prev_stamp = frame.stamp_ns
            if pose is not None:  # a frame without odometry keeps the last pose: its motion is not lost
                prev_pose = pose
            s.frames += 1
            return FrameResult(
                frame=frame,
                dt=dt,
                odometry=odo,
                detections=raw,
                static=static,
                belief=belief,
                people=people,
                people_size=[int(v) for v in found.sizes],
                people_probability=[float(v) for v in found.scores],
                step=step,
                tracks=tracks,
            )

        def synced() -> Iterator[Frame]:
            for m in bag.messages(self._topics()):
                yield from sync.push(replace(m, stamp_ns=m.bag_time_ns) if use_bag_time else m)
            yield from sync.finish()

        t0 = time.perf_counter()
        try:
            for frame in itertools.islice(synced(), max_frames):
                yield process(frame)
        finally:
            self.summary.elapsed_s = time.perf_counter() - t0
            self.summary.sync = sync.stats

    def run(
        self,
        bag: BagSource,
        out_dir: str | Path | None = None,
        *,
        max_frames: int | None = None,
        progress: bool = False,
        overwrite: bool = False,
        metadata: Mapping[str, Any] | None = None,
        bag_out: str | Path | None = None,
        keep: bool = False,
        bag_format: str | None = None,
    ) -> tuple[RunSummary, list[FrameResult]]:
        """Run over ``bag``, writing ``out_dir`` (and ``bag_out``) incrementally.

        A run that stops part-way (a truncated or corrupt bag, :class:`~pfpeople.bag.reader.BagReadError`;
        any other error) ends with ``status = "failed"`` and the error in ``run.json``; one stopped by SIGINT
        (Ctrl-C) or SIGTERM (:class:`~pfpeople.output.RunInterrupted`, a ``KeyboardInterrupt``) ends with
        ``status = "interrupted"``. Either way the frames processed so far are kept (``frames`` in ``run.json``
        is the number on disk), the result bag is closed (indexed), and the exception re-raised. Driver
        messages that made no frame are counted in ``run.json`` ``skipped_frames`` by reason
        (``clock_jump``: an outlier stamp; ``non_monotonic``: a stamp not after the previous one).
        Returns the summary and (with ``keep=True``) every :class:`FrameResult`.
        ``bag_out`` is a ROS 1 ``.bag`` or a rosbag2 folder (``bag_format`` "ros1", "mcap" or "sqlite3"; default
        from the path, see :mod:`pfpeople.bag.writer`), checked before anything runs; ``overwrite`` also replaces
        an existing one.
        """
        with interrupt_signals():
            return self._run(
                bag,
                out_dir,
                max_frames=max_frames,
                progress=progress,
                overwrite=overwrite,
                metadata=metadata,
                bag_out=bag_out,
                keep=keep,
                bag_format=bag_format,
            )

    def _run(
        self,
        bag: BagSource,
        out_dir: str | Path | None,
        *,
        max_frames: int | None,
        progress: bool,
        overwrite: bool,
        metadata: Mapping[str, Any] | None,
        bag_out: str | Path | None,
        keep: bool,
        bag_format: str | None,
    ) -> tuple[RunSummary, list[FrameResult]]:
        _check_max_frames(max_frames)
        if bag_out is not None:
            from pfpeople.bag.writer import check_bag_out

            check_bag_out(bag_out, bag_format, overwrite=overwrite)
        self.prepare(bag)
        names = [d.name for d in self.config.detectors]
        writer = None
        if out_dir is not None:
            meta = {
                "config": self.config.to_dict(),
                "grid_frame": self.grid_frame,
                "frames_in_grid": {k: [p.x, p.y, p.yaw] for k, p in self.frame_mounts.items()},
                "detector_models": [dataclasses.asdict(m) for m in self.models],
                "provenance": {"bag": [str(p) for p in bag.paths], "bag_topics": bag.topics, **dict(metadata or {})},
            }
            writer = RunWriter(out_dir, spec=self.spec, detector_names=names, metadata=meta, overwrite=overwrite)
        results = self.frames(bag, max_frames=max_frames)
        bag_writer = None
        bar = None
        kept: list[FrameResult] = []
        status, error = "complete", None
        try:  # from here on, whatever stops the run is recorded in run.json and the frames written stay valid
            if bag_out is not None:
                from pfpeople.bag.writer import ResultBagWriter

                bag_writer = ResultBagWriter(
                    bag_out,
                    spec=self.spec,
                    frame_id=self.grid_frame,
                    detector_names=names,
                    bag_format=bag_format,
                    overwrite=overwrite,
                )
            if progress:
                from tqdm import tqdm

                total = bag.message_counts.get(self.config.driver)
                bar = tqdm(total=total if max_frames is None or total is None else min(total, max_frames), unit="frame")
            for r in results:
                f = r.frame
                with deferred_signals():  # a frame goes to every output or to none
                    if writer is not None:
                        writer.write_frame(
                            frame=f.index,
                            driver_index=f.driver.index,
                            stamp_ns=f.stamp_ns,
                            bag_time_ns=f.bag_time_ns,
                            dt_s=r.dt,
                            odometry=None if r.odometry is None else (r.odometry.v, r.odometry.omega),
                            forced=f.forced,
                            belief=r.belief,
                            people=r.people,
                            people_size=r.people_size,
                            people_probability=r.people_probability,
                            detections=r.detections,
                            tracks=None if r.tracks is None else track_rows(f.index, f.stamp_ns, r.tracks),
                            static=r.static,
                        )
                    if bag_writer is not None:
                        bag_writer.write(
                            f.bag_time_ns, f.stamp_ns, r.belief, r.people, r.detections, getattr(r, "tracks", None)
                        )
                if keep:
                    kept.append(r)
                if bar is not None:
                    bar.update(1)
        except KeyboardInterrupt as exc:  # SIGINT or SIGTERM (RunInterrupted): recorded, no traceback needed
            status, error = "interrupted", str(exc) or "interrupted by SIGINT"
            self.summary.error = error
            log.debug("run interrupted after %d frames: %s", self.summary.frames, error)
            raise
        except BaseException as exc:
            status, error = "failed", f"{type(exc).__name__}: {exc}"
            self.summary.error = error
            log.error("run stopped after %d frames: %s", self.summary.frames, error)
            raise
        finally:
            with deferred_signals():  # a second signal waits until every file is closed
                try:
                    results.close()  # ends the frame generator now, so the summary has its elapsed time and sync stats
                    if bar is not None:
                        bar.close()
                    if bag_writer is not None:
                        bag_writer.close()
                finally:
                    if writer is not None:
                        skipped = {
                            reason: n
                            for reason in ("clock_jump", "non_monotonic")
                            if (n := self.summary.sync.get(reason, {}).get(self.config.driver, 0))
                        }
                        writer.close(status=status, error=error, stats=self.summary.as_dict(), skipped_frames=skipped)
        return self.summary, kept
