"""``pfpeople-eval sweep``: tiny sweeps (1-2 seeds, 2-4 frames) on a 2-worker local cluster.

``particles = 10`` is below one particle per cell (900): the particle filter refuses it, so those tasks fail and
are recorded while the others complete. The cluster uses threads (``processes=False``) to start fast.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from evaluation.harness.ab import FilterSpec, run_ab
from evaluation.harness.sweep import (
    SWEEP_KEYS,
    SweepPoint,
    _filters,
    check_scenarios,
    parse_param,
    run_sweep,
    sweep_points,
)
from evaluation.scenarios.scenario import Scenario
from pfpeople.pipeline.batch import dask_client

FRAMES = 4


@pytest.fixture(scope="module")
def client() -> Iterator[Any]:
    with dask_client(workers=2, processes=False) as c:
        yield c


def test_tiny_sweep_rows_match_the_ab_harness(tmp_path: Path, client: Any) -> None:
    rows = run_sweep(
        ["complementary"], [0, 1], {"frames": [FRAMES], "particles": [0, 10]}, tmp_path, client=client, progress=False
    )
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    assert tasks == [
        "complementary_seed0_frames=4_particles=0",
        "complementary_seed0_frames=4_particles=10",
        "complementary_seed1_frames=4_particles=0",
        "complementary_seed1_frames=4_particles=10",
    ]
    by_task = {t: [r for r in rows if r["task"] == t] for t in tasks}
    for t in tasks[1::2]:  # 10 particles: refused by the particle filter, recorded, one row
        (row,) = by_task[t]
        assert row["status"] == "failed" and "n_particles must be at least" in row["error"]
        assert "n_particles" in (tmp_path / "tasks" / t / "error.txt").read_text()
    for t in tasks[0::2]:  # grid filters only: 3 detectors, the paper's grid and the recommended grid
        ok = by_task[t]
        assert [(r["filter"], r["classifier"]) for r in ok][3:] == [
            ("grid (paper)", "blobs"),
            ("grid (paper)", "threshold"),
            ("recommended grid", "peaks"),
            ("recommended grid", "threshold"),
        ]
        assert [r["classifier"] for r in ok[:3]] == ["detector"] * 3
        assert all(r["status"] == "complete" and r["n_frames"] == FRAMES for r in ok)
        assert all(r["particles"] is None for r in ok)  # grid rows do not depend on the particle count
        assert (tmp_path / "tasks" / t / "run.json").is_file()
    # The sweep's numbers are the harness's on the same scenario and seed.
    direct = run_ab(Scenario.from_name("complementary", n_frames=FRAMES, seed=1), [FilterSpec(name="grid (paper)")])
    blobs = next(r for r in by_task[tasks[2]] if r["classifier"] == "blobs")
    assert blobs["filter"] == "grid (paper)" and blobs["seed"] == 1
    for key in ("recall", "precision", "fpcpf"):
        assert blobs[key] == pytest.approx(direct.filters[0].scores[key], nan_ok=True)


def test_sweep_command_and_bad_parameters(tmp_path: Path, client: Any, capsys: pytest.CaptureFixture[str]) -> None:
    from evaluation.cli import main

    args = ["sweep", "--scenario", "complementary", "--seeds", "3", "--out", str(tmp_path), "--no-progress"]
    rc = main(
        [
            *args,
            "--param",
            "frames=2",
            "--param",
            "particles=0",
            "--param",
            "form=paper,linear",
            "--scheduler",
            client.scheduler.address,
        ]
    )
    assert rc == 0
    assert "2 task(s): 2 complete, 0 failed" in capsys.readouterr().out
    with (tmp_path / "sweep.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    assert list(table[0])[:6] == ["task", "scenario", "seed", "frames", "particles", "form"]
    assert {r["filter"] for r in table if r["classifier"] == "blobs"} == {"grid (paper)", "grid (linear)"}
    # the recommended grid has no form: it runs once, in the first task, and its rows leave form empty
    recommended = [r for r in table if r["filter"] == "recommended grid"]
    assert [r["classifier"] for r in recommended] == ["peaks", "threshold"]
    assert {r["task"] for r in recommended} == {"complementary_seed3_frames=2_particles=0_form=paper"}
    assert {r["form"] for r in recommended} == {""}
    assert main([*args, "--param", "speed=1,2"]) == 2
    assert "unknown sweep parameter 'speed'" in capsys.readouterr().err
    with pytest.raises(ValueError, match="'frames': 'x' is not an integer"):
        parse_param("frames=10,x")
    with pytest.raises(ValueError, match="'form': 'fast' is not one of"):
        parse_param("form=fast")
    with pytest.raises(ValueError, match="scenario 'nowhere'"):
        check_scenarios(["nowhere"])
    with pytest.raises(ValueError, match="unknown sweep parameter 'pf'"):
        SweepPoint(scenario="default", seed=0, params=(("pf", 1),))
    assert len(sweep_points(["a", "b"], [0, 1, 2], {"gate": [0.3, 0.5]})) == 12


def test_each_filter_runs_once_per_sweep() -> None:
    params = {"particles": [0, 1000, 2000], "form": ["paper", "linear"], "gate": [0.3, 0.5]}
    points = sweep_points(["a"], [0, 1], params)
    seen = [(p.seed, run, p.run_values(run)) for p in points for run in p.planned()]
    assert len(seen) == len(set(seen))
    grids = [s for s in seen if s[1].startswith("grid")]
    # per seed and gate: grid (paper), grid (linear), recommended grid, whatever the particle counts
    assert len(grids) == 2 * 2 * 3
    particles = [s for s in seen if s[1].startswith("particle")]
    assert len(particles) == 2 * 2 * 2 * 2  # seeds x gates x counts x modes; form does not matter
    assert sum(s[1] == "detectors" for s in seen) == 2 * 2
    # a point left with nothing to run is no task: particles = 0 with the linear form only adds the grid
    assert [p.runs for p in sweep_points(["a"], [0], {"particles": [0], "form": ["paper", "linear"]})] == [
        ("detectors", "grid paper", "grid recommended"),
        ("grid paper",),
    ]
    assert sweep_points(["a"], [0], {"motion_model": ["paper", "persistent"], "particles": [0]})[1:] == []
    only = sweep_points(["a"], [0], {"mode": ["recommended"]})
    assert [p.runs for p in only] == [("detectors", "grid recommended", "particle recommended")]
    with pytest.raises(ValueError, match="unknown run 'kalman'"):
        SweepPoint(scenario="a", seed=0, runs=("kalman",))


def test_recommended_particles_run_with_their_own_motion_model(client: Any) -> None:
    rows = run_sweep(["complementary"], [2], {"frames": [2], "particles": [1000]}, client=client, progress=False)
    assert all(r["status"] == "complete" for r in rows), rows
    filters = list(dict.fromkeys(r["filter"] for r in rows if r["classifier"] not in ("detector", "threshold")))
    assert filters == ["grid (paper)", "recommended grid", "particles 1e3", "recommended particles 1e3"]
    ((_, spec),) = [f for f in _filters(SweepPoint(scenario="c", seed=0, runs=("particle recommended",)))]
    assert (spec.mode, spec.motion_model, spec.n_particles) == ("recommended", "persistent", 5000)
    assert {r["particles"] for r in rows if "particles" in r["filter"]} == {1000}
    assert {r["particles"] for r in rows if "grid" in r["filter"] or r["classifier"] == "detector"} == {None}


def test_help_names_only_accepted_values(capsys: pytest.CaptureFixture[str]) -> None:
    from evaluation.cli import main

    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for key, spec in SWEEP_KEYS.items():
        assert f"{key}: " in text
        listed = re.findall(rf"{key}: [^;]*?\(([a-z|]+);", text)
        assert listed == (["|".join(spec.choices)] if spec.choices else []), key
        for value in spec.choices:
            assert parse_param(f"{key}={value}") == (key, [value])
    # every --param of the examples parses
    for example in text.split("Examples: ")[1].split("pfpeople-eval sweep")[1:]:
        for item in re.findall(r"--param (\S+)", example):
            parse_param(item)
    with pytest.raises(ValueError, match="'odometry': 'reported' is not one of"):
        parse_param("odometry=reported")
