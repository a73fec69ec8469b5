"""Free space seen by the lasers: a coasting track whose place a laser sees through is not reported.

A track that gets no hit coasts at its constant-velocity prediction (:class:`~pfpeople.track.multi_person.
MultiPersonTracker`) and is reported for up to ``report_coast_s``. Two reasons leave a person undetected: the
detectors missed them (their legs are there in the scan), or the person is not where the track predicts (they
left, stopped or turned; the scan shows what is behind the place). A laser tells the two apart: when every beam
within ``half_width`` (m, across the line of sight) of the predicted position returns at least ``margin`` (m)
behind it, or reports no return (``+inf``, REP-117), the laser sees through the place and nobody is there. A
person hidden behind someone else stays reported: the beams stop in front of the place.

How ``half_width`` was chosen: ``docs/ablations.md``, "Seen through".

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
        lo_range, hi_range = float(scan.range_min), float(scan.range_max)
        for i in (~out & (r > 1e-6) & (r <= scan.range_max)).nonzero()[0].tolist():
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
            # every beam usable (no return: +inf; or a valid range, LaserScan.valid, at least range_min) and
            # returning at least margin behind: the beams' tests in Python floats (the same comparisons)
            behind = float(r[i]) + margin
            out[i] = all(
                (v == math.inf or (math.isfinite(v) and lo_range <= v <= hi_range)) and v >= behind
                for v in ranges[lo : hi + 1].tolist()
            )
    return out
