"""Short appearances: stretches of scans in which a person is seen, and whether the run reported them."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from evaluation.metrics.appearances import appearance_rows, appearances, format_appearance_rows, main

PERIOD_NS = 100_000_000  # a 10 Hz laser


def _write(tmp_path: Path, truth: list[tuple[int, int, float, float, int]], found: list[tuple[int, float, float]]):
    """A run directory (a 10 x 10 m grid from (0, -5)) and its ground truth: (scan, person, x, y, hit_beams) rows
    and reported people (scan, x, y)."""
    run = tmp_path / "run"
    run.mkdir()
    grid = {"resolution": 0.5, "nx": 20, "ny": 20, "x0": 0.0, "y0": -5.0}
    (run / "run.json").write_text(json.dumps({"grid": grid}))
    with (run / "people.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "driver_index", "x_m", "y_m", "mean_probability"])
        w.writerows([k, k, x, y, 0.9] for k, x, y in found)
    gt = tmp_path / "gt.csv"
    with gt.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scan_index", "stamp_ns", "person_id", "x_laser_m", "y_laser_m", "hit_beams", "speed_mps"])
        w.writerows([k, k * PERIOD_NS, p, x, y, b, 1.0] for k, p, x, y, b in truth)
    return run, gt


def test_appearances_are_split_by_gaps_and_binned_by_duration(tmp_path: Path) -> None:
    truth = [(k, 0, 2.0, 0.0, 5) for k in range(5)]  # person 0: 5 scans, 0.5 s
    truth += [(k, 1, 4.0, 1.0, 5 if k not in (10, 11, 12) else 1) for k in range(41)]  # a 0.3 s gap: one appearance
    truth += [(k, 2, 6.0, -1.0, 5 if k < 10 or k >= 20 else 0) for k in range(30)]  # a 1 s gap: two appearances
    truth += [(k, 3, 20.0, 0.0, 9) for k in range(30)]  # outside the grid: never counted
    found = [(1, 2.1, 0.0), (3, 2.0, 0.4), (3, 2.0, -0.3)]  # person 0 found in 2 scans (one match per person)
    found += [(k, 4.0, 1.2) for k in range(20)]  # person 1 found in the first 20 scans, 17 of them seen
    found += [(25, 7.0, -1.0)]  # 1 m from person 2: no match
    run, gt = _write(tmp_path, truth, found)
    got = sorted((a.person, round(a.duration_s, 3), a.scans, a.found) for a in appearances(run, gt))
    assert got == [(0, 0.5, 5, 2), (1, 4.1, 38, 17), (2, 1.0, 10, 0), (2, 1.0, 10, 0)]
    short, mid, long_ = appearance_rows(appearances(run, gt))
    assert (short.appearances, short.reported, short.scans_found) == (1, 1.0, 2 / 5)
    assert (mid.appearances, mid.reported, mid.scans_found) == (2, 0.0, 0.0)  # 1.0 s lies in [1, 3)
    assert (long_.appearances, long_.reported, long_.scans_found) == (1, 1.0, 17 / 38)
    assert "1-3 s" in format_appearance_rows([short, mid, long_])


def test_an_empty_bin_is_nan_and_bad_input_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run, gt = _write(tmp_path, [(0, 0, 2.0, 0.0, 5), (1, 0, 2.0, 0.0, 5)], [])
    rows = appearance_rows(appearances(run, gt))
    assert rows[0].appearances == 1 and rows[0].reported == 0.0
    assert math.isnan(rows[1].reported) and math.isnan(rows[2].scans_found)
    assert main([str(run), str(gt)]) == 0 and "appearances" in capsys.readouterr().out
    bad = tmp_path / "bad.csv"
    bad.write_text("scan_index,x_laser_m,y_laser_m\n0,1,1\n")
    with pytest.raises(ValueError, match=r"stamp_ns.*person_id.*hit_beams"):
        appearances(run, bad)
