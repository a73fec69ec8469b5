"""Labelled scans for the learned detector: people's centres, where the labels hold, and which people a laser sees.

A :class:`LabelledScan` is one scan with the centres of the people annotated in it (m, the scan's frame) and the
*region* where the annotation is complete. A return inside the region is a person's (within
:data:`POSITIVE_RADIUS` of a centre) or not (beyond :data:`IGNORE_RADIUS` of every centre; in between it is neither:
an arm, a bag, a mixed pixel); a return outside it is masked out of the loss and out of the scores, never taken as a
negative (Beyer et al. 2018 do the same with their "don't care" labels). The sources:

============================  ==========================================================================================
source                        people, region
============================  ==========================================================================================
leg_tracker ``positive_*``    labelled legs paired into people (0.1-0.6 m apart, closest first; an unpaired leg is a
                              person at its position); the box leg_tracker labelled in (x 0.5-5 m, ``|y|`` < 0.75 m)
leg_tracker ``negative_2``    nobody; everywhere (three lasers on a robot driving through empty rooms)
``person_following_outdoor``  the followed person; only around them (passers-by are not annotated)
simulated scenes              every person (``pfpeople-eval simulate-bag``); everywhere
weak labels                   people found by motion through space seen free
                              (:mod:`pfpeople.detect.learned.weak_labels`); where the background is known
============================  ==========================================================================================

A person counts as *seen* when at least :data:`SEEN_RETURNS` returns lie within :data:`POSITIVE_RADIUS` of the
centre (the simulator's ``hit_beams`` where it gives them): the scores count the seen people and ignore the others
(:mod:`evaluation.metrics.average_precision`).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D
from pfpeople.detect.leg_tracker_bags import iter_scans, load_labelled_scans
from pfpeople.sensors import LaserScan

__all__ = [
    "IGNORE_RADIUS",
    "POSITIVE_BOX",
    "POSITIVE_RADIUS",
    "SEEN_RETURNS",
    "LabelledScan",
    "Region",
    "count_returns",
    "motion_since_previous",
    "negative_scans",
    "pair_legs_into_people",
    "people_bag_scans",
    "positive_bag_scans",
    "simulated_scans",
    "with_scan_matched_motion",
]

#: A return within this distance (m) of a person's centre is the person's: both legs in mid-stride (the labelled leg
#: pairs of leg_tracker's bags are up to 0.43 m apart: 99th percentile).
POSITIVE_RADIUS = 0.4
#: Returns between :data:`POSITIVE_RADIUS` and this distance (m) of a centre are neither person nor background.
IGNORE_RADIUS = 0.7
#: Returns on a person for the scores to count them (fewer: the laser hardly sees them; ignored, not missed).
SEEN_RETURNS = 3
#: leg_tracker's labelling box in the scan frame: x_min, x_max, y_min, y_max (m).
POSITIVE_BOX = (0.5, 5.0, -0.75, 0.75)


@dataclass(frozen=True, kw_only=True)
class Region:
    """Where a scan's annotation is complete: everywhere, inside a box, or only near the annotated people.

    Parameters
    ----------
    box : tuple of float, optional
        ``(x_min, x_max, y_min, y_max)`` (m, scan frame).
    near_people : float, optional
        Only within this distance (m) of an annotated centre.
    """

    box: tuple[float, float, float, float] | None = None
    near_people: float | None = None

    def contains(self, points: NDArray[np.float64], people: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which ``points`` ``(N, 2)`` lie in the region (given the scan's annotated ``people`` ``(K, 2)``)."""
        inside = np.ones(points.shape[0], dtype=bool)
        if self.box is not None:
            x0, x1, y0, y1 = self.box
            inside &= (points[:, 0] >= x0) & (points[:, 0] <= x1) & (points[:, 1] >= y0) & (points[:, 1] <= y1)
        if self.near_people is not None:
            if people.shape[0] == 0:
                return np.zeros(points.shape[0], dtype=bool)
            d = np.linalg.norm(points[:, None, :] - people[None, :, :], axis=-1).min(axis=1)
            inside &= d <= self.near_people
        return inside


EVERYWHERE = Region()


