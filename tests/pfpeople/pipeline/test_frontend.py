"""The front end in a second process (pfpeople.pipeline.front_end, ``Pipeline(front_process=...)``): the same run,
errors,
logs and counters as in one process."""

from __future__ import annotations

import dataclasses
import logging
import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_fixtures import legs_only, write_scan_bag

from evaluation.scenarios.scan import write_scene_bag
from pfpeople.config import load_config
from pfpeople.detect.adapters import LegAdapter
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.front_end import FRONT_COUNTERS, front_process_available
from pfpeople.pipeline.runner import Pipeline
from pfpeople.run_state import RunSummary

pytestmark = pytest.mark.skipif(not front_process_available()[0], reason=front_process_available()[1])

RUN_FILES = ("frames.csv", "detections.csv", "people.csv", "tracks.csv", "support.csv")


@pytest.fixture(scope="module")
def wheelchair(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """60 frames of the scan-level wheelchair scene: odometry, a yawed laser, both laser detectors, clutter."""
    return write_scene_bag("wheelchair", tmp_path_factory.mktemp("wheelchair"), frames=60)


@pytest.mark.parametrize("kind", ["grid", "particle"])
def test_two_processes_write_the_same_run_as_one(wheelchair: Any, tmp_path: Path, kind: str) -> None:
    cfg = load_config(wheelchair.run_toml)
    cfg = replace(cfg, filter=replace(cfg.filter, kind=kind, n_particles=5000))
    summaries = {}
    for n in (1, 2):
        with BagSource(wheelchair.bag) as src:
            summaries[n], _ = Pipeline(cfg, front_process=n == 2).run(src, tmp_path / str(n))
    one, two = tmp_path / "1", tmp_path / "2"
    for name in RUN_FILES:
        assert (one / name).read_bytes() == (two / name).read_bytes(), name
    assert np.array_equal(np.load(one / "grids.npy"), np.load(two / "grids.npy"))
    a, b = summaries[1].as_dict(), summaries[2].as_dict()
    a.pop("elapsed_s"), b.pop("elapsed_s"), a.pop("fps", None), b.pop("fps", None)
    assert a == b and a["frames"] == 60 and sum(a["suppressed"].values()) > 0


class _Boom(RuntimeError):
    pass


class _FailingLegAdapter(LegAdapter):
    """The leg detector, with a bug at its fourth frame."""

    def detect(self, msgs: Any) -> Any:
        self.calls = getattr(self, "calls", 0) + 1
        if self.calls == 4:
            raise _Boom("leg detector bug at its 4th frame")
        return super().detect(msgs)


def test_an_error_in_the_front_end_ends_the_run_at_that_frame(tmp_path: Path) -> None:
    bag = tmp_path / "scans.bag"
    write_scan_bag(bag, 10)
    pipe = Pipeline(legs_only(), adapters={"leg": _FailingLegAdapter}, front_process=True)
    with BagSource(bag) as src, pytest.raises(_Boom, match="4th frame") as err:
        pipe.run(src, tmp_path / "run")
    assert any("front-end process" in note for note in getattr(err.value, "__notes__", []))
    meta = load_run(tmp_path / "run").meta
    assert meta["status"] == "failed" and meta["frames"] == 3  # the three frames before it are kept
    assert meta["error"] == "_Boom: leg detector bug at its 4th frame"


def test_a_run_that_cannot_use_it_warns_and_runs_in_one_process(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = tmp_path / "scans.bag"
    write_scan_bag(bag, 5)
    monkeypatch.setattr("pfpeople.pipeline.runner.front_process_available", lambda: (False, "1 usable core"))
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, _ = Pipeline(legs_only(), front_process=True).run(src, None)
    assert summary.frames == 5
    assert "front_process: one process (1 usable core)" in caplog.text


def test_pfpeople_run_one_process_flag_gives_the_same_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from pfpeople.cli import main

    bag = tmp_path / "scans.bag"
    write_scan_bag(bag, 12)
    used: list[bool | None] = []
    real_init = Pipeline.__init__

    def spy(self: Pipeline, *args: Any, **kwargs: Any) -> None:
        used.append(kwargs.get("front_process"))
        real_init(self, *args, **kwargs)

    monkeypatch.setattr(Pipeline, "__init__", spy)
    for name, extra in (("default", []), ("one", ["--one-process"])):
        assert main(["run", str(bag), "--driver", "/scan", "--out", str(tmp_path / name), "--no-progress", *extra]) == 0
    assert used == [None, False]
    for name in RUN_FILES:
        assert (tmp_path / "default" / name).read_bytes() == (tmp_path / "one" / name).read_bytes(), name


def test_a_bag_that_cannot_be_read_further_keeps_the_frames_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Reading fails after 7 scans (both processes' readers: the child is forked with the patched class): the run
    fails with the reading error and keeps the same frames as in one process."""
    from pfpeople.io.bag.reader import BagReadError

    bag = tmp_path / "scans.bag"
    write_scan_bag(bag, 12)
    real = BagSource.messages

    def cut(self: BagSource, topics: Any) -> Any:
        for k, m in enumerate(real(self, topics)):
            if k == 7:
                raise BagReadError("truncated after message 7")
            yield m

    monkeypatch.setattr(BagSource, "messages", cut)
    frames = {}
    for n in (1, 2):
        with BagSource(bag) as src, pytest.raises(BagReadError, match="truncated after message 7"):
            Pipeline(legs_only(), front_process=n == 2).run(src, tmp_path / str(n))
        meta = load_run(tmp_path / str(n)).meta
        assert meta["status"] == "failed" and "truncated after message 7" in meta["error"]
        frames[n] = meta["frames"]
    assert frames[1] == frames[2] >= 6
    for name in ("frames.csv", "people.csv", "detections.csv"):
        assert (tmp_path / "1" / name).read_bytes() == (tmp_path / "2" / name).read_bytes(), name


class _DyingLegAdapter(LegAdapter):
    """The leg detector, whose process dies at its fourth frame (as if killed)."""

    def detect(self, msgs: Any) -> Any:
        self.calls = getattr(self, "calls", 0) + 1
        if self.calls == 4:
            os._exit(9)
        return super().detect(msgs)


def test_a_front_end_process_that_dies_ends_the_run_with_a_named_error(tmp_path: Path) -> None:
    bag = tmp_path / "scans.bag"
    write_scan_bag(bag, 10)
    pipe = Pipeline(legs_only(), adapters={"leg": _DyingLegAdapter}, front_process=True)
    with (
        BagSource(bag) as src,
        pytest.raises(RuntimeError, match=r"front-end process ended before frame 3 \(exit code 9\)"),
    ):
        pipe.run(src, tmp_path / "run")
    meta = load_run(tmp_path / "run").meta
    assert meta["status"] == "failed" and meta["frames"] == 3


def test_every_count_but_the_back_ends_comes_back_from_the_front_process() -> None:
    """A new :class:`RunSummary` count (e.g. ``odometry_jumps``) is copied back from the front-end process."""
    back = {"frames", "sync", "elapsed_s", "error", "mount_changes", "bad_transforms", "blas_threads", "readmitted"}
    back |= {"fov_narrowed"}
    assert set(FRONT_COUNTERS) == {f.name for f in dataclasses.fields(RunSummary)} - back
