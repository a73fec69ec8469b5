"""The bag pipeline: bag -> synchronised frames -> detectors -> filter -> classification -> outputs.

:class:`Pipeline` orchestrates parts that live in their own modules, each replaceable through its constructor:

- sensor setup (topics, TF mounts, each laser's field of view, the default grid): :mod:`pfpeople.pipeline.sensor_setup`,
  argument ``sensor_setup``;
- one adapter per detector kind (leg, boosted, hog, topic) in the registry :data:`pfpeople.detect.adapters.ADAPTERS`,
  argument ``adapters`` (add or replace a kind);
- frame timing and ego-motion: :class:`pfpeople.perception.odometry.OdometryIntegrator`, argument ``odometry_factory``;
- static clutter and laser odometry: :class:`pfpeople.perception.clutter_stage.ClutterStage` (``[clutter]``);
- filter, classifier, tracker: :mod:`pfpeople.pipeline.assembly`, :mod:`pfpeople.track`, argument ``filter_factory``;
- outputs: :mod:`pfpeople.io.sinks` (run directory, result bag, progress bar), arguments ``sink_factory`` and
  ``sinks`` (extra sinks).

Per frame (driven by the config's ``driver`` topic, see :mod:`pfpeople.io.bag.sync`):

1. Inputs: each detector's input message is chosen by its sync policy; a detector whose input is missing
   (nothing within the tolerance), empty (a LaserScan with no beams) or unusable (the converters raise
   :class:`~pfpeople.io.bag.reader.MessageDataError`) has **no data** in the frame: its entry is ``None`` and the
   filter treats it as covering no cell (counted and logged once). A ``topic`` detector with
   ``assign = "preceding"`` and no message in the frame detected nobody (an empty array): such topics
   typically publish only when someone is detected. Any other exception from a detector is a bug: it ends the
   run (``status = "failed"``).
2. Detections: the detector adapters run the built-in detectors (``leg``, ``boosted``, ``hog``) on the
   converted message or read positions from ``topic`` messages, and map them from the detector's frame to the
   grid frame by the 2-D TF mount, which is also written into the detector's ``DetectorModel`` (``mount_x``,
   ``mount_y``, ``mount_yaw``) so its field of view is placed correctly.
3. Ego-motion (:mod:`pfpeople.perception.odometry`): the odometry pose of the grid frame, interpolated to the frame
stamp,
   gives the grid frame's body velocity ``(v, vy, omega)`` over ``dt`` (``vy``: the sideways motion of a laser
   mounted off the rotation axis); without odometry, the driving laser's scan matching can (``[clutter]
   laser_odometry``); otherwise the robot is taken as standing.
4. Static clutter (:mod:`pfpeople.perception.clutter_stage`): laser detections the static-clutter map calls static are
kept
   from the filter.
5. Filter step (``GridFilter`` or ``ParticleFilter``, same ``step`` signature), the classification of the belief,
   the tracker and the people it confirms (:mod:`pfpeople.track.reported_people`, ``[tracking] people``), and one frame
   to every sink.

The first frame uses ``dt = 0.1 s`` (:data:`FIRST_DT_S`); a gap between frames longer than :data:`MAX_GAP_S`
or an odometry jump (:func:`pfpeople.perception.odometry.is_odometry_jump`) restarts the filter, the clutter maps and
the tracker (counted).

The mounts are read before the run and followed along it (:mod:`pfpeople.pipeline.mounts`): each frame's detectors are
placed with their frame's TF mount at the frame's stamp (latest transform at or before it), and a message in another
frame than its topic's first is placed by its own frame's mount (counted). The TF edges of the mounts are checked
too (:class:`pfpeople.io.bag.tf.MountWatch`): a mount that moves (a panning laser) is warned once per edge and counted
(``stats.mount_changes``).

Steps 1-4 are the *front end* of a frame (:meth:`Pipeline._front`): they need only the frame and their own state.
Step 5 is the *back end* (:meth:`Pipeline._back`). With two or more cores the front end runs in a second process,
a few frames ahead of the back end (:mod:`pfpeople.pipeline.front_end`, ``Pipeline(front_process=...)``): the same
results, more frames per second.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable, Generator, Iterator, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import NDArray

from gridbridge.classifiers import classify_frame
from gridbridge.filter import BeliefFilter
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from gridbridge.validation import check_int, finite_rows
from pfpeople.config import BagConfig, FilterConfig, run_topics
from pfpeople.detect import segment_kernels as _kernels
from pfpeople.detect.adapters import (
    ADAPTERS,
    AdapterFactory,
    Detections,
    Detector,
    DetectorAdapter,
    EmptyInputError,
    adapter_attr,
    adapter_factory,
    build_detector,
)
from pfpeople.io.bag.reader import BadScanError, BagMessage, BagSource, MessageDataError
from pfpeople.io.bag.sync import Frame, FrameAssembler
from pfpeople.io.bag.tf import MountWatch, TfBuffer
from pfpeople.io.run_dir import check_output_paths, deferred_signals, interrupt_signals
from pfpeople.io.sinks import RunInfo, RunOutcome, Sink, close_sinks, open_sinks, standard_sinks
from pfpeople.perception import clutter_kernels
from pfpeople.perception.clutter_stage import ClutterStage
from pfpeople.perception.odometry import FIRST_DT_S, MAX_GAP_S, OdometryIntegrator, odometry_between
from pfpeople.pipeline.assembly import build_classifier, build_people_tracker
from pfpeople.pipeline.blas import blas_threads_in_use, limit_blas, resolve_blas_threads
from pfpeople.pipeline.front_end import FrontProcess, FrontResult, front_process_available
from pfpeople.pipeline.mounts import MountTracker
from pfpeople.pipeline.sensor_setup import (
    TF_PRELOAD_S,
    SensorSetup,
    SetupSensors,
    check_grid_seen,
    setup_sensors,
    warn_coarse_lasers,
    warn_dense_lasers,
)
from pfpeople.pipeline.views import follow_views
from pfpeople.pipeline.warm_up import warm_up_back_end
from pfpeople.run_state import FrameResult, RunSummary, WarnOnce, count
from pfpeople.sensors import LaserScan, Pose2D
from pfpeople.track.reported_people import point_like, support_positions
from pfpeople.track.stopped_people import StoppedPeople

__all__ = [
    "FIRST_DT_S",
    "MAX_GAP_S",
    "TF_PRELOAD_S",
    "Detector",
    "FrameResult",
    "OdometryFactory",
    "Pipeline",
    "RunSummary",
    "SinkFactory",
    "build_detector",
    "make_filter",
    "odometry_between",
]

log = logging.getLogger(__name__)

#: The filter interface the pipeline uses (one Protocol for both filters, :class:`gridbridge.filter.BeliefFilter`).
StepFilter: TypeAlias = BeliefFilter
#: ``factory(config, base_to_grid, summary, warn)`` -> the run's
#: :class:`~pfpeople.perception.odometry.OdometryIntegrator`.
OdometryFactory: TypeAlias = Callable[[BagConfig, Pose2D | None, RunSummary, WarnOnce], OdometryIntegrator]
#: ``factory(out_dir, *, bag_out, bag_format, overwrite, progress, with_input)`` -> sinks
#: (:func:`pfpeople.io.sinks.standard_sinks`).
SinkFactory: TypeAlias = Callable[..., list[Sink]]


def make_filter(config: FilterConfig, spec: GridSpec, detectors: Sequence[DetectorModel]) -> StepFilter:
    """The run's filter (:func:`pfpeople.pipeline.assembly.build_filter`)."""
    from pfpeople.pipeline.assembly import build_filter

    return build_filter(config, spec, detectors)


