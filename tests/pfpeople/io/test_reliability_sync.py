"""Issue 27 (4): a topic recorded 0.3 s after its stamps (latency) joins its frames by stamp.

Before, frames went out two tolerances after the driver, so odometry 0.3 s late was missing from 58 of 60
frames with a warning about the tolerance. Now each topic's lag behind the driver is measured as it arrives and
frames wait that much longer (bounded by ``max_pending``); the lag is in ``stats["lag_ms"]`` and warned once.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from bag_fixtures import MS, config, msg, run_sync, write_bag

from pfpeople.io.bag.reader import BagSource
from pfpeople.io.bag.sync import FrameAssembler
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.runner import Pipeline


def _late_stream(lag_ms: float, n: int = 30) -> list:
    """Driver at 10 Hz; /odom at 50 Hz, each message in the stream ``lag_ms`` after its stamp."""
    items = [(100.0 * k + 3, msg("/scan", 100.0 * k)) for k in range(n)]
    items += [(20.0 * k + lag_ms, msg("/odom", 20.0 * k)) for k in range(-5, 5 * n + 5)]
    return [m for _, m in sorted(items, key=lambda it: it[0])]


def test_frames_wait_for_a_lagging_topic_and_the_lag_is_counted(caplog: pytest.LogCaptureFixture) -> None:
    asm = FrameAssembler("/scan", {"/odom": "interpolate"}, tolerance_ns=50 * MS)
    with caplog.at_level(logging.WARNING):
        frames = run_sync(asm, _late_stream(300.0))
    assert len(frames) == 30  # each frame gets the odometry stamped at its own stamp (it ends the wait)
    assert all([m.stamp_ns for m in f.inputs["/odom"]] == [f.stamp_ns] for f in frames)
    assert asm.stats["lag_ms"] == {"/odom": 280} and asm.stats["frames"]["forced"] == 0
    assert caplog.text.count("topic /odom arrives") == 1 and "frames wait for it" in caplog.text
    on_time = FrameAssembler("/scan", {"/odom": "interpolate"}, tolerance_ns=50 * MS)
    run_sync(on_time, _late_stream(1.0))
    assert on_time.stats["lag_ms"] == {}


def test_a_lag_beyond_max_pending_forces_frames_naming_the_topic(caplog: pytest.LogCaptureFixture) -> None:
    asm = FrameAssembler("/scan", {"/odom": "interpolate"}, tolerance_ns=50 * MS, max_pending=2)
    with caplog.at_level(logging.WARNING):
        frames = run_sync(asm, _late_stream(600.0))
    assert len(frames) == 30 and asm.stats["frames"]["forced"] > 0
    assert "lagging topics: /odom (lag 0.500 s): set max_pending_frames to at least 7 to wait for them" in caplog.text
    wide = FrameAssembler("/scan", {"/odom": "interpolate"}, tolerance_ns=50 * MS, max_pending=7)
    run_sync(wide, _late_stream(600.0))
    assert wide.stats["frames"]["forced"] == 0 and wide.stats["lag_ms"] == {"/odom": 580}


@pytest.mark.parametrize("two_processes", [False, True])
def test_odometry_recorded_late_is_used_in_every_frame(tmp_path: Path, two_processes: bool) -> None:
    bag = tmp_path / "late_odom.bag"
    write_bag(bag, n_scans=30, odom_latency_s=0.3)
    with BagSource(bag) as src:
        summary, _ = Pipeline(config(), front_process=two_processes).run(src, tmp_path / "run")
    assert summary.frames == 30 and summary.frames_without_odometry == 0  # was 28 of 30
    assert load_run(tmp_path / "run").meta["stats"]["sync"]["lag_ms"] == {"/odom": 280}
