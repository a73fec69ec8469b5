"""``pfpeople-eval sweep``: a tiny sweep (2 seeds x 2 particle counts, 4 frames) on a 2-worker local cluster.

``particles = 10`` is below one particle per cell (900): the particle filter refuses it, so those tasks fail and
are recorded while the others complete. The cluster uses threads (``processes=False``) to start fast.
"""

from __future__ import annotations

import csv
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from evaluation.ab import FilterSpec, run_ab
from evaluation.scenarios.scenario import Scenario
from evaluation.sweep import SweepPoint, check_scenarios, parse_param, run_sweep, sweep_points
from pfpeople.batch import dask_client

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
    for t in tasks[0::2]:  # grid filter only: 3 detectors + blobs + threshold rows
        ok = by_task[t]
        assert [(r["classifier"], r["status"]) for r in ok] == [("detector", "complete")] * 3 + [
            ("blobs", "complete"),
            ("threshold", "complete"),
        ]
        assert all(r["n_frames"] == FRAMES and r["particles"] == 0 for r in ok)
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
