"""The benchmark's real labelled leg bags (scene ``positive_bags``): ground truth, pooled rows, a short run."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

import evaluation.harness.benchmark as bench
from evaluation.harness.benchmark import BenchRow, pooled_rows, write_labelled_people_csv
from pfpeople.config import load_config
from pfpeople.detect.leg_tracker_bags import load_labelled_scans


def test_pooled_rows_count_matches_over_runs() -> None:
    a = BenchRow("positive_1", "detector x", 10, recall=0.5, fp_per_frame=0.1, extra={"tp": 5, "fn": 5, "fp": 1})
    b = BenchRow("positive_2", "detector x", 30, recall=0.9, fp_per_frame=0.0, extra={"tp": 27, "fn": 3, "fp": 0})
    c = BenchRow("positive_2", "pipeline", 30, recall=1.0, extra={"tp": 2, "fn": 0, "fp": 4})  # recall only
    d = BenchRow("positive_2", "skipped", 0)  # no counts: left out
    rows = pooled_rows([a, b, c, d], "all")
    assert [r.source for r in rows] == ["detector x", "pipeline"]
    x, p = rows
    # (5 + 27) / (10 + 30) matches, not the mean of the two recalls (0.7)
    assert (x.scene, x.frames, x.recall, x.fp_per_frame) == ("all", 40, pytest.approx(0.8), pytest.approx(1 / 40))
    assert x.note == "2 runs pooled" and x.extra == {"tp": 32, "fn": 8, "fp": 1}
    assert p.recall == 1.0 and math.isnan(p.fp_per_frame) and math.isnan(p.precision)


@pytest.mark.realdata
def test_labelled_people_csv_pairs_the_labelled_legs(shared_data: Path, tmp_path: Path) -> None:
    bag = shared_data / "leg_tracker" / "positive_2_extracted.bag"
    if not bag.is_file():
        pytest.skip(f"{bag} is absent")
    out = tmp_path / "gt.csv"
    n = write_labelled_people_csv(bag, out)
    scans = load_labelled_scans(bag)
    with out.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == n > 0
    by_scan: dict[int, list[dict[str, str]]] = {}
    for r in rows:
        by_scan.setdefault(int(r["scan_index"]), []).append(r)
    assert set(by_scan) <= set(range(len(scans)))
    checked = {"pair": 0, "apart": 0}
    for k, scan in enumerate(scans):
        got = by_scan.get(k, [])
        assert [int(r["person_id"]) for r in got] == list(range(1, len(got) + 1))
        legs = scan.legs
        # brute force: a pair of legs 0.1-0.6 m apart is one person at its midpoint, every other leg one person
        d = np.hypot(*(legs[:, None] - legs[None]).transpose(2, 0, 1)) if len(legs) else np.zeros((0, 0))
        near = (d >= 0.1) & (d <= 0.6)
        if len(legs) == 2 and near[0, 1]:
            assert len(got) == 1
            mid = legs.mean(axis=0)
            assert (float(got[0]["x_laser_m"]), float(got[0]["y_laser_m"])) == pytest.approx(tuple(mid), abs=1e-4)
            checked["pair"] += 1
        elif not near.any():
            assert len(got) == len(legs)
            checked["apart"] += 1
        # every person lies in the labelling box of the bag (x 0.5-5 m, |y| < 0.75 m), with rounding
        for r in got:
            assert 0.4 <= float(r["x_laser_m"]) <= 5.1 and abs(float(r["y_laser_m"])) <= 0.8
    assert checked["pair"] >= 10 and checked["apart"] >= 1, checked


@pytest.mark.realdata
def test_positive_bags_scene_runs_each_bag_with_a_model_that_has_not_seen_it(
    shared_data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    leg = shared_data / "leg_tracker"
    if not all((leg / f"positive_{k}_extracted.bag").is_file() for k in (2, 3)):
        pytest.skip("positive_2 / positive_3 bags are absent")
    monkeypatch.setattr(bench, "POSITIVE_BAGS", (2, 3))  # two bags, 15 scans each: a few seconds
    logs, rows, skip = bench.scene_logs("positive_bags", data=shared_data, work=tmp_path, frames=15)
    assert skip == "" and [r.scene for r in rows] == ["positive_2", "positive_3"]
    assert all(r.source == "recommended (pipeline)" and r.frames == 15 for r in rows)
    assert all(0.0 <= r.recall <= 1.0 and math.isnan(r.precision) for r in rows)
    assert all(log.recall_only and sum(len(t) for t in log.truth) > 0 for log in logs)
    for k, other in ((2, 3), (3, 2)):
        # the boosted detector runs with the model trained without this bag; everything else as inspect wrote it
        side = (tmp_path / "models" / f"without_positive_{k}.json").read_text()
        assert f"positive_{other}_extracted.bag" in side and f"positive_{k}_extracted.bag" not in side
        cfg = load_config(tmp_path / f"positive_{k}.toml")
        assert cfg.time_source == "header" and [d.kind for d in cfg.detectors] == ["leg", "boosted", "single-legs"]
        ran = json.loads((tmp_path / f"positive_{k}_run" / "run.json").read_text())["config"]["detectors"]
        assert ran[1]["params"]["model_path"] == str(tmp_path / "models" / f"without_positive_{k}.yml")
    monkeypatch.setattr(bench, "POSITIVE_BAGS", ())
    assert bench.scene_logs("positive_bags", data=shared_data, work=tmp_path / "none")[2].startswith("no positive_")
