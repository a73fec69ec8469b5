"""Laser detector 1: a leg-pattern detector in the spirit of Bellotto & Hu (2009).

Bellotto & Hu find legs as narrow, roughly circular blobs in the range profile and group them into three
patterns: two separate legs (LA), two legs together (SL, one wider blob) and forward-straight legs (FS). Here the
scan is cut into segments (:mod:`pfpeople.detect.segments`) and a segment is a **leg candidate** when its
geometry is leg-like (all thresholds are :class:`LegDetectorParams` fields):

* ``min_points <= n_points``, ``min_width <= width <= max_width`` (one leg or two legs together); where a leg
  ``far_leg_width`` wide cannot give ``min_points`` returns (at range ``r`` a scan with beam spacing ``d_phi``
  puts ``floor(far_leg_width / (r d_phi))`` beams on it), that count is the minimum, but never below 3,
* a fitted circle radius in ``[min_radius, max_radius]`` and small residuals (``circularity``, ``linearity``),
* convex towards the sensor: ``mean_curvature <= max_mean_curvature`` (negative = bulging towards the laser),
* an inscribed-angle mean (Xavier et al. 2005) in ``[min_iav, max_iav]`` (an arc, not a corner or a line).

People are formed from the candidates by :func:`people_from_legs`: a candidate wider than
``max_single_leg_width`` is two legs together and is a person by itself (pattern SL); the narrower ones are
paired greedily, closest pair first, when their centres are ``min_separation .. max_separation`` apart
(patterns LA / FS); the person is the midpoint. An unpaired single leg counts as a person only with
``count_single_legs=True``. The learned detector (:mod:`pfpeople.detect.boosted`) reuses the same pairing.

**Far leg blobs** (``far_from`` m, :func:`far_people`): beyond ``far_from`` a run of at most ``far_max_points``
returns, at most ``far_max_width`` wide, with at least the returns a ``far_leg_width`` leg gives at its range (at
least one), standing ``far_min_jump`` in front of both neighbouring beams is a far leg blob; two blobs paired as
legs are a person when no other small foreground run lies within ``far_isolation`` of their midpoint (a chair or
a table shows three or four legs). ``far_from = inf`` turns them off.

How the defaults were chosen (thresholds, ``far_leg_width``, far leg blobs, single legs off), with the
ablation tables: ``docs/ablations.md``, "The leg detector's defaults".
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from gridbridge.params import CALIBRATED_LASER_DETECTORS, DetectorModel
from gridbridge.validation import check_int, check_positive
from pfpeople.detect import segment_kernels as _kernels
from pfpeople.detect.segments import (
    FEATURE_NAMES,
    SegmentationParams,
    scan_segments,
    segment_scan,
)
from pfpeople.perception.clutter_kernels import near_any
from pfpeople.sensors import LaserScan
from pfpeople.units import Beams, Metres, PerMetre, Radians

__all__ = [
    "MIN_LEG_BEAMS",
    "LegDetector",
    "LegDetectorParams",
    "PairingParams",
    "far_leg_blobs",
    "far_people",
    "leg_beam_range",
    "pair_legs",
    "people_and_single_legs",
    "people_from_legs",
]

_F = {name: k for k, name in enumerate(FEATURE_NAMES)}

#: A far person within this distance (m) of a person the leg tests found is that person (:func:`far_people`).
FAR_DUPLICATE = 0.3
#: The fewest returns a leg candidate has (the floor under ``far_leg_width`` in :meth:`LegDetector.leg_mask`).
MIN_LEG_BEAMS = 3


@dataclass(frozen=True, kw_only=True)
class PairingParams:
    """How leg detections become people (shared by both laser detectors).

    Parameters
    ----------
    min_separation, max_separation : float
        Distance range (m) between the centres of two legs of one person. The labelled leg pairs of the
        leg_tracker bags are 0.18-0.43 m apart (1st-99th percentile).
    max_single_leg_width : float
        A leg segment wider than this (m) is two legs together and a person by itself.
    count_single_legs : bool
        Whether an unpaired single leg is reported as a person.
    """

    min_separation: Metres = 0.1
    max_separation: Metres = 0.6
    max_single_leg_width: Metres = 0.25
    count_single_legs: bool = False

    def __post_init__(self) -> None:
        check_positive(self.min_separation, "PairingParams.min_separation", allow_zero=True)
        check_positive(self.max_separation, "PairingParams.max_separation")
        if self.min_separation >= self.max_separation:
            raise ValueError("PairingParams.min_separation must be below max_separation")
        check_positive(self.max_single_leg_width, "PairingParams.max_single_leg_width")


@dataclass(frozen=True, kw_only=True)
class LegDetectorParams:
    """Thresholds of :class:`LegDetector` (lengths in m, angles in rad, curvature in 1/m; the shape tests are
    described in the module docstring).

    Parameters
    ----------
    segmentation : SegmentationParams
        How the scan is cut into segments.
    pairing : PairingParams
        How leg candidates become people.
    min_points : int
        Returns a leg candidate has at least (where a ``far_leg_width`` leg can give them; never below 3).
    far_leg_width : float
        Where a leg this wide gets fewer than ``min_points`` returns at its range, that count is the minimum.
    min_width, max_width : float
        Width of a candidate (one leg, or two legs together).
    min_radius, max_radius : float
        Radius of the circle fitted to a candidate.
    max_linearity, max_circularity : float
        Largest residuals of the line and circle fits (a leg is round, not straight).
    max_mean_curvature : float
        Largest mean curvature (negative: bulging towards the laser).
    min_iav, max_iav : float
        Range of the inscribed-angle mean (Xavier et al. 2005: an arc, not a corner or a line).
    far_from : float
        Beyond this range far leg blobs are looked for (:func:`far_people`); ``inf``: off.
    far_max_points : int
        A far leg blob has at most this many returns.
    far_max_width : float
        A far leg blob is at most this wide.
    far_min_jump : float
        A far leg blob stands this far in front of both neighbouring beams.
    far_isolation : float
        Two far blobs paired as legs are a person when no other small foreground run lies within this distance
        of their midpoint (a chair or a table shows three or four legs); 0: no test.
    """

    segmentation: SegmentationParams = field(default_factory=SegmentationParams)
    pairing: PairingParams = field(default_factory=PairingParams)
    min_points: Beams = 4
    far_leg_width: Metres = 0.10
    min_width: Metres = 0.05
    max_width: Metres = 0.45
    min_radius: Metres = 0.03
    max_radius: Metres = 0.25
    max_linearity: Metres = 0.03
    max_circularity: Metres = 0.05
    max_mean_curvature: PerMetre = -2.0
    min_iav: Radians = 1.5
    max_iav: Radians = 3.2
    far_from: Metres = 5.0
    far_max_points: Beams = 5
    far_max_width: Metres = 0.2
    far_min_jump: Metres = 0.3
    far_isolation: Metres = 0.8

    def __post_init__(self) -> None:
        check_int(self.far_max_points, "LegDetectorParams.far_max_points", minimum=1)
        if not (isinstance(self.far_from, int | float) and self.far_from > 0):  # inf: off
            raise ValueError(f"LegDetectorParams.far_from must be a positive number (m) or inf, got {self.far_from!r}")
        check_positive(self.far_max_width, "LegDetectorParams.far_max_width")
        check_positive(self.far_min_jump, "LegDetectorParams.far_min_jump", allow_zero=True)
        check_positive(self.far_isolation, "LegDetectorParams.far_isolation", allow_zero=True)
        check_int(self.min_points, "LegDetectorParams.min_points", minimum=3)
        for name in ("far_leg_width", "min_width", "min_radius", "max_linearity", "max_circularity", "min_iav"):
            check_positive(getattr(self, name), f"LegDetectorParams.{name}", allow_zero=True)
        for name in ("max_width", "max_radius", "max_iav"):
            check_positive(getattr(self, name), f"LegDetectorParams.{name}")
        if not math.isfinite(self.max_mean_curvature):
            raise ValueError("LegDetectorParams.max_mean_curvature must be finite")
        for lo, hi in (("min_width", "max_width"), ("min_radius", "max_radius"), ("min_iav", "max_iav")):
            if getattr(self, lo) >= getattr(self, hi):
                raise ValueError(f"LegDetectorParams.{lo} must be below {hi}")


def leg_beam_range(params: LegDetectorParams, angle_increment: float) -> float:
    """The range (m) beyond which a leg gives too few returns for the leg tests, at a beam spacing (rad).

    A leg ``far_leg_width`` wide at range ``r`` gets ``floor(far_leg_width / (r d_phi))`` beams; the tests need
    :data:`MIN_LEG_BEAMS` (``min_points`` when ``far_leg_width = 0``, for a leg of the default width), so beyond
    ``width / (beams d_phi)`` a leg is found only as a far leg blob (from ``far_from`` on). ``inf`` for a spacing
    of 0.

    Parameters
    ----------
    params : LegDetectorParams
        The detector's thresholds.
    angle_increment : float
        The scan's beam spacing (rad; its sign is ignored).
    """
    width, beams = params.far_leg_width, MIN_LEG_BEAMS
    if width <= 0:
        width, beams = LegDetectorParams().far_leg_width, params.min_points
    inc = abs(angle_increment)
    return width / (beams * inc) if inc > 0 else math.inf


def far_leg_blobs(scan: LaserScan, params: LegDetectorParams) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The far leg blobs of a scan (see :class:`LegDetectorParams`), and every small run beyond ``far_from``.

    A far leg blob is a run of at most ``far_max_points`` consecutive valid beams (cut at the segmentation's
    ``jump_distance``), all at ``far_from`` m or more, at most ``far_max_width`` wide (first to last point), with
    at least as many beams as a leg ``far_leg_width`` wide gives at its range (at least 1), and in front of both
    neighbouring beams by ``far_min_jump`` m or more (a neighbour that is invalid, or not the adjacent beam,
    counts as far): at range a leg gives 1-3 returns, too few for the shape features.

    Returns
    -------
    blobs : ndarray, shape (B, 2)
        Centres of the far leg blobs (m, scan frame).
    small : ndarray, shape (S, 2)
        Centres of every run of at most ``far_max_points`` beams at ``far_from`` m or more in front of both
        neighbours as above, whatever its width and beam count: the blobs and thinner things (chair and table
        legs among them: ``far_isolation``).
    """
    p = params
    none = np.zeros((0, 2))
    if not math.isfinite(p.far_from):
        return none, none
    segs = segment_scan(scan, params=p.segmentation, min_points=1)  # every run: they cover every valid beam
    if not len(segs):
        return none, none
    if _jit.enabled("pfpeople"):
        inc = abs(scan.angle_increment)
        par = np.array([p.far_max_points, p.far_from, p.far_min_jump, p.far_leg_width, inc, p.far_max_width, 0.0])
        keep, small, centres = _kernels.far_blobs(
            segs.points, segs.beams, segs.starts, segs.counts, segs.range_before, segs.range_after, par
        )
        return centres[keep].reshape(-1, 2), centres[small].reshape(-1, 2)
    starts, counts = segs.starts, segs.counts
    ends = starts + counts - 1
    r = np.hypot(segs.points[:, 0], segs.points[:, 1])
    # a neighbouring run's range counts only when its beam is the adjacent one (else: no return there, far)
    adjacent = np.abs(np.diff(segs.beams)) == 1
    before = np.where(np.concatenate(([False], adjacent))[starts], segs.range_before, np.inf)
    after = np.where(np.concatenate((adjacent, [False]))[ends], segs.range_after, np.inf)
    rmin = np.minimum.reduceat(r, starts)
    rmean = np.add.reduceat(r, starts) / counts
    small = (counts <= p.far_max_points) & (rmin >= p.far_from)
    small &= (before - rmean >= p.far_min_jump) & (after - rmean >= p.far_min_jump)
    inc = abs(scan.angle_increment)
    need = np.maximum(np.floor(p.far_leg_width / (np.maximum(rmean, 1e-3) * max(inc, 1e-9))), 1)
    width = np.hypot(*(segs.points[ends] - segs.points[starts]).T)
    keep = small & (counts >= need) & (width <= p.far_max_width)
    centres = segs.centroids
    return centres[keep].reshape(-1, 2), centres[small].reshape(-1, 2)


