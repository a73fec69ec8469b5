"""Training segments from bags annotated with people's positions (not legs): e.g. the scan-level simulator's bags.

leg_tracker's labelled bags (:mod:`pfpeople.detect.training`) come from a standing scanner with people walking
in a box; they hold no furniture seen by a moving robot and few people standing. A bag whose ground truth gives
every person's centre per scan (the CSV format of :mod:`pfpeople.io.ground_truth`, keyed by ``scan_index``, in the
scan's frame, with an optional ``hit_beams`` column: how many beams reached the person) adds both. Each segment of such
a scan (:func:`pfpeople.detect.segments.scan_segments`) is labelled by the distance ``d`` from its centroid to
the nearest annotated person:

* **positive** (a leg, or both legs seen as one segment) when ``d <= person_radius`` from a person the laser saw
  (``hit_beams`` > 0, or no such column);
* **negative** when ``d > clear_radius`` from every annotated person, seen or hidden;
* skipped otherwise: a hidden person's occluder, an arm, a bag, or a person's edge split off.

``person_radius`` (0.3 m) holds both legs of a person standing or in mid-stride (the simulator puts the legs
0.10-0.25 m apart when standing, up to 0.6 m in a stride); ``clear_radius`` (1.0 m) keeps a companion's or a
passer-by's segments out of the negatives. The labels are scene-independent rules, not fitted values.

Use ``pfpeople train-detector --people-bags DIR``: every ``<name>.bag`` below ``DIR`` with ``<name>_gt.csv`` beside
it, as ``pfpeople-eval simulate-bag SCENE --out DIR/SCENE --seed S`` writes them.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from gridbridge.validation import check_int, check_positive
from pfpeople.detect.leg_tracker_bags import iter_scans
from pfpeople.detect.segments import FEATURE_NAMES, SegmentationParams, scan_segments
from pfpeople.io.ground_truth import read_gt_csv
from pfpeople.sensors import LaserScan

__all__ = ["PeopleScan", "find_people_bags", "label_people_segments", "load_people_scans", "people_training_set"]


@dataclass(frozen=True, kw_only=True, eq=False)
class PeopleScan:
    """A scan with its annotated people.

    Attributes
    ----------
    scan : LaserScan
    people : ndarray, shape (P, 2)
        People's centres (m) in the scan's frame.
    seen : ndarray, shape (P,), bool
        Whether some beam reached the person (``hit_beams > 0``; all True without that column).
    """

    scan: LaserScan
    people: NDArray[np.float64]
    seen: NDArray[np.bool_]


def find_people_bags(folder: str | Path) -> list[tuple[Path, Path]]:
    """Every ``<name>.bag`` below ``folder`` (sorted) with its ``<name>_gt.csv`` beside it.

    Raises
    ------
    FileNotFoundError
        If ``folder`` is not a directory, holds no such pair, or a bag has no ground-truth file (named).
    """
    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(f"people-bags folder not found: {root}")
    bags = sorted(p for p in root.rglob("*.bag") if p.is_file())
    if not bags:
        raise FileNotFoundError(f"no <name>.bag with <name>_gt.csv beside it below {root}")
    out = []
    for bag in bags:
        gt = bag.with_name(f"{bag.stem}_gt.csv")
        if not gt.is_file():
            raise FileNotFoundError(f"{bag} has no ground-truth file {gt.name} beside it")
        out.append((bag, gt))
    return out


def _hit_beams(gt_csv: Path) -> NDArray[np.int64] | None:
    """The ``hit_beams`` column in file order (None when the file has none)."""
    with gt_csv.open(newline="", encoding="utf-8-sig") as fh:
        reader = csv.DictReader(fh)
        if "hit_beams" not in (reader.fieldnames or []):
            return None
        return np.array([int(float(row["hit_beams"])) for row in reader], dtype=np.int64)


def load_people_scans(
    bag: str | Path, gt_csv: str | Path, *, topic: str = "/scan", scan_step: int = 1
) -> list[PeopleScan]:
    """Every ``scan_step``-th scan of ``topic`` with the people annotated for it.

    Parameters
    ----------
    bag, gt_csv : path
        A ROS1 bag and its ground truth (keyed by ``scan_index``, the scan's index on ``topic``; positions in the
        scan's ``frame_id``).
    topic : str
        The LaserScan topic.
    scan_step : int
        Keep scans ``0, scan_step, 2 scan_step, ...``.

    Raises
    ------
    ValueError
        If the ground truth is not keyed by ``scan_index`` or names another frame than the scans'.
    """
    check_int(scan_step, "scan_step", minimum=1)
    gt = read_gt_csv(gt_csv)
    if gt.key != "scan_index":
        raise ValueError(f"{gt_csv}: training needs rows keyed by scan_index, got {gt.key}")
    beams = _hit_beams(Path(gt_csv))
    seen_rows = np.ones(len(gt), dtype=bool) if beams is None else beams > 0
    out: list[PeopleScan] = []
    for k, (_, scan) in enumerate(iter_scans(bag, [topic])):
        if gt.frame is not None and scan.frame_id and gt.frame != scan.frame_id:
            raise ValueError(
                f"{gt_csv}: positions are in frame {gt.frame!r}, the scans of {topic} in {scan.frame_id!r}"
            )
        if k % scan_step:
            continue
        rows = gt.keys == k
        out.append(PeopleScan(scan=scan, people=gt.xy[rows], seen=seen_rows[rows]))
    return out


def label_people_segments(
    centroids: NDArray[np.float64],
    people: NDArray[np.float64],
    seen: NDArray[np.bool_],
    *,
    person_radius: float = 0.3,
    clear_radius: float = 1.0,
) -> NDArray[np.int8]:
    """Label segments (module docstring): 1 on a seen person, 0 clear of everyone, -1 skipped.

    Parameters
    ----------
    centroids : ndarray, shape (S, 2)
        Segment centroids (m, scan frame).
    people : ndarray, shape (P, 2)
        People's centres (m, scan frame).
    seen : ndarray, shape (P,), bool
        Which people some beam reached.
    person_radius, clear_radius : float
        Radii (m), ``person_radius < clear_radius``.
    """
    check_positive(person_radius, "person_radius")
    check_positive(clear_radius, "clear_radius")
    if person_radius >= clear_radius:
        raise ValueError(f"person_radius ({person_radius}) must be below clear_radius ({clear_radius})")
    c = np.asarray(centroids, dtype=float).reshape(-1, 2)
    p = np.asarray(people, dtype=float).reshape(-1, 2)
    out = np.zeros(c.shape[0], dtype=np.int8)
    if not p.shape[0] or not c.shape[0]:
        return out
    d = np.hypot(c[:, None, 0] - p[None, :, 0], c[:, None, 1] - p[None, :, 1])
    out[d.min(axis=1) <= clear_radius] = -1
    vis = np.asarray(seen, dtype=bool).reshape(-1)
    if vis.any():
        out[d[:, vis].min(axis=1) <= person_radius] = 1
    return out


def people_training_set(
    scans: list[PeopleScan],
    *,
    person_radius: float = 0.3,
    clear_radius: float = 1.0,
    segmentation: SegmentationParams | None = None,
) -> tuple[NDArray[np.float32], NDArray[np.int32], dict[str, int]]:
    """Features ``X`` (n, F) and labels ``y`` (n,) of the labelled segments of ``scans``, with counts
    (``positives``, ``negatives``, ``skipped``)."""
    Xs: list[NDArray[np.float64]] = [np.zeros((0, len(FEATURE_NAMES)))]
    ys: list[NDArray[np.int8]] = [np.zeros(0, dtype=np.int8)]
    skipped = 0
    for item in scans:
        segs, feats = scan_segments(item.scan, params=segmentation)
        if not feats.shape[0]:
            continue
        lab = label_people_segments(
            segs.centroids, item.people, item.seen, person_radius=person_radius, clear_radius=clear_radius
        )
        Xs.append(feats[lab >= 0])
        ys.append(lab[lab >= 0])
        skipped += int(np.count_nonzero(lab < 0))
    X, y = np.concatenate(Xs).astype(np.float32), np.concatenate(ys).astype(np.int32)
    counts = {
        "positives": int(np.count_nonzero(y == 1)),
        "negatives": int(np.count_nonzero(y == 0)),
        "skipped": skipped,
    }
    return X, y, counts
