"""Detector adapters: one per detector kind, from a frame's input messages to person positions.

An adapter owns one configured detector of a run (:class:`pfpeople.config.DetectorConfig`): it builds
the detector object, knows which message types its topic must carry, converts the messages assigned to a
frame, runs the detector and maps the positions from the detector's frame into the grid frame by the 2-D
mount ``T`` (the detector frame's pose in the grid frame, from TF): ``p_grid = T p_sensor``.

========  ===============================  ===================================================================
kind      adapter                          input
========  ===============================  ===================================================================
leg       :class:`LegAdapter`              ``sensor_msgs/LaserScan`` -> :class:`pfpeople.detect.LegDetector`
boosted   :class:`BoostedAdapter`          ``sensor_msgs/LaserScan`` -> ``BoostedSegmentDetector``
learned   :class:`LearnedAdapter`          ``sensor_msgs/LaserScan`` -> ``LearnedPeopleDetector`` (needs the ego-motion)
motion    :class:`MotionAdapter`           ``sensor_msgs/LaserScan`` -> ``MotionDetector`` (needs the ego-motion)
hog       :class:`HogAdapter`              ``sensor_msgs/(Compressed)Image`` -> ``HogCameraDetector`` (which
                                           places its positions in the grid frame itself, given ``mounting``)
topic     :class:`TopicAdapter`            positions read from detection messages (PoseArray, ...)
========  ===============================  ===================================================================

:data:`ADAPTERS` maps each kind to its adapter class; :class:`pfpeople.pipeline.runner.Pipeline` looks kinds up
there (or in the ``adapters`` mapping it is given), so a kind is added or replaced without touching the
pipeline. An adapter class is called as ``cls(config, mount, detector)`` (``detector``: a ready detector
object to use instead of building one, or None) and needs the members of :class:`DetectorAdapter`.
The pipeline reads ``input_types`` and ``laser`` from the factory itself before building any adapter (to
check the topics and fill in a laser's field of view), so a factory that is not a class carries them as
attributes (default: any type, not a laser).

Ego-motion: an adapter whose class sets ``uses_ego_motion = True`` (a detector with a memory of earlier scans,
aligned by the robot's motion) is called as ``detect(msgs, motion=SensorMotion(...))``: the motion of its sensor
frame since the previous frame (:class:`SensorMotion`), known before any detector runs (the pipeline's ego-motion
stage, :mod:`pfpeople.pipeline.ego_stage`). Other adapters are called as ``detect(msgs)``.

Bad data versus bugs: a message that cannot be used raises
:class:`~pfpeople.io.bag.reader.MessageDataError` (raised by the message converters of
:mod:`pfpeople.io.bag.reader`; :class:`EmptyInputError` for a LaserScan without beams). The pipeline counts
such a frame as **no data** for the detector. Any other exception, a ``ValueError`` or ``ZeroDivisionError``
from inside a detector included, is a bug and ends the run.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from gridbridge.params import DetectorModel
from pfpeople.config import DetectorConfig
from pfpeople.detect.coverage import frame_view, scan_sector
from pfpeople.detect.settings import kwargs_from_table
from pfpeople.detect.spacing import detector_scan
from pfpeople.io.bag.reader import (
    IMAGE_TYPES,
    LASER_TYPES,
    BadScanError,
    BagMessage,
    MessageDataError,
    image_from_msg,
    laser_from_msg,
    positions_from_msg,
)
from pfpeople.sensors import LaserScan, Pose2D

__all__ = [
    "ADAPTERS",
    "AdapterFactory",
    "BoostedAdapter",
    "Detections",
    "Detector",
    "DetectorAdapter",
    "EmptyInputError",
    "HogAdapter",
    "LearnedAdapter",
    "LegAdapter",
    "MotionAdapter",
    "SensorMotion",
    "TopicAdapter",
    "build_detector",
    "make_adapter",
    "model_for",
    "read_scan",
]


class Detector(Protocol):
    """What the pipeline needs of a detector."""

    model: DetectorModel

    def detect(self, data: Any, /) -> NDArray[np.float64]: ...


class EmptyInputError(MessageDataError):
    """A well-formed input message without any measurement (a LaserScan with no beams).

    Parameters
    ----------
    topic : str
        The message's topic.
    stamp_ns : int
        The message's stamp (ns).
    """

    def __init__(self, topic: str, stamp_ns: int) -> None:
        super().__init__(f"topic {topic!r}: empty LaserScan (no beams) at {stamp_ns} ns")
        self.topic = topic
        self.stamp_ns = stamp_ns


@dataclass(frozen=True, eq=False)
class Detections:
    """One detector's output in one frame.

    Attributes
    ----------
    sensor : ndarray, shape (M, 2)
        Positions (m) as the detector gave them: in the detector's frame (for a self-mounted detector, such
        as HOG, already in the grid frame).
    grid : ndarray, shape (M, 2)
        The same positions (m) in the grid frame.
    scan : LaserScan or None
        The converted LaserScan of a laser detector (the static-clutter map and scan matching use it).
    support_sensor, support : ndarray, shape (S, 2)
        Weaker evidence than a detection (m; detector frame, grid frame): positions that may keep a person the
        tracker already follows but never start one. The laser detectors give their unpaired single legs
        (:func:`pfpeople.detect.legs.people_and_single_legs`); empty for other detectors.
    field_of_view : tuple of float or None
        ``(fov_min, fov_max)`` (rad, detector frame) the detector covered in this frame: a laser detector's configured
        field of view, or the part of it its scan covered (:func:`pfpeople.detect.coverage.frame_view`); None for
        detectors whose view does not follow their input.
    ppv : ndarray, shape (M,), or None
        Each detection's own PPV, from its score (a detector calibrated by score, :mod:`pfpeople.detect.score_ppv`);
        None: the detector model's PPV holds for every detection.
    """

    sensor: NDArray[np.float64]
    grid: NDArray[np.float64]
    scan: LaserScan | None = None
    support_sensor: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    support: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    field_of_view: tuple[float, float] | None = None
    ppv: NDArray[np.float64] | None = None

    @property
    def fused(self) -> NDArray[np.float64]:
        """The filters' entry (grid frame): ``grid`` ``(M, 2)``, or ``(M, 3)`` with each detection's :attr:`ppv`
        (:func:`gridbridge.measurement.split_detections`)."""
        return self.grid if self.ppv is None else np.column_stack([self.grid, self.ppv])


@dataclass(frozen=True, kw_only=True)
class SensorMotion:
    """The motion of a detector's sensor frame into one frame, for the adapters with ``uses_ego_motion = True``.

    Attributes
    ----------
    ego : Pose2D or None
        The sensor frame at this frame's stamp expressed in the sensor frame at the previous frame's stamp (m, rad:
        ``p_prev = ego.apply(p_now)``), from odometry or the driving laser's scan matching (the grid frame's motion
        ``E`` moved to the sensor by its mount ``T``: ``T^-1 E T``); None when unknown (no odometry, a failed scan
        match, the first frame).
    dt : float
        Time since the previous frame (s; 0.1 on the first frame and after a restart).
    stamp_ns : int
        The frame's stamp (ns).
    restarted : bool
        True on the first frame of a run and where the run restarted (a gap, an odometry jump): nothing before
        this frame is to be remembered.
    """

    ego: Pose2D | None
    dt: float
    stamp_ns: int
    restarted: bool = False


class DetectorAdapter(Protocol):
    """One configured detector of a run, as the pipeline uses it.

    Attributes
    ----------
    config : DetectorConfig
        The detector's configuration (with the field of view of its LaserScan filled in, for laser kinds).
    mount : Pose2D
        The detector frame's pose in the grid frame (m, rad).
    model : DetectorModel
        The detector's grid model (named after the detector, with its mount).
    detector : Detector or None
        The detector object (None when positions are read from the bag).
    input_types : tuple of str or None
        Message types the detector's topic must carry (None: any).
    laser : bool
        True when the input is a LaserScan (its field of view and range size the model and the default
        grid; the static-clutter map works on it).
    nobody_when_missing : bool
        True when a frame without an input message means the detector saw nobody (empty positions) rather
        than having no data.
    uses_ego_motion : bool, optional
        True: :meth:`detect` is called with the keyword ``motion`` (:class:`SensorMotion`); default False.
    """

    config: DetectorConfig
    mount: Pose2D
    model: DetectorModel
    detector: Detector | None
    input_types: tuple[str, ...] | None
    laser: bool
    nobody_when_missing: bool

    def check_first(self, msg: BagMessage) -> None:
        """Check the topic's first message before the run (raise ``ValueError`` if it can never work)."""
        ...

    def detect(self, msgs: Sequence[BagMessage]) -> Detections:
        """Positions from the messages assigned to one frame (at least one); an adapter with ``uses_ego_motion``
        takes ``motion: SensorMotion`` as a keyword too.

        Raises
        ------
        MessageDataError
            If the messages hold no usable data (the frame has no data for this detector).
        """
        ...


