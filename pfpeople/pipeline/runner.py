"""A bag run: the bag's messages through the run loop (:class:`pfpeople.pipeline.stream.PeopleStream`) into sinks.

:class:`Pipeline` reads a bag, feeds its messages to a :class:`~pfpeople.pipeline.stream.PeopleStream` (the
streaming API a live node uses too: one code path) and writes each frame's result to the sinks
(:mod:`pfpeople.pipeline.sinks`: run directory, result bag, progress). Its collaborators, each in its own module
and each replaceable through the constructor:

- sensor setup (topics, TF mounts, each laser's field of view, the default grid): :mod:`pfpeople.pipeline.sensor_setup`,
  argument ``sensor_setup``;
- the run's parts (:mod:`pfpeople.pipeline.parts`): the detector adapters (``adapters``, ``detectors``), the
  odometry integrator (``odometry_factory``), the filter (``filter_factory``);
- outputs: ``sink_factory`` and ``sinks`` (extra sinks).

The run loop itself (:mod:`pfpeople.pipeline.stream`) is message intake (:mod:`pfpeople.pipeline.intake`: frames
driven by the config's ``driver`` topic, TF followed), the front end (:mod:`pfpeople.pipeline.front`: ego-motion,
detectors, static clutter) and the back end (:mod:`pfpeople.pipeline.back`: filter, classifier, tracker).

The first frame uses ``dt = 0.1 s`` (:data:`FIRST_DT_S`); a gap between frames longer than :data:`MAX_GAP_S`
or an odometry jump (:func:`pfpeople.perception.odometry.is_odometry_jump`) restarts the filter, the clutter maps and
the tracker (counted). With two or more cores the front end runs in a second process, a few frames ahead of the back
end (:mod:`pfpeople.pipeline.front_end`, ``Pipeline(front_process=...)``): the same results, more frames per second.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable, Generator, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeAlias

from gridbridge.filter import BeliefFilter
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from gridbridge.validation import check_int
from pfpeople.config import BagConfig
from pfpeople.detect.adapters import AdapterFactory, Detector, DetectorAdapter, build_detector
from pfpeople.io.bag.reader import BagMessage, BagSource
from pfpeople.io.bag.tf import TfBuffer
from pfpeople.io.run_dir import check_output_paths, deferred_signals, interrupt_signals
from pfpeople.perception.odometry import FIRST_DT_S, MAX_GAP_S, odometry_between
from pfpeople.pipeline.blas import blas_threads_in_use, limit_blas, resolve_blas_threads
from pfpeople.pipeline.ego_stage import log_ego_motion
from pfpeople.pipeline.front_end import FrontProcess, front_process_available
from pfpeople.pipeline.parts import OdometryFactory, PartFactories, default_odometry, make_filter
from pfpeople.pipeline.sensor_setup import TF_PRELOAD_S, SensorSetup, SetupSensors
from pfpeople.pipeline.sinks import RunInfo, RunOutcome, Sink, close_sinks, open_sinks, standard_sinks
from pfpeople.pipeline.stream import PeopleStream, setup_run
from pfpeople.run_state import FrameResult, RunSummary
from pfpeople.sensors import Pose2D

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
    "default_odometry",
    "make_filter",
    "odometry_between",
]

log = logging.getLogger(__name__)

#: ``factory(out_dir, *, bag_out, bag_format, overwrite, progress, with_input)`` -> sinks
#: (:func:`pfpeople.pipeline.sinks.standard_sinks`).
SinkFactory: TypeAlias = Callable[..., list[Sink]]


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
        Replaces :func:`pfpeople.pipeline.sinks.standard_sinks`: the sinks made from :meth:`run`'s ``out_dir``,
        ``bag_out``, ``bag_format``, ``overwrite`` and ``progress``.
    sinks : sequence of Sink, optional
        Extra sinks every run writes to, after the standard ones.
    front_process : bool or None, optional
        Run the front end of each frame (ego-motion, detectors, static clutter) in a second process, a few frames
        ahead of the back end (:mod:`pfpeople.pipeline.front_end`). Same results, more frames per second on two or
        more cores. None (default): when :func:`pfpeople.pipeline.front_end.front_process_available` says it can
        and no front-end part (``detectors``, ``adapters``, ``odometry_factory``) is given: the state of those
        would be in the child process, out of the caller's sight. True: ask for it (one process, with a warning,
        where it cannot run); False: one process.
    blas_threads : int, optional
        BLAS threads per process while the frames run (:mod:`pfpeople.pipeline.blas`; the front-end process
        included). None (default): ``PFPEOPLE_BLAS_THREADS``, else 1; 0: no limit. Same results.

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
        filter_factory: Callable[[GridSpec, Sequence[DetectorModel]], BeliefFilter] | None = None,
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
        #: BLAS threads per process during the frames (0: no limit).
        self.blas_threads = resolve_blas_threads(blas_threads)
        unknown = set(detectors or {}) - {d.name for d in config.detectors}
        if unknown:
            raise ValueError(f"detectors {sorted(unknown)} are not in the config")
        self.factories = PartFactories(
            detectors=dict(detectors or {}),
            adapters=dict(adapters or {}),
            filter=filter_factory,
            odometry=odometry_factory,
        )
        self._setup_sensors = sensor_setup
        self._sink_factory: SinkFactory = sink_factory or standard_sinks
        self._extra_sinks = list(sinks)
        self.summary = RunSummary()
        #: The run loop (set by :meth:`prepare`).
        self.stream: PeopleStream | None = None

    # -- what the run is made of (after prepare) --------------------------------------------------------------

    @property
    def setup(self) -> SensorSetup | None:
        """Frames, mounts, detectors and grid of the run (None before :meth:`prepare`)."""
        return None if self.stream is None else self.stream.parts.setup

    @property
    def spec(self) -> GridSpec:
        """The grid (the config's, or the default one before :meth:`prepare`)."""
        if self.stream is not None:
            return self.stream.spec
        return self.config.grid.fixed or GridSpec(resolution=self.config.grid.resolution)

    @property
    def grid_frame(self) -> str:
        return self.config.grid_frame if self.stream is None else self.stream.grid_frame

    @property
    def filter(self) -> BeliefFilter | None:
        return None if self.stream is None else self.stream.parts.back.filter

    @property
    def adapters(self) -> list[DetectorAdapter]:
        return [] if self.stream is None else self.stream.parts.adapters

    @property
    def models(self) -> list[DetectorModel]:
        """The detectors' models as built (mounted as read before the run)."""
        return [] if self.stream is None else self.stream.models

    @property
    def mounts(self) -> list[Pose2D]:
        """Each detector's mount read before the run."""
        return [] if self.setup is None else list(self.setup.mounts)

    # -- running ---------------------------------------------------------------------------------------------

    def prepare(self, bag: BagSource) -> TfBuffer:
        """Check topics and types, read the TF mounts, build the run loop (detectors, filter and the rest)."""
        setup = setup_run(self.config, bag, self.factories, setup=self._setup_sensors)
        self.stream = PeopleStream(
            self.config, setup, parts=self.factories, summary=self.summary, start_time_ns=bag.start_time_ns
        )
        load_decoders = getattr(bag, "load_decoders", None)  # a caller's source may have none
        if load_decoders is not None:
            load_decoders(self.stream.topics(bag))
        return setup.tf

    def _messages(self, source: BagSource, topics: Sequence[str]) -> Iterator[BagMessage]:
        """The messages of ``topics`` in ``source`` (the run's and its TF topics)."""
        yield from source.messages(topics)

    def frames(self, bag: BagSource, *, max_frames: int | None = None) -> Generator[FrameResult, None, None]:
        """Process the bag frame by frame (call :meth:`prepare` first, or let this call it)."""
        _check_max_frames(max_frames)
        if self.stream is None:
            self.prepare(bag)
        stream = self.stream
        assert stream is not None
        stream.parts.front.ego.reset()
        topics = stream.topics(bag)
        intake = stream.new_intake(watch=True, start_time_ns=bag.start_time_ns)

        def child_frames() -> Iterator[Any]:  # in the front-end process: its own reader of the same bag
            with BagSource(bag.paths) as source:
                own = stream.new_intake(watch=False, start_time_ns=source.start_time_ns)
                yield from itertools.islice(own.frames(self._messages(source, topics)), max_frames)

        with limit_blas(self.blas_threads):  # the front-end process, forked in here, inherits the limit
            self.summary.blas_threads = self.summary.front_blas_threads = blas_threads_in_use()
            t0 = time.perf_counter()
            try:
                frames = itertools.islice(intake.frames(self._messages(bag, topics)), max_frames)
                if not self._two_processes(bag):
                    for frame in frames:
                        yield stream.process(frame)
                    return
                front = FrontProcess(child_frames, stream.parts.front, self.summary)
                stream.front = front.take
                try:
                    for frame in frames:
                        yield stream.process(frame)
                finally:
                    front.close()
                    stream.front = stream.parts.front
            finally:
                self.summary.elapsed_s = time.perf_counter() - t0
                self.summary.sync = intake.stats
                log_ego_motion(self.summary, scan_matched=stream.parts.scan_matched, driver=self.config.driver)

    def _two_processes(self, bag: BagSource) -> bool:
        """Whether this run's front end runs in a second process (``front_process``)."""
        if self.front_process is False or (self.front_process is None and self.factories.custom_front):
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
        bag: BagSource | str | Path | Sequence[str | Path],
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
        """Run over ``bag`` (an open :class:`BagSource`, or the path(s) of one), writing ``out_dir`` (and
        ``bag_out``, and every extra sink) incrementally.

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
        The outputs are sinks (:mod:`pfpeople.pipeline.sinks`), written in order with signals deferred, so a frame
        goes to every output or to none; a signal that arrives while a frame is computed is raised once it is
        written (raised inside a compiled kernel, it would surface as a ``SystemError``).
        """
        options: dict[str, Any] = {"max_frames": max_frames, "metadata": metadata, "keep": keep}
        outputs: dict[str, Any] = {"out_dir": out_dir, "bag_out": bag_out, "bag_format": bag_format}
        outputs.update(overwrite=overwrite)
        outputs.update(progress=progress, bag_input=bag_input)
        with interrupt_signals():
            if isinstance(bag, BagSource):
                return self._run(bag, outputs, **options)
            with BagSource(bag) as source:
                return self._run(source, outputs, **options)

    def _run_info(self, bag: BagSource, max_frames: int | None, metadata: Mapping[str, Any] | None) -> RunInfo:
        """What the sinks are opened with: the configuration, the bag, the grid, the detectors and the mounts."""
        assert self.setup is not None
        return RunInfo(
            config=self.config,
            bag=bag,
            spec=self.spec,
            grid_frame=self.grid_frame,
            detector_names=tuple(d.name for d in self.config.detectors),
            detector_models=tuple(self.models),
            frame_mounts=dict(self.setup.frame_mounts),
            max_frames=max_frames,
            metadata=dict(metadata or {}),
            mount_links=() if self.setup is None else tuple(self.setup.tf.fallback_links(self.setup.frame_mounts)),
            output_frame="" if self.stream is None or self.stream.parts.output is None else self.stream.output_frame,
        )

    def _run_sinks(self, outputs: Mapping[str, Any]) -> list[Sink]:
        """The run's sinks, in write order: the sink factory's (run directory, result bag, progress; see
        :meth:`run` for the arguments), then the extra sinks."""
        o = dict(outputs)
        made = self._sink_factory(o.pop("out_dir"), with_input=o.pop("bag_input"), **o)
        return [*made, *self._extra_sinks]

    def _run(
        self,
        bag: BagSource,
        outputs: Mapping[str, Any],
        *,
        max_frames: int | None,
        metadata: Mapping[str, Any] | None,
        keep: bool,
    ) -> tuple[RunSummary, list[FrameResult]]:
        _check_max_frames(max_frames)
        check_output_paths(getattr(bag, "paths", ()), out_dir=outputs["out_dir"], bag_out=outputs["bag_out"])
        sinks = self._run_sinks(outputs)
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
