"""The back end of a frame: the filter step, the classification of the belief and the tracker.

On a frame's front-end result (:class:`pfpeople.pipeline.front.FrontResult`):

1. the detectors are given the mounts the front end placed them with and the fields of view their scans covered,
   and the filter's detector models too (:func:`pfpeople.pipeline.views.follow_views`); a restart resets the
   filter, the classifier and the tracker;
2. the static detections at the place a tracked person stopped are readmitted
   (:mod:`pfpeople.track.stopped_people`, counted in ``readmitted``);
3. the filter step (``GridFilter`` or ``ParticleFilter``, one ``step`` signature), the classification of the belief
   (:func:`gridbridge.classifiers.classify_frame`), the tracker and the people it confirms
   (:mod:`pfpeople.track.reported_people`, ``[tracking] people``): one
   :class:`~pfpeople.run_state.FrameResult`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge.classifiers import classify_frame
from gridbridge.filter import BeliefFilter
from gridbridge.grid import GridSpec
from gridbridge.validation import finite_rows
from pfpeople.detect.adapters import Detections, DetectorAdapter
from pfpeople.io.bag.sync import Frame
from pfpeople.pipeline.front import FrontResult
from pfpeople.pipeline.views import follow_views
from pfpeople.run_state import FrameResult, RunSummary, WarnOnce, count
from pfpeople.sensors import LaserScan, Pose2D
from pfpeople.track.reported_people import point_like, support_positions
from pfpeople.track.stopped_people import StoppedPeople

__all__ = ["BackEnd"]

Positions = list[NDArray[np.float64] | None]


class BackEnd:
    """A frame's back end (see the module docstring); call it on each frame's front-end result in order.

    Parameters
    ----------
    adapters : sequence of DetectorAdapter
        The run's detectors (their names, topics and models; their mounts follow the front end's).
    spec : GridSpec
        The grid.
    filter : BeliefFilter
        The filter.
    classifier : object
        Belief -> people (:mod:`gridbridge.classifiers`).
    tracker : object or None
        The tracker and the people it confirms (:class:`pfpeople.track.reported_people.PeopleTracker`; None: off).
    stopped : StoppedPeople or None
        The anchors of the tracks that walked and stopped (None: no tracker or no static-clutter map).
    summary : RunSummary
        The run's counts (``frames``, ``readmitted``, ``fov_narrowed``).
    warn : WarnOnce
        The run's warn-once logger.
    """

    def __init__(
        self,
        adapters: Sequence[DetectorAdapter],
        *,
        spec: GridSpec,
        filter: BeliefFilter,
        classifier: Any,
        tracker: Any,
        stopped: StoppedPeople | None,
        summary: RunSummary,
        warn: WarnOnce,
    ) -> None:
        self.adapters = list(adapters)
        self.spec = spec
        self.filter = filter
        self.classifier = classifier
        self.tracker = tracker
        self.stopped = stopped
        self.summary = summary
        self.warn = warn

    @property
    def models(self) -> list[Any]:
        """The detectors' models, in the configuration's order."""
        return [a.model for a in self.adapters]

    def __call__(self, frame: Frame, front: FrontResult) -> FrameResult:
        """The filter, the classifier and the tracker on ``front``, the front end's result for ``frame``."""
        motion, found = front.motion, front.found
        follow_views(self.adapters, front.mounts, front.found, self.filter, self.summary, self.warn)
        if motion.restarted:
            self.filter.reset()
        dets, static = self._readmit(front)
        step = self.filter.step(dets, motion.odometry, motion.dt)
        belief = np.asarray(step.posterior, dtype=float)
        if motion.restarted and hasattr(self.classifier, "reset"):
            self.classifier.reset()
        observed = np.asarray(step.covered).any(axis=0)
        people_found = classify_frame(self.classifier, belief, self.spec, observed=observed, ego=motion.motion)
        tracks, support = None, None
        if self.tracker is not None:
            people_found, tracks, support = self._track(front, people_found, belief, observed, dets)
        self.summary.frames += 1
        return FrameResult(
            frame=frame,
            dt=motion.dt,
            odometry=motion.odometry,
            detections=[None if f is None else f.grid for f in found],
            static=static,
            belief=belief,
            people=people_found.positions.reshape(-1, 2),
            people_size=[int(v) for v in people_found.sizes],
            people_probability=[float(v) for v in people_found.scores],
            step=step,
            tracks=tracks,
            support=support,
            support_static=None if support is None else front.support_static,
            scans=self._scans(front),
            output_pose=front.output_pose,
        )

    def _track(
        self, front: FrontResult, people_found: Any, belief: NDArray[np.float64], observed: Any, dets: Positions
    ) -> tuple[Any, list[Any], Positions | None]:
        """The tracker's step: the people it reports, its tracks and the support positions it was given."""
        motion, found = front.motion, front.found
        if motion.restarted:
            self.tracker.reset()
        kept_support, support = None, None
        if self.tracker.use_support:
            support = [None if f is None else f.support for f in found]
            kept_support = support_positions(support, front.support_static)
        models = self.models
        tracked = self.tracker.step(
            people_found,
            belief,
            self.spec,
            motion.dt,
            observed=observed,
            ego=motion.motion,
            support=kept_support,
            detections=support_positions([_xy(d) for d, m in zip(dets, models, strict=True) if point_like(m)]),
            views=self._laser_views(found) if self.tracker.see_through else None,
        )
        if self.stopped is not None:
            let_through = [_xy(d) for d, m in zip(front.dets, models, strict=True) if point_like(m)]
            self.stopped.update(tracked.live, support_positions(let_through))
        return tracked.people, tracked.tracks, support

    def _readmit(self, front: FrontResult) -> tuple[Positions, list[NDArray[np.bool_] | None]]:
        """The detections the filter sees and the static flags, the static detections at a stopped person's
        anchor (:mod:`pfpeople.track.stopped_people`, its anchors moved into this frame first) readmitted (counted
        in ``readmitted``)."""
        stopped = self.stopped
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
            static[k], dets[k] = flags, f.fused[~flags]
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


def _xy(detections: NDArray[np.float64] | None) -> NDArray[np.float64] | None:
    """The positions ``(M, 2)`` of a filter entry (``(M, 2)``, or ``(M, 3)`` with each detection's PPV)."""
    return None if detections is None else detections[:, :2]