def far_people(
    scan: LaserScan, params: LegDetectorParams, *, legs: NDArray[np.float64], people: NDArray[np.float64]
) -> NDArray[np.float64]:
    """People ``(F, 2)`` (m, scan frame) from the far leg blobs of ``scan`` (:func:`far_leg_blobs`).

    The blobs are paired as legs are (``params.pairing``, closest pair first); a pair is a person at its midpoint
    when the small foreground runs within ``far_isolation`` of it are only its own two (a chair or a table
    shows three or four legs). Blobs within ``FAR_DUPLICATE / 3`` of a leg candidate ``legs`` (K, 2) are that
    leg, and a far person within ``FAR_DUPLICATE`` of a person already found ``people`` (M, 2) is that person.
    """
    blobs, small = far_leg_blobs(scan, params)
    blobs = blobs[~near_any(blobs, legs, FAR_DUPLICATE / 3)]
    if blobs.shape[0] < 2:
        return np.zeros((0, 2))
    pr = params.pairing
    pairs, _ = pair_legs(blobs, min_separation=pr.min_separation, max_separation=pr.max_separation)
    far = 0.5 * (blobs[pairs[:, 0]] + blobs[pairs[:, 1]])
    if far.shape[0] and params.far_isolation > 0:
        d2 = ((far[:, None, :] - small[None, :, :]) ** 2).sum(axis=2)
        far = far[(d2 < params.far_isolation**2).sum(axis=1) <= 2]
    return far[~near_any(far, people, FAR_DUPLICATE)].reshape(-1, 2)


