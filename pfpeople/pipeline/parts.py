"""The parts of a run, built once its sensors are set up: detectors, ego-motion, clutter maps, filter, tracker.

:func:`build_parts` turns a configuration and its :class:`~pfpeople.pipeline.sensor_setup.SensorSetup` (topics,
mounts, fields of view, grid) into the :class:`RunParts` of a run: the front end (:class:`pfpeople.pipeline.front.
FrontEnd`: ego-motion stage, detectors, static-clutter maps), the back end (:class:`pfpeople.pipeline.back.BackEnd`:
filter, classifier, tracker) and the TF followers the message intake feeds (:mod:`pfpeople.pipeline.mounts`).
Each part can be replaced (:class:`PartFactories`): the detector adapters by kind, ready detector objects by
name, the filter, the odometry integrator.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TypeAlias

from gridbridge.filter import BeliefFilter
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.config import BagConfig, FilterConfig
from pfpeople.detect import segment_kernels as _kernels
from pfpeople.detect.adapters import ADAPTERS, AdapterFactory, Detector, DetectorAdapter, adapter_factory
from pfpeople.io.bag.tf import MountWatch
from pfpeople.perception import clutter_kernels
from pfpeople.perception.odometry import OdometryIntegrator
from pfpeople.perception.scan_matching import LaserEgoMotion
from pfpeople.pipeline.assembly import build_classifier, build_people_tracker
from pfpeople.pipeline.back import BackEnd
from pfpeople.pipeline.clutter_stage import ClutterStage
from pfpeople.pipeline.detection import DetectionStage
from pfpeople.pipeline.ego_stage import EgoMotionStage
from pfpeople.pipeline.front import FrontEnd
from pfpeople.pipeline.mounts import MountTracker
from pfpeople.pipeline.output_frame import OutputFrame
from pfpeople.pipeline.sensor_setup import SensorSetup, check_grid_seen, warn_coarse_lasers, warn_dense_lasers
from pfpeople.pipeline.warm_up import warm_up_back_end
from pfpeople.run_state import RunSummary, WarnOnce
from pfpeople.sensors import Pose2D
from pfpeople.track.stopped_people import StoppedPeople

__all__ = ["OdometryFactory", "PartFactories", "RunParts", "build_parts", "default_odometry", "make_filter"]

#: ``factory(config, base_to_grid, summary, warn)`` -> the run's
#: :class:`~pfpeople.perception.odometry.OdometryIntegrator`.
OdometryFactory: TypeAlias = Callable[[BagConfig, Pose2D | None, RunSummary, WarnOnce], OdometryIntegrator]
#: ``factory(spec, models)`` -> the run's filter.
FilterFactory: TypeAlias = Callable[[GridSpec, Sequence[DetectorModel]], BeliefFilter]


def make_filter(config: FilterConfig, spec: GridSpec, detectors: Sequence[DetectorModel]) -> BeliefFilter:
    """The run's filter (:func:`pfpeople.pipeline.assembly.build_filter`)."""
    from pfpeople.pipeline.assembly import build_filter

    return build_filter(config, spec, detectors)


def default_odometry(
    config: BagConfig, base_to_grid: Pose2D | None, summary: RunSummary, warn: WarnOnce
) -> OdometryIntegrator:
    """The run's :class:`~pfpeople.perception.odometry.OdometryIntegrator`: the ``odometry`` topic, else laser
    odometry if ``[clutter] laser_odometry``."""
    return OdometryIntegrator(
        config.odometry,
        base_to_grid,
        laser_odometry=config.clutter.laser_odometry,
        base_frame=config.base_frame,
        summary=summary,
        warn=warn,
    )


@dataclass(frozen=True)
class PartFactories:
    """Replacements of a run's parts (each None: the built-in one).

    Attributes
    ----------
    detectors : mapping of str to Detector
        Ready detector objects by detector name; their ``model`` is used as given (name and mount included).
    adapters : mapping of str to AdapterFactory
        Detector kind -> adapter factory, added to or replacing :data:`pfpeople.detect.adapters.ADAPTERS`.
    filter : callable or None
        ``(spec, models) -> filter`` replacing :func:`make_filter` (such a filter is not warmed up: it may share
        state with its copies).
    odometry : callable or None
        ``(config, base_to_grid, summary, warn) -> OdometryIntegrator`` replacing :func:`default_odometry`.
    """

    detectors: Mapping[str, Detector] = field(default_factory=dict)
    adapters: Mapping[str, AdapterFactory] = field(default_factory=dict)
    filter: FilterFactory | None = None
    odometry: OdometryFactory | None = None

    @property
    def registry(self) -> dict[str, AdapterFactory]:
        """The adapter factories by kind."""
        return {**ADAPTERS, **dict(self.adapters)}

    @property
    def custom_front(self) -> bool:
        """Whether a front-end part is replaced (its state belongs where the caller can see it)."""
        return bool(self.detectors or self.adapters or self.odometry)


