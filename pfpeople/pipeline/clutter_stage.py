"""The run's static-clutter stage: one :class:`pfpeople.perception.clutter_map.ClutterSuppressor` per laser topic.

Each laser topic with a detector has its own static-clutter map (:mod:`pfpeople.perception.clutter_map`), kept in the
laser's frame: the grid-frame ego-motion ``E`` (from odometry) becomes ``T^-1 E T`` with ``T`` the laser's mount in
the grid frame. Each map keeps the people its detectors saw moving out of itself
(:class:`pfpeople.perception.clutter_map.MovingPeople`).
A detection the map calls static, or whose nearest return is the robot's own (:mod:`pfpeople.perception.self_returns`),
is suppressed: the filter does not see it (it is still written, with ``static = 1``, and counted in
``suppressed``), unless it *arrived*: one of the laser's scans of the last second saw through most of its returns
(:mod:`pfpeople.perception.arrivals`; a person who stands sways, furniture does not), or a detection of a detector
with ``[[detectors]] hold_arrivals`` arrived within 0.3 m in the last 2 s (the place is held), counted in ``arrived``.
Without odometry, a laser's map takes the laser's motion from scan matching: the driving laser's from the
run's ego-motion stage (:mod:`pfpeople.pipeline.ego_stage`, which matched it before the detectors ran; a failed
or skipped match forgets the map), the other lasers' from their maps' own scan matchers.
The detectors' support positions (single legs, :class:`pfpeople.detect.adapters.Detections`) that are suppressed so
are dropped as well (:attr:`ClutterStage.support_static`); they never enter the map or its moving-people sets.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D
from pfpeople.config import BagConfig
from pfpeople.detect.adapters import Detections, DetectorAdapter
from pfpeople.perception.arrivals import RecentScans
from pfpeople.perception.scan_matching import EgoMatch
from pfpeople.run_state import RunSummary, count

__all__ = ["ClutterStage"]

#: No positions (read only): a detector without support positions in a frame.
_NONE = np.zeros((0, 2))
_NONE.setflags(write=False)


class ClutterStage:
    """Static-clutter suppression of the laser detections of a run (see the module docstring).

    Parameters
    ----------
    config : BagConfig
        The run's configuration (``[clutter]``, ``[filter] mode``, the driver topic).
    adapters : sequence of DetectorAdapter
        The run's detectors, in the configuration's order (laser ones get a map per topic).
    summary : RunSummary
        Where ``suppressed`` is counted (per detector).

    Raises
    ------
    ValueError
        If ``[clutter.params]`` are not :class:`pfpeople.perception.clutter_map.ClutterConfig` fields.
    """

    def __init__(self, config: BagConfig, adapters: Sequence[DetectorAdapter], summary: RunSummary) -> None:
        self.config = config
        self.adapters = list(adapters)
        self.summary = summary
        self.suppressors: dict[str, Any] = {}
        #: Per detector, after :meth:`step`: which of its support positions the map calls static (None: no data or
        #: no map).
        self.support_static: list[NDArray[np.bool_] | None] = []
        #: Per laser topic with a map, after :meth:`step`: which of its scan's end points (``LaserScan.points()``
        #: rows, NaN ones included) lie in a cell the map calls static (``StaticClutterMap.static_points``).
        self.scan_static: dict[str, NDArray[np.bool_]] = {}
        c = config
        if c.clutter.enabled:
            from pfpeople.perception.clutter_map import ClutterConfig, ClutterSuppressor

            try:
                ccfg = ClutterConfig(**dict(c.clutter.params))
            except TypeError as exc:
                raise ValueError(f"[clutter.params]: {exc}") from None
            for a in self.adapters:
                if a.laser and a.config.topic not in self.suppressors:
                    self.suppressors[a.config.topic] = ClutterSuppressor(ccfg)
        #: Per laser topic with a map, its scans of the last second (:mod:`pfpeople.perception.arrivals`).
        self.recent = {topic: RecentScans() for topic in self.suppressors}

    @property
    def active(self) -> bool:
        """True when some laser topic has a map."""
        return bool(self.suppressors)

    def reset(self) -> None:
        """Forget every map (the filter restarts after a gap)."""
        for sup in self.suppressors.values():
            sup.map.forget()
        for recent in self.recent.values():
            recent.clear()

    def step(
        self,
        found: Sequence[Detections | None],
        ego_grid: Pose2D | None,
        dt: float,
        stamp_ns: int,
        driver_match: EgoMatch | None = None,
    ) -> tuple[list[NDArray[np.float64] | None], list[NDArray[np.bool_] | None]]:
        """Update the maps with the frame's scans and suppress the static detections.

        Parameters
        ----------
        found : sequence of Detections or None
            Per detector, its output in the frame (None: no data).
        ego_grid : Pose2D or None
            The grid frame's motion since the previous frame, from odometry (None: unknown).
        dt : float
            Time step (s).
        stamp_ns : int
            Frame stamp (ns).
        driver_match : EgoMatch, optional
            The driving laser's scan match of this frame (laser frame), given when ``ego_grid`` is None and the
            driving laser's map steps in this frame.

        Returns
        -------
        detections : list of ndarray (M_k, 2) or (M_k, 3), or None
            The grid-frame detections the filter sees (static ones removed; :attr:`Detections.fused`).
        static : list of ndarray (M_k,) of bool or None
            Per detector, which of its detections were suppressed (None: not a suppressed laser detector).

        Raises
        ------
        RuntimeError
            If the driving laser's map steps without an ego-motion (``ego_grid`` and ``driver_match`` None): the
            ego-motion stage and this stage disagree on whether it steps (a bug).
        """
        kept: list[NDArray[np.float64] | None] = [None if f is None else f.fused for f in found]
        static: list[NDArray[np.bool_] | None] = [None] * len(found)
        self.support_static = [None] * len(found)
        self.scan_static = {}
        scans = {
            a.config.topic: f.scan
            for a, f in zip(self.adapters, found, strict=True)
            if f is not None and f.scan is not None
        }
        for topic, sup in self.suppressors.items():
            match = driver_match if topic == self.config.driver else None
            self._step_topic(topic, sup, scans.get(topic), found, (ego_grid, match), dt, stamp_ns, kept, static)
        return kept, static

    def _step_topic(
        self,
        topic: str,
        sup: Any,
        scan: Any,
        found: Sequence[Detections | None],
        egos: tuple[Pose2D | None, EgoMatch | None],
        dt: float,
        stamp_ns: int,
        kept: list[NDArray[np.float64] | None],
        static: list[NDArray[np.bool_] | None],
    ) -> None:
        """:meth:`step` for one laser ``topic``, its map ``sup``
        (:class:`pfpeople.perception.clutter_map.ClutterSuppressor`)
        and its scan (:class:`pfpeople.sensors.LaserScan`; None: none in the frame): fills ``kept`` and ``static``
        of its detectors in place. ``egos``: the grid frame's motion from odometry and the laser's scan match from
        the ego-motion stage (None, None: the map matches the scan itself)."""
        idx = [k for k, a in enumerate(self.adapters) if a.config.topic == topic and found[k] is not None]
        if scan is None or not idx:
            return
        mount = self.adapters[idx[0]].mount  # the laser's pose in the grid frame
        ego_grid, match = egos
        ego, ego_ok = None, True
        if ego_grid is not None:
            ego = mount.inverse().compose(ego_grid).compose(mount)
        elif topic == self.config.driver:
            if match is None:
                raise RuntimeError(f"the static-clutter map of the driving laser {topic!r} got no ego-motion")
            ego, ego_ok = match.ego, match.ok
        points = scan.points()  # once: the map's update and its static returns
        st = sup.step(
            points,
            [f.sensor for k in idx if (f := found[k]) is not None],
            ego=ego,
            ego_ok=ego_ok,
            stamp_ns=stamp_ns,
            dt=dt,
            free=scan.free_rays(sup.map.config.max_range),
        )
        self.scan_static[topic] = sup.map.static_points(points)
        recent = self.recent[topic]
        if not st.ego_ok:
            recent.clear()
        self._arrivals(idx, st.keep, found, recent, points, sup.map.pose, stamp_ns)
        recent.add(scan, sup.map.pose, stamp_ns)
        for k, keep in zip(idx, st.keep, strict=True):
            static[k] = ~keep
            kept[k] = self._keep(k, keep, kept[k])
        if self.config.tracking.single_legs:  # only such a tracker needs the support positions' static flags
            support = [f.support_sensor if (f := found[k]) is not None and len(f.support) else _NONE for k in idx]
            for k, flags in zip(idx, sup.clutter_flags(support), strict=True):  # one query of them all
                self.support_static[k] = flags

    def _arrivals(
        self,
        idx: Sequence[int],
        keeps: Sequence[NDArray[np.bool_]],
        found: Sequence[Detections | None],
        recent: RecentScans,
        points: NDArray[np.float64],
        pose: Pose2D,
        stamp_ns: int,
    ) -> None:
        """The static detections (``~keeps[i]``) of the topic's detectors ``idx`` that arrived (``recent``, asked once
        for them all; ``points`` and ``pose``: the scan's end points and laser frame in the map frame) are kept
        (``keeps`` set in place) and counted in ``arrived``."""
        static = [np.flatnonzero(~keep) for keep in keeps]
        sizes = [len(s) for s in static]
        if not any(sizes):
            return
        dets = [f.sensor[s] for k, s in zip(idx, static, strict=True) if (f := found[k]) is not None]
        precise = [self.adapters[k].config.hold_arrivals for k in idx]  # their arrivals are held
        holdable = np.concatenate([np.full(len(s), p) for s, p in zip(static, precise, strict=True)])
        came = recent.arrived(np.concatenate(dets), points, pose, stamp_ns, holdable)
        start = 0
        for k, keep, s in zip(idx, keeps, static, strict=True):
            mine, start = came[start : start + len(s)], start + len(s)
            keep[s[mine]] = True
            count(self.summary.arrived, self.adapters[k].config.name, int(np.count_nonzero(mine)))

    def _keep(self, k: int, keep: NDArray[np.bool_], grid: NDArray[np.float64] | None) -> NDArray[np.float64] | None:
        """Detector ``k``'s detections (grid frame) less the suppressed ones, counted."""
        count(self.summary.suppressed, self.adapters[k].config.name, int(np.count_nonzero(~keep)))
        return grid[keep] if grid is not None and len(grid) else grid
