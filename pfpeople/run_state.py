"""What the parts of a bag run share: one processed frame, the run's counts, and warn-once logging.

:class:`FrameResult` is what :class:`pfpeople.pipeline.runner.Pipeline` yields per frame and what every sink
(:mod:`pfpeople.pipeline.sinks`) writes; :class:`RunSummary` collects the counts that the detector adapters
(:mod:`pfpeople.detect.adapters`), the odometry integrator (:mod:`pfpeople.perception.odometry`) and the clutter stage
(:mod:`pfpeople.pipeline.clutter_stage`) add to during a run (written to ``run.json`` as ``stats``); :class:`WarnOnce`
logs a condition the first time it happens in a run (the count says how often).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge.ego_motion import Odometry
from gridbridge.geometry import Pose2D
from pfpeople.io.bag.sync import Frame

__all__ = ["EGO_SOURCES", "FrameResult", "RunSummary", "WarnOnce", "count"]


@dataclass(frozen=True, kw_only=True, eq=False)
class FrameResult:
    """One processed frame: detections in the grid frame (None: no data), belief, classified people.

    Attributes
    ----------
    frame : Frame
        The synchronised input frame.
    dt : float
        Time step of the filter (s).
    odometry : Odometry or None
        Controls of the ego-motion step (m/s, rad/s; None: the robot was taken as standing).
    detections : list of ndarray (M_k, 2) or None
        Positions (m, grid frame) per detector, in the configuration's order; None: no data in the frame.
    belief : ndarray, shape (nx, ny)
        Posterior probability of a person per cell.
    people : ndarray, shape (P, 2)
        Classified people (m, grid frame).
    people_size, people_probability : list
        Cells and mean probability of each person.
    step : object
        The filter's step result (posterior, covered cells, ...).
    tracks : list or None
        Confirmed tracks (:mod:`pfpeople.track`) when tracking is on.
    static : list of ndarray (M_k,) of bool or None
        Per detector, the detections the static-clutter map suppressed (None: no suppression).
    support : list of ndarray (S_k, 2) or None, or None
        Per detector, its support positions (m, grid frame; the laser detectors' single legs) when the tracker
        was given support; None: it was not.
    support_static : list of ndarray (S_k,) of bool or None, or None
        Per detector, which support positions the static-clutter map called static (the tracker did not get them).
    scans : dict of str to (ndarray (N, 2), ndarray (N,) of bool or None)
        Per laser topic, its scan's valid end points (m, grid frame) and which of them lie in a cell its
        static-clutter map calls static (None: the topic has no map); empty when the run has no laser.
    output_pose : Pose2D or None
        With ``[output] frame``, the grid frame's pose in the output frame at the frame's stamp (None: no output
        frame, or unknown there; :mod:`pfpeople.pipeline.output_frame`).
    """

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
    support: list[NDArray[np.float64] | None] | None = None
    support_static: list[NDArray[np.bool_] | None] | None = None
    scans: dict[str, tuple[NDArray[np.float64], NDArray[np.bool_] | None]] = field(default_factory=dict)
    output_pose: Pose2D | None = None


#: The keys of :attr:`RunSummary.ego_motion`: where a frame's ego-motion came from.
EGO_SOURCES = ("odometry", "scan_matching", "none")


def _ego_counts() -> dict[str, int]:
    return dict.fromkeys(EGO_SOURCES, 0)


@dataclass
class RunSummary:
    """Counts of a run (also written to ``run.json`` as ``stats``).

    ``ego_motion`` counts the frames by where the filter's ego-motion came from: ``odometry`` (the odometry
    topic), ``scan_matching`` (the driving laser's scan matcher, ``[clutter] laser_odometry``; the same frames
    as ``laser_odometry_frames``) or ``none`` (the robot was taken as standing: no odometry in the frame, a
    failed or skipped scan match, or the first frame of the run or after a restart, which have no previous
    frame); the three add up to the frames processed.

    ``bad_scans`` counts, per detector and reason (``beam_count``, ``span``, ``no_return``: see
    :class:`pfpeople.io.bag.reader.BadScanError`), the LaserScans refused for contradicting their angles or holding
    no usable range; they are in ``bad_messages`` and ``no_data`` too.

    ``max_lateral_m`` is the largest sideways displacement (m) of the grid frame in one step (the chord across
    the step's mean heading, :func:`pfpeople.perception.odometry.odometry_between`), large for a driving laser mounted
    off the robot's rotation axis and yawed. Informative: the filters apply it (``Odometry.vy``, ``vy_mps`` in
    ``frames.csv``).

    ``odometry_jumps`` counts the odometry steps too fast to be motion
    (:func:`pfpeople.perception.odometry.is_odometry_jump`:
    a reset or relocalised odometry); each restarted the filter and is also in ``filter_restarts``.
    ``odometry_other_child`` counts the odometry messages whose child frame is not the base frame (used as the
    base frame's pose; :mod:`pfpeople.perception.odometry`). ``mount_changes`` counts, per TF edge ``"parent -> child"``
    of the run's mounts, the transforms during the run off the value read before it (a panning or moving mount;
    :class:`pfpeople.io.bag.tf.MountWatch`). The run follows them (:mod:`pfpeople.pipeline.mounts`): ``mounts_followed``
    counts, per detector, the frames placed with a mount other than the one read before the run;
    ``frame_id_changes`` the messages in a frame other than the detector's first one (each placed by its own
    frame's mount), ``frame_id_unplaced`` those of them TF does not place (no data). ``bad_transforms`` counts, per
    TF edge, the transforms read during the run that were broken (NaN, a zero quaternion) and left out.
    ``fov_narrowed`` counts, per detector, the frames whose scan covered less than its field of view (the cells
    outside what it covered got no update: :mod:`pfpeople.pipeline.views`).

    ``suppressed`` counts, per detector, the detections the static-clutter map called static; ``readmitted`` those
    of them the filter saw all the same, at the place a tracked person stopped
    (:mod:`pfpeople.track.stopped_people`). ``arrived`` counts the detections on places the map has seen occupied
    long enough to be static that it lets through all the same, because the laser saw through most of their returns
    within the last second, or (a detector with ``hold_arrivals``) one of its detections arrived within 0.3 m in the
    last 2 s (:mod:`pfpeople.perception.arrivals`); they are not in ``suppressed``.

    ``blas_threads`` is the most threads a BLAS library of the run's process would use while the frames ran
    (:mod:`pfpeople.pipeline.blas`: 1 by default; 0: no BLAS library found), ``front_blas_threads`` the same in the
    front end's process (:mod:`pfpeople.pipeline.front_end`; the run's own process when there is one).

    ``output_unplaced`` (only with ``[output] frame``; None otherwise, and then not in ``run.json``) counts the
    frames whose results could not be placed in the output frame (:mod:`pfpeople.pipeline.output_frame`).
    """

    frames: int = 0
    elapsed_s: float = 0.0
    no_data: dict[str, int] = field(default_factory=dict)
    empty_scans: dict[str, int] = field(default_factory=dict)
    bad_messages: dict[str, int] = field(default_factory=dict)
    bad_scans: dict[str, dict[str, int]] = field(default_factory=dict)
    frames_without_odometry: int = 0
    filter_restarts: int = 0
    odometry_jumps: int = 0
    odometry_other_child: int = 0
    mount_changes: dict[str, int] = field(default_factory=dict)
    mounts_followed: dict[str, int] = field(default_factory=dict)
    frame_id_changes: dict[str, int] = field(default_factory=dict)
    frame_id_unplaced: dict[str, int] = field(default_factory=dict)
    bad_transforms: dict[str, int] = field(default_factory=dict)
    fov_narrowed: dict[str, int] = field(default_factory=dict)
    max_lateral_m: float = 0.0
    suppressed: dict[str, int] = field(default_factory=dict)
    readmitted: dict[str, int] = field(default_factory=dict)
    arrived: dict[str, int] = field(default_factory=dict)
    laser_odometry_frames: int = 0
    ego_motion: dict[str, int] = field(default_factory=_ego_counts)
    sync: dict[str, dict[str, int]] = field(default_factory=dict)
    blas_threads: int = 0
    front_blas_threads: int = 0
    error: str | None = None
    output_unplaced: int | None = None

    @property
    def fps(self) -> float:
        return self.frames / self.elapsed_s if self.elapsed_s > 0 else math.nan

    def as_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        if self.output_unplaced is None:
            del out["output_unplaced"]
        out["fps"] = self.fps
        return out


def count(table: dict[str, int], name: str, n: int = 1) -> None:
    """Add ``n`` to ``table[name]`` (a :class:`RunSummary` count per detector or topic)."""
    table[name] = table.get(name, 0) + n


class WarnOnce:
    """Log a warning the first time a key is seen (the conditions it reports are counted, not repeated).

    Parameters
    ----------
    logger : logging.Logger
        Where the warnings go.
    """

    def __init__(self, logger: logging.Logger) -> None:
        self.logger = logger
        self.seen: set[str] = set()

    def __call__(self, key: str, msg: str, *args: object, logger: logging.Logger | None = None) -> None:
        """Warn ``msg % args`` unless ``key`` was warned before (to ``logger``, default the instance's)."""
        if key not in self.seen:
            self.seen.add(key)
            (logger or self.logger).warning(msg, *args)
