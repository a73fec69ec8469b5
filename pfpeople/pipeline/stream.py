"""The streaming API: a frame's messages in as they arrive (scans, odometry, TF), its people, tracks and grid out.

:class:`PeopleStream` is the run loop of pfpeople: a bag run (:class:`pfpeople.pipeline.runner.Pipeline`,
:func:`pfpeople.run_bag`) feeds it the bag's messages, a live node (``pfpeople node``) the messages of its
subscriptions; both get the same :class:`~pfpeople.run_state.FrameResult` per frame. Per message::

    message --FrameIntake--> frames (TF -> mounts)           pfpeople.pipeline.intake
    frame   --FrontEnd-----> ego-motion, detections, clutter  pfpeople.pipeline.front
            --BackEnd------> filter, people, tracks           pfpeople.pipeline.back

It is built from a configuration and a source of the run's first messages (a bag, or the messages a live node
buffered: anything with the :class:`~pfpeople.io.bag.reader.BagSource` methods ``require``, ``messages``,
``topics``, ``topic_types``, ``message_counts`` and ``start_time_ns``), which fix the mounts, the detectors' fields
of view and the grid (:mod:`pfpeople.pipeline.sensor_setup`). Example::

    from pfpeople.config import load_config
    from pfpeople.io.bag.reader import BagSource
    from pfpeople.pipeline.stream import PeopleStream

    config = load_config("my.toml")
    with BagSource("my.bag") as bag:
        stream = PeopleStream.open(config, bag)
        for message in bag.messages(stream.topics(bag)):  # or messages as a robot receives them
            for r in stream.push(message):  # the frames this message completed (often none)
                print(r.frame.stamp_ns, r.people, [t.id for t in r.tracks or []], r.belief.shape)
        for r in stream.finish():  # the frames still waiting for late messages
            ...

A message that completes no frame costs almost nothing; the frames' work happens in :meth:`PeopleStream.push`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.config import BagConfig, run_topics
from pfpeople.detect.adapters import adapter_attr, adapter_factory
from pfpeople.io.bag.sync import Frame
from pfpeople.pipeline.front import FrontResult
from pfpeople.pipeline.intake import FrameIntake
from pfpeople.pipeline.parts import PartFactories, RunParts, build_parts
from pfpeople.pipeline.sensor_setup import SensorSetup, SetupSensors, setup_sensors
from pfpeople.run_state import FrameResult, RunSummary, WarnOnce

__all__ = ["PeopleStream", "setup_run"]

log = logging.getLogger(__name__)


def setup_run(
    config: BagConfig, source: Any, parts: PartFactories | None = None, *, setup: SetupSensors | None = None
) -> SensorSetup:
    """The sensor setup of a run of ``config`` on ``source`` (:func:`pfpeople.pipeline.sensor_setup.setup_sensors`,
    or ``setup``), with the message types and laser kinds of the detector adapters of ``parts``."""
    registry = (parts or PartFactories()).registry
    factories = {d.kind: adapter_factory(d.kind, registry) for d in config.detectors}
    return (setup or setup_sensors)(
        config,
        source,
        input_types={k: adapter_attr(f, "input_types", None) for k, f in factories.items()},
        laser_kinds={k for k, f in factories.items() if adapter_attr(f, "laser", False)},
    )


class PeopleStream:
    """Messages in, one :class:`~pfpeople.run_state.FrameResult` per frame out (see the module docstring).

    Parameters
    ----------
    config : BagConfig
        The run's configuration (as ``pfpeople run`` takes it).
    setup : SensorSetup
        Frames, mounts, fields of view and grid (:func:`setup_run`; :meth:`open` makes it from a source).
    parts : PartFactories, optional
        Replacements of the detectors, the adapters, the filter or the odometry integrator.
    summary : RunSummary, optional
        Where the run's counts go (default a new one: :attr:`summary`).
    start_time_ns : int, optional
        The time the warnings about moving mounts count from (a bag's start; default the first message's).

    Raises
    ------
    ValueError
        For a configuration the setup cannot run (see :func:`pfpeople.pipeline.parts.build_parts` and
        :func:`pfpeople.pipeline.intake.sync_policies`).
    """

    def __init__(
        self,
        config: BagConfig,
        setup: SensorSetup,
        *,
        parts: PartFactories | None = None,
        summary: RunSummary | None = None,
        start_time_ns: int | None = None,
    ) -> None:
        self.config = config
        self.summary = summary if summary is not None else RunSummary()
        self.warn = WarnOnce(logging.getLogger("pfpeople.pipeline.runner"))
        self.parts: RunParts = build_parts(
            config, setup, parts=parts or PartFactories(), summary=self.summary, warn=self.warn
        )
        self._log_ego_source()
        self.intake = self.new_intake(watch=True, start_time_ns=start_time_ns)
        #: The front end each frame goes through (replaceable: the bag run's front-end process).
        self.front: Callable[[Frame], FrontResult] = self.parts.front
        self.parts.front.ego.reset()

    @classmethod
    def open(cls, config: BagConfig, source: Any, *, parts: PartFactories | None = None) -> PeopleStream:
        """A stream whose setup comes from ``source`` (a bag, or the first messages of a live run)."""
        setup = setup_run(config, source, parts)
        return cls(config, setup, parts=parts, start_time_ns=getattr(source, "start_time_ns", None))

    def new_intake(self, *, watch: bool, start_time_ns: int | None = None) -> FrameIntake:
        """A message intake feeding this stream's mounts (``watch``: check the mounts' TF for changes)."""
        p = self.parts
        return FrameIntake(
            self.config,
            mounts=p.mounts,
            watch=p.mount_watch if watch else None,
            summary=self.summary,
            warn=self.warn,
            start_time_ns=start_time_ns,
            output=p.output,
        )

    def topics(self, source: Any = None) -> list[str]:
        """The topics the stream reads: the driver, the detectors' and the odometry's, and the TF topics (those of
        ``source`` when given: a bag's)."""
        tf = [t for t in self.config.tf_topics if source is None or t in source.topics]
        return [*run_topics(self.config), *sorted(tf)]

    @property
    def spec(self) -> GridSpec:
        """The grid of every belief (grid frame)."""
        return self.parts.setup.spec

    @property
    def grid_frame(self) -> str:
        """The frame of the grid and of every position."""
        return self.parts.setup.grid_frame

    @property
    def output_frame(self) -> str:
        """The frame of the results besides the grid frame (``[output] frame``; the grid frame when none)."""
        return self.grid_frame if self.parts.output is None else self.parts.output.frame

    @property
    def models(self) -> list[DetectorModel]:
        """The detectors' models as built (mounted as read before the run)."""
        return self.parts.models

    def push(self, message: Any) -> list[FrameResult]:
        """Take one message (a :class:`~pfpeople.io.bag.reader.BagMessage`); returns the results of the frames it
        completed, in order."""
        return [self.process(f) for f in self.intake.push(message)]

    def finish(self) -> list[FrameResult]:
        """The results of the frames still pending (the input ended); the frame assembler's counts go to
        ``summary.sync``."""
        out = [self.process(f) for f in self.intake.finish()]
        self.summary.sync = self.intake.stats
        return out

    def process(self, frame: Frame) -> FrameResult:
        """One frame: the back end on the front end's result."""
        return self.parts.back(frame, self.front(frame))

    def _log_ego_source(self) -> None:
        c = self.config
        if c.odometry:
            return
        if self.parts.scan_matched:
            log.info(
                "no odometry topic configured: the ego-motion comes from scan matching the driving laser %s where "
                "its scans match; in the other frames the robot is taken as standing (counted: run.json stats "
                "ego_motion)",
                c.driver,
            )
        else:
            log.info("no odometry topic configured: the robot is taken as standing in every frame")
