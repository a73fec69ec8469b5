"""``python -m evaluation.bench.pipeline``: the worker and the driver at tiny sizes (no time is asserted)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from evaluation.bench import pipeline as bench_pipeline


@pytest.fixture(scope="module")
def tiny_scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    work = tmp_path_factory.mktemp("scenes")
    args = bench_pipeline._parser().parse_args(["--max-frames", "6", "--work", str(work)])
    spec = bench_pipeline._case("wheelchair", args)
    assert not isinstance(spec, str)
    return work


def test_worker_prints_one_json_line(tiny_scene: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tiny_scene / "wheelchair_6" / "wheelchair.bag"
    cfg = tiny_scene / "wheelchair_6" / "wheelchair_starter.toml"
    argv = ["--worker", "--bag", str(bag), "--config", str(cfg), "--filter", "particle", "--out", str(tmp_path / "r")]
    assert bench_pipeline.main([*argv, "--max-frames", "5", "--stages", "--particles", "4000"]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out["frames"] == 5 and out["n_particles"] == 4000
    for key in ("elapsed_s", "fps", "rtf", "recorded_s", "cpu_ms", "cpu_rtf", "filter_cpu_ms", "peak_rss_mb"):
        assert out[key] > 0, key
    assert {"reading", "detectors", "segmentation", "features", "clutter", "filter", "tracking", "writing"} <= set(
        out["stages_ms"]
    )
    assert (tmp_path / "r" / "people.csv").is_file()


def test_worker_needs_its_arguments(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_pipeline.main(["--worker"]) == 2
    assert "--bag" in capsys.readouterr().err


def test_driver_runs_workers_without_baseline(
    tiny_scene: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    js = tmp_path / "runs.json"
    argv = ["--cases", "wheelchair", "person_following", "--filters", "grid"]
    argv += ["--max-frames", "6", "--baseline", "none", "--work", str(tiny_scene), "--data", str(tmp_path)]
    assert bench_pipeline.main([*argv, "--json", str(js), "--busy", "1"]) == 0
    text = capsys.readouterr().out
    assert "person_following: skipped" in text and "median RT factor: this" in text and "release" not in text
    assert "load: 1 busy-loop process(es) while measuring" in text
    runs = json.loads(js.read_text())
    assert [(r["case"], r["code"], r["frames"], r["same_outputs"]) for r in runs] == [("wheelchair", "this", 6, "-")]
    assert runs[0]["blas_threads"] in (0, 1)  # pfpeople.pipeline.blas: one thread per library (0: no BLAS library seen)


def test_busy_loops_end_with_the_block() -> None:
    import psutil

    before = {p.pid for p in psutil.Process().children()}
    with bench_pipeline.busy_loops(2):
        spinning = [p for p in psutil.Process().children() if p.pid not in before]
        assert len(spinning) == 2 and all(p.is_running() for p in spinning)
    assert not any(p.is_running() and p.status() != psutil.STATUS_ZOMBIE for p in spinning)


def test_worker_names_the_motion_model_of_this_checkout_and_of_a_release() -> None:
    from types import SimpleNamespace

    from gridbridge import GridFilter
    from pfpeople import ParticleFilter, PersistentSampling

    pf = ParticleFilter(n_particles=1000, rng=np.random.default_rng(0), people_motion=PersistentSampling())
    assert bench_pipeline._motion_model(pf) == "persistent"
    assert bench_pipeline._motion_model(SimpleNamespace(motion_model="paper")) == "paper"  # a release's filter
    assert bench_pipeline._motion_model(GridFilter()) is None


def test_side_by_side_rounds_pin_each_code_to_its_own_cpu_and_swap(monkeypatch: pytest.MonkeyPatch) -> None:
    """The round's runs go at once (both started before either ends), code i on CPU (i + round) mod CPUs."""
    import os
    import threading

    started: list[str] = []
    both = threading.Barrier(2, timeout=10)

    def fake(root: Path, module: str, argv: list[str], *, cpu: int | None = None) -> dict:
        started.append(argv[0])
        both.wait()  # raises BrokenBarrierError if the other run does not start while this one runs
        return {"cpu": cpu, "argv": argv}

    monkeypatch.setattr(bench_pipeline._local("release_baseline"), "run_worker", fake)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    roots = {"this": Path("a"), "release": Path("b")}
    argvs = {"this": ["t"], "release": ["r"]}
    assert bench_pipeline._round(roots, argvs, 0) == {
        "this": {"cpu": 0, "argv": ["t"]},
        "release": {"cpu": 1, "argv": ["r"]},
    }
    assert bench_pipeline._round(roots, argvs, 1) == {
        "this": {"cpu": 1, "argv": ["t"]},
        "release": {"cpu": 0, "argv": ["r"]},
    }
    assert sorted(started) == ["r", "r", "t", "t"]


@pytest.mark.parametrize("extra", [["--processes", "2"], ["--busy", "1"]])
def test_side_by_side_refuses_what_it_cannot_measure(extra: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_pipeline.main(["--side-by-side", "--baseline", "none", *extra]) == 2
    assert "--side-by-side needs a core per code measured" in capsys.readouterr().err
