"""Range-normalised cut-outs of a laser scan around points (DROW3: Beyer et al. 2018, Sect. III-A).

A learned detector looks at a fixed *metric* neighbourhood of every return, whatever its range: for a centre at
bearing ``phi_c`` and range ``r_c`` (m, scan frame) the window spans ``width`` metres across the beam, i.e. the
bearings ``phi_c + t alpha`` for ``t`` in ``[-1, 1]`` with ``alpha = atan(width / (2 max(r_c, 0.01)))``, sampled at
``points`` evenly spaced bearings. Each sample is the scan's range at that bearing, linearly interpolated between the
two nearest beams, clipped to ``[r_c - depth, r_c + depth]`` and normalised to ``(r - r_c) / depth`` in ``[-1, 1]``:
a person's legs look the same at 1 m and at 7 m, a wall behind them is ``+1`` and an occluder in front ``-1``.

Beams without a return (``+inf``, ``range_max`` and beyond: REP-117), unusable beams (NaN, below ``range_min``) and
bearings outside the scan's field of view read as far (``+1``): nothing was seen there, as DROW pads with 29.99 m.
This is the free space around a return, which a segment-based detector never sees.

The same function cuts a *past* scan around the current scan's points moved into that scan's frame by the
ego-motion (DR-SPAAM's temporal input: Jia et al. 2020): the window keeps the current point's range, so a static
object looks the same in both and a person who has moved leaves ``+1`` (seen through) where they stand now.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from gridbridge.validation import check_int, check_positive
from pfpeople.detect.learned.kernels import cutout_samples
from pfpeople.sensors import LaserScan

__all__ = ["CutoutParams", "beam_cutouts", "centre_beams", "cutouts", "scan_cutouts"]


@dataclass(frozen=True, kw_only=True)
class CutoutParams:
    """The window of a cut-out.

    Parameters
    ----------
    width : float
        Width of the window across the beam (m): two legs and some of what surrounds them.
    depth : float
        Range clip on either side of the centre (m); the sample scale.
    points : int
        Samples per cut-out.
    max_range : float
        Centres farther than this (m) are not looked at (a person beyond has too few returns to vote).
    """

    width: float = 1.0
    depth: float = 0.5
    points: int = 32
    max_range: float = 12.0

    def __post_init__(self) -> None:
        check_positive(self.width, "CutoutParams.width")
        check_positive(self.depth, "CutoutParams.depth")
        check_int(self.points, "CutoutParams.points", minimum=2)
        check_positive(self.max_range, "CutoutParams.max_range")


def _far_ranges(scan: LaserScan) -> NDArray[np.float64]:
    """The scan's ranges with every beam that returned nothing usable set to ``+inf`` (read as far)."""
    return np.where(scan.valid, scan.ranges, np.inf)


def centre_beams(scan: LaserScan, params: CutoutParams) -> NDArray[np.intp]:
    """Indices of the beams a detector looks at: a usable return no farther than ``params.max_range``."""
    r = scan.ranges
    with np.errstate(invalid="ignore"):
        return np.flatnonzero(scan.valid & (r <= params.max_range))


def cutouts(
    scan: LaserScan, bearings: NDArray[np.float64], ranges: NDArray[np.float64], params: CutoutParams
) -> NDArray[np.float32]:
    """Cut-outs of ``scan`` around the centres ``(bearings, ranges)`` (rad, m; in ``scan``'s frame).

    Parameters
    ----------
    scan : LaserScan
        The scan sampled (the current one, or a past one with the centres moved into its frame).
    bearings, ranges : ndarray, shape (C,)
        The centres' bearings and ranges.
    params : CutoutParams

    Returns
    -------
    ndarray, shape (C, params.points), float32
        Normalised samples in ``[-1, 1]`` (module docstring), bearings ascending with ``t``.
    """
    n = scan.ranges.size
    c = np.asarray(ranges, dtype=float)
    if c.size == 0 or n == 0:
        return np.ones((c.size, params.points), dtype=np.float32)
    full_turn = n * abs(scan.angle_increment) >= 2.0 * math.pi - 1e-9
    if _jit.enabled("pfpeople"):
        out = np.empty((c.size, params.points), dtype=np.float32)
        b = np.ascontiguousarray(bearings, dtype=float)
        cutout_samples(
            _far_ranges(scan), scan.angle_min, scan.angle_increment, full_turn, b, c, params.width, params.depth, out
        )
        return out
    return _cutouts_numpy(scan, np.asarray(bearings, dtype=float), c, params, full_turn)


