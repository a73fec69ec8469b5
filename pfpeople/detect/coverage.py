"""The sector a LaserScan covers, and a laser detector's field of view in one frame.

A laser detector's model has the field of view of its configuration (``[detectors.model] fov_min, fov_max``, by
default its first LaserScan's ``angle_min .. angle_max``). A later scan may cover less: a driver that narrows its
scans (a consistent ``angle_min`` and beam count over a smaller sector), or a scan of one beam. Where that scan has no
beam, nothing was seen: a cell there must get no update, not "nobody detected" (which drove a person's belief from
0.99 to 0.02 in 6 frames). So each scan gives its detectors the field of view it covers (:func:`frame_view`):

- a scan covers the bearings of its beams, each beam the half spacing on either side of its bearing
  (:func:`scan_sector`: ``[first - |inc| / 2, last + |inc| / 2]``, whatever the sign of the increment);
- the frame's field of view is the configured one intersected with that sector (a wider scan does not widen it);
- a scan narrower by at most one beam spacing on each side is the configured view (drivers differ by one beam on
  whether ``angle_max`` is the last bearing); a scan spanning a full turn covers any view;
- a scan whose sector and the view do not overlap by more than that covers nothing: the detector has no data in the
  frame (:class:`pfpeople.io.bag.reader.BadScanError`, reason ``"sector"``).

The run counts the frames a detector's view was narrowed (``stats.fov_narrowed``) and warns once per detector
(:mod:`pfpeople.pipeline.views`).
"""

from __future__ import annotations

import math

from pfpeople.sensors import LaserScan

__all__ = ["FULL_TURN", "frame_view", "scan_sector"]

FULL_TURN = 2.0 * math.pi
_EPS = 1e-9


def scan_sector(scan: LaserScan) -> tuple[float, float]:
    """``(lowest, highest)`` bearing (rad, the scan's frame) the beams of ``scan`` cover, half a spacing beyond the
    first and the last; a width of 0 for one beam with a spacing of 0."""
    n = scan.ranges.size
    inc = abs(scan.angle_increment)
    first, last = scan.angle_min, scan.angle_min + scan.angle_increment * max(n - 1, 0)
    return min(first, last) - inc / 2, max(first, last) + inc / 2


def _overlap(view: tuple[float, float], sector: tuple[float, float]) -> tuple[float, float]:
    """The intersection of ``view`` with ``sector`` turned by the whole turn that overlaps it most (bearings of
    one direction differ by turns); ``(lo, hi)`` with ``hi <= lo`` for none."""
    best = (0.0, 0.0)
    for turns in (-1, 0, 1):
        lo = max(view[0], sector[0] + turns * FULL_TURN)
        hi = min(view[1], sector[1] + turns * FULL_TURN)
        if hi - lo > best[1] - best[0]:
            best = (lo, hi)
    return best


def frame_view(view: tuple[float, float], scan: LaserScan) -> tuple[float, float] | None:
    """The field of view ``(fov_min, fov_max)`` (rad) of a detector configured with ``view`` in the frame of
    ``scan`` (see the module docstring); None when the scan covers ``view`` up to one beam spacing a side.

    Returns
    -------
    tuple of float or None
        The narrowed view, or None; ``(lo, lo)`` when the scan covers nothing of ``view``.
    """
    inc = abs(scan.angle_increment)
    sector = scan_sector(scan)
    if sector[1] - sector[0] >= FULL_TURN - _EPS:
        return None
    lo, hi = _overlap(view, sector)
    if hi - lo <= inc + _EPS:
        return (view[0], view[0])
    if lo - view[0] <= inc + _EPS and view[1] - hi <= inc + _EPS:
        return None
    return (lo, hi)
