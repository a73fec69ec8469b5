"""evaluation.metrics.standing_walking: recall of standing and walking people, the suppressed fraction, and the
recall at equal visibility (``min_hit_beams``), on a hand-made run directory whose figures are counted by hand."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from evaluation.metrics.standing_walking import motion_split

# ground truth: scan, person, x, y, hit_beams, speed (m/s); the grid is [0, 6) x [-3, 3)
_GT = [
    (0, 0, 1.0, 0.0, 12, 0.1),  # standing, seen, reported
    (0, 1, 3.0, 1.0, 1, 0.0),  # standing, hidden (1 beam), not reported
    (0, 2, 2.0, -2.0, 8, 1.2),  # walking, seen, reported
    (1, 0, 1.0, 0.1, 10, 0.2),  # standing, seen, not reported
    (1, 2, 2.2, -2.0, 2, 1.1),  # walking, hidden, reported
    (1, 3, 9.0, 0.0, 20, 1.0),  # outside the grid: never counted
    (2, 0, 1.0, 0.1, 10, math.nan),  # no speed (a person appearing): neither
]
# reported people: scan, x, y
_PEOPLE = [(0, 1.1, 0.0), (0, 2.0, -1.8), (1, 2.3, -2.1), (2, 1.0, 0.1)]
# detections: scan, x, y, static
_DETS = [(0, 1.0, 0.05, 0), (0, 3.0, 1.1, 1), (1, 1.0, 0.2, 1), (1, 5.0, 2.5, 1), (1, 2.2, -2.0, 0)]


def _run_dir(tmp_path: Path) -> tuple[Path, Path]:
    run = tmp_path / "run"
    run.mkdir()
    grid = {"x0": 0.0, "y0": -3.0, "resolution": 0.3, "nx": 20, "ny": 20}
    (run / "run.json").write_text(json.dumps({"grid": grid}), encoding="utf-8")
    people = ["frame,driver_index,stamp_ns,bag_time_ns,x_m,y_m,size_cells,mean_probability"]
    people += [f"{k},{k},0,0,{x},{y},3,0.9" for k, x, y in _PEOPLE]
    (run / "people.csv").write_text("\n".join(people) + "\n", encoding="utf-8")
    dets = ["frame,driver_index,stamp_ns,bag_time_ns,detector,x_m,y_m,static"]
    dets += [f"{k},{k},0,0,laser_legs,{x},{y},{s}" for k, x, y, s in _DETS]
    (run / "detections.csv").write_text("\n".join(dets) + "\n", encoding="utf-8")
    gt = tmp_path / "gt.csv"
    rows = ["scan_index,stamp_ns,person_id,x_laser_m,y_laser_m,hit_beams,speed_mps"]
    rows += [f"{k},0,{p},{x:.4f},{y:.4f},{b},{v:.3f}" for k, p, x, y, b, v in _GT]  # as the simulator writes
    gt.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return run, gt


def test_recall_of_everyone_and_the_suppressed_fraction(tmp_path: Path) -> None:
    run, gt = _run_dir(tmp_path)
    m = motion_split(run, gt)
    # standing: scan 0 person 0 (hit), person 1 (miss), scan 1 person 0 (miss): 1 of 3
    assert (m.n_standing, m.recall_standing) == (3, pytest.approx(1 / 3))
    # walking: scan 0 person 2 (hit), scan 1 person 2 (hit); person 3 is outside the grid
    assert (m.n_walking, m.recall_walking) == (2, 1.0)
    # detections within 0.3 m of a true person: scan 0 two (one static), scan 1 two (one static), scan 2 none
    assert (m.n_true_detections, m.suppressed_true) == (4, 0.5)


def test_recall_of_the_people_the_laser_sees(tmp_path: Path) -> None:
    run, gt = _run_dir(tmp_path)
    m = motion_split(run, gt, seen_beams=3)
    assert (m.n_standing_seen, m.recall_standing_seen) == (2, 0.5)  # the hidden standing person is out
    assert (m.n_walking_seen, m.recall_walking_seen) == (1, 1.0)  # the hidden walker is out
    assert (m.n_true_detections, m.suppressed_true) == (4, 0.5)  # the suppressed fraction counts everyone
    assert motion_split(run, gt, seen_beams=9).n_standing_seen == 2  # 10 and 12 beams
    assert motion_split(run, gt, seen_beams=11).n_standing_seen == 1


def test_without_hit_beams_no_one_counts_as_seen(tmp_path: Path) -> None:
    run, gt = _run_dir(tmp_path)
    lines = gt.read_text(encoding="utf-8").splitlines()
    cut = [",".join(c for i, c in enumerate(line.split(",")) if i != 5) for line in lines]
    gt.write_text("\n".join(cut) + "\n", encoding="utf-8")
    m = motion_split(run, gt)
    assert m.n_standing == 3 and m.recall_standing == pytest.approx(1 / 3)  # everyone's recall as before
    assert m.n_standing_seen == m.n_walking_seen == 0
    assert math.isnan(m.recall_standing_seen) and math.isnan(m.recall_walking_seen)
