"""Output sinks of a bag run: where each processed frame goes.

A sink is opened once the run is prepared (:class:`RunInfo`: grid, frames, detectors), receives every
:class:`~pfpeople.run_state.FrameResult`, and is closed with the run's :class:`RunOutcome` (status
``"complete"``, ``"failed"`` or ``"interrupted"``, the error, the summary), whatever stopped the run.

=========================  ===================================================================================
sink                       output
=========================  ===================================================================================
:class:`RunDirSink`        a run directory (:class:`pfpeople.io.run_dir.RunWriter`: ``run.json``, ``grids.npy``,
                           CSVs), written frame by frame
:class:`ResultBagSink`     a result bag, ROS 1 or rosbag2 (:class:`pfpeople.io.bag.writer.ResultBagWriter`)
:class:`ProgressSink`      a progress bar (sparse lines off a terminal)
=========================  ===================================================================================

:func:`standard_sinks` makes these from the arguments of :meth:`pfpeople.pipeline.runner.Pipeline.run`; the
pipeline takes a replacement for it and extra sinks (anything with ``open``, ``write`` and ``close``, the
:class:`Sink` protocol).

Order and failures (:class:`pfpeople.pipeline.runner.Pipeline`): sinks are opened in order, each frame is written to
every sink with signals deferred (a SIGINT or SIGTERM arriving mid-frame waits until the frame is in every
output: one frame goes to every output or to none), and the sinks are closed in reverse order, each even if
another failed to close. A failure to open the first sink stops the run before anything is written; once a
sink is open, any failure (a later sink's open included) ends the run as ``"failed"`` and is recorded by the
sinks that are open.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.config import BagConfig
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.bag.tf import TfLink
from pfpeople.pipeline.output_frame import positions_in, results_in, tracks_in
from pfpeople.run_state import FrameResult, RunSummary
from pfpeople.sensors import Pose2D
from pfpeople.track import track_rows

__all__ = [
    "ProgressSink",
    "ResultBagSink",
    "RunDirSink",
    "RunInfo",
    "RunOutcome",
    "Sink",
    "standard_sinks",
]


@dataclass(frozen=True, kw_only=True, eq=False)
class RunInfo:
    """What a sink learns when the run starts.

    Attributes
    ----------
    config : BagConfig
        The run's configuration.
    bag : BagSource
        The input bag (paths, topics, message counts).
    spec : GridSpec
        The grid of every belief.
    grid_frame : str
        The frame of the grid and of every position.
    detector_names : tuple of str
        Detector names, in the order of :attr:`FrameResult.detections`.
    detector_models : tuple of DetectorModel
        The detectors' models (mounted in the grid frame).
    frame_mounts : dict of str to Pose2D
        Pose in the grid frame of each frame positions may be given in.
    max_frames : int or None
        The frame limit of the run.
    metadata : mapping
        Extra provenance (e.g. the command).
    mount_links : tuple of TfLink
        The transforms the run took from the configuration's ``[mounts]`` because TF had none (parent: the base
        frame): :meth:`pfpeople.io.bag.tf.TfBuffer.fallback_links` of the frames placed.
    output_frame : str
        The frame of the results besides the grid frame (``[output] frame``; ``""``: none). Each frame's
        :attr:`FrameResult.output_pose` places them there.
    """

    config: BagConfig
    bag: BagSource
    spec: GridSpec
    grid_frame: str
    detector_names: tuple[str, ...]
    detector_models: tuple[DetectorModel, ...]
    frame_mounts: dict[str, Pose2D]
    max_frames: int | None = None
    metadata: Mapping[str, Any] = field(default_factory=dict)
    mount_links: tuple[TfLink, ...] = ()
    output_frame: str = ""


@dataclass(frozen=True)
class RunOutcome:
    """How a run ended: ``status`` ("complete", "failed", "interrupted"), ``error`` text, final ``summary``."""

    status: str
    error: str | None
    summary: RunSummary


class Sink(Protocol):
    """Where processed frames go (see the module docstring)."""

    def open(self, run: RunInfo) -> None:
        """Start the output (create files)."""
        ...

    def write(self, result: FrameResult) -> None:
        """Write one frame."""
        ...

    def close(self, outcome: RunOutcome) -> None:
        """Finish the output (also after a failure; never called for a sink whose ``open`` failed)."""
        ...


class RunDirSink:
    """The run directory (:mod:`pfpeople.io.run_dir`).

    Parameters
    ----------
    out_dir : path
        The run directory.
    overwrite : bool
        Replace a run already in ``out_dir``.
    result_bag : ResultBagSink, optional
        The run's result bag: ``run.json`` gets ``result_bag`` (:meth:`ResultBagSink.describe`: its path,
        format, topics and types, the detection topics and the detector names renamed for them).
    scans : bool
        Write every laser scan (``scans.npy``, 10 bytes a return: about 7 kB a 720-beam scan) and, for particle
        runs, a subsample of the particles (``particles.npy``, at most 16 kB a frame); False writes neither.
    """

    def __init__(
        self,
        out_dir: str | Path,
        *,
        overwrite: bool = False,
        result_bag: ResultBagSink | None = None,
        scans: bool = True,
    ) -> None:
        self.out_dir = out_dir
        self.overwrite = overwrite
        self.result_bag = result_bag
        self.scans = scans
        self.writer: Any = None
        self._driver = ""
        self._output = False

    def open(self, run: RunInfo) -> None:
        from pfpeople.io.run_dir import RunWriter

        meta = {
            "config": run.config.to_dict(),
            "grid_frame": run.grid_frame,
            "frames_in_grid": {k: [p.x, p.y, p.yaw] for k, p in run.frame_mounts.items()},
            "detector_models": [dataclasses.asdict(m) for m in run.detector_models],
            "provenance": {"bag": [str(p) for p in run.bag.paths], "bag_topics": run.bag.topics, **dict(run.metadata)},
        }
        if self.result_bag is not None:
            meta["result_bag"] = self.result_bag.describe(run)
        self._driver = run.config.driver
        self.writer = RunWriter(
            self.out_dir,
            spec=run.spec,
            detector_names=run.detector_names,
            metadata=meta,
            overwrite=self.overwrite,
            output_frame=run.output_frame,
        )
        self._output = bool(run.output_frame)

    def write(self, result: FrameResult) -> None:
        r, f = result, result.frame
        parts = getattr(r.step, "particles", None) if self.scans else None
        tracks = None if r.tracks is None else track_rows(f.index, f.stamp_ns, r.tracks)
        out: dict[str, Any] = {}
        if self._output:
            out, tracks = _output_columns(r, tracks)
        self.writer.write_frame(
            frame=f.index,
            driver_index=f.driver.index,
            stamp_ns=f.stamp_ns,
            bag_time_ns=f.bag_time_ns,
            dt_s=r.dt,
            odometry=r.odometry,
            forced=f.forced,
            belief=r.belief,
            people=r.people,
            people_size=r.people_size,
            people_probability=r.people_probability,
            detections=r.detections,
            tracks=tracks,
            static=r.static,
            support=r.support,
            support_static=r.support_static,
            scans=r.scans if self.scans else None,
            particles=None if parts is None else (parts.x, parts.y),
            **out,
        )

    def close(self, outcome: RunOutcome) -> None:
        """Write the status, error, statistics and the driver messages skipped by reason into ``run.json``."""
        if self.writer is None:
            return
        s = outcome.summary
        skipped = {
            reason: n
            for reason in ("clock_jump", "non_monotonic")
            if (n := s.sync.get(reason, {}).get(self._driver, 0))
        }
        self.writer.close(status=outcome.status, error=outcome.error, stats=s.as_dict(), skipped_frames=skipped)


def _output_columns(
    r: FrameResult, tracks: list[tuple[Any, ...]] | None
) -> tuple[dict[str, Any], list[tuple[Any, ...]] | None]:
    """The output-frame values of a frame (:mod:`pfpeople.pipeline.output_frame`): the run writer's ``output_pose``
    and ``people_out`` arguments, and the ``tracks.csv`` rows with their output-frame columns (NaN: no pose)."""
    pose = r.output_pose
    if pose is None:
        nan = (math.nan,) * 7
        return {}, None if tracks is None else [(*row, *nan) for row in tracks]
    out = {"output_pose": (pose.x, pose.y, pose.yaw), "people_out": positions_in(pose, r.people)}
    if tracks is None or r.tracks is None:
        return out, tracks
    moved = tracks_in(pose, r.tracks)
    rows = [
        (*row, t.x, t.y, t.vx, t.vy, float(t.covariance[0, 0]), float(t.covariance[0, 1]), float(t.covariance[1, 1]))
        for row, t in zip(tracks, moved, strict=True)
    ]
    return out, rows


def input_topics(run: RunInfo) -> dict[str, str]:
    """The input topics a result bag copies: the LaserScan topics the run reads and ``/tf``, ``/tf_static``.

    Returns topic -> message type; empty when the input is not a bag that can be opened again (no ``paths``).
    """
    from pfpeople.config import run_topics
    from pfpeople.io.bag.reader import LASER_TYPES, TF_TYPES

    if not getattr(run.bag, "paths", None):
        return {}
    have = run.bag.topics
    out = {t: have[t] for t in run_topics(run.config) if have.get(t) in LASER_TYPES}
    out.update({t: have[t] for t in ("/tf", "/tf_static") if have.get(t) in TF_TYPES})
    return out


class ResultBagSink:
    """A result bag (:mod:`pfpeople.io.bag.writer`): belief, people, detections and tracks of every frame, and the
    input.

    Header stamps of the results are the source scan's header stamp (the driver message's, also with
    ``time_source = "bag"``, where the frame stamps are record times); record times are the driver's. With
    ``with_input`` the input topics (:func:`input_topics`) are copied from a second reader of the input bag,
    each message up to the record time of the frame being written; when the run ends, a run that read the whole
    bag copies the rest of the input (e.g. another laser's scans recorded after the driver's last one), a run
    stopped early (``max_frames``, an interruption, a failure) the input of the frames it wrote (up to the
    latest record time of the messages its last frame used). The ``[mounts]`` the run used for frames without
    TF (:attr:`RunInfo.mount_links`) go on ``/tf_static``, so every laser is placed in the bag.

    Parameters
    ----------
    path : path
        A ROS 1 ``.bag`` or a rosbag2 folder; checked now (:func:`pfpeople.io.bag.writer.check_bag_out`), so a
        bad path fails before the run.
    bag_format : {"ros1", "mcap", "sqlite3"}, optional
        Default from the path.
    overwrite : bool
        Replace an existing bag.
    with_input : bool
        Copy the input scans and TF into the bag.
    """

    def __init__(
        self, path: str | Path, *, bag_format: str | None = None, overwrite: bool = False, with_input: bool = True
    ) -> None:
        from pfpeople.io.bag.writer import check_bag_out

        check_bag_out(path, bag_format, overwrite=overwrite)
        self.path = path
        self.bag_format = bag_format
        self.overwrite = overwrite
        self.with_input = with_input
        self.writer: Any = None
        self._output = False
        self._source: Any = None
        self._inputs: Any = None
        self._next: Any = None
        self._frames = 0
        self._max_frames: int | None = None
        self._used_until = -1  # latest record time (ns) of an input message of a frame written

    def describe(self, run: RunInfo) -> dict[str, Any]:
        """What the bag will hold (for ``run.json`` ``result_bag``): path, format, topics and types, renames."""
        from pfpeople.io.bag.writer import ROSBAG2_METADATA_VERSION, bag_format_for, detector_topics, output_topics

        fmt = bag_format_for(self.path, self.bag_format)
        inputs = input_topics(run) if self.with_input else {}
        topics, renamed = detector_topics(run.detector_names)
        return {
            "path": str(self.path),
            "format": fmt,
            "rosbag2_metadata_version": None if fmt == "ros1" else ROSBAG2_METADATA_VERSION,
            "topics": output_topics(run.detector_names, inputs),
            "input_topics": sorted(inputs),
            "detector_topics": topics,
            "renamed_topics": renamed,
        }

    def open(self, run: RunInfo) -> None:
        from pfpeople.io.bag.writer import ResultBagWriter

        inputs = input_topics(run) if self.with_input else {}
        self._output = bool(run.output_frame)
        self.writer = ResultBagWriter(
            self.path,
            spec=run.spec,
            frame_id=run.grid_frame,
            results_frame_id=run.output_frame or None,
            detector_names=run.detector_names,
            bag_format=self.bag_format,
            overwrite=self.overwrite,
            input_topics=inputs,
            static_transforms=run.mount_links,
        )
        self._max_frames = run.max_frames
        if inputs:
            self._source = BagSource(run.bag.paths)
            self._inputs = self._source.messages(inputs)
            self._next = next(self._inputs, None)

    def _copy_input(self, until_ns: float) -> None:
        """Copy the input messages recorded at or before ``until_ns``."""
        while self._next is not None and self._next.bag_time_ns <= until_ns:
            m = self._next
            self.writer.write_input(m.bag_time_ns, m.topic, m.msg)
            self._next = next(self._inputs, None)

    def write(self, result: FrameResult) -> None:
        from pfpeople.io.bag.reader import header_stamp_ns

        f = result.frame
        self._copy_input(f.bag_time_ns)
        stamp = header_stamp_ns(f.driver.msg) or f.stamp_ns
        people, tracks = results_in(result, output=self._output)  # none where the output frame's pose is unknown
        self.writer.write(
            f.bag_time_ns,
            stamp,
            result.belief,
            people,
            result.detections,
            tracks,
            people_reliability=result.people_probability
            if len(result.people_probability) == len(result.people)
            else None,
        )
        self._frames += 1
        used = [m.bag_time_ns for msgs in f.inputs.values() for m in msgs]
        self._used_until = max([self._used_until, f.bag_time_ns, *used])

    def close(self, outcome: RunOutcome) -> None:
        try:
            if self.writer is not None:
                whole = outcome.status == "complete" and (self._max_frames is None or self._frames < self._max_frames)
                self._copy_input(math.inf if whole else self._used_until)
                self.writer.close()
        finally:
            if self._source is not None:
                self._source.close()
                self._source = None


class ProgressSink:
    """A progress bar over the driver's messages (at most ``max_frames``); sparse lines when not on a terminal."""

    def __init__(self) -> None:
        self.bar: Any = None

    def open(self, run: RunInfo) -> None:
        from pfpeople.progress import progress_bar

        total = run.bag.message_counts.get(run.config.driver)
        limit = run.max_frames
        self.bar = progress_bar(total=total if limit is None or total is None else min(total, limit), unit="frame")

    def write(self, result: FrameResult) -> None:
        self.bar.update(1)

    def close(self, outcome: RunOutcome) -> None:
        if self.bar is not None:
            self.bar.close()


