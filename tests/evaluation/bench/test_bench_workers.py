"""The benchmarks' worker mode, their tables and evaluation.bench.release_baseline, at tiny sizes (no time asserted)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from evaluation.bench import ego_motion as bench_ego_motion
from evaluation.bench import grid as bench_grid
from evaluation.bench import particles as bench_particles
from evaluation.bench import raycast as bench_raycast
from evaluation.bench import release_baseline
from evaluation.bench.release_baseline import BaselineError, release_checkout, run_worker


def _last_json(capsys: pytest.CaptureFixture[str]) -> dict:
    lines = [line for line in capsys.readouterr().out.splitlines() if line.strip()]
    return json.loads(lines[-1])


def test_particle_worker_prints_one_json_line(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["--worker", "--sizes", "900", "--repeats", "1", "--warmup", "0", "--baseline-max", "900"]
    assert bench_particles.main([*argv, "--stonesoup-max", "0", "--no-grid"]) == 0
    data = _last_json(capsys)
    assert data["grid"] == {} and data["rss_start_mb"] > 0
    (row,) = data["particles"]
    assert row["n"] == 900 and 0.0 <= row["resampled"] <= 1.0 and row["rss_mb"] >= data["rss_start_mb"]
    assert row["pf_ms"] > 0 and row["forced_ms"] > 0 and row["filterpy_ms"] > 0
    assert row["stonesoup_ms"] is None or math.isnan(row["stonesoup_ms"])  # JSON NaN, above --stonesoup-max


def test_particle_table_lines_from_worker_results() -> None:
    row = {"n": 1000, "pf_ms": 2.0, "resampled": 0.5, "forced_ms": 2.5, "filterpy_ms": math.nan, "ratio": math.nan}
    row |= {"stonesoup_ms": 40.0, "rss_mb": 200.0}
    rel = dict(row, pf_ms=6.0, forced_ms=5.0, stonesoup_ms=math.nan, rss_mb=150.0)
    data = {"grid": {"paper": 0.5}, "grid_release": {"paper": 1.5}, "rows": [{"now": row, "release": rel}]}
    lines = bench_particles.table(data)
    assert "ratio 3.00" in lines[0]
    fields = lines[-1].split()
    assert fields[:4] == ["1000", "2.00", "6.00", "3.00"] and fields[7] == "2.00" and fields[8] == "-"
    assert fields[9:] == ["40.0", "20.0", "200", "150"]
    no_release = bench_particles.table({"grid": {}, "grid_release": {}, "rows": [{"now": row, "release": None}]})
    assert no_release[-1].split()[2] == "-"


def test_particle_cli_rejects_bad_sizes() -> None:
    with pytest.raises(SystemExit):
        bench_particles.main(["--sizes", "0"])


def test_particle_cli_without_baseline_runs_this_checkouts_worker(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["--sizes", "900", "--repeats", "1", "--warmup", "0", "--baseline-max", "0", "--stonesoup-max", "0"]
    assert bench_particles.main([*argv, "--baseline", "none"]) == 0
    out = capsys.readouterr().out
    assert "grid filter (paper )" in out and out.splitlines()[-1].split()[0] == "900"


def test_grid_worker_and_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_grid.main(["--worker", "--sizes", "12", "--repeats", "2"]) == 0
    data = _last_json(capsys)
    assert [r["form"] for r in data["rows"]] == ["paper", "linear"] and data["rss_mb"] > 0
    assert data["plain_ms"] is None or math.isnan(data["plain_ms"])  # only with --plain
    data["plain_ms"] = 30.0
    rel = {"rows": [dict(r, ms=2 * r["ms"]) for r in data["rows"]], "plain_ms": math.nan, "rss_mb": 100.0}
    lines = bench_grid.table({"now": data, "release": rel})
    assert lines[2].split()[6] == "2.00" and "release 100 MB" in lines[-1]
    assert bench_grid.table({"now": data, "release": None})[2].split()[5] == "-"


def test_raycast_worker_and_driver(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_raycast.main(["--worker", "--frames", "3", "--scenes", "wheelchair", "--clock", "cpu"]) == 0
    data = _last_json(capsys)
    fig = data["scenes"]["wheelchair"]
    assert data["random_ms"] > 0 and fig["cast_ms"] > 0 and fig["loop_ms"] > 0 and len(fig["sha256"]) == 64
    assert bench_raycast.main(["--frames", "3", "--scenes", "wheelchair", "--repeat", "1", "--baseline", "none"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[2].split() == ["this", "numpy", "numpy/this"]
    assert out[-1] == "wheelchair: the same ranges in every run and code: yes"  # compiled == numpy, bit for bit


def test_ego_motion_worker_and_driver(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench_ego_motion.main(["--worker", "--calls", "50"]) == 0
    assert _last_json(capsys)["us"] > 0
    assert bench_ego_motion.main(["--calls", "50", "--repeat", "1", "--baseline", "none"]) == 0
    line = capsys.readouterr().out.splitlines()[-1]
    assert line.startswith("ego_motion_sigma_points: this ") and "baseline" not in line


def _git(repo: Path, *args: str) -> str:
    out = subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True)
    return out.stdout.strip()


@pytest.fixture
def toy_repo(tmp_path: Path) -> Path:
    """A git repository whose one commit has a ``pfpeople`` package and a worker module."""
    repo = tmp_path / "toy"
    (repo / "pfpeople").mkdir(parents=True)
    (repo / "pfpeople" / "__init__.py").write_text("VERSION = 'toy-release'\n")
    worker = "import json, sys\nimport pfpeople\nprint('noise')\n"
    worker += "print(json.dumps({'v': pfpeople.VERSION, 'argv': sys.argv[1:]}))\n"
    (repo / "toyworker.py").write_text(worker)
    (repo / "bad.py").write_text("print('no json here')\n")
    _git(repo, "init", "-q")
    _git(repo, "add", ".")
    _git(repo, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "toy")
    return repo


def test_release_checkout_and_worker_in_a_toy_repository(toy_repo: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rev = _git(toy_repo, "rev-parse", "HEAD")
    root = release_checkout(rev[:8], repo=toy_repo)
    assert root == toy_repo / ".bench" / f"release-{rev[:10]}" and (root / "pfpeople").is_dir()
    assert release_checkout(rev, repo=toy_repo) == root  # made once, reused
    (toy_repo / "pfpeople" / "__init__.py").write_text("VERSION = 'working-tree'\n")  # not the release's
    monkeypatch.setattr(release_baseline, "REPO", toy_repo)
    out = run_worker(root, "toyworker", ["--worker", "x"])
    assert out == {"v": "toy-release", "argv": ["--worker", "x"]}
    with pytest.raises(BaselineError, match="printed no JSON"):
        run_worker(root, "bad", [])
    (toy_repo / "bad.py").write_text("raise SystemExit(3)\n")
    with pytest.raises(BaselineError, match="exited 3"):
        run_worker(root, "bad", [])


def test_release_checkout_names_an_unknown_revision(toy_repo: Path) -> None:
    with pytest.raises(BaselineError, match=r"cannot resolve the baseline revision 'no-such-rev'"):
        release_checkout("no-such-rev", repo=toy_repo)


def test_release_checkout_outside_a_git_repository(tmp_path: Path) -> None:
    with pytest.raises(BaselineError, match="cannot resolve"):
        release_checkout("HEAD", repo=tmp_path)


def test_default_baseline_is_a_revision_of_this_repository() -> None:
    if not (release_baseline.REPO / ".git").exists():
        pytest.skip("not a git checkout")
    git = [
        "git",
        "-C",
        str(release_baseline.REPO),
        "rev-parse",
        "--verify",
        f"{release_baseline.PREVIOUS_RELEASE}^{{commit}}",
    ]
    assert subprocess.run(git, capture_output=True, check=False).returncode == 0
    assert sys.executable  # the worker runs with this interpreter


def test_particle_worker_builds_the_filter_with_either_constructor(monkeypatch: pytest.MonkeyPatch) -> None:
    """The worker's shim: this checkout's components, or a release's keywords when it has no components."""
    from pfpeople import Resampling

    pf = bench_particles._particle_filter(900, ess_threshold=2.0, resampler=bench_particles.filterpy_systematic)
    assert pf.resampling == Resampling(scheme=bench_particles.filterpy_systematic, ess_threshold=2.0)
    assert bench_particles._particle_filter(900).resampling == Resampling()
    calls: list[dict] = []
    assert bench_particles._has_components()
    monkeypatch.setattr(bench_particles, "_has_components", lambda: False)  # a release before the components
    monkeypatch.setattr(bench_particles, "ParticleFilter", lambda **kw: calls.append(kw))
    bench_particles._particle_filter(900, ess_threshold=2.0)
    assert calls[0]["n_particles"] == 900 and calls[0]["ess_threshold"] == 2.0 and "resampling" not in calls[0]


