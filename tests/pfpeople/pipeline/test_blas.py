"""One BLAS thread per process during a run (pfpeople.pipeline.blas): applied in the run, in the front-end process too,
recorded in run.json, restored after, and the opt-out (``--blas-threads 0``, ``PFPEOPLE_BLAS_THREADS``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from bag_fixtures import legs_only, write_scan_bag

from pfpeople.io.bag.reader import BagSource
from pfpeople.pipeline.blas import (
    BLAS_THREADS_ENV,
    blas_threads_in_use,
    limit_blas,
    resolve_blas_threads,
    usable_cpus,
)
from pfpeople.pipeline.front_end import front_process_available
from pfpeople.pipeline.runner import Pipeline
from pfpeople.run_state import FrameResult

#: BLAS threads of this process outside any limit (the libraries' own: one per core, or OPENBLAS_NUM_THREADS).
OWN = blas_threads_in_use()
needs_blas = pytest.mark.skipif(OWN == 0, reason="no BLAS library that threadpoolctl can see")


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("blas") / "scans.bag"
    write_scan_bag(path, 6)
    return path


def _stats(run_dir: Path) -> dict[str, Any]:
    stats: dict[str, Any] = json.loads((run_dir / "run.json").read_text())["stats"]
    return stats


class _BlasSpy:
    """A sink that asks threadpoolctl, at every frame of the run, how many threads BLAS would use."""

    def __init__(self) -> None:
        self.seen: list[int] = []

    def open(self, run: Any) -> None:
        pass

    def write(self, result: FrameResult) -> None:
        self.seen.append(blas_threads_in_use())

    def close(self, outcome: Any) -> None:
        pass


def test_the_number_of_threads_comes_from_the_argument_the_environment_or_is_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    assert resolve_blas_threads() == 1
    assert resolve_blas_threads(0) == 0 and resolve_blas_threads(3) == min(3, usable_cpus())  # capped at the CPUs
    monkeypatch.setenv(BLAS_THREADS_ENV, " 0 ")
    assert resolve_blas_threads() == 0 and resolve_blas_threads(2) == min(2, usable_cpus())
    monkeypatch.setenv(BLAS_THREADS_ENV, "")
    assert resolve_blas_threads() == 1
    for bad in ("two", "-1", "1.5"):
        monkeypatch.setenv(BLAS_THREADS_ENV, bad)
        with pytest.raises(ValueError, match=BLAS_THREADS_ENV):
            resolve_blas_threads()
    for wrong in (-1, 1.0, True):
        with pytest.raises(ValueError, match="blas_threads"):
            resolve_blas_threads(wrong)  # type: ignore[arg-type]


@needs_blas
def test_the_limit_holds_inside_the_block_and_is_undone_after() -> None:
    with limit_blas(1):
        assert blas_threads_in_use() == 1
    assert blas_threads_in_use() == OWN
    with limit_blas(0):
        assert blas_threads_in_use() == OWN


@needs_blas
def test_overlapping_blocks_share_the_limit_and_the_last_one_out_undoes_it() -> None:
    """Runs in two threads of one process (a Dask cluster of threads) end in any order."""
    first, second = limit_blas(1), limit_blas(1)
    first.__enter__()
    second.__enter__()
    first.__exit__(None, None, None)
    assert blas_threads_in_use() == 1  # the second run is still going
    second.__exit__(None, None, None)
    assert blas_threads_in_use() == OWN


@needs_blas
@pytest.mark.parametrize("two", [False, True], ids=["one_process", "front_process"])
def test_a_run_uses_one_blas_thread_per_process_and_records_it(
    bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, two: bool
) -> None:
    if two and not front_process_available()[0]:
        pytest.skip(front_process_available()[1])
    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    spy = _BlasSpy()
    with BagSource(bag) as src:
        summary, _ = Pipeline(legs_only(), front_process=two, sinks=[spy]).run(src, tmp_path / "run")
    assert summary.frames == 6 and spy.seen == [1] * 6
    stats = _stats(tmp_path / "run")
    assert stats["blas_threads"] == 1 and stats["front_blas_threads"] == 1
    assert blas_threads_in_use() == OWN  # the process's own counts are back after the run


@needs_blas
def test_blas_threads_zero_or_the_environment_opts_out(
    bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    spy = _BlasSpy()
    with BagSource(bag) as src:
        Pipeline(legs_only(), front_process=False, sinks=[spy], blas_threads=0).run(src, tmp_path / "zero")
    assert spy.seen == [OWN] * 6 and _stats(tmp_path / "zero")["blas_threads"] == OWN
    monkeypatch.setenv(BLAS_THREADS_ENV, "0")
    with BagSource(bag) as src:
        Pipeline(legs_only(), front_process=False).run(src, tmp_path / "env")
    assert _stats(tmp_path / "env")["blas_threads"] == OWN


@needs_blas
def test_pfpeople_run_limits_blas_by_default_and_takes_blas_threads(
    bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from pfpeople.cli import main

    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    base = ["run", str(bag), "--driver", "/scan", "--no-progress"]
    assert main([*base, "--out", str(tmp_path / "default")]) == 0
    stats = _stats(tmp_path / "default")
    assert stats["blas_threads"] == 1 and stats["front_blas_threads"] == 1
    assert main([*base, "--out", str(tmp_path / "zero"), "--blas-threads", "0", "--one-process"]) == 0
    assert _stats(tmp_path / "zero")["blas_threads"] == OWN
    for name in ("frames.csv", "detections.csv", "people.csv", "tracks.csv"):
        assert (tmp_path / "default" / name).read_bytes() == (tmp_path / "zero" / name).read_bytes(), name


def test_a_bad_blas_threads_value_is_bad_input(
    bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from pfpeople.cli import main

    base = ["run", str(bag), "--driver", "/scan", "--no-progress", "--out", str(tmp_path / "run")]
    assert main([*base, "--blas-threads", "-2"]) == 2
    assert "blas_threads must be an integer >= 0" in capsys.readouterr().err
    monkeypatch.setenv(BLAS_THREADS_ENV, "many")
    assert main(base) == 2
    assert f"{BLAS_THREADS_ENV} must be an integer >= 0" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


@needs_blas
def test_a_batch_task_limits_blas_and_passes_the_opt_out_on(
    bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from pfpeople.pipeline.batch import run_bag

    monkeypatch.delenv(BLAS_THREADS_ENV, raising=False)
    assert run_bag(bag, legs_only(), tmp_path / "default")["status"] == "complete"
    assert _stats(tmp_path / "default")["blas_threads"] == 1
    assert run_bag(bag, legs_only(), tmp_path / "zero", blas_threads=0)["status"] == "complete"
    assert _stats(tmp_path / "zero")["blas_threads"] == OWN
