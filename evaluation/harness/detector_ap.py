"""Every laser detector alone, scored as DROW scores detectors: AP at 0.3 and 0.5 m, recall at precision 0.90,
standing and walking recall, false people per scan.

Scenes (:mod:`pfpeople.detect.learned.samples`): the scan-level scenes (with their odometry: the motion and the
learned detector see the ego-motion a run gives them), leg_tracker's labelled bags (in their labelling box) and
``negative_2``'s three lasers (nobody there: false people per scan; its scan-matched ego-motion). People with fewer
than three returns on them are ignored (neither found nor missed); standing is below 0.3 m/s
(:mod:`evaluation.metrics.standing_walking`).

Each detector gives a score per person (:class:`Scored`): the learned detector its vote's probability, the motion
detector the fraction of moved returns, the boosted classifier the smaller boosted score of a pair's legs (legs
taken down to :data:`BOOSTED_FLOOR`, then paired as the detector pairs them: its curve is the detector's at every
threshold); the leg and single-legs detectors have no score (one threshold: their AP is recall x precision).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfpeople.detect import BoostedSegmentDetector, LegDetector, SingleLegDetector
from pfpeople.detect.learned.samples import LabelledScan
from pfpeople.detect.learned.scoring import detector_scores, scored_frames
from pfpeople.detect.legs import people_and_single_legs
from pfpeople.detect.precision_recall import ScoredFrame, pr_curve
from pfpeople.detect.training import scan_features
from pfpeople.sensors import LaserScan

__all__ = [
    "BOOSTED_FLOOR",
    "STANDING_MPS",
    "ApRow",
    "Scored",
    "ap_row",
    "builtin_detectors",
    "format_ap_rows",
    "grid_box",
    "rows_from_frames",
    "run_frames",
]

#: The lowest boosted leg score the scored boosted detector pairs (its default threshold is 0).
BOOSTED_FLOOR = -2.0
#: Below this speed (m/s) a person stands (:mod:`evaluation.metrics.standing_walking`).
STANDING_MPS = 0.3


class Scored:
    """A detector without its own scores, made a scored one: every detection scores 1."""

    def __init__(self, detector: Any) -> None:
        self.detector = detector

    def detect_scored(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        d = np.asarray(self.detector.detect(scan), dtype=float).reshape(-1, 2)
        return d, np.ones(d.shape[0])


class ScoredBoosted:
    """The boosted classifier with a score per person: the smaller leg score of a pair, a together-legs
    segment's own score (module docstring)."""

    def __init__(self, detector: BoostedSegmentDetector) -> None:
        self.detector = detector

    def detect_scored(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        d = self.detector
        feats, centroids, widths = scan_features(scan, segmentation=d.segmentation)
        scores = d._scores(feats)
        keep = scores > BOOSTED_FLOOR
        legs, w, s = centroids[keep], widths[keep], scores[keep]
        people, _ = people_and_single_legs(legs, w, params=d.pairing)
        if not people.shape[0]:
            return np.zeros((0, 2)), np.zeros(0)
        dist = np.linalg.norm(people[:, None, :] - legs[None, :, :], axis=-1)
        near = dist <= 0.5 * d.pairing.max_separation + 1e-9
        score = np.array([s[row].min() if row.any() else s[np.argmin(dd)] for row, dd in zip(near, dist, strict=True)])
        return people, score


def builtin_detectors(boosted_model: Any = None) -> dict[str, Callable[[], Any]]:
    """Factories of the segment-based detectors, scored (``boosted_model``: a model file for the boosted and
    single-legs detectors, e.g. one trained without a held-out bag)."""
    return {
        "laser_legs": lambda: Scored(LegDetector()),
        "laser_boosted": lambda: ScoredBoosted(BoostedSegmentDetector(boosted_model)),
        "laser_single_legs": lambda: Scored(SingleLegDetector(model_path=boosted_model)),
    }


@dataclass(frozen=True, kw_only=True)
class ApRow:
    """One detector on one scene (NaN where undefined)."""

    scene: str
    detector: str
    frames: int
    ap_03: float
    ap_05: float
    recall_at_p90: float
    recall_standing: float
    recall_walking: float
    false_per_scan: float


def _split(frames: Sequence[ScoredFrame], scans: Sequence[LabelledScan], walking: bool) -> list[ScoredFrame]:
    """The frames with only the seen people of one kind counted (the others ignored)."""
    out = []
    for f, ls in zip(frames, scans, strict=True):
        speed = ls.speed if ls.speed is not None else np.full(ls.people.shape[0], np.nan)
        judged = ls.region.contains(ls.people, ls.people) if ls.region.box is not None else np.ones(len(speed), bool)
        v = speed[judged]
        kind = v >= STANDING_MPS if walking else v < STANDING_MPS
        out.append(ScoredFrame(detections=f.detections, scores=f.scores, truth=f.truth, ignore=f.ignore | ~kind))
    return out


def _recall(frames: Sequence[ScoredFrame]) -> float:
    c = pr_curve(frames, 0.5)
    if c.positives == 0:
        return math.nan
    return float(c.recall[-1]) if c.recall.size else 0.0


def ap_row(
    scene: str, name: str, detector: Any, scans: Sequence[LabelledScan], *, threshold: float = -math.inf
) -> ApRow:
    """Score ``detector`` on ``scans`` (module docstring); ``threshold``: the operating threshold the standing /
    walking recall and the false people per scan are counted at."""
    return rows_from_frames(scene, name, scored_frames(detector, scans), scans, threshold=threshold)


def _f(v: float) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.3f}"


