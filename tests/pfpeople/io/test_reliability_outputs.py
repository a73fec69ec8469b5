"""Issue 27: outputs never write over inputs or over each other; a killed run never blocks a rerun.

Bags are the synthetic ones of ``tests/pfpeople/io/test_reliability_bags.py`` (``write_scan_bag``) and
``tests/pfpeople/pipeline/test_pipeline_bags.py`` (``write_bag``, ROS 2).
"""

from __future__ import annotations

import json
import logging
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import write_bag, write_scan_bag
from rosbags.highlevel import AnyReader

from gridbridge.grid import GridSpec
from pfpeople.cli import main
from pfpeople.io import locks
from pfpeople.io.bag.writer import BagLockedError, ResultBagWriter, lock_path
from pfpeople.io.run_dir import RunLockedError, RunWriter, check_output_paths
from pfpeople.pipeline.front_end import front_process_available

ROOT = Path(__file__).resolve().parents[3]


def _run(bag: Path, out: Path, bag_out: Path | str, *extra: str) -> int:
    return main(["run", str(bag), "--driver", "/scan", "--out", str(out), "--bag-out", str(bag_out), *extra])


@pytest.mark.parametrize("via", ["same", "symlink", "hardlink"])
def test_bag_out_naming_the_input_bag_is_refused_and_the_input_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], via: str
) -> None:
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    before = bag.read_bytes()
    target = bag
    if via == "symlink":
        target = tmp_path / "link.bag"
        target.symlink_to(bag)
    elif via == "hardlink":
        target = tmp_path / "hard.bag"
        os.link(bag, target)
    assert _run(bag, tmp_path / "run", target, "--overwrite", "--no-progress", "--one-process") == 2
    err = capsys.readouterr().err
    assert re.search(rf"bag output '{re.escape(str(target))}' would write over the input '{re.escape(str(bag))}'", err)
    assert bag.read_bytes() == before and not (tmp_path / "run").exists()


@pytest.mark.parametrize("where", ["folder", "inside", "inside-symlink"])
def test_bag_out_naming_the_input_ros2_folder_or_a_path_in_it_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], where: str
) -> None:
    folder = tmp_path / "in_ros2"
    write_bag(folder, ros2=True, n_scans=3)
    files = sorted(p.name for p in folder.iterdir())
    target = {"folder": folder, "inside": folder / "out.bag", "inside-symlink": tmp_path / "ln" / "out.bag"}[where]
    (tmp_path / "ln").symlink_to(folder)
    assert _run(folder, tmp_path / "run", target, "--overwrite", "--no-progress") == 2
    assert "would write over the input" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == files and not (tmp_path / "run").exists()