def standard_sinks(
    out_dir: str | Path | None,
    *,
    bag_out: str | Path | None = None,
    bag_format: str | None = None,
    overwrite: bool = False,
    progress: bool = False,
    with_input: bool = True,
    scans: bool = True,
) -> list[Sink]:
    """The sinks :meth:`pfpeople.pipeline.runner.Pipeline.run` writes by default, in order: the run directory
    (``out_dir``; with the scans and particles unless ``scans`` is False, see :class:`RunDirSink`), the result bag
    (``bag_out``, checked now; ``with_input``: the input scans and TF copied in), the progress bar
    (``progress``)."""
    sinks: list[Sink] = []
    bag_sink = (
        None
        if bag_out is None
        else ResultBagSink(bag_out, bag_format=bag_format, overwrite=overwrite, with_input=with_input)
    )
    if out_dir is not None:
        sinks.append(RunDirSink(out_dir, overwrite=overwrite, result_bag=bag_sink, scans=scans))
    if bag_sink is not None:
        sinks.append(bag_sink)
    if progress:
        sinks.append(ProgressSink())
    return sinks


def open_sinks(sinks: Sequence[Sink], run: RunInfo, opened: list[Sink]) -> None:
    """Open ``sinks`` in order, appending each one opened to ``opened``."""
    for sink in sinks:
        sink.open(run)
        opened.append(sink)


def close_sinks(sinks: Sequence[Sink], outcome: RunOutcome) -> None:
    """Close ``sinks`` in reverse order; every sink is closed even if another raises (the last error propagates)."""
    if not sinks:
        return
    try:
        sinks[-1].close(outcome)
    finally:
        close_sinks(sinks[:-1], outcome)
