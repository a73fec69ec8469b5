"""``pfpeople-eval benchmark`` on a short scan-level scene: the table's rows, and ``--seed`` reaching the simulation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from evaluation.cli import main as eval_main
from pfpeople.io.ground_truth import read_gt_csv


def _bench(tmp_path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[str, dict, Path]:
    work = tmp_path / "work"
    out = tmp_path / "bench.json"
    args = ["benchmark", "--scenes", "scan:corridor", "--frames", "24", "--work", str(work), "--json", str(out)]
    assert eval_main([*args, "--no-progress", *extra]) == 0
    return capsys.readouterr().out, json.loads(out.read_text()), work


def test_benchmark_rows_and_seed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text, rows, work = _bench(tmp_path / "a", capsys, "--no-mot")
    sources = [r["source"] for r in rows]
    assert sources[:2] == ["detector laser-legs", "detector laser-boosted"]
    assert "recommended (pipeline)" in sources and "paper grid + blobs" in sources
    assert all(r["scene"] == "scan:corridor" and r["frames"] == 24 for r in rows)
    assert all(0.0 <= r["recall"] <= 1.0 for r in rows if r["recall"] is not None)
    assert "seed" not in text
    gt0 = read_gt_csv(work / "corridor" / "corridor_gt.csv")
    text1, _, work1 = _bench(tmp_path / "b", capsys, "--no-mot", "--seed", "1")
    assert text1.startswith("scan-level scenes simulated with seed 1")
    gt1 = read_gt_csv(work1 / "corridor" / "corridor_gt.csv")
    # another seed: other people in the same corridor (the ground-truth positions differ)
    assert len(gt0) > 0 and len(gt1) > 0
    assert not (gt0.xy.shape == gt1.xy.shape and np.allclose(gt0.xy, gt1.xy))


def test_mot_rows_score_both_filters_tracks(tmp_path: Path) -> None:
    """The MOT rows of a scan-level scene: the grid pipeline's tracks, then the same run's with the particle
    filter (run into ``<name>_prun`` with the recommended particle filter), then tracking-by-detection; again
    on the people a laser sees."""
    from evaluation.harness.benchmark import mot_rows, scene_logs

    work = tmp_path / "work"
    _, _, skip = scene_logs("scan:corridor", data=tmp_path, work=work, frames=24)
    assert skip == ""
    rows = mot_rows("scan:corridor", data=tmp_path, work=work, frames=24)
    head = ["tracks.csv (pipeline)", "tracks.csv (particle pipeline)", "laser-legs (raw)"]
    assert [r.source for r in rows[:3]] == head and [r.source for r in rows[5:8]] == head
    assert [r.sequence for r in rows] == ["corridor"] * 5 + ["corridor [hit_beams>=3]"] * 5
    meta = json.loads((work / "corridor_prun" / "run.json").read_text())
    assert meta["config"]["filter"]["kind"] == "particle" and meta["frames"] == 24
    assert all(r.scores.num_frames == 24 and r.scores.num_gt > 0 for r in rows)
