"""``pfpeople batch``: many bags as Dask tasks on a 2-worker local cluster, one of them corrupt.

The cluster (threads, ``processes=False``: process workers cost seconds to start; the command's default is
processes) is shared by the module. Bags are small synthetic ROS 1 bags (:func:`write_synthetic_bag`).
"""

from __future__ import annotations

import csv
import logging
import math
import sys
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
from rosbags.highlevel import AnyReader

from evaluation.bench.batch import SYNTHETIC_CONFIG, write_synthetic_bag
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.batch import (
    ROW_COLUMNS,
    dashboard_available,
    dask_client,
    quiet_dask_logs,
    run_batch,
    run_dir_names,
    write_table,
)

N_SCANS = 8


@pytest.fixture(scope="module")
def client() -> Iterator[Any]:
    with dask_client(workers=2, processes=False) as c:
        assert len(c.scheduler_info()["workers"]) == 2
        yield c


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    root = tmp_path_factory.mktemp("bags")
    rng = np.random.default_rng(7)
    good = [write_synthetic_bag(root / f"walk{k}.bag", n_scans=N_SCANS, rng=rng) for k in range(2)]
    # Corrupt from the middle on: the data of the second half of its chunks overwritten (the index is intact).
    corrupt = write_synthetic_bag(root / "corrupt.bag", n_scans=2 * N_SCANS, rng=rng, chunk_threshold=2048)
    with AnyReader([corrupt]) as r:
        chunk_pos = sorted(c.pos for rd in r.readers for c in rd.chunk_infos)  # type: ignore[union-attr]
    data = bytearray(corrupt.read_bytes())
    start = chunk_pos[len(chunk_pos) // 2]
    data[start + 60 : start + 120] = b"\xff" * 60  # the first record header in that chunk
    corrupt.write_bytes(bytes(data))
    return [good[0], corrupt, good[1]]


def test_one_corrupt_bag_does_not_stop_the_others(tmp_path: Path, client: Any, bags: list[Path]) -> None:
    out = tmp_path / "runs"
    rows = run_batch(bags, SYNTHETIC_CONFIG, out, client=client, progress=False)
    assert [r["bag"] for r in rows] == [str(b) for b in bags]  # order as given, whatever finished first
    assert [r["status"] for r in rows] == ["complete", "failed", "complete"]
    assert all(tuple(r) == ROW_COLUMNS for r in rows)
    for r in (rows[0], rows[2]):
        run = load_run(r["run_dir"])
        assert r["frames"] == N_SCANS and run.meta["status"] == "complete" and r["error"] == ""
        assert r["people_per_frame"] == pytest.approx(float(np.mean(run.frames["n_people"])), abs=1e-12)
        assert r["fps"] > 0 and r["wall_s"] > 0
        assert run.meta["stats"]["blas_threads"] == 1  # pfpeople.pipeline.blas: one BLAS thread per worker during a run
    bad = rows[1]
    assert bad["error"].startswith("BagReadError: ") and "corrupt.bag" in bad["error"]
    assert "truncated or corrupt after" in bad["error"]
    assert Path(bad["run_dir"]) == (out / "corrupt").absolute()
    assert "BagReadError" in (out / "corrupt" / "batch_error.txt").read_text()
    # The frames before the corrupt chunk are kept and counted; the run directory says why it stopped.
    run = load_run(bad["run_dir"])
    assert run.meta["status"] == "failed" and "BagReadError" in run.meta["error"]
    assert 2 <= bad["frames"] == run.n_frames < 2 * N_SCANS and math.isnan(bad["fps"])
    assert 0 <= bad["cpu_s"] <= bad["wall_s"] + 0.05
    # A second batch into the same folder is refused before anything runs, naming the run directories.
    with pytest.raises(FileExistsError, match="walk0"):
        run_batch(bags, SYNTHETIC_CONFIG, out, client=client, progress=False)
    # Tables: CSV (NaN as an empty cell) and Parquet (NaN as null).
    write_table(rows, tmp_path / "t.csv", ROW_COLUMNS)
    with (tmp_path / "t.csv").open(newline="") as fh:
        back = list(csv.DictReader(fh))
    assert [b["status"] for b in back] == ["complete", "failed", "complete"] and back[1]["fps"] == ""
    assert int(back[0]["frames"]) == N_SCANS
    table = pq.read_table(write_table(rows, tmp_path / "t.parquet")).to_pylist()
    assert table[1]["fps"] is None and table[2]["frames"] == N_SCANS and table[1]["error"] == bad["error"]


def test_batch_command_on_a_running_scheduler(
    tmp_path: Path, client: Any, bags: list[Path], capsys: pytest.CaptureFixture[str]
) -> None:
    from pfpeople.cli import main

    cfg = tmp_path / "cfg.toml"
    cfg.write_text('[frames]\ndriver = "/scan"\n[[detectors]]\nname = "laser_legs"\nkind = "leg"\ntopic = "/scan"\n')
    address = client.scheduler.address
    base = ["batch", *map(str, bags), "--config", str(cfg), "--out", str(tmp_path / "o"), "--no-progress"]
    assert main([*base, "--scheduler", address, "--max-frames", "3", "--table", str(tmp_path / "r.csv")]) == 0
    text = capsys.readouterr().out
    assert "3 bag(s): 3 complete, 0 failed" in text
    with (tmp_path / "r.csv").open(newline="") as fh:
        frames = [r["frames"] for r in csv.DictReader(fh)]
    assert frames == ["3", "3", "3"]  # the corrupt bag's first 3 frames are readable
    assert main([*base, "--scheduler", address, "--workers", "2"]) == 2
    assert "cannot be combined with a scheduler" in capsys.readouterr().err
    assert main([*base, "--table", str(tmp_path / "r.xlsx")]) == 2
    assert "must end in one of ['.csv', '.parquet']" in capsys.readouterr().err


def test_run_dir_names_are_unique() -> None:
    assert run_dir_names(["a/x.bag", "b/x.bag", "c/x.bag.zip", "y"]) == ["x", "x-2", "x-3", "y"]
    names = run_dir_names(["a/x.bag", "x-2.bag", "b/x.bag"])
    assert len(set(names)) == 3
    with pytest.raises(ValueError, match="workers must be a positive integer"):
        with dask_client(workers=0):
            pass


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


@pytest.fixture
def distributed_log() -> Iterator[_Records]:
    """Records of the ``distributed`` loggers (they may not propagate to the root), levels restored after."""
    import distributed  # noqa: F401  (its import configures its loggers)

    root, handler = logging.getLogger("distributed"), _Records()
    level = root.level
    root.addHandler(handler)
    try:
        yield handler
    finally:
        root.removeHandler(handler)
        root.setLevel(level)


def test_dask_quiet_by_default_and_no_dashboard_link_without_bokeh(
    distributed_log: _Records, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "bokeh", types.ModuleType("bokeh"))
    assert dashboard_available()
    monkeypatch.setitem(sys.modules, "bokeh", None)  # import bokeh -> ImportError
    assert not dashboard_available()
    quiet_dask_logs(verbose=False)
    assert logging.getLogger("distributed.scheduler").getEffectiveLevel() == logging.WARNING
    with dask_client(workers=1, processes=False):
        pass
    assert [r for r in distributed_log.records if r.levelno < logging.WARNING] == []
    quiet_dask_logs(verbose=True)  # -v: the cluster's INFO lines, still without a dead dashboard link
    with dask_client(workers=1, processes=False):
        pass
    messages = [r.getMessage() for r in distributed_log.records]
    assert any("Scheduler at" in m for m in messages), messages
    assert not any("dashboard" in m.lower() for m in messages), [m for m in messages if "dashboard" in m.lower()]


def test_batch_out_that_is_a_file_is_refused_naming_it(
    tmp_path: Path, bags: list[Path], capsys: pytest.CaptureFixture[str]
) -> None:
    """``--out FILE`` gave a bare "[Errno 17] File exists"; refused before any cluster starts."""
    from pfpeople.cli import main

    cfg = tmp_path / "cfg.toml"
    cfg.write_text('[frames]\ndriver = "/scan"\n[[detectors]]\nname = "laser_legs"\nkind = "leg"\ntopic = "/scan"\n')
    afile = tmp_path / "out.txt"
    afile.write_text("not a folder\n")
    for out, what in ((afile, "is a file, not a folder"), (afile / "sub", f"its parent {str(afile)!r} is a file")):
        argv = ["batch", str(bags[0]), "--config", str(cfg), "--out", str(out), "--no-progress"]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"--out {str(out)!r}" in err and what in err and "Errno" not in err
    assert afile.read_text() == "not a folder\n"