def default_odometry(
    config: BagConfig, base_to_grid: Pose2D | None, summary: RunSummary, warn: WarnOnce
) -> OdometryIntegrator:
    """The run's :class:`~pfpeople.perception.odometry.OdometryIntegrator`: the ``odometry`` topic, else laser odometry
    if
    ``[clutter] laser_odometry``."""
    return OdometryIntegrator(
        config.odometry,
        base_to_grid,
        laser_odometry=config.clutter.laser_odometry,
        base_frame=config.base_frame,
        summary=summary,
        warn=warn,
    )


def _check_max_frames(max_frames: int | None) -> None:
    if max_frames is not None:
        check_int(max_frames, "max_frames", minimum=0)


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
    adapters : mapping of str to callable, optional
        Detector kind -> adapter factory (``factory(config, mount, detector)``, e.g. an adapter class),
        added to or replacing the entries of :data:`pfpeople.detect.adapters.ADAPTERS` for this pipeline.
    sensor_setup : callable, optional
        Replaces :func:`pfpeople.pipeline.sensor_setup.setup_sensors` (same signature).
    odometry_factory : callable, optional
        ``(config, base_to_grid, summary, warn) -> OdometryIntegrator`` replacing :func:`default_odometry`.
    sink_factory : callable, optional
        Replaces :func:`pfpeople.io.sinks.standard_sinks`: the sinks made from :meth:`run`'s ``out_dir``,
        ``bag_out``, ``bag_format``, ``overwrite`` and ``progress``.
    sinks : sequence of Sink, optional
        Extra sinks every run writes to, after the standard ones.
    front_process : bool or None, optional
        Run the front end of each frame (ego-motion, detectors, static clutter) in a second process, a few frames
        ahead of the back end (filter, classifier, tracker, outputs; :mod:`pfpeople.pipeline.front_end`). Same results,
        more frames per second on two or more cores. None (default): when :func:`pfpeople.pipeline.front_end.
        front_process_available` says it can and no front-end part (``detectors``, ``adapters``,
        ``odometry_factory``) is given: the state of those would be in the child process, out of the caller's
        sight. True: ask for it (one process, with a warning, where it cannot run); False: one process.
    blas_threads : int, optional
        BLAS threads per process while the frames run (:mod:`pfpeople.pipeline.blas`: numpy's and scipy's OpenBLAS
        limited with threadpoolctl, the front-end process included; the libraries' own counts restored after). None
        (default): the environment variable ``PFPEOPLE_BLAS_THREADS``, else 1; 0: no limit. Same results, and
        on a loaded machine no BLAS thread waits for a busy core.

    Raises
    ------
    ValueError
        If ``detectors`` names a detector that is not in the config, or ``blas_threads`` (or
        ``PFPEOPLE_BLAS_THREADS``) is not an integer >= 0.
    """

    def __init__(
        self,
        config: BagConfig,
        *,
        detectors: Mapping[str, Detector] | None = None,
        filter_factory: Callable[[GridSpec, Sequence[DetectorModel]], StepFilter] | None = None,
        adapters: Mapping[str, AdapterFactory] | None = None,
        sensor_setup: SetupSensors | None = None,
        odometry_factory: OdometryFactory | None = None,
        sink_factory: SinkFactory | None = None,
        sinks: Sequence[Sink] = (),
        front_process: bool | None = None,
        blas_threads: int | None = None,
    ) -> None:
        self.config = config
        self.front_process = front_process
        #: BLAS threads per process during the frames (0: no limit;
        #: :func:`pfpeople.pipeline.blas.resolve_blas_threads`).
        self.blas_threads = resolve_blas_threads(blas_threads)
        self._given = dict(detectors or {})
        unknown = set(self._given) - {d.name for d in config.detectors}
        if unknown:
            raise ValueError(f"detectors {sorted(unknown)} are not in the config")
        self._filter_factory = filter_factory
        self.adapter_registry: dict[str, AdapterFactory] = {**ADAPTERS, **dict(adapters or {})}
        self._setup_sensors: SetupSensors = sensor_setup or setup_sensors
        self._odometry_factory: OdometryFactory = odometry_factory or default_odometry
        self._sink_factory: SinkFactory = sink_factory or standard_sinks
        # parts given by the caller run where the caller can see them, unless front_process=True asks otherwise
        self._custom_front = bool(detectors or adapters or odometry_factory)
        self._extra_sinks = list(sinks)
        self.summary = RunSummary()
        self.grid_frame = config.grid_frame
        self.models: list[DetectorModel] = []
        self.mounts: list[Pose2D] = []
        self.frame_mounts: dict[str, Pose2D] = {}
        self.adapters: list[DetectorAdapter] = []
        self.setup: SensorSetup | None = None
        self.filter: StepFilter | None = None
        self.spec: GridSpec = config.grid if config.grid is not None else GridSpec()
        self.classifier: Any = None
        #: The tracker and the people it confirms (pfpeople.track.reported_people.PeopleTracker; None: tracking off).
        self.tracker: Any = None
        self.odometry: OdometryIntegrator | None = None
        #: The TF edges of the mounts, checked for changes during the run (set by :meth:`prepare`).
        self._mount_watch: MountWatch | None = None
        #: Each frame's mounts, followed over TF time (set by :meth:`prepare`).
        self._mounts: MountTracker | None = None
        self.clutter: ClutterStage | None = None
        #: The anchors of the tracks that walked and stopped (None: no tracker or no static-clutter map).
        self._stopped: StoppedPeople | None = None
        self._warn = WarnOnce(log)

    # -- preparation -----------------------------------------------------------------------------------------

    def _topics(self) -> list[str]:
        return run_topics(self.config)

    def prepare(self, bag: BagSource) -> TfBuffer:
        """Check topics and types, read the TF mounts, build the detector adapters, the filter and the rest."""
        _kernels.warm_up()  # the front end's compiled kernels load here, not in the first frame
        clutter_kernels.warm_up()
        c = self.config
        factories = {d.kind: adapter_factory(d.kind, self.adapter_registry) for d in c.detectors}
        setup = self._setup_sensors(
            c,
            bag,
            input_types={k: adapter_attr(f, "input_types", None) for k, f in factories.items()},
            laser_kinds={k for k, f in factories.items() if adapter_attr(f, "laser", False)},
        )
        self.setup = setup
        self.grid_frame = setup.grid_frame
        self.frame_mounts = dict(setup.frame_mounts)
        self.spec = setup.spec
        self.adapters = []
        for d, mount in zip(setup.detectors, setup.mounts, strict=True):
            adapter = factories[d.kind](d, mount, self._given.get(d.name))
            if d.topic in setup.first:  # fails early, naming the type, if the topic can never work
                adapter.check_first(setup.first[d.topic])
            self.adapters.append(adapter)
        self.models = [a.model for a in self.adapters]
        self.mounts = [a.mount for a in self.adapters]
        check_grid_seen(self.spec, self.models, configured=c.grid is not None)
        warn_coarse_lasers(self.adapters, setup.first)
        warn_dense_lasers(self.adapters, setup.first)
        factory = self._filter_factory or (lambda spec, models: make_filter(c.filter, spec, models))
        self.filter = factory(self.spec, self.models)
        self.classifier = build_classifier(c.classifier, c.filter.mode)
        if self._filter_factory is None:  # a caller's filter may share state with its copies: not warmed up
            warm_up_back_end(self.filter, self.classifier, self.spec, self.models)  # copies: the run is unchanged
        load_decoders = getattr(bag, "load_decoders", None)  # a caller's source may have none
        if load_decoders is not None:
            load_decoders([*self._topics(), *c.tf_topics])
        self.clutter = ClutterStage(c, self.adapters, self.summary)
        self.odometry = self._odometry_factory(c, setup.base_to_grid, self.summary, self._warn)
        self.tracker = build_people_tracker(c.tracking, self.classifier, c.filter.mode)
        self._stopped = StoppedPeople() if self.tracker is not None and self.clutter.active else None
        edges = [e for f in self.frame_mounts for e in setup.tf.edges(setup.grid_frame, f)]
        self._mount_watch = MountWatch(edges)
        self._mounts = MountTracker(setup.tf, setup.grid_frame, self.adapters, setup.first, self.summary, self._warn)
        return setup.tf

    # -- running ---------------------------------------------------------------------------------------------

    def _messages(self, source: BagSource, *, watch_mounts: bool) -> Iterator[BagMessage]:
        """The run topics' messages of ``source``; the TF topics too, followed (:mod:`pfpeople.pipeline.mounts`) and,
        with
        ``watch_mounts``, checked (:meth:`_check_mounts`) on the way, not yielded."""
        tf_topics = set(self.config.tf_topics) & set(source.topics)
        for m in source.messages([*self._topics(), *sorted(tf_topics)]):
            if m.topic in tf_topics:
                if self._mounts is not None:
                    self._mounts.add(m.msg, m.topic)
                if watch_mounts and self._mount_watch is not None and m.topic in self._mount_watch.topics:
                    self._check_mounts(m, source.start_time_ns)
            else:
                yield m

    def _check_mounts(self, m: BagMessage, start_ns: int) -> None:
        """Count (per edge) and warn once about the transforms of ``m`` off the mounts' values the run uses."""
        assert self._mount_watch is not None
        for ch in self._mount_watch.check(m.msg):
            e = ch.edge
            count(self.summary.mount_changes, e.name)
            self._warn(
                f"mount:{e.name}",
                "TF %s (topic %r) changes during the run: %.1f s into the bag it is (%.3f m, %.3f m, %.3f rad), "
                "%.3g m and %.3g rad off the value read before the run (%.3f m, %.3f m, %.3f rad). The run follows "
                "it: each frame's detections are placed with the latest transform at or before the frame's stamp "
                "(counted in mount_changes and, per detector, mounts_followed)",
                e.name,
                e.topic,
                (m.bag_time_ns - start_ns) * 1e-9,
                ch.pose.x,
                ch.pose.y,
                ch.pose.yaw,
                ch.distance_m,
                abs(ch.turn_rad),
                e.pose.x,
                e.pose.y,
                e.pose.yaw,
            )

    def _detect(self, adapter: DetectorAdapter, frame: Frame) -> Detections | None:
        """One detector's output in ``frame``; None when it has no data there (counted, warned once)."""
        d = adapter.config
        msgs = [frame.driver] if d.topic == self.config.driver else frame.inputs.get(d.topic, [])
        s = self.summary
        if not msgs:
            if adapter.nobody_when_missing:
                nobody = np.zeros((0, 2))
                return Detections(nobody, nobody)
            count(s.no_data, d.name)
            self._warn(
                f"nodata:{d.name}",
                "detector %s: no %s message within the tolerance of frame %d "
                "(it covers no cell in such frames; counted)",
                d.name,
                d.topic,
                frame.index,
            )
            return None
        if self._mounts is not None and not self._mounts.place(self.adapters.index(adapter), adapter, msgs[0]):
            count(s.no_data, d.name)
            return None
        try:
            return adapter.detect(msgs)
        except EmptyInputError as exc:
            count(s.empty_scans, d.name)
            count(s.no_data, d.name)
            self._warn(
                f"empty:{d.name}",
                "topic %s: empty LaserScan (no beams) at %d ns; detector %s has no data in such frames (counted)",
                exc.topic,
                exc.stamp_ns,
                d.name,
            )
        except BadScanError as exc:  # one warning per topic and reason: the message names the topic
            count(s.bad_messages, d.name)
            count(s.no_data, d.name)
            count(s.bad_scans.setdefault(d.name, {}), exc.reason)
            self._warn(
                f"badscan:{d.topic}:{exc.reason}",
                "detector %s: unusable input (%s); the detectors on %s have no data in such frames (they cover "
                "no cell; counted in stats.bad_messages and stats.bad_scans.%s)",
                d.name,
                exc,
                d.topic,
                exc.reason,
            )
        except MessageDataError as exc:  # bad data only: a bug in a detector propagates
            count(s.bad_messages, d.name)
            count(s.no_data, d.name)
            self._warn(
                f"bad:{d.name}", "detector %s: unusable input (%s); no data in such frames (counted)", d.name, exc
            )
        return None

    def _front(self, frame: Frame) -> FrontResult:
        """The part of a frame that does not depend on the filter: ego-motion, detectors, static clutter."""
        assert self.odometry is not None and self.clutter is not None
        motion = self.odometry.begin(frame)
        if self._mounts is not None:
            self._mounts.advance(frame.stamp_ns)
        if motion.restarted:
            self.clutter.reset()
        found = [self._detect(a, frame) for a in self.adapters]
        dets: list[NDArray[np.float64] | None] = [None if f is None else f.grid for f in found]
        static: list[NDArray[np.bool_] | None] = [None] * len(found)
        sup_static: list[NDArray[np.bool_] | None] = [None] * len(found)
        scan_static: dict[str, NDArray[np.bool_]] = {}
        if self.clutter.active:
            dets, static, laser_ego = self.clutter.step(found, motion.ego, motion.dt, frame.stamp_ns)
            sup_static = list(self.clutter.support_static)
            scan_static = dict(self.clutter.scan_static)
            motion = self.odometry.from_laser(motion, laser_ego)
        self.odometry.end(frame, motion)
        return FrontResult(
            motion=motion,
            found=found,
            dets=dets,
            static=static,
            support_static=sup_static,
            scan_static=scan_static,
            mounts=tuple(a.mount for a in self.adapters),
        )

    def _back(self, frame: Frame, front: FrontResult) -> FrameResult:
        """The filter, the classifier and the tracker on a frame's :meth:`_front` result."""
        assert self.filter is not None and self.clutter is not None
        motion, found = front.motion, front.found
        follow_views(self.adapters, front.mounts, front.found, self.filter, self.summary, self._warn)
        if motion.restarted:
            self.filter.reset()
        raw: list[NDArray[np.float64] | None] = [None if f is None else f.grid for f in found]
        dets, static = self._readmit(front)
        step = self.filter.step(dets, motion.odometry, motion.dt)
        belief = np.asarray(step.posterior, dtype=float)
        if motion.restarted and hasattr(self.classifier, "reset"):
            self.classifier.reset()
        observed = np.asarray(step.covered).any(axis=0)
        people_found = classify_frame(self.classifier, belief, self.spec, observed=observed, ego=motion.motion)
        tracks = None
        support: list[NDArray[np.float64] | None] | None = None
        if self.tracker is not None:
            if motion.restarted:
                self.tracker.reset()
            kept_support = None
            if self.tracker.use_support:
                support = [None if f is None else f.support for f in found]
                kept_support = support_positions(support, front.support_static)
            tracked = self.tracker.step(
                people_found,
                belief,
                self.spec,
                motion.dt,
                observed=observed,
                ego=motion.motion,
                support=kept_support,
                detections=support_positions([d for d, m in zip(dets, self.models, strict=True) if point_like(m)]),
                views=self._laser_views(found) if self.tracker.see_through else None,
            )
            people_found, tracks = tracked.people, tracked.tracks
            if self._stopped is not None:
                let_through = [d for d, m in zip(front.dets, self.models, strict=True) if point_like(m)]
                self._stopped.update(tracked.live, support_positions(let_through))
        people = people_found.positions.reshape(-1, 2)
        self.summary.frames += 1
        return FrameResult(
            frame=frame,
            dt=motion.dt,
            odometry=motion.odometry,
            detections=raw,
            static=static,
            belief=belief,
            people=people,
            people_size=[int(v) for v in people_found.sizes],
            people_probability=[float(v) for v in people_found.scores],
            step=step,
            tracks=tracks,
            support=support,
            support_static=None if support is None else front.support_static,
            scans=self._scans(front),
        )

    def _readmit(self, front: FrontResult) -> tuple[list[NDArray[np.float64] | None], list[NDArray[np.bool_] | None]]:
        """The detections the filter sees and the static flags, the static detections at a stopped person's
        anchor (:mod:`pfpeople.track.stopped_people`, its anchors moved into this frame first) readmitted (counted
        in ``readmitted``)."""
        stopped = self._stopped
        if stopped is None:
            return front.dets, front.static
        if front.motion.restarted:
            stopped.reset()
        stopped.move(front.motion.motion)
        dets, static = list(front.dets), list(front.static)
        for k, (f, st) in enumerate(zip(front.found, front.static, strict=True)):
            if f is None or st is None or not st.any():
                continue
            back = stopped.readmit(f.grid[st])
            if not back.any():
                continue
            flags = st.copy()
            flags[np.flatnonzero(st)[back]] = False
            static[k], dets[k] = flags, f.grid[~flags]
            count(self.summary.readmitted, self.adapters[k].config.name, int(np.count_nonzero(back)))
        return dets, static

    def _scans(self, front: FrontResult) -> dict[str, tuple[NDArray[np.float64], NDArray[np.bool_] | None]]:
        """Each laser topic's scan of the frame, once: valid end points (m, grid frame) and static flags."""
        out: dict[str, tuple[NDArray[np.float64], NDArray[np.bool_] | None]] = {}
        for f, a in zip(front.found, self.adapters, strict=True):
            topic = a.config.topic
            if f is None or f.scan is None or topic in out or getattr(a, "self_mounted", False):
                continue
            pts = f.scan.points()
            ok = finite_rows(pts)
            static = front.scan_static.get(topic)
            out[topic] = (a.mount.apply(pts[ok]), None if static is None else static[ok])
        return out

    def _laser_views(self, found: list[Detections | None]) -> list[tuple[LaserScan, Pose2D]]:
        """This frame's laser scans, each once, with the pose of its laser frame in the grid frame."""
        views: dict[int, tuple[LaserScan, Pose2D]] = {}
        for f, a in zip(found, self.adapters, strict=True):
            if f is not None and f.scan is not None and not getattr(a, "self_mounted", False):
                views.setdefault(id(f.scan), (f.scan, a.mount))
        return list(views.values())

    def _process(self, frame: Frame) -> FrameResult:
        """One frame in this process: :meth:`_back` of :meth:`_front`."""
        return self._back(frame, self._front(frame))

    def frames(self, bag: BagSource, *, max_frames: int | None = None) -> Generator[FrameResult, None, None]:
        """Process the bag frame by frame (call :meth:`prepare` first, or let this call it)."""
        _check_max_frames(max_frames)
        if self.filter is None:
            self.prepare(bag)
        assert self.odometry is not None
        c = self.config
        policies = self._sync_policies()
        use_bag_time = c.time_source == "bag"
        self.odometry.reset()

        def synced(source: BagSource, sync: FrameAssembler, watch_mounts: bool = True) -> Iterator[Frame]:
            for m in self._messages(source, watch_mounts=watch_mounts):
                yield from sync.push(replace(m, stamp_ns=m.bag_time_ns) if use_bag_time else m)
            yield from sync.finish()

        def assembler() -> FrameAssembler:
            return FrameAssembler(
                c.driver, policies, tolerance_ns=c.sync_tolerance_ns, max_pending=c.max_pending_frames
            )

        def child_frames() -> Iterator[Frame]:  # in the front-end process: its own reader of the same bag
            with BagSource(bag.paths) as source:
                yield from itertools.islice(synced(source, assembler(), watch_mounts=False), max_frames)

        sync = assembler()
        with limit_blas(self.blas_threads):  # the front-end process, forked in here, inherits the limit
            self.summary.blas_threads = self.summary.front_blas_threads = blas_threads_in_use()
            t0 = time.perf_counter()
            try:
                frames = itertools.islice(synced(bag, sync), max_frames)
                if self._two_processes(bag):
                    front = FrontProcess(child_frames, self._front, self.summary)
                    try:
                        for frame in frames:
                            yield self._back(frame, front.take(frame))
                    finally:
                        front.close()
                else:
                    for frame in frames:
                        yield self._process(frame)
            finally:
                self.summary.elapsed_s = time.perf_counter() - t0
                self.summary.sync = sync.stats
                self._log_ego_motion()

    def _sync_policies(self) -> dict[str, str]:
        """How each non-driver topic joins the frames (the detectors' ``assign``, odometry interpolated); logs the
        ego-motion source.

        Raises
        ------
        ValueError
            For a topic given two policies, or an odometry topic that is also a detector or the driver topic.
        """
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
        elif self._scan_matched():
            log.info(
                "no odometry topic configured: the ego-motion comes from scan matching the driving laser %s where "
                "its scans match; in the other frames the robot is taken as standing (counted: run.json stats "
                "ego_motion)",
                c.driver,
            )
        else:
            log.info("no odometry topic configured: the robot is taken as standing in every frame")
        return policies

    def _scan_matched(self) -> bool:
        """Whether the run's ego-motion comes from scan matching the driving laser (no odometry topic)."""
        c = self.config
        return (
            not c.odometry
            and c.clutter.laser_odometry
            and self.clutter is not None
            and c.driver in self.clutter.suppressors
        )

    def _log_ego_motion(self) -> None:
        """Log where the frames' ego-motion came from; warn when scan matching gave it in under half the frames
        that could have had it (all but the first frame of the run and after each restart)."""
        s = self.summary
        e = s.ego_motion
        total = sum(e.values())
        if not total:
            return
        log.info(
            "ego-motion of %d frames: %d from odometry, %d from scan matching, %d none (the robot stood)",
            total,
            e.get("odometry", 0),
            e.get("scan_matching", 0),
            e.get("none", 0),
        )
        possible = total - 1 - s.filter_restarts
        matched = e.get("scan_matching", 0)
        if self._scan_matched() and possible > 0 and matched < 0.5 * possible:
            log.warning(
                "scan matching of %s gave the ego-motion of only %d of %d frames (%.0f %%): the other frames had "
                "none (for the filter the robot stood still), so wherever it moved then, the grid and the tracks "
                "moved with it (an odometry topic would give the motion)",
                self.config.driver,
                matched,
                possible,
                100.0 * matched / possible,
            )

    def _two_processes(self, bag: BagSource) -> bool:
        """Whether this run's front end runs in a second process (``front_process``)."""
        if self.front_process is False or (self.front_process is None and self._custom_front):
            return False
        why = ""
        if not isinstance(bag, BagSource):
            why = f"the source is a {type(bag).__name__}, not a BagSource the front-end process can open again"
        else:
            _ok, why = front_process_available()
        if why:
            if self.front_process:
                log.warning("front_process: one process (%s)", why)
            else:
                log.debug("one process: %s", why)
            return False
        return True

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
        bag_input: bool = True,
    ) -> tuple[RunSummary, list[FrameResult]]:
        """Run over ``bag``, writing ``out_dir`` (and ``bag_out``, and every extra sink) incrementally.

        A run that stops part-way (a truncated or corrupt bag, :class:`~pfpeople.io.bag.reader.BagReadError`;
        any other error) ends with ``status = "failed"`` and the error in ``run.json``; one stopped by SIGINT
        (Ctrl-C) or SIGTERM (:class:`~pfpeople.io.run_dir.RunInterrupted`, a ``KeyboardInterrupt``) ends with
        ``status = "interrupted"``. Either way the frames processed so far are kept (``frames`` in ``run.json``
        is the number on disk), the result bag is closed (indexed), and the exception re-raised. Driver
        messages that made no frame are counted in ``run.json`` ``skipped_frames`` by reason
        (``clock_jump``: an outlier stamp; ``non_monotonic``: a stamp not after the previous one).
        Returns the summary and (with ``keep=True``) every :class:`FrameResult`.
        ``bag_out`` is a ROS 1 ``.bag`` or a rosbag2 folder (``bag_format`` "ros1", "mcap" or "sqlite3"; default
        from the path, see :mod:`pfpeople.io.bag.writer`), checked before anything runs; ``overwrite`` also replaces
        an existing one; ``bag_input`` copies the input's LaserScan topics and ``/tf``, ``/tf_static`` into it.
        No output may write over an input bag (:func:`pfpeople.io.run_dir.check_output_paths`).
        The outputs are sinks (:mod:`pfpeople.io.sinks`), written in order with signals deferred, so a frame goes to
        every output or to none; a signal that arrives while a frame is computed is raised once it is written (raised
        inside a compiled kernel, it would surface as a ``SystemError``).
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
                bag_input=bag_input,
            )

    def _run_info(self, bag: BagSource, max_frames: int | None, metadata: Mapping[str, Any] | None) -> RunInfo:
        """What the sinks are opened with: the configuration, the bag, the grid, the detectors and the mounts."""
        return RunInfo(
            config=self.config,
            bag=bag,
            spec=self.spec,
            grid_frame=self.grid_frame,
            detector_names=tuple(d.name for d in self.config.detectors),
            detector_models=tuple(self.models),
            frame_mounts=dict(self.frame_mounts),
            max_frames=max_frames,
            metadata=dict(metadata or {}),
        )

    def _run_sinks(
        self,
        out_dir: str | Path | None,
        bag_out: str | Path | None,
        *,
        bag_format: str | None,
        overwrite: bool,
        progress: bool,
        bag_input: bool,
    ) -> list[Sink]:
        """The run's sinks, in write order: the sink factory's (run directory, result bag, progress; see
        :meth:`run` for the arguments), then the extra sinks."""
        return [
            *self._sink_factory(
                out_dir,
                bag_out=bag_out,
                bag_format=bag_format,
                overwrite=overwrite,
                progress=progress,
                with_input=bag_input,
            ),
            *self._extra_sinks,
        ]

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
        bag_input: bool,
    ) -> tuple[RunSummary, list[FrameResult]]:
        _check_max_frames(max_frames)
        check_output_paths(getattr(bag, "paths", ()), out_dir=out_dir, bag_out=bag_out)
        sinks = self._run_sinks(
            out_dir, bag_out, bag_format=bag_format, overwrite=overwrite, progress=progress, bag_input=bag_input
        )
        self.prepare(bag)
        info = self._run_info(bag, max_frames, metadata)
        opened: list[Sink] = []
        if sinks:  # nothing is open to record a failure here: it simply raises
            open_sinks(sinks[:1], info, opened)
        results = self.frames(bag, max_frames=max_frames)
        kept: list[FrameResult] = []
        status, error = "complete", None
        written = 0
        try:  # from here on, whatever stops the run is recorded by the open sinks and the frames written stay valid
            open_sinks(sinks[1:], info, opened)
            while True:
                with deferred_signals():  # a frame is made and written whole: a signal is raised between frames
                    r = next(results, None)
                    if r is None:
                        break
                    for sink in opened:
                        sink.write(r)
                    written += 1
                if keep:
                    kept.append(r)
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
            with deferred_signals():  # a second signal waits until every output is closed
                try:
                    results.close()  # ends the frame generator now, so the summary has its elapsed time and sync stats
                finally:
                    # a signal can stop the run after a frame was processed but before it was written: the summary
                    # counts the frames the outputs hold
                    self.summary.frames = written
                    close_sinks(opened, RunOutcome(status, error, self.summary))
        return self.summary, kept