def test_module_exists_tells_the_layouts_apart() -> None:
    from evaluation.bench.stage_timer import module_exists

    assert module_exists("pfpeople.particle.filter") and module_exists("pfpeople.pipeline")
    assert module_exists("gridbridge") and module_exists("pfpeople.io.bag.reader")
    assert not module_exists("pfpeople.particle_filter") and not module_exists("pfpeople.bag.config")


def test_a_release_worker_imports_the_release_modules_not_this_checkouts(tmp_path: Path) -> None:
    """A release before the folder layout, on the path first: its module, although an editable install of this
    checkout could supply the new name (``pfpeople.config``) from here."""
    old = tmp_path / "pfpeople" / "bag"
    old.mkdir(parents=True)
    (tmp_path / "pfpeople" / "__init__.py").write_text("")
    (old / "__init__.py").write_text("")
    (old / "config.py").write_text("MARK = 'release'\n")
    script = Path(__file__).resolve().parents[3] / "evaluation" / "bench" / "pipeline.py"
    code = (
        "import importlib.util, sys; "
        f"spec = importlib.util.spec_from_file_location('bp', {str(script)!r}); "
        "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m); "
        "print(m._module('pfpeople.config', 'pfpeople.bag.config').MARK)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env={"PYTHONPATH": str(tmp_path)}, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "release"


def test_run_worker_pins_the_worker_to_one_cpu(toy_repo: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    (toy_repo / "affinity.py").write_text("import json, os\nprint(json.dumps(sorted(os.sched_getaffinity(0))))\n")
    monkeypatch.setattr(release_baseline, "REPO", toy_repo)
    cpu = max(os.sched_getaffinity(0))
    assert run_worker(toy_repo, "affinity", [], cpu=cpu) == [cpu]
    assert run_worker(toy_repo, "affinity", []) == sorted(os.sched_getaffinity(0))  # unpinned: the parent's CPUs