@dataclass(frozen=True, kw_only=True, eq=False)
class LabelledScan:
    """One scan with its annotated people.

    Attributes
    ----------
    scan : LaserScan
    people : ndarray, shape (K, 2)
        Centres (m, scan frame).
    returns : ndarray, shape (K,), int
        Returns on each person (:func:`count_returns`, or the simulator's ``hit_beams``).
    region : Region
        Where the annotation is complete.
    source : str
        Which recording or scene (and laser) the scan is from: leave-one-out folds group by it.
    index : int
        The scan's index in its source (consecutive scans of a source have consecutive indices).
    ego : tuple of float
        The laser frame's motion since the source's previous scan ``(x, y, yaw)`` (m, rad; the current frame in the
        previous one), or NaNs when unknown.
    known : ndarray, shape (B,), bool, optional
        Per beam, whether its return's label is known (weak labels: :mod:`pfpeople.detect.learned.weak_labels`);
        None: wherever ``region`` says.
    background : ndarray, shape (B,), bool, optional
        Per beam, a return of the static background outside ``region`` (a standing laser's recording, weakly
        labelled): a known negative for training; the scores keep to ``region``.
    speed : ndarray, shape (K,), optional
        Each person's speed (m/s; NaN unknown): the standing / walking split of the scores.
    """

    scan: LaserScan
    people: NDArray[np.float64]
    returns: NDArray[np.int64]
    region: Region
    source: str
    index: int
    ego: tuple[float, float, float] = field(default=(float("nan"),) * 3)
    known: NDArray[np.bool_] | None = None
    background: NDArray[np.bool_] | None = None
    speed: NDArray[np.float64] | None = None

    @property
    def seen(self) -> NDArray[np.bool_]:
        """People with at least :data:`SEEN_RETURNS` returns on them, shape (K,)."""
        return self.returns >= SEEN_RETURNS


def count_returns(scan: LaserScan, people: NDArray[np.float64], radius: float = POSITIVE_RADIUS) -> NDArray[np.int64]:
    """Returns of ``scan`` within ``radius`` (m) of each of ``people`` ``(K, 2)``, shape (K,)."""
    if people.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    pts = scan.points()
    pts = pts[np.isfinite(pts).all(axis=1)]
    d = np.linalg.norm(pts[:, None, :] - people[None, :, :], axis=-1)
    return np.count_nonzero(d <= radius, axis=0).astype(np.int64)


def pair_legs_into_people(legs: NDArray[np.float64]) -> NDArray[np.float64]:
    """People ``(M, 2)`` from labelled legs ``(K, 2)``: pairs 0.1-0.6 m apart, closest first, at their midpoint; an
    unpaired leg is a person at its own position (as the benchmark's labelled people)."""
    legs = np.asarray(legs, dtype=float).reshape(-1, 2)
    free = np.ones(len(legs), dtype=bool)
    pairs = []
    if len(legs) > 1:
        d = np.linalg.norm(legs[:, None] - legs[None], axis=-1)
        iu = np.triu_indices(len(legs), 1)
        for k in np.argsort(d[iu], kind="mergesort"):
            i, j = iu[0][k], iu[1][k]
            if free[i] and free[j] and 0.1 <= d[i, j] <= 0.6:
                pairs.append(0.5 * (legs[i] + legs[j]))
                free[i] = free[j] = False
    singles = [legs[i] for i in np.flatnonzero(free)]
    return np.asarray(pairs + singles, dtype=float).reshape(-1, 2)


def positive_bag_scans(path: str | Path, source: str | None = None) -> list[LabelledScan]:
    """The labelled scans of a leg_tracker ``positive_*_extracted.bag`` (stationary laser: zero ego-motion); the
    returns of the static background outside the labelling box are known negatives for training
    (:func:`pfpeople.detect.learned.weak_labels.static_background`)."""
    from pfpeople.detect.learned.weak_labels import static_background

    path = Path(path)
    out = []
    labelled = load_labelled_scans(path)
    background = static_background([ls.scan for ls in labelled])
    for k, ls in enumerate(labelled):
        people = pair_legs_into_people(ls.legs)
        out.append(
            LabelledScan(
                scan=ls.scan,
                people=people,
                returns=count_returns(ls.scan, people),
                region=Region(box=POSITIVE_BOX),
                source=source or path.stem.replace("_extracted", ""),
                index=k,
                ego=(0.0, 0.0, 0.0),
                background=background[k],
            )
        )
    return out


def negative_scans(path: str | Path, topics: Sequence[str], source: str | None = None) -> list[LabelledScan]:
    """Every scan of ``topics`` in a bag with nobody in it (leg_tracker's ``negative_2``); one source per topic
    (``<stem>:<topic>``); ego-motion unknown (no odometry)."""
    path = Path(path)
    out = []
    counts: dict[str, int] = {}
    nobody = np.zeros((0, 2))
    for topic, scan in iter_scans(path, topics):
        k = counts.get(topic, 0)
        counts[topic] = k + 1
        out.append(
            LabelledScan(
                scan=scan,
                people=nobody,
                returns=np.zeros(0, dtype=np.int64),
                region=EVERYWHERE,
                source=f"{source or path.stem}:{topic}",
                index=k,
            )
        )
    return out