@functools.lru_cache(maxsize=64)
def _pair_indices(k: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """``np.triu_indices(k, 1)`` (read-only, kept per ``k``: it is asked for every scan)."""
    ii, jj = np.triu_indices(k, 1)
    ii.flags.writeable = False
    jj.flags.writeable = False
    return ii, jj


def pair_legs(
    legs: NDArray[np.float64], *, min_separation: float, max_separation: float
) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Greedy pairing of legs into people, closest admissible pair first.

    Parameters
    ----------
    legs : ndarray, shape (K, 2)
        Leg centres (m).
    min_separation, max_separation : float
        Admissible distance between the two legs of a pair (m).

    Returns
    -------
    pairs : ndarray, shape (P, 2)
        Indices into ``legs`` of each pair (each leg in at most one pair; ties broken by index).
    paired : ndarray, shape (K,)
        True for legs that are in a pair.
    """
    pts = np.asarray(legs, dtype=float).reshape(-1, 2)
    k = pts.shape[0]
    paired = np.zeros(k, dtype=bool)
    if k < 2:
        return np.zeros((0, 2), dtype=np.intp), paired
    if _jit.enabled("pfpeople"):
        return _kernels.pair_greedy(np.ascontiguousarray(pts), float(min_separation), float(max_separation))
    ii, jj = _pair_indices(k)
    d = np.hypot(*(pts[ii] - pts[jj]).T)
    ok = (d >= min_separation) & (d <= max_separation)
    ii, jj, d = ii[ok], jj[ok], d[ok]
    order = np.lexsort((jj, ii, d))
    out: list[tuple[int, int]] = []
    for a, b in zip(ii[order], jj[order], strict=True):
        if not paired[a] and not paired[b]:
            paired[a] = paired[b] = True
            out.append((int(a), int(b)))
    return np.array(out, dtype=np.intp).reshape(-1, 2), paired


def people_and_single_legs(
    legs: NDArray[np.float64], widths: NDArray[np.float64], *, params: PairingParams
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Person positions from leg segments (see the module docstring), and the single legs left unpaired.

    Parameters
    ----------
    legs : ndarray, shape (K, 2)
        Centres of the segments classified as legs (m).
    widths : ndarray, shape (K,)
        Their widths (m); wider than ``params.max_single_leg_width`` means two legs together.
    params : PairingParams
        Pairing rules.

    Returns
    -------
    people : ndarray, shape (M, 2)
        Person positions (m): legs-together segments first, then pair midpoints, then (only with
        ``params.count_single_legs``) the single legs.
    single : ndarray, shape (S, 2)
        The narrow legs in no pair (m), whether or not ``people`` counts them: a tracker may use them to keep a
        person it already follows (one leg hidden by the other) without starting people from them
        (:class:`pfpeople.track.multi_person.MultiPersonTracker`, ``support``).
    """
    legs = np.asarray(legs, dtype=float).reshape(-1, 2)
    widths = np.asarray(widths, dtype=float).reshape(-1)
    if widths.size != legs.shape[0]:
        raise ValueError(f"widths has {widths.size} entries for {legs.shape[0]} legs")
    if _jit.enabled("pfpeople"):
        out: tuple[NDArray[np.float64], NDArray[np.float64]] = _kernels.people_pairs(
            np.ascontiguousarray(legs),
            np.ascontiguousarray(widths),
            float(params.max_single_leg_width),
            float(params.min_separation),
            float(params.max_separation),
            bool(params.count_single_legs),
        )
        return out
    together = widths > params.max_single_leg_width
    narrow = legs[~together]  # the single legs, in order (taken once)
    pairs, paired = pair_legs(narrow, min_separation=params.min_separation, max_separation=params.max_separation)
    alone = narrow[~paired].reshape(-1, 2)
    parts = [legs[together], 0.5 * (narrow[pairs[:, 0]] + narrow[pairs[:, 1]])]
    if params.count_single_legs:
        parts.append(alone)
    return np.concatenate(parts, axis=0).reshape(-1, 2), alone


def people_from_legs(
    legs: NDArray[np.float64], widths: NDArray[np.float64], *, params: PairingParams
) -> NDArray[np.float64]:
    """Person positions ``(M, 2)`` (m) from leg segments: the first output of :func:`people_and_single_legs`."""
    return people_and_single_legs(legs, widths, params=params)[0]


class LegDetector:
    """Laser detector 1: geometric leg candidates paired into people (Bellotto & Hu 2009 style).

    Parameters
    ----------
    params : LegDetectorParams, optional
        Thresholds; defaults documented in the module docstring.
    model : DetectorModel, optional
        PPV / FNR, field of view and range used by the grid. Default: the values measured on the
        labelled data (:data:`gridbridge.params.CALIBRATED_LASER_DETECTORS`), 180 deg field of view, unbounded
        range; a pipeline run takes the field of view and range from the LaserScan.

    Notes
    -----
    Detections outside ``model``'s field of view or range are not removed: the detector reports what the scan
    shows; the grid ignores cells outside the field of view.
    """

    def __init__(self, *, params: LegDetectorParams | None = None, model: DetectorModel | None = None) -> None:
        self.params = params if params is not None else LegDetectorParams()
        self.model = model if model is not None else CALIBRATED_LASER_DETECTORS[0]
        if not isinstance(self.model, DetectorModel):
            raise TypeError(f"model must be a DetectorModel, got {type(self.model).__name__}")

    def leg_mask(self, features: NDArray[np.float64], angle_increment: float | None = None) -> NDArray[np.bool_]:
        """True for rows of ``features`` (S, F) (see :data:`FEATURE_NAMES`) that are leg candidates.

        ``angle_increment`` (rad): the scan's beam spacing, for ``far_leg_width``; None: ``min_points`` at every
        range."""
        p = self.params
        f = np.asarray(features, dtype=float).reshape(-1, len(FEATURE_NAMES))
        need: Any = p.min_points
        if p.far_leg_width > 0 and angle_increment is not None and angle_increment > 0:
            expected = np.floor(p.far_leg_width / (np.maximum(f[:, _F["distance"]], 1e-3) * angle_increment))
            need = np.clip(expected, MIN_LEG_BEAMS, p.min_points)
        w = f[:, _F["width"]]
        r = f[:, _F["radius"]]
        iav = f[:, _F["iav"]]
        return (
            (f[:, _F["n_points"]] >= need)
            & (w >= p.min_width)
            & (w <= p.max_width)
            & (r >= p.min_radius)
            & (r <= p.max_radius)
            & (f[:, _F["linearity"]] <= p.max_linearity)
            & (f[:, _F["circularity"]] <= p.max_circularity)
            & (f[:, _F["mean_curvature"]] <= p.max_mean_curvature)
            & (iav >= p.min_iav)
            & (iav <= p.max_iav)
        )

    def _legs(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        segs, feats = scan_segments(scan, params=self.params.segmentation)
        keep = self.leg_mask(feats, abs(scan.angle_increment))
        return segs.centroids[keep], feats[keep, _F["width"]]

    def detect_legs(self, scan: LaserScan) -> NDArray[np.float64]:
        """Leg positions ``(K, 2)`` (segment centroids, m, scan frame); a legs-together segment is one entry."""
        return self._legs(scan)[0]

    def detect(self, scan: LaserScan) -> NDArray[np.float64]:
        """Person positions ``(M, 2)`` (m, scan frame); ``(0, 2)`` for an empty or all-invalid scan."""
        return self.detect_with_singles(scan)[0]

    def detect_with_singles(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Person positions ``(M, 2)`` and unpaired single legs ``(S, 2)`` (m, scan frame)
        (:func:`people_and_single_legs`)."""
        legs, widths = self._legs(scan)
        people, singles = people_and_single_legs(legs, widths, params=self.params.pairing)
        far = far_people(scan, self.params, legs=legs, people=people)
        if far.shape[0]:
            people = np.concatenate((people, far))
        return people, singles