def format_ap_rows(rows: Sequence[ApRow]) -> str:
    """The table: scene, detector, frames, AP0.3, AP0.5, recall at P 0.90, standing / walking recall, FP/scan."""
    head = (
        f"{'scene':<26}{'detector':<22}{'frames':>7}{'AP0.3':>7}{'AP0.5':>7}{'R@P.9':>7}"
        f"{'stand':>7}{'walk':>7}{'FP/scan':>8}"
    )
    lines = [head]
    for r in rows:
        lines.append(
            f"{r.scene:<26}{r.detector:<22}{r.frames:>7}{_f(r.ap_03):>7}{_f(r.ap_05):>7}{_f(r.recall_at_p90):>7}"
            f"{_f(r.recall_standing):>7}{_f(r.recall_walking):>7}{_f(r.false_per_scan):>8}"
        )
    return "\n".join(lines)


def as_dicts(rows: Sequence[ApRow]) -> list[Mapping[str, Any]]:
    """Rows as JSON-able dicts."""
    return [dict(r.__dict__) for r in rows]


def rows_from_frames(
    scene: str, name: str, frames: Sequence[ScoredFrame], scans: Sequence[LabelledScan], *, threshold: float
) -> ApRow:
    """An :class:`ApRow` of frames already scored (e.g. a run's reported people with their probabilities)."""
    s = detector_scores(frames, threshold=threshold)
    at = [
        ScoredFrame(
            detections=f.detections[f.scores >= threshold],
            scores=f.scores[f.scores >= threshold],
            truth=f.truth,
            ignore=f.ignore,
        )
        for f in frames
    ]
    return ApRow(
        scene=scene,
        detector=name,
        frames=len(frames),
        ap_03=s.ap_03,
        ap_05=s.ap_05,
        recall_at_p90=s.recall_at_p90,
        recall_standing=_recall(_split(at, scans, walking=False)),
        recall_walking=_recall(_split(at, scans, walking=True)),
        false_per_scan=s.false_per_scan,
    )


def run_frames(run_dir: Path, scans: Sequence[LabelledScan]) -> list[ScoredFrame]:
    """A run's reported people (``people.csv``, scored by their ``mean_probability``) against the people of the
    labelled scans of its driving laser (``driver_index``: the scan's index), in the scans' regions; the run's grid
    frame must be the scans' laser frame."""
    import csv

    per: dict[int, list[tuple[float, float, float]]] = {}
    with (Path(run_dir) / "people.csv").open(newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            per.setdefault(int(row["driver_index"]), []).append(
                (float(row["x_m"]), float(row["y_m"]), float(row["mean_probability"]))
            )
    frames = []
    for ls in scans:
        rows = np.array(per.get(ls.index, []), dtype=float).reshape(-1, 3)
        inside = ls.region.contains(rows[:, :2], ls.people)
        judged = ls.region.contains(ls.people, ls.people)
        frames.append(ScoredFrame.of(rows[inside, :2], rows[inside, 2], ls.people[judged], ~ls.seen[judged]))
    return frames


def grid_box(run_dir: Path) -> tuple[float, float, float, float]:
    """The grid's extent ``(x_min, x_max, y_min, y_max)`` (m, grid frame) of a run directory."""
    import json

    g = json.loads((Path(run_dir) / "run.json").read_text(encoding="utf-8"))["grid"]
    r = float(g["resolution"])
    return (float(g["x0"]), float(g["x0"]) + r * int(g["nx"]), float(g["y0"]), float(g["y0"]) + r * int(g["ny"]))