def _gt_rows(gt_csv: Path) -> dict[int, list[tuple[float, float, int, float]]]:
    """Rows of a ground-truth CSV keyed by ``scan_index``: ``(x, y, hit_beams or -1, speed_mps or NaN)`` (the first
    x_/y_ columns)."""
    rows: dict[int, list[tuple[float, float, int, float]]] = {}
    with gt_csv.open(newline="", encoding="utf-8-sig") as fh:
        reader = csv.DictReader(fh)
        cols = reader.fieldnames or []
        xcol = next((c for c in cols if c.startswith("x_") and c.endswith("_m")), "x")
        ycol = xcol.replace("x_", "y_", 1) if xcol != "x" else "y"
        if "scan_index" not in cols or xcol not in cols or ycol not in cols:
            raise ValueError(f"{gt_csv}: needs scan_index and x_<frame>_m / y_<frame>_m columns, has {cols}")
        for row in reader:
            hits = int(float(row["hit_beams"])) if row.get("hit_beams") not in (None, "") else -1
            speed = float(row["speed_mps"]) if row.get("speed_mps") not in (None, "") else float("nan")
            rows.setdefault(int(row["scan_index"]), []).append((float(row[xcol]), float(row[ycol]), hits, speed))
    return rows


def people_bag_scans(
    bag: str | Path,
    gt_csv: str | Path,
    *,
    topic: str,
    region: Region = EVERYWHERE,
    source: str | None = None,
    ego: NDArray[np.float64] | None = None,
) -> list[LabelledScan]:
    """The scans of ``topic`` with the people of a ground-truth CSV keyed by ``scan_index`` (the simulator's
    ``<scene>_gt.csv``, or ``person_following_outdoor_1_gt.csv`` with ``region=Region(near_people=...)``).

    ``ego`` ``(S, 3)``: per scan, the laser frame's motion since the previous scan (NaN rows: unknown).
    """
    bag, gt_csv = Path(bag), Path(gt_csv)
    rows = _gt_rows(gt_csv)
    out = []
    for k, (_, scan) in enumerate(iter_scans(bag, [topic])):
        r = rows.get(k, [])
        people = np.array([(x, y) for x, y, _, _ in r], dtype=float).reshape(-1, 2)
        hits = np.array([h for _, _, h, _ in r], dtype=np.int64)
        returns = hits if len(hits) and (hits >= 0).all() else count_returns(scan, people)
        e = (float("nan"),) * 3 if ego is None or k >= len(ego) else tuple(float(v) for v in ego[k])
        out.append(
            LabelledScan(
                scan=scan,
                people=people,
                returns=returns,
                region=region,
                source=source or bag.stem,
                index=k,
                ego=e,  # type: ignore[arg-type]
                speed=np.array([v for *_, v in r], dtype=float),
            )
        )
    return out


def simulated_scans(
    bag: str | Path, gt_csv: str | Path, *, topic: str = "/scan", odometry: str = "/odom", source: str | None = None
) -> list[LabelledScan]:
    """The scans of a simulated scene (``pfpeople-eval simulate-bag``) with every person and the laser's motion
    from the scene's wheel odometry (with its drift, slip and latency) and mount."""
    from pfpeople.detect.learned.ego import odometry_motions, read_odometry, static_mount

    scans = [s for _, s in iter_scans(Path(bag), [topic])]
    if not scans:
        raise ValueError(f"{bag}: no scans on {topic}")
    stamps, poses = read_odometry(bag, odometry)
    ego = odometry_motions([s.stamp_ns for s in scans], stamps, poses, static_mount(bag, scans[0].frame_id))
    return people_bag_scans(bag, gt_csv, topic=topic, source=source, ego=ego)


def with_scan_matched_motion(scans: Sequence[LabelledScan]) -> list[LabelledScan]:
    """One laser's scans, in order, with their ego-motion from scan matching
    (:func:`pfpeople.detect.learned.ego.scan_matched_motions`; NaN for the first scan and failed matches): for
    recordings without odometry, as a run matches their scans too."""
    from pfpeople.detect.learned.ego import scan_matched_motions

    ego = scan_matched_motions([s.scan for s in scans])
    return [replace(s, ego=(float(e[0]), float(e[1]), float(e[2]))) for s, e in zip(scans, ego, strict=True)]


def motion_since_previous(ls: LabelledScan, previous: LabelledScan | None) -> Pose2D | None:
    """The laser's motion since ``previous`` (``ls.ego``, metres and radians in ``previous``'s laser frame) when
    ``ls`` directly follows it in its source and the motion is known; else None."""
    if previous is None or previous.source != ls.source or previous.index != ls.index - 1:
        return None
    if not all(math.isfinite(v) for v in ls.ego):
        return None
    return Pose2D(x=ls.ego[0], y=ls.ego[1], yaw=ls.ego[2])
