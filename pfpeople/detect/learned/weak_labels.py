"""Weak labels from an unlabelled recording of a standing laser: things that move through space seen free are people.

leg_tracker's own labels were made this way (people walking in front of a laser standing in an empty area); the same
rule labels any recording of a standing laser, with no one drawing a box:

1. **Background.** Per beam, the range the laser sees behind everything that passes: the ``background_quantile``
   of its readings over the whole recording (a beam that returns nothing at least that often sees free space to the
   laser's range). A return within ``static_band`` of its beam's background is *background*: a wall, a table, a
   chair that never moved. A return more than ``foreground_gap`` in front of it is *foreground*.
2. **Candidates.** Per scan, foreground returns are grouped in bearing order (a gap of more than ``link`` metres
   splits; groups whose centres lie within ``merge`` metres join: two legs); a group of at least ``min_returns``
   returns no wider than ``max_width`` is a candidate at its centre pushed ``leg_radius`` along its bearing.
3. **Tracks.** Candidates of consecutive scans are linked to the nearest track within ``gate`` metres (greedy,
   nearest pair first). A track that lasts at least ``min_duration`` seconds and travels at least ``min_path``
   metres is a person: each of its candidates is a labelled person.

The labelled scan knows the background returns (class 0) and the returns within
:data:`~pfpeople.detect.learned.samples.POSITIVE_RADIUS` of a labelled person (class 1); every other return (a
foreground candidate that did not walk, the band between background and foreground) is masked out of the loss.
Standing people, and anything that moves less than ``min_path``, are never labelled: the labels are of walkers,
their negatives of what stood still for most of the recording.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gridbridge.validation import check_positive
from pfpeople.detect.learned.samples import POSITIVE_RADIUS, LabelledScan, Region, count_returns
from pfpeople.sensors import LaserScan

__all__ = ["WeakLabelParams", "WeakLabelReport", "static_background", "weak_labels"]


@dataclass(frozen=True, kw_only=True)
class WeakLabelParams:
    """Settings of :func:`weak_labels` (module docstring; m, s)."""

    background_quantile: float = 0.9
    static_band: float = 0.1
    foreground_gap: float = 0.3
    link: float = 0.3
    merge: float = 0.5
    min_returns: int = 3
    max_width: float = 0.9
    leg_radius: float = 0.06
    gate: float = 0.5
    min_duration: float = 1.0
    min_path: float = 1.0

    def __post_init__(self) -> None:
        if not 0.5 <= self.background_quantile < 1.0:
            raise ValueError(f"WeakLabelParams.background_quantile must be in [0.5, 1), got {self.background_quantile}")
        for name in ("static_band", "foreground_gap", "link", "merge", "max_width", "gate", "min_path"):
            check_positive(getattr(self, name), f"WeakLabelParams.{name}")
        check_positive(self.min_duration, "WeakLabelParams.min_duration", allow_zero=True)


@dataclass(frozen=True, kw_only=True)
class WeakLabelReport:
    """What :func:`weak_labels` found: scans, candidates, tracks, people tracks and labelled person-scans."""

    scans: int
    candidates: int
    tracks: int
    people_tracks: int
    labels: int


def _background(scans: Sequence[LaserScan], q: float) -> NDArray[np.float64]:
    """Per-beam background range (m; ``inf`` where the beam sees nothing at least ``1 - q`` of the time)."""
    r = np.stack([np.where(s.no_return, np.inf, np.where(s.valid, s.ranges, np.nan)) for s in scans])
    with np.errstate(invalid="ignore"):
        return np.nanquantile(np.where(np.isnan(r), -np.inf, r), q, axis=0)


def static_background(scans: Sequence[LaserScan], params: WeakLabelParams | None = None) -> NDArray[np.bool_]:
    """Per scan and beam ``(S, B)``, whether the return is the standing laser's static background (module docstring,
    step 1: within ``static_band`` of its beam's background range); all False for a recording whose beams change."""
    p = params if params is not None else WeakLabelParams()
    if not scans:
        return np.zeros((0, 0), dtype=bool)
    if len({(s.ranges.size, s.angle_min, s.angle_increment) for s in scans}) != 1:
        return np.zeros((len(scans), scans[0].ranges.size), dtype=bool)
    bg = _background(scans, p.background_quantile)
    r = np.stack([np.where(s.valid, s.ranges, np.nan) for s in scans])
    with np.errstate(invalid="ignore"):
        return np.abs(r - bg[None, :]) <= p.static_band


