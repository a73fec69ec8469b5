"""Issue 11: runs that end any way keep a consistent, closed, final run directory; safe against a second writer.

The signal test runs ``python -m pfpeople.cli run`` in a subprocess on a synthetic bag long enough to be
mid-run (5000 identical scans; the signal comes after 10 frames), waits until frames are on disk, sends the
signal, and checks that ``run.json``, ``frames.csv``, ``grids.npy`` and the result bag agree.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import legs_only, write_scan_bag
from rosbags.highlevel import AnyReader

from gridbridge.grid import GridSpec
from pfpeople.cli import main
from pfpeople.io.run_dir import RunLockedError, RunWriter, load_run

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def long_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp("long") / "long.bag"
    write_scan_bag(bag, 5000)
    return bag


def _start(bag: Path, out: Path, bag_out: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "pfpeople.cli", "run", str(bag), "--driver", "/scan", "--out", str(out)]
    cmd += ["--bag-out", str(bag_out), "--no-progress"]
    return subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)


def _wait_for_frames(proc: subprocess.Popen[str], frames_csv: Path, n: int = 10, timeout: float = 60.0) -> None:
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        if proc.poll() is not None:
            raise AssertionError(f"the run ended before the signal: {proc.communicate()}")
        if frames_csv.is_file() and frames_csv.read_text().count("\n") > n:
            return
        time.sleep(0.02)
    raise AssertionError("no frames written in time")


def test_sigterm_and_sigint_mid_run_leave_a_final_consistent_run(tmp_path: Path, long_bag: Path) -> None:
    cases = {signal.SIGTERM: 143, signal.SIGINT: 130}
    procs = {}
    try:  # both runs at once (they are independent): the test waits for one Python start-up, not two
        for sig in cases:
            out = tmp_path / signal.Signals(sig).name
            out.mkdir()
            procs[sig] = (_start(long_bag, out / "run", out / "out.bag"), out)
        for sig, (proc, out) in procs.items():
            _wait_for_frames(proc, out / "run" / "frames.csv")
            proc.send_signal(sig)
        errs = {sig: proc.communicate(timeout=60)[1] for sig, (proc, _) in procs.items()}
    finally:
        for proc, _ in procs.values():
            if proc.poll() is None:
                proc.kill()
    for sig, code in cases.items():
        proc, out = procs[sig]
        err, run_dir = errs[sig], out / "run"
        assert proc.returncode == code
        name = signal.Signals(sig).name
        assert "Traceback" not in err and err.count("interrupted by") == 1  # one line
        assert err.strip().splitlines()[-1] == (
            f"pfpeople run: interrupted by {name}; the frames processed are kept in {run_dir} (status 'interrupted')"
        )
        meta = json.loads((run_dir / "run.json").read_text())
        run = load_run(run_dir)
        n = meta["frames"]
        assert meta["status"] == "interrupted" and meta["error"] == f"interrupted by {name}"
        assert 10 <= n < 5000
        shape = (n, meta["grid"]["nx"], meta["grid"]["ny"])
        assert np.load(run_dir / "grids.npy", mmap_mode="r").shape == shape  # the header counts what is on disk
        assert (run_dir / "frames.csv").read_text().count("\n") == n + 1  # header + one complete row per frame
        assert run.n_frames == n and list(run.frames["frame"]) == list(range(n))
        assert np.all(np.isfinite(run.grids)) and meta["stats"]["frames"] == n
        with AnyReader([out / "out.bag"]) as r:  # closed and indexed: readable, one belief per frame
            counts = {c.topic: c.msgcount for c in r.connections}
        assert counts["/pfpeople/belief"] == n


def test_second_writer_and_overwrite_of_a_live_run_are_refused(tmp_path: Path) -> None:
    spec = GridSpec()
    out = tmp_path / "run"
    first = RunWriter(out, spec=spec, detector_names=["d"])
    try:
        for overwrite in (False, True):
            with pytest.raises(RunLockedError, match=r"is being written by another process \(pid \d+\)"):
                RunWriter(out, spec=spec, detector_names=["d"], overwrite=overwrite)
        first.write_frame(
            frame=0,
            driver_index=0,
            stamp_ns=1,
            bag_time_ns=1,
            dt_s=0.1,
            odometry=None,
            forced=False,
            belief=np.full(spec.shape, 0.5),
            people=np.zeros((0, 2)),
            detections=[None],
        )
    finally:
        first.close()
    # Once closed, --overwrite replaces it.
    second = RunWriter(out, spec=spec, detector_names=["d"], overwrite=True)
    second.close()
    assert load_run(out).n_frames == 0 and json.loads((out / "run.json").read_text())["status"] == "complete"


def test_out_with_the_users_files_is_never_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    rc = main(["run", str(bag), "--driver", "/scan", "--out", str(out), "--no-progress", "--overwrite"])
    assert rc == 2
    assert "is not empty and holds no run.json (thesis.tex)" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir() if p.name != ".lock") == ["thesis.tex"]
    assert (out / "thesis.tex").read_text() == "precious"


@pytest.mark.parametrize(
    ("bag_out", "match"),
    [
        ("missing/dir/out.bag", r"parent folder '.*missing/dir' does not exist"),
        (".", r"bag output '.*' would write over the input '.*b\.bag'"),  # the folder holds the input
        ("b.bag", r"bag output '.*b\.bag' would write over the input '.*b\.bag'"),
    ],
)
def test_bad_bag_out_is_refused_before_the_run_directory_exists(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], bag_out: str, match: str
) -> None:
    import re

    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "run"
    target = str(tmp_path / bag_out)
    assert main(["run", str(bag), "--driver", "/scan", "--out", str(out), "--bag-out", target, "--no-progress"]) == 2
    assert re.search(match, capsys.readouterr().err)
    assert not out.exists()  # nothing to block the rerun


def test_disk_full_names_the_file_and_keeps_a_readable_run(tmp_path: Path) -> None:
    if not Path("/dev/full").exists():
        pytest.skip("/dev/full is not available")
    spec = GridSpec()
    out = tmp_path / "run"
    w = RunWriter(out, spec=spec, detector_names=["d"])
    frame = dict(
        driver_index=0,
        bag_time_ns=1,
        dt_s=0.1,
        odometry=None,
        forced=False,
        belief=np.full(spec.shape, 0.5),
        people=np.zeros((0, 2)),
        detections=[np.zeros((0, 2))],
    )
    w.write_frame(frame=0, stamp_ns=1, **frame)  # type: ignore[arg-type]
    w._grids.close()
    w._grids = open("/dev/full", "wb")  # every write from now on fails with ENOSPC
    with pytest.raises(OSError, match=r"No space left on device: '.*grids\.npy'") as info:
        w.write_frame(frame=1, stamp_ns=2, **frame)  # type: ignore[arg-type]
    assert info.value.errno == errno.ENOSPC
    try:
        w.close(status="failed", error=str(info.value))
    except OSError as exc:  # the full "disk" cannot take the buffered bytes either: named, after run.json
        assert exc.errno == errno.ENOSPC
    run = load_run(out)
    assert run.meta["status"] == "failed" and run.meta["frames"] == 1 and run.n_frames == 1


def test_a_row_cut_short_is_not_a_frame(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "run"
    from pfpeople.io.bag.reader import BagSource
    from pfpeople.pipeline.runner import Pipeline

    with BagSource(bag) as src:
        Pipeline(legs_only()).run(src, out)
    text = (out / "frames.csv").read_text()
    (out / "frames.csv").write_text(text[: text.rindex("\n", 0, len(text) - 1) + 8])  # last row cut after 7 chars
    run = load_run(out)
    assert run.n_frames == 2 and len(run.frames["frame"]) == 2


def test_a_signal_during_a_frame_is_raised_after_it_is_written(tmp_path: Path) -> None:
    """SIGTERM arriving while frame 3 is computed (here: from inside its filter step, where compiled kernels run
    and a raised signal would become a SystemError) ends the run after frame 3 is on disk: 4 frames, interrupted."""
    from bag_fixtures import config, write_bag

    from pfpeople.io.bag.reader import BagSource
    from pfpeople.io.run_dir import RunInterrupted, interrupt_signals
    from pfpeople.pipeline.runner import Pipeline, make_filter

    bag = tmp_path / "synthetic.bag"
    write_bag(bag)
    cfg = config()

    def factory(spec: GridSpec, models: object) -> object:
        filt = make_filter(cfg.filter, spec, models)  # type: ignore[arg-type]
        step, calls = filt.step, []

        def signalled_step(*args: object, **kwargs: object) -> object:
            calls.append(1)
            if len(calls) == 4:
                os.kill(os.getpid(), signal.SIGTERM)
            return step(*args, **kwargs)

        filt.step = signalled_step  # type: ignore[method-assign]
        return filt

    with interrupt_signals(), BagSource(bag) as src, pytest.raises(RunInterrupted):
        Pipeline(cfg, front_process=False, filter_factory=factory).run(src, tmp_path / "run")  # type: ignore[arg-type]
    meta = json.loads((tmp_path / "run" / "run.json").read_text())
    assert meta["status"] == "interrupted" and meta["frames"] == 4
    assert (tmp_path / "run" / "frames.csv").read_text().count("\n") == 5
