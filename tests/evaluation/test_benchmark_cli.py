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
    text, data, work = _bench(tmp_path / "a", capsys, "--no-mot")
    rows, ap = data["detection"], data["detectors"]
    assert [r["detector"] for r in ap] == [
        "laser_legs",
        "laser_boosted",
        "laser_single_legs",
        "laser_motion",
        "laser_learned",
        "fused (pipeline)",
    ]
    assert all(r["scene"] == "scan:corridor" and r["frames"] == 24 for r in ap)
    assert all(r["ap_05"] is None or 0.0 <= r["ap_05"] <= 1.0 for r in ap)
    assert "Each detector alone and the fused output" in text
    sources = [r["source"] for r in rows]
    assert sources[:2] == ["detector laser_legs", "detector laser_boosted"]
    assert "recommended (pipeline)" in sources and "paper grid + blobs" in sources
    assert all(r["scene"] == "scan:corridor" and r["frames"] == 24 for r in rows)
    assert all(0.0 <= r["recall"] <= 1.0 for r in rows if r["recall"] is not None)
    assert "seed" not in text
    gt0 = read_gt_csv(work / "corridor" / "corridor_gt.csv")
    text1, _, work1 = _bench(tmp_path / "b", capsys, "--no-mot", "--no-ap", "--seed", "1")
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
    head = ["tracks.csv (pipeline)", "tracks.csv (particle pipeline)", "laser_legs (raw)"]
    assert [r.source for r in rows[:3]] == head and [r.source for r in rows[5:8]] == head
    assert [r.sequence for r in rows] == ["corridor"] * 5 + ["corridor [hit_beams>=3]"] * 5
    meta = json.loads((work / "corridor_prun" / "run.json").read_text())
    assert meta["config"]["filter"]["kind"] == "particle" and meta["frames"] == 24
    assert all(r.scores.num_frames == 24 and r.scores.num_gt > 0 for r in rows)


def test_particle_overrides_parse_filter_keys() -> None:
    from evaluation.harness.benchmark import particle_overrides

    got = particle_overrides(["seed=3", "compiled_draws=true", "max_overflow=0.2", "motion_model=paper"])
    assert got == {"seed": 3, "compiled_draws": True, "max_overflow": 0.2, "motion_model": "paper"}
    assert particle_overrides([]) == {}
    assert particle_overrides(['motion_model="persistent"']) == {"motion_model": "persistent"}


@pytest.mark.parametrize(
    ("item", "match"),
    [
        ("seed", r"--particle 'seed': expected KEY=VALUE"),
        ("=3", r"expected KEY=VALUE"),
        ("kind=grid", r"'kind' is not a \[filter\] key; keys: .*compiled_draws.*seed"),
        ("particles=5", r"'particles' is not a \[filter\] key"),
        ("compiled_draws=yes", r"\[filter\] compiled_draws: must be a valid boolean, got 'yes'"),
        ("motion_model=fast", r"motion_model"),
    ],
)
def test_particle_overrides_refuse_bad_items(item: str, match: str) -> None:
    from evaluation.harness.benchmark import particle_overrides

    with pytest.raises(ValueError, match=match):
        particle_overrides([item])


def test_benchmark_cli_refuses_a_bad_particle_setting_before_running(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    work = tmp_path / "work"
    argv = ["benchmark", "--scenes", "scan:corridor", "--frames", "24", "--work", str(work), "--no-progress"]
    assert eval_main([*argv, "--particle", "sead=3"]) == 2
    assert "--particle 'sead=3': 'sead' is not a [filter] key" in capsys.readouterr().err
    assert not (work / "corridor").exists()  # nothing was simulated


def test_particle_overrides_reach_every_particle_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``particle`` replaces the particle filter's settings in the particle mode's rows, the tracking rows' particle
    pipeline run (``<name>_prun``), and nowhere else (the grid modes keep theirs)."""
    from evaluation.harness import benchmark

    seen: list[tuple[str, str, int, bool]] = []
    real = benchmark.mode_row

    def spy(log, mode, **kw):  # type: ignore[no-untyped-def]
        seen.append((mode.name, mode.filter.kind, mode.filter.seed, mode.filter.compiled_draws))
        return real(log, mode, **kw)

    monkeypatch.setattr(benchmark, "mode_row", spy)
    work = tmp_path / "work"
    mot: list = []
    particle = {"seed": 5, "compiled_draws": False}  # not the defaults (0, true)
    benchmark.run_benchmark(["scan:corridor"], data=tmp_path, frames=12, work=work, mot=mot, particle=particle)
    assert ("recommended particles", "particle", 5, False) in seen
    assert all(seed == 0 and drawn for _, kind, seed, drawn in seen if kind == "grid")
    assert len(seen) == len(benchmark.MODES)
    meta = json.loads((work / "corridor_prun" / "run.json").read_text())
    assert meta["config"]["filter"]["seed"] == 5 and meta["config"]["filter"]["compiled_draws"] is False
    grid_meta = json.loads((work / "corridor_run" / "run.json").read_text())
    assert grid_meta["config"]["filter"]["seed"] == 0 and grid_meta["config"]["filter"]["kind"] == "grid"
    assert mot and all(r.scores.num_frames == 12 for r in mot)