@dataclass(frozen=True, eq=False)
class RunParts:
    """A run's parts (see the module docstring).

    Attributes
    ----------
    setup : SensorSetup
        Frames, mounts, detectors' configurations and grid.
    adapters : list of DetectorAdapter
        The detectors, in the configuration's order (the front end's and the back end's).
    models : list of DetectorModel
        Their models as built (mounted as read before the run).
    front : FrontEnd
        Ego-motion, detectors, static-clutter maps.
    back : BackEnd
        Filter, classifier, tracker.
    mounts : MountTracker
        The mounts followed over TF (fed by the message intake).
    mount_watch : MountWatch
        The TF edges of the mounts, checked for changes.
    scan_matched : bool
        Whether the run's ego-motion comes from scan matching the driving laser (no odometry topic, ``[clutter]
        laser_odometry``, a static-clutter map on the driving laser).
    output : OutputFrame or None
        The output frame (``[output] frame`` other than the grid frame; None: the results stay in the grid frame).
    """

    setup: SensorSetup
    adapters: list[DetectorAdapter]
    models: list[DetectorModel]
    front: FrontEnd
    back: BackEnd
    mounts: MountTracker
    mount_watch: MountWatch
    scan_matched: bool
    output: OutputFrame | None = None


def build_adapters(config: BagConfig, setup: SensorSetup, parts: PartFactories) -> list[DetectorAdapter]:
    """The detector adapters of ``setup``'s detectors, each checked on its topic's first message."""
    registry = parts.registry
    adapters = []
    for d, mount in zip(setup.detectors, setup.mounts, strict=True):
        adapter = adapter_factory(d.kind, registry)(d, mount, parts.detectors.get(d.name))
        if d.topic in setup.first:  # fails early, naming the type, if the topic can never work
            adapter.check_first(setup.first[d.topic])
        adapters.append(adapter)
    return adapters


def build_parts(
    config: BagConfig, setup: SensorSetup, *, parts: PartFactories, summary: RunSummary, warn: WarnOnce
) -> RunParts:
    """The run's parts (see the module docstring); the compiled kernels of the frames are loaded here.

    Raises
    ------
    ValueError
        If no detector sees a cell of the grid (:func:`pfpeople.pipeline.sensor_setup.check_grid_seen`), or a
        detector's settings are bad (naming it).
    """
    _kernels.warm_up()  # the front end's compiled kernels load here, not in the first frame
    clutter_kernels.warm_up()
    c = config
    adapters = build_adapters(c, setup, parts)
    models = [a.model for a in adapters]
    check_grid_seen(setup.spec, models, configured=c.grid.fixed is not None)
    warn_coarse_lasers(adapters, setup.first)
    warn_dense_lasers(adapters, setup.first)
    filt = (parts.filter or (lambda spec, m: make_filter(c.filter, spec, m)))(setup.spec, models)
    classifier = build_classifier(c.classifier)
    if parts.filter is None:  # a caller's filter may share state with its copies: not warmed up
        warm_up_back_end(filt, classifier, setup.spec, models)  # copies: the run is unchanged
    clutter = ClutterStage(c, adapters, summary)
    mounts = MountTracker(setup.tf, setup.grid_frame, adapters, setup.first, summary, warn)
    front = _front(c, setup, parts, adapters, clutter, mounts, summary, warn)
    tracker = build_people_tracker(c.tracking, classifier)
    back = BackEnd(
        adapters,
        spec=setup.spec,
        filter=filt,
        classifier=classifier,
        tracker=tracker,
        stopped=StoppedPeople() if tracker is not None and clutter.active else None,
        summary=summary,
        warn=warn,
    )
    watch = MountWatch([e for f in setup.frame_mounts for e in setup.tf.edges(setup.grid_frame, f)])
    matched = not c.odometry and c.clutter.laser_odometry and front.ego.matcher is not None
    return RunParts(setup, adapters, models, front, back, mounts, watch, matched, front.output)


def _front(
    c: BagConfig,
    setup: SensorSetup,
    parts: PartFactories,
    adapters: list[DetectorAdapter],
    clutter: ClutterStage,
    mounts: MountTracker,
    summary: RunSummary,
    warn: WarnOnce,
) -> FrontEnd:
    """The front end: the ego-motion stage (scan matching the driving laser where it has a static-clutter map),
    the detectors and the static-clutter maps."""
    detection = DetectionStage(adapters, driver=c.driver, mounts=mounts, summary=summary, warn=warn)
    integrator = (parts.odometry or default_odometry)(c, setup.base_to_grid, summary, warn)
    matcher = LaserEgoMotion() if c.driver in clutter.suppressors else None
    ego = EgoMotionStage(integrator, matcher=matcher, driver_mount=detection.driver_mount)
    output = None
    if c.output.frame and c.output.frame != setup.grid_frame:
        output = OutputFrame(
            c.output.frame,
            tf=setup.tf,
            grid_frame=setup.grid_frame,
            odometry_topic=c.odometry,
            summary=summary,
            warn=warn,
        )
    return FrontEnd(ego, detection, clutter, mounts, output)