def _cutouts_numpy(
    scan: LaserScan, bearings: NDArray[np.float64], c: NDArray[np.float64], params: CutoutParams, full_turn: bool
) -> NDArray[np.float32]:
    """The numpy twin of :func:`pfpeople.detect.learned.kernels.cutout_samples`."""
    n = scan.ranges.size
    half = np.arctan(0.5 * params.width / np.maximum(c, 0.01))
    t = np.linspace(-1.0, 1.0, params.points)
    u = (bearings[:, None] + half[:, None] * t[None, :] - scan.angle_min) / scan.angle_increment
    if full_turn:  # a 360 deg laser: bearings wrap around
        u = np.mod(u, n)
        outside = np.zeros(u.shape, dtype=bool)
    else:
        outside = (u < 0.0) | (u > n - 1)
    lo = np.clip(np.floor(u), 0, n - 1).astype(np.intp)
    hi = np.where(full_turn, (lo + 1) % n, np.minimum(lo + 1, n - 1))
    frac = np.clip(u - lo, 0.0, 1.0)
    far = _far_ranges(scan)
    low_edge, high_edge = (c - params.depth)[:, None], (c + params.depth)[:, None]
    a = np.clip(far[lo], low_edge, high_edge)
    b = np.clip(far[hi], low_edge, high_edge)
    v = a + frac * (b - a)
    v[outside] = np.broadcast_to(high_edge, v.shape)[outside]
    return ((v - c[:, None]) / params.depth).astype(np.float32)


def beam_cutouts(
    scan: LaserScan,
    values: NDArray[np.float64],
    bearings: NDArray[np.float64],
    ranges: NDArray[np.float64],
    params: CutoutParams,
) -> NDArray[np.float32]:
    """Cut-outs ``(C, params.points)`` of a per-beam quantity ``values`` ``(B,)`` of ``scan`` (e.g. 1 where the
    return moved) around the centres ``(bearings, ranges)``: each sample takes the value of the nearest beam, 0
    outside the field of view; the windows are those of :func:`cutouts`."""
    n = scan.ranges.size
    c = np.asarray(ranges, dtype=float)
    if c.size == 0 or n == 0:
        return np.zeros((c.size, params.points), dtype=np.float32)
    half = np.arctan(0.5 * params.width / np.maximum(c, 0.01))
    t = np.linspace(-1.0, 1.0, params.points)
    u = (
        np.asarray(bearings, dtype=float)[:, None] + half[:, None] * t[None, :] - scan.angle_min
    ) / scan.angle_increment
    k = np.rint(u).astype(np.intp)
    if n * abs(scan.angle_increment) >= 2.0 * math.pi - 1e-9:
        return np.asarray(values, dtype=np.float32)[np.mod(k, n)]
    inside = (k >= 0) & (k < n)
    return np.where(inside, np.asarray(values, dtype=np.float32)[np.clip(k, 0, n - 1)], np.float32(0.0))


def scan_cutouts(scan: LaserScan, params: CutoutParams) -> tuple[NDArray[np.intp], NDArray[np.float32]]:
    """The :func:`centre_beams` of ``scan`` and their cut-outs ``(C, params.points)`` of the scan itself."""
    idx = centre_beams(scan, params)
    return idx, cutouts(scan, scan.angles[idx], scan.ranges[idx], params)
