"""Recall of standing and of walking people, and the true-person detections the static-clutter map suppressed.

Most people in an office or a station stand most of the time; a front end that needs motion to call something a
person misses them while its overall recall, dominated by walkers in a busy scene, looks fine. This module
scores a ``pfpeople run`` directory against a ground-truth CSV with a ``speed_mps`` column (the scan-level
simulator writes one, :mod:`evaluation.scenarios.scan.bagfile`):

* a ground-truth row is **standing** when its speed is below ``STANDING_MPS`` (0.3 m/s: the simulator's standing
  people shuffle at 0.0-0.2 m/s, its walkers walk at 0.5 m/s and more), **walking** otherwise; rows without a
  speed (NaN, within 0.5 s of a person appearing or leaving) count in neither;
* recall of each: reported people (``people.csv``) matched one to one to the true people of the same scan
  (``scan_index`` = the run's ``driver_index``) within ``gate`` (Hungarian assignment on the distance), among the
  true people inside the run's grid;
* **suppressed**: of the detections (``detections.csv``) within ``SUPPRESS_GATE_M`` of a true person, the fraction
  the static-clutter map suppressed (``static = 1``);
* the same recalls of the **seen** people only, those with at least ``seen_beams`` laser beams on them (the
  ground truth's ``hit_beams``): standing people hide each other in groups and stand farther away, so the recall
  of the people the laser sees compares standing and walking people at equal visibility.

The run's grid frame must be the ground truth's frame (the scan-level scenes' grid is in the driving laser's
frame); positions are compared as they are.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

__all__ = ["STANDING_MPS", "SUPPRESS_GATE_M", "MotionSplit", "matched_people", "motion_split", "run_rows_by_frame"]

STANDING_MPS = 0.3
SUPPRESS_GATE_M = 0.3


@dataclass(frozen=True)
class MotionSplit:
    """Recall of standing and walking people, of everyone and of the people the laser sees (``nan`` without such
    people), and the suppressed fraction."""

    recall_standing: float
    recall_walking: float
    n_standing: int
    n_walking: int
    recall_standing_seen: float
    recall_walking_seen: float
    n_standing_seen: int
    n_walking_seen: int
    suppressed_true: float
    n_true_detections: int


def run_rows_by_frame(path: Path, cols: tuple[str, ...]) -> dict[int, NDArray[np.float64]]:
    """Rows of a run CSV grouped by ``driver_index``: ``{index: (N, len(cols))}``."""
    out: dict[int, list[list[float]]] = {}
    with path.open(newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            out.setdefault(int(row["driver_index"]), []).append([float(row[c]) for c in cols])
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def _truth(gt_csv: Path, grid: dict[str, float]) -> dict[int, NDArray[np.float64]]:
    """Ground truth inside the grid per scan: ``{scan_index: (P, 4) x, y, speed, hit_beams}`` (``hit_beams`` NaN
    when the file has no such column)."""
    x0, y0, r = grid["x0"], grid["y0"], grid["resolution"]
    x1, y1 = x0 + grid["nx"] * r, y0 + grid["ny"] * r
    out: dict[int, list[list[float]]] = {}
    with gt_csv.open(newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        names = reader.fieldnames or []
        if "speed_mps" not in names:
            raise ValueError(f"{gt_csv}: the standing / walking split needs a speed_mps column; has {names}")
        beams = "hit_beams" in names
        xc = next(c for c in names if c.startswith("x_") and c.endswith("_m"))
        yc = "y_" + xc[2:]
        for row in reader:
            x, y = float(row[xc]), float(row[yc])
            if x0 <= x < x1 and y0 <= y < y1:
                b = float(row["hit_beams"]) if beams else math.nan
                out.setdefault(int(row["scan_index"]), []).append([x, y, float(row["speed_mps"]), b])
    return {k: np.asarray(v, dtype=float) for k, v in out.items()}


def matched_people(found: NDArray[np.float64], truth: NDArray[np.float64], gate: float) -> NDArray[np.bool_]:
    """Which true people ``(P, >=2)`` are matched one to one by ``found`` ``(M, >=2)`` within ``gate`` (m)."""
    hit = np.zeros(truth.shape[0], dtype=bool)
    if not found.shape[0] or not truth.shape[0]:
        return hit
    d = np.hypot(found[:, None, 0] - truth[None, :, 0], found[:, None, 1] - truth[None, :, 1])
    rows, cols = linear_sum_assignment(np.where(d <= gate, d, 1e6))
    hit[cols[d[rows, cols] <= gate]] = True
    return hit


def _count_recalls(hits: dict[str, list[int]], hit: NDArray[np.bool_], t: NDArray[np.float64], seen_beams: int) -> None:
    """Add one scan's matched / true counts of standing and walking people, of everyone and of the seen ones."""
    seen = t[:, 3] >= seen_beams  # False for NaN: no hit_beams column
    for name, sel in (("standing", t[:, 2] < STANDING_MPS), ("walking", t[:, 2] >= STANDING_MPS)):
        for key, mask in ((name, sel), (name + "_seen", sel & seen)):
            hits[key][0] += int(np.count_nonzero(hit & mask))
            hits[key][1] += int(np.count_nonzero(mask))


