"""Free space seen by the lasers: a coasting track whose place a laser sees through is not reported.

A track that gets no hit coasts at its constant-velocity prediction (:class:`~pfpeople.mot.tracker.
MultiPersonTracker`) and is reported for up to ``report_coast_s``. Two reasons leave a person undetected: the
detectors missed them (their legs are there in the scan), or the person is not where the track predicts (they
left, stopped or turned; the scan shows what is behind the place). A laser tells the two apart: when every beam
within ``half_width`` (m, across the line of sight) of the predicted position returns at least ``margin`` (m)
behind it, or reports no return (``+inf``, REP-117), the laser sees through the place and nobody is there. A
person hidden behind someone else stays reported: the beams stop in front of the place.

``half_width = 0.5`` m (a person's half width and the prediction's error) was chosen with ``pfpeople run`` on the
scan-level scenes, one run per value (MOTA / identity switches of ``tracks.csv`` on wheelchair / corridor /
crowd; issue 10): off .568 / 24, .845 / 4, .698 / 20; 0.3 m .561 / 24, .845 / 4, .726 / 20; **0.5 m** .569 / 24,
.845 / 4, .727 / 20; 0.7 m .570 / 24, -, .726 / 20. At 0.3 m the crowd lost 262 false and 16 true track frames,
the wheelchair scene 8 false and 23 true ones: there the coasting prediction was 0.4-0.64 m from its person,
within the 0.75 m match gate, and the beams beside the person saw through. On the crowd's people that a laser
sees (``[hit_beams>=3]``) MOTA rises from .745 to .780. The followed person of person_following_outdoor_1 and
negative_2 did not change; the ETH/UCY replays have no scans.

Positions are in the grid frame (m); each view is a :class:`~pfpeople.sensors.LaserScan` with the pose of its
laser frame in the grid frame. A place outside a scan's field of view or beyond its ``range_max``, or a beam
window with an invalid return (NaN, below ``range_min``), says nothing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfpeople.sensors import LaserScan, Pose2D

__all__ = ["LaserView", "seen_through"]

#: One laser's scan of this frame and the pose of its laser frame in the grid frame.
LaserView = tuple[LaserScan, Pose2D]


def seen_through(
    positions: ArrayLike, views: Sequence[LaserView], *, half_width: float = 0.5, margin: float = 0.5
) -> NDArray[np.bool_]:
    """Whether some laser sees through each position (see the module docstring).

    Parameters
    ----------
    positions : array_like, shape (N, 2)
        Places (m, grid frame).
    views : sequence of (LaserScan, Pose2D)
        The lasers of this frame, each with the pose of its frame in the grid frame.
    half_width : float
        Half the width (m) across the line of sight whose beams are looked at (a person's half width).
    margin : float
        A beam sees through a place when it returns at least this much (m) farther.

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    pts = np.asarray(positions, dtype=float).reshape(-1, 2)
    out = np.zeros(pts.shape[0], dtype=bool)
    for scan, mount in views:
        if not pts.shape[0] or out.all():
            break
        local = mount.inverse().apply(pts)
        r = np.hypot(local[:, 0], local[:, 1])
        bearing = np.arctan2(local[:, 1], local[:, 0])
        ranges = np.asarray(scan.ranges, dtype=float)
        n = ranges.size
        inc = float(scan.angle_increment)
        if n == 0 or inc == 0.0:
            continue
        with np.errstate(invalid="ignore"):
            usable = np.isposinf(ranges) | (scan.valid & (ranges >= scan.range_min))
        for i in np.flatnonzero(~out & (r > 1e-6) & (r <= scan.range_max)).tolist():
            half = math.atan2(half_width, float(r[i]))
            # the bearing from the first beam, in the scan's direction (a 360 deg scan may start anywhere)
            if inc > 0:
                rel = (float(bearing[i]) - scan.angle_min) % (2.0 * math.pi)
            else:
                rel = -((scan.angle_min - float(bearing[i])) % (2.0 * math.pi))
            # beam indices whose bearing lies within [bearing - half, bearing + half]
            k0 = (rel - half) / inc
            k1 = (rel + half) / inc
            lo, hi = math.ceil(min(k0, k1) - 1e-9), math.floor(max(k0, k1) + 1e-9)
            if lo < 0 or hi >= n or hi < lo:  # (partly) outside the field of view
                continue
            window = ranges[lo : hi + 1]
            out[i] = bool(usable[lo : hi + 1].all() and np.all(window >= r[i] + margin))
    return out