def test_out_over_the_input_and_bag_out_over_the_run_directory_are_refused(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    bag.write_bytes(b"x")
    folder = tmp_path / "ros2"
    folder.mkdir()
    with pytest.raises(ValueError, match=r"output directory '.*ros2/run' would write over the input '.*ros2'"):
        check_output_paths([folder], out_dir=folder / "run")
    with pytest.raises(ValueError, match=r"output directory '.*' would write over the input '.*b\.bag'"):
        check_output_paths([bag], out_dir=tmp_path)  # the run directory would hold the input
    d = tmp_path / "outputs" / "D"
    for bag_out in (d, d / "grids.npy", d / ".lock", d.parent):
        with pytest.raises(ValueError, match=r"bag output '.*' conflicts with the output directory '.*D'"):
            check_output_paths([bag], out_dir=d, bag_out=bag_out)
    check_output_paths([bag], out_dir=d, bag_out=d / "result.bag")  # a bag of its own in the run directory: fine


def test_out_equal_to_bag_out_is_refused_before_the_run_directory_exists(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "D"
    assert _run(bag, out, out, "--no-progress", "--bag-format", "mcap") == 2
    assert "conflicts with the output directory" in capsys.readouterr().err
    assert not out.exists()


def _frame(w: ResultBagWriter, k: int) -> None:
    w.write(k + 1, k + 1, np.full(w.spec.shape, 0.5), np.zeros((0, 2)), [None])


@pytest.mark.parametrize("name", ["out.bag", "out_ros2"])
def test_a_second_bag_writer_is_refused_and_the_bag_is_renamed_into_place(tmp_path: Path, name: str) -> None:
    spec = GridSpec(nx=10, ny=10)
    path = tmp_path / name
    kw = {"spec": spec, "frame_id": "base_link", "detector_names": ["d"]}
    with ResultBagWriter(path, **kw) as old:  # an old bag, replaced with overwrite below
        _frame(old, 0)
    first = ResultBagWriter(path, overwrite=True, **kw)
    try:
        for k in range(3):
            _frame(first, k)
        assert lock_path(path).read_text() == f"{os.getpid()}\n"
        for overwrite in (False, True):
            with pytest.raises(
                BagLockedError, match=r"bag output '.*' is being written by another process \(pid \d+\)"
            ):
                ResultBagWriter(path, overwrite=overwrite, **kw)
        with AnyReader([path]) as r:  # the old bag stays whole while the new one is written
            assert {c.topic: c.msgcount for c in r.connections}["/pfpeople/belief"] == 1
    finally:
        first.close()
    with AnyReader([path]) as r:
        assert {c.topic: c.msgcount for c in r.connections}["/pfpeople/belief"] == 3
    # no temporary folder, no lock file left; the Foxglove layout beside the bag
    assert sorted(p.name for p in tmp_path.iterdir()) == [name, f"{name}.foxglove-layout.json"]


def test_two_runs_on_the_same_bag_out_the_second_is_refused_before_its_run_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = tmp_path / "long.bag"
    write_scan_bag(bag, 3000)
    bag_out = tmp_path / "out.bag"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "pfpeople.cli", "run", str(bag), "--driver", "/scan", "--out", str(tmp_path / "a")]
    cmd += ["--bag-out", str(bag_out), "--no-progress", "--one-process"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        frames_csv, t_end = tmp_path / "a" / "frames.csv", time.monotonic() + 30
        while not (frames_csv.is_file() and frames_csv.read_text().count("\n") > 5):
            assert proc.poll() is None and time.monotonic() < t_end
            time.sleep(0.02)
        assert _run(bag, tmp_path / "b", bag_out, "--overwrite", "--no-progress", "--one-process") == 2
        err = capsys.readouterr().err
        assert re.search(r"bag output '.*out\.bag' is being written by another process \(pid \d+\)", err)
        assert not (tmp_path / "b").exists()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 143
    finally:
        if proc.poll() is None:
            proc.kill()
    n = json.loads((tmp_path / "a" / "run.json").read_text())["frames"]
    with AnyReader([bag_out]) as r:  # the first run's bag, whole: one belief per frame on disk
        assert {c.topic: c.msgcount for c in r.connections}["/pfpeople/belief"] == n
    assert not lock_path(bag_out).exists() and sorted(p.name for p in tmp_path.iterdir()) == [
        "a",
        "long.bag",
        "out.bag",
        "out.bag.foxglove-layout.json",
    ]


def test_a_lock_held_for_a_dead_pid_is_taken_over_with_a_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "run"
    out.mkdir()
    lock = out / ".lock"
    lock.write_text(f"{dead.pid}\n")
    holder = locks.acquire(lock, "x")  # a live process still holds it (here: this one, through another file)
    lock.write_text(f"{dead.pid}\n")
    try:
        with caplog.at_level(logging.WARNING, logger="pfpeople.io.locks"):
            w = RunWriter(out, spec=GridSpec(nx=4, ny=4), detector_names=["d"])
        w.close()
    finally:
        locks.release(holder)
    assert f"held for a dead process (pid {dead.pid}): taking it over" in caplog.text
    lock.write_text("1\n")  # pid 1 is alive: refused as before
    held = locks.acquire(lock, "y")
    lock.write_text("1\n")
    try:
        with pytest.raises(RunLockedError, match=r"is being written by another process \(pid 1\)"):
            RunWriter(out, spec=GridSpec(nx=4, ny=4), detector_names=["d"], overwrite=True)
    finally:
        locks.release(held)


def _children(pid: int) -> list[int]:
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _alive(pid: int) -> bool:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return False
    return fields[0] != "Z"


@pytest.mark.skipif(not front_process_available()[0], reason="no front-end process here (needs Linux, 2 cores)")
def test_kill_9_of_a_run_kills_its_front_end_and_the_rerun_succeeds(tmp_path: Path) -> None:
    bag = tmp_path / "long.bag"
    write_scan_bag(bag, 3000)
    out = tmp_path / "run"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "pfpeople.cli", "run", str(bag), "--driver", "/scan", "--out", str(out)]
    with (tmp_path / "stderr.txt").open("w") as err:
        proc = subprocess.Popen([*cmd, "--no-progress"], env=env, stdout=subprocess.DEVNULL, stderr=err)
    children: list[int] = []
    try:
        t_end = time.monotonic() + 30
        while not ((out / "frames.csv").is_file() and (out / "frames.csv").read_text().count("\n") > 5):
            assert proc.poll() is None and time.monotonic() < t_end, (tmp_path / "stderr.txt").read_text()
            time.sleep(0.02)
        children = _children(proc.pid)
        assert children, "no front-end process"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        t_end = time.monotonic() + 5
        while any(_alive(c) for c in children) and time.monotonic() < t_end:
            time.sleep(0.05)
        assert not any(_alive(c) for c in children)
    finally:
        if proc.poll() is None:
            proc.kill()
        for c in children:  # never leave an orphan of this test behind
            if _alive(c):
                os.kill(c, signal.SIGKILL)
    rerun = ["--overwrite", "--no-progress", "--max-frames", "3", "--one-process"]
    assert main(["run", str(bag), "--driver", "/scan", "--out", str(out), *rerun]) == 0
    assert json.loads((out / "run.json").read_text())["frames"] == 3


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_run_json_respects_the_umask(tmp_path: Path, umask: int, mode: int) -> None:
    old = os.umask(umask)
    try:
        w = RunWriter(tmp_path / "run", spec=GridSpec(nx=4, ny=4), detector_names=["d"])
        w.update(note="rewritten")  # every rewrite keeps the mode
        w.close()
    finally:
        os.umask(old)
    assert (tmp_path / "run" / "run.json").stat().st_mode & 0o777 == mode
    assert (tmp_path / "run" / "grids.npy").stat().st_mode & 0o777 == mode  # as every other file of the run