def motion_split(run_dir: str | Path, gt_csv: str | Path, *, gate: float = 0.5, seen_beams: int = 3) -> MotionSplit:
    """Score a run directory's people by the motion of the true people (see the module docstring).

    Parameters
    ----------
    run_dir : path
        A ``pfpeople run`` output directory (``run.json``, ``people.csv``, ``detections.csv``).
    gt_csv : path
        Ground truth with ``scan_index``, ``x_<frame>_m``, ``y_<frame>_m`` and ``speed_mps`` columns, in the run's
        grid frame; with a ``hit_beams`` column also the recall of the people the laser sees.
    gate : float
        Largest distance (m) of a match.
    seen_beams : int
        The beams on a true person (``hit_beams``) from which they count as seen (the ``*_seen`` recalls; NaN
        without a ``hit_beams`` column). The suppressed fraction always counts every true person.

    Returns
    -------
    MotionSplit
    """
    run_dir, gt_csv = Path(run_dir), Path(gt_csv)
    grid = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))["grid"]
    truth = _truth(gt_csv, grid)
    people = run_rows_by_frame(run_dir / "people.csv", ("x_m", "y_m"))
    dets = run_rows_by_frame(run_dir / "detections.csv", ("x_m", "y_m", "static"))
    hits = {k: [0, 0] for k in ("standing", "walking", "standing_seen", "walking_seen")}
    near, suppressed = 0, 0
    for k, t in truth.items():
        _count_recalls(hits, matched_people(people.get(k, np.zeros((0, 2))), t, gate), t, seen_beams)
        d = dets.get(k)
        if d is not None and d.shape[0]:
            close = (
                np.hypot(d[:, None, 0] - t[None, :, 0], d[:, None, 1] - t[None, :, 1]).min(axis=1) <= SUPPRESS_GATE_M
            )
            near += int(np.count_nonzero(close))
            suppressed += int(np.count_nonzero(close & (d[:, 2] > 0.5)))

    def ratio(a: int, b: int) -> float:
        return a / b if b else math.nan

    st, wk, st_seen, wk_seen = (hits[k] for k in ("standing", "walking", "standing_seen", "walking_seen"))
    return MotionSplit(
        recall_standing=ratio(*st),
        recall_walking=ratio(*wk),
        n_standing=st[1],
        n_walking=wk[1],
        recall_standing_seen=ratio(*st_seen),
        recall_walking_seen=ratio(*wk_seen),
        n_standing_seen=st_seen[1],
        n_walking_seen=wk_seen[1],
        suppressed_true=ratio(suppressed, near),
        n_true_detections=near,
    )