#: How an adapter is made: ``factory(config, mount, detector)``; adapter classes are such factories.
AdapterFactory = Callable[[DetectorConfig, Pose2D, Detector | None], DetectorAdapter]


def model_for(cfg: DetectorConfig, mount: Pose2D, base: DetectorModel | None) -> DetectorModel:
    """The model of ``cfg``: ``base`` (default :class:`DetectorModel`) overridden by ``cfg.model``, named after
    the detector and mounted at ``mount`` unless ``cfg.model`` gives the mount."""
    return cfg.model.applied(base, name=cfg.name, mount=mount)


def _import_detector_class(kind: str, cls_name: str) -> type:
    try:
        module = importlib.import_module("pfpeople.detect")
        return getattr(module, cls_name)
    except (ImportError, AttributeError) as exc:
        raise ValueError(
            f"detector kind {kind!r} needs pfpeople.detect.{cls_name}, which cannot be imported: {exc}"
        ) from None


class BuiltinAdapter:
    """Shared part of the adapters of the built-in detectors (:mod:`pfpeople.detect`).

    Parameters
    ----------
    config : DetectorConfig
        The detector's configuration; ``config.params`` are the detector's constructor arguments (checked
        against its annotations, :mod:`pfpeople.detect.settings`), ``config.model`` overrides its model.
    mount : Pose2D
        The detector frame's pose in the grid frame.
    detector : Detector, optional
        A detector to use instead of building one; its ``model`` is used as given (name and mount included).

    Raises
    ------
    ValueError
        If ``[detectors.params]`` do not fit the constructor (naming the detector and the parameter).
    """

    #: Class name in :mod:`pfpeople.detect` (imported when the first detector is built).
    detector_class = ""
    input_types: tuple[str, ...] | None = None
    laser = False
    nobody_when_missing = False
    uses_ego_motion = False
    #: True when the detector maps its positions into the grid frame itself (it is given ``mounting``).
    self_mounted = False

    def __init__(self, config: DetectorConfig, mount: Pose2D, detector: Detector | None = None) -> None:
        self.config = config
        self.mount = mount
        self.detector: Detector | None = detector if detector is not None else self.build(config, mount)
        self.model: DetectorModel = self.detector.model

    @classmethod
    def build(cls, config: DetectorConfig, mount: Pose2D) -> Detector:
        """The detector of ``config`` (built once: the boosted detector loads its model file here)."""
        detector_cls = _import_detector_class(config.kind, cls.detector_class)
        try:
            kwargs = kwargs_from_table(detector_cls, config.params)
            if cls.self_mounted:
                kwargs.setdefault("mounting", mount)
            det: Detector = detector_cls(**kwargs)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"detector {config.name!r} ({config.kind}): {exc}") from None
        det.model = model_for(config, mount, det.model)
        return det

    def check_first(self, msg: BagMessage) -> None:
        """Nothing to check before the run (the converters check every message)."""

    def read(self, msg: BagMessage) -> Any:
        """The detector's input from one message (raises :class:`MessageDataError` for unusable data)."""
        raise NotImplementedError

    def detect(self, msgs: Sequence[BagMessage]) -> Detections:
        """Run the detector on the frame's (first) message; see :meth:`DetectorAdapter.detect`.

        A detector with ``detect_with_ppv(data) -> (positions, ppv or None)`` (calibrated by score) gives each
        detection its own PPV, unless ``[detectors.model] ppv`` is configured (then that one PPV holds for all).
        """
        data = self.read(msgs[0])
        assert self.detector is not None
        scan = data if isinstance(data, LaserScan) else None
        given = self.detector_input(data)
        with_ppv = getattr(self.detector, "detect_with_ppv", None) if self.config.model.ppv is None else None
        if with_ppv is not None:
            people, ppv = with_ppv(given)
            return replace(self.located(people, scan=scan), ppv=ppv)
        with_singles = getattr(self.detector, "detect_with_singles", None)
        if with_singles is None:
            return self.located(self.detector.detect(given), scan=scan)
        people, singles = with_singles(given)
        return self.located(people, scan=scan, support=singles)

    def detector_input(self, data: Any) -> Any:
        """What the detector gets of the message's data (by default the data itself)."""
        return data

    def located(self, positions: Any, *, scan: LaserScan | None = None, support: Any = None) -> Detections:
        """``positions`` ``(M, 2)`` and ``support`` ``(S, 2)`` (m) as the detector gave them, with their
        grid-frame copies."""
        pts = self._to_grid(positions)
        sup = self._to_grid(np.zeros((0, 2)) if support is None else support)
        return Detections(pts[0], pts[1], scan, support_sensor=sup[0], support=sup[1])

    def _to_grid(self, positions: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        pts = np.asarray(positions, dtype=float).reshape(-1, 2)
        if not len(pts):
            pts = np.zeros((0, 2))
            return pts, pts
        return pts, pts if self.self_mounted else self.mount.apply(pts)


#: The latest (message, LaserScan) read: the detectors of one laser (and the ego-motion stage's scan matcher) get
#: the same scan object, so they share its segmentation (:func:`pfpeople.detect.segments.scan_segments`).
_LATEST_SCAN: tuple[BagMessage, LaserScan] | None = None


def read_scan(msg: BagMessage) -> LaserScan:
    """The :class:`LaserScan` of ``msg``, converted once for every reader of the same message object.

    Raises
    ------
    EmptyInputError
        If the scan has no beams.
    MessageDataError
        If the message is not a usable LaserScan (:func:`pfpeople.io.bag.reader.laser_from_msg`).
    """
    global _LATEST_SCAN
    latest = _LATEST_SCAN
    if latest is not None and latest[0] is msg:  # another reader of the same laser read this message
        return latest[1]
    scan = laser_from_msg(msg.msg, stamp_ns=msg.stamp_ns, frame_id=msg.frame_id, topic=msg.topic)
    if scan.ranges.size == 0:
        raise EmptyInputError(msg.topic, msg.stamp_ns)
    _LATEST_SCAN = (msg, scan)
    return scan


class LaserAdapter(BuiltinAdapter):
    """A detector on a ``sensor_msgs/LaserScan`` (positions in the laser's frame).

    The detector gets a scan denser than the spacing the laser detectors are built for thinned to it
    (:func:`pfpeople.detect.spacing.detector_scan`); the static-clutter map and the rest of the run get every beam.
    """

    input_types: tuple[str, ...] | None = LASER_TYPES
    laser = True

    def __init__(self, config: DetectorConfig, mount: Pose2D, detector: Detector | None = None) -> None:
        super().__init__(config, mount, detector)
        #: The configured field of view ``(fov_min, fov_max)`` (rad); a frame's scan may cover less of it.
        self.view = (self.model.fov_min, self.model.fov_max)

    def detect(self, msgs: Sequence[BagMessage]) -> Detections:
        """:meth:`BuiltinAdapter.detect`, with the model's field of view set to the part of the configured one the
        frame's scan covers (:func:`pfpeople.detect.coverage.frame_view`; also in the result's ``field_of_view``).

        Raises
        ------
        BadScanError
            Reason ``"sector"``: the scan covers nothing of the field of view (no data in the frame).
        """
        scan = self.read(msgs[0])
        view = frame_view(self.view, scan) or self.view
        if view[1] <= view[0]:
            lo, hi = scan_sector(scan)
            raise BadScanError(
                f"topic {msgs[0].topic!r}: LaserScan at stamp {scan.stamp_ns} ns covers {math.degrees(lo):.1f} .. "
                f"{math.degrees(hi):.1f} deg ({scan.ranges.size} beam(s)), nothing of the field of view "
                f"{math.degrees(self.view[0]):.1f} .. {math.degrees(self.view[1]):.1f} deg",
                "sector",
            )
        if view != (self.model.fov_min, self.model.fov_max):
            self.model = replace(self.model, fov_min=view[0], fov_max=view[1])
        return replace(super().detect(msgs), field_of_view=view)

    def detector_input(self, data: Any) -> Any:
        """The scan thinned for the detector (:func:`pfpeople.detect.spacing.detector_scan`)."""
        return detector_scan(data)

    def read(self, msg: BagMessage) -> LaserScan:
        """The :class:`LaserScan` of ``msg``.

        Raises
        ------
        EmptyInputError
            If the scan has no beams.
        MessageDataError
            If the message is not a usable LaserScan (:func:`pfpeople.io.bag.reader.laser_from_msg`).
        """
        return read_scan(msg)


class LegAdapter(LaserAdapter):
    """``kind = "leg"``: :class:`pfpeople.detect.LegDetector` (geometric legs paired into people)."""

    detector_class = "LegDetector"


class BoostedAdapter(LaserAdapter):
    """``kind = "boosted"``: :class:`pfpeople.detect.BoostedSegmentDetector` (boosted segment classifier)."""

    detector_class = "BoostedSegmentDetector"


class SingleLegAdapter(LaserAdapter):
    """``kind = "single-legs"``: :class:`pfpeople.detect.SingleLegDetector` (unpaired single legs as people)."""

    detector_class = "SingleLegDetector"


class TemporalLaserAdapter(LaserAdapter):
    """A LaserScan detector with a memory of earlier scans (``observe_motion``, ``reset``): each frame it is told
    its laser's motion since the previous frame (:class:`SensorMotion`; forgotten on a restart) before it runs."""

    uses_ego_motion = True

    def detect(self, msgs: Sequence[BagMessage], *, motion: SensorMotion | None = None) -> Detections:
        """:meth:`LaserAdapter.detect` after giving the detector ``motion`` (None or a restart: unknown)."""
        known = None if motion is None or motion.restarted else motion.ego
        self.detector.observe_motion(known)  # type: ignore[union-attr]
        return super().detect(msgs)


class LearnedAdapter(TemporalLaserAdapter):
    """``kind = "learned"``: :class:`pfpeople.detect.LearnedPeopleDetector` (a learned whole-scan detector)."""

    detector_class = "LearnedPeopleDetector"


class MotionAdapter(TemporalLaserAdapter):
    """``kind = "motion"``: :class:`pfpeople.detect.MotionDetector` (returns in space seen free before)."""

    detector_class = "MotionDetector"


class HogAdapter(BuiltinAdapter):
    """``kind = "hog"``: :class:`pfpeople.detect.HogCameraDetector` on a (compressed) image.

    The detector is built with ``mounting`` = the camera's mount, so it returns grid-frame positions.
    """

    detector_class = "HogCameraDetector"
    input_types: tuple[str, ...] | None = IMAGE_TYPES
    self_mounted = True

    def read(self, msg: BagMessage) -> Any:
        """The :class:`pfpeople.sensors.CameraImage` of ``msg``.

        Raises
        ------
        MessageDataError
            If the image cannot be decoded, or its size differs from the detector's camera intrinsics.
        """
        image = image_from_msg(msg.msg, msg.msgtype, stamp_ns=msg.stamp_ns, frame_id=msg.frame_id, topic=msg.topic)
        intr = getattr(self.detector, "intrinsics", None)
        if intr is not None and image.pixels.shape[:2] != (intr.height, intr.width):
            raise MessageDataError(
                f"image has shape {image.pixels.shape[:2]} (H, W) but the intrinsics are for "
                f"({intr.height}, {intr.width})"
            )
        return image


class TopicAdapter:
    """``kind = "topic"``: positions read from detection messages (no detector runs).

    All messages assigned to the frame are read (:func:`pfpeople.io.bag.reader.positions_from_msg`); with
    ``assign = "preceding"`` a frame without a message means nobody was detected (such topics typically
    publish only when someone is). The model is ``config.model`` (which gives at least PPV and FNR).

    Parameters
    ----------
    config, mount, detector
        As :class:`BuiltinAdapter`; ``detector``, if given, only supplies the model.
    """

    input_types: tuple[str, ...] | None = None
    laser = False
    uses_ego_motion = False

    def __init__(self, config: DetectorConfig, mount: Pose2D, detector: Detector | None = None) -> None:
        self.config = config
        self.mount = mount
        self.detector: Detector | None = detector
        self.model: DetectorModel = detector.model if detector is not None else model_for(config, mount, None)
        self.nobody_when_missing = config.assign == "preceding"

    def check_first(self, msg: BagMessage) -> None:
        """Fail early, naming the type, if the topic's messages hold no positions."""
        positions_from_msg(msg.msg, topic=msg.topic, msgtype=msg.msgtype)

    def detect(self, msgs: Sequence[BagMessage]) -> Detections:
        """Positions (m, the messages' frame) of every message, mapped into the grid frame."""
        pts = np.concatenate([positions_from_msg(m.msg, topic=m.topic, msgtype=m.msgtype) for m in msgs])
        if not len(pts):
            pts = np.zeros((0, 2))
            return Detections(pts, pts)
        return Detections(pts, self.mount.apply(pts))


#: Detector kind -> adapter class (the default registry).
ADAPTERS: dict[str, AdapterFactory] = {
    "leg": LegAdapter,
    "boosted": BoostedAdapter,
    "single-legs": SingleLegAdapter,
    "learned": LearnedAdapter,
    "motion": MotionAdapter,
    "hog": HogAdapter,
    "topic": TopicAdapter,
}


def adapter_factory(kind: str, registry: Mapping[str, AdapterFactory] | None = None) -> AdapterFactory:
    """The adapter factory of ``kind`` in ``registry`` (default :data:`ADAPTERS`).

    Raises
    ------
    ValueError
        If no adapter is registered for ``kind``.
    """
    reg = ADAPTERS if registry is None else registry
    try:
        return reg[kind]
    except KeyError:
        raise ValueError(f"no detector adapter for kind {kind!r}; registered: {sorted(reg)}") from None


def adapter_attr(factory: AdapterFactory, name: str, default: Any) -> Any:
    """A class attribute of an adapter factory (``input_types``, ``laser``), known before it is called."""
    return getattr(factory, name, default)


def make_adapter(
    cfg: DetectorConfig,
    mount: Pose2D,
    detector: Detector | None = None,
    *,
    registry: Mapping[str, AdapterFactory] | None = None,
) -> DetectorAdapter:
    """The adapter of ``cfg`` (from ``registry``, default :data:`ADAPTERS`) mounted at ``mount``."""
    return adapter_factory(cfg.kind, registry)(cfg, mount, detector)


def build_detector(cfg: DetectorConfig, mount: Pose2D) -> Detector | None:
    """The built-in detector of ``cfg`` with its model overridden by ``cfg.model`` and mounted at ``mount``.

    Returns None for ``kind="topic"`` (no detector object: positions come from the bag). Bad
    ``[detectors.params]`` raise ValueError naming the detector and the parameter.
    """
    return make_adapter(cfg, mount).detector