def _candidates(scan: LaserScan, fg: NDArray[np.bool_], p: WeakLabelParams) -> list[NDArray[np.float64]]:
    """Candidate centres of the foreground returns ``fg`` (B,) of ``scan`` (module docstring, step 2)."""
    idx = np.flatnonzero(fg)
    if idx.size < p.min_returns:
        return []
    b, r = scan.angles[idx], scan.ranges[idx]
    pts = np.column_stack((r * np.cos(b), r * np.sin(b)))
    starts = np.r_[0, np.flatnonzero(np.linalg.norm(np.diff(pts, axis=0), axis=1) > p.link) + 1]
    groups = [pts[a:e] for a, e in zip(starts, np.r_[starts[1:], len(pts)], strict=True)]
    merged: list[NDArray[np.float64]] = []
    for g in groups:
        if merged and np.linalg.norm(g.mean(axis=0) - merged[-1].mean(axis=0)) <= p.merge:
            merged[-1] = np.vstack((merged[-1], g))
        else:
            merged.append(g)
    out = []
    for g in merged:
        if len(g) >= p.min_returns and np.linalg.norm(g.max(axis=0) - g.min(axis=0)) <= p.max_width:
            c = g.mean(axis=0)
            out.append(c * (1.0 + p.leg_radius / max(float(np.hypot(*c)), 1e-6)))
    return out


def _link(frames: list[list[NDArray[np.float64]]], gate: float) -> list[list[tuple[int, int]]]:
    """Tracks as lists of ``(scan, candidate)`` by greedy nearest-pair linking of consecutive scans."""
    tracks: list[list[tuple[int, int]]] = []
    live: dict[int, int] = {}  # candidate index in the previous scan -> track
    for k, cands in enumerate(frames):
        now: dict[int, int] = {}
        if k and live and cands:
            prev = np.array(frames[k - 1])
            cur = np.array(cands)
            d = np.linalg.norm(cur[:, None, :] - prev[None, :, :], axis=-1)
            for flat in np.argsort(d, axis=None, kind="mergesort"):
                i, j = divmod(int(flat), d.shape[1])
                if d[i, j] > gate:
                    break
                if i in now or j not in live or live[j] in now.values():
                    continue
                now[i] = live[j]
                tracks[live[j]].append((k, i))
        for i in range(len(cands)):
            if i not in now:
                now[i] = len(tracks)
                tracks.append([(k, i)])
        live = now
    return tracks


def _is_person(
    track: list[tuple[int, int]], frames: list[list[NDArray[np.float64]]], stamps: NDArray[np.int64], p: WeakLabelParams
) -> bool:
    pos = np.array([frames[k][i] for k, i in track])
    duration = (stamps[track[-1][0]] - stamps[track[0][0]]) * 1e-9
    path = float(np.linalg.norm(np.diff(pos, axis=0), axis=1).sum()) if len(pos) > 1 else 0.0
    return duration >= p.min_duration and path >= p.min_path


def _labelled(
    scan: LaserScan, k: int, centres_list: list[NDArray[np.float64]], static: NDArray[np.bool_], source: str
) -> LabelledScan:
    """Scan ``k`` with its labelled people: the background and the people's returns known, the rest masked."""
    centres = np.array(centres_list, dtype=float).reshape(-1, 2)
    known = static.copy()
    if centres.shape[0]:
        pts = scan.points()
        with np.errstate(invalid="ignore"):
            known |= np.linalg.norm(pts[:, None, :] - centres[None, :, :], axis=-1).min(axis=1) <= POSITIVE_RADIUS
    return LabelledScan(
        scan=scan,
        people=centres,
        returns=count_returns(scan, centres),
        region=Region(),
        source=source,
        index=k,
        ego=(0.0, 0.0, 0.0),
        known=known,
    )


def weak_labels(
    scans: Sequence[LaserScan], *, source: str, params: WeakLabelParams | None = None
) -> tuple[list[LabelledScan], WeakLabelReport]:
    """Labelled scans of a standing laser's recording (module docstring), and what was found.

    Raises
    ------
    ValueError
        If the scans do not all have the same beams (a standing laser's recording).
    """
    p = params if params is not None else WeakLabelParams()
    if not scans:
        return [], WeakLabelReport(scans=0, candidates=0, tracks=0, people_tracks=0, labels=0)
    if len({(s.ranges.size, s.angle_min, s.angle_increment) for s in scans}) != 1:
        raise ValueError(f"{source}: weak labels need one laser's scans with the same beams throughout")
    bg = _background(scans, p.background_quantile)
    fg_all, static_all, frames = [], [], []
    for s in scans:
        r = np.where(s.valid, s.ranges, np.nan)
        with np.errstate(invalid="ignore"):
            fg = r < bg - p.foreground_gap
            static = np.abs(r - bg) <= p.static_band
        fg_all.append(fg)
        static_all.append(static)
        frames.append(_candidates(s, fg, p))
    stamps = np.array([s.stamp_ns for s in scans], dtype=np.int64)
    tracks = _link(frames, p.gate)
    people: dict[int, list[NDArray[np.float64]]] = {}
    n_people = 0
    for tr in tracks:
        if _is_person(tr, frames, stamps, p):
            n_people += 1
            for k, i in tr:
                people.setdefault(k, []).append(frames[k][i])
    out = [_labelled(s, k, people.get(k, []), static_all[k], source) for k, s in enumerate(scans)]
    report = WeakLabelReport(
        scans=len(scans),
        candidates=sum(len(f) for f in frames),
        tracks=len(tracks),
        people_tracks=n_people,
        labels=sum(len(v) for v in people.values()),
    )
    return out, report
