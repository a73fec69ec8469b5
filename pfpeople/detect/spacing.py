"""The beam spacing the laser detectors are built for, and dense scans thinned to it.

The leg, boosted and single-legs detectors describe a segment of the scan by features of neighbouring beams
(:mod:`pfpeople.detect.segments`: curvature, inscribed angle, circularity, linearity), and their thresholds and the
boosted model were set on lasers of 0.25-0.5 deg. On a much denser scan the range noise between neighbouring beams
(1-3 cm for common lasers) dominates those features and the detectors go blind: two people at 2 and 3 m, 1 cm of
range noise, the leg detector found 1.3 people a scan at 0.25 deg, 0.2 at 0.1 deg; the boosted detector 2 at 0.1 deg,
1 at 0.02 deg and none at 0.005 deg without noise.

So a scan whose spacing is finer than :data:`FINEST_SPACING_DEG` reaches the detectors thinned to every ``k``-th beam,
``k = round(TARGET_SPACING_DEG / spacing)`` (:func:`detector_scan`): 0.1 deg becomes 0.3 deg, 0.005 deg every 60th
beam; the same scans found 1.4 and 2 people. Lasers of 0.2 deg and coarser are given to the detectors as they are
(the common 0.25 deg ones included). Only the detectors see the thinned scan: the static-clutter map, scan matching
and ``scans.npy`` keep every beam. A run warns once per topic naming the spacing and ``k``
(:func:`pfpeople.pipeline.sensor_setup.warn_dense_lasers`).
"""

from __future__ import annotations

import math
from dataclasses import replace

from pfpeople.sensors import LaserScan

__all__ = ["FINEST_SPACING_DEG", "TARGET_SPACING_DEG", "detector_scan", "thinning"]

#: Scans with a finer beam spacing (deg) than this are thinned for the detectors.
FINEST_SPACING_DEG = 0.2
#: The spacing (deg) a thinned scan gets, about (the lasers the detectors were built on: 0.25-0.5 deg).
TARGET_SPACING_DEG = 0.3

#: The latest (scan, thinned scan) of :func:`detector_scan`: the detectors of one laser get the same object, so they
#: share its segmentation (:func:`pfpeople.detect.segments.scan_segments`).
_LATEST: tuple[LaserScan, LaserScan] | None = None


def thinning(angle_increment: float) -> int:
    """Every how many beams a scan of spacing ``angle_increment`` (rad; its sign ignored) reaches the detectors: 1 for
    :data:`FINEST_SPACING_DEG` and coarser, else ``round(TARGET_SPACING_DEG / spacing)``."""
    spacing = math.degrees(abs(angle_increment))
    if spacing == 0.0 or spacing >= FINEST_SPACING_DEG:
        return 1
    return max(1, round(TARGET_SPACING_DEG / spacing))


def detector_scan(scan: LaserScan) -> LaserScan:
    """``scan`` as the laser detectors get it: itself, or every :func:`thinning`-th beam from the first (the same
    bearings, ``angle_increment`` times ``k``); the latest result is kept by the scan's identity."""
    global _LATEST
    k = thinning(scan.angle_increment)
    if k == 1:
        return scan
    latest = _LATEST
    if latest is not None and latest[0] is scan:
        return latest[1]
    thinned = replace(scan, ranges=scan.ranges[::k].copy(), angle_increment=scan.angle_increment * k)
    _LATEST = (scan, thinned)
    return thinned
