"""Frame synchronisation of bag messages (pfpeople.io.bag.sync): nearest, preceding, interpolate, bounded memory."""

from __future__ import annotations

import tracemalloc

import pytest
from bag_fixtures import MS, msg, run_sync

from pfpeople.io.bag.sync import FrameAssembler


def test_nearest_within_tolerance_else_no_data() -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=30 * MS)
    stream = [msg("/scan", 0), msg("/cam", 20), msg("/cam", 45), msg("/scan", 100), msg("/cam", 140), msg("/scan", 200)]
    frames = run_sync(asm, stream)
    assert [f.stamp_ns for f in frames] == [0, 100 * MS, 200 * MS]
    assert [m.stamp_ns for m in frames[0].inputs["/cam"]] == [20 * MS]  # 20 ms beats 45 ms
    assert frames[1].inputs["/cam"] == []  # nearest is 40 ms away > 30 ms tolerance
    assert frames[2].inputs["/cam"] == []
    assert asm.stats["frames"]["emitted"] == 3


def test_nearest_waits_for_a_later_closer_message() -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=50 * MS)
    assert asm.push(msg("/cam", 80)) == []
    assert asm.push(msg("/scan", 100)) == []  # a closer /cam may still come
    out = asm.push(msg("/cam", 105))
    assert len(out) == 1 and out[0].inputs["/cam"][0].stamp_ns == 105 * MS


def test_preceding_takes_the_messages_up_to_the_next_frame() -> None:
    asm = FrameAssembler("/scan", {"/people": "preceding"}, tolerance_ns=50 * MS)
    stream = [
        msg("/scan", 0),
        msg("/people", 20),
        msg("/people", 20),
        msg("/scan", 100),
        msg("/scan", 200),
        msg("/people", 220),
    ]
    frames = run_sync(asm, stream)
    assert [len(f.inputs["/people"]) for f in frames] == [2, 0, 1]


def test_interpolate_brackets_the_frame_stamp() -> None:
    asm = FrameAssembler("/scan", {"/odom": "interpolate"}, tolerance_ns=20 * MS)
    stream = [msg("/odom", 0), msg("/odom", 30), msg("/scan", 40), msg("/odom", 60), msg("/scan", 200)]
    frames = run_sync(asm, stream)
    assert [m.stamp_ns for m in frames[0].inputs["/odom"]] == [30 * MS, 60 * MS]
    assert frames[1].inputs["/odom"] == []  # 140 ms after the last odometry: beyond the tolerance


def test_non_monotonic_messages_are_skipped_and_counted(caplog: pytest.LogCaptureFixture) -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=30 * MS)
    stream = [
        msg("/scan", 0),
        msg("/scan", 100),
        msg("/scan", 50),
        msg("/scan", 100),
        msg("/cam", 90),
        msg("/cam", 80),
        msg("/scan", 200),
    ]
    frames = run_sync(asm, stream)
    assert [f.stamp_ns // MS for f in frames] == [0, 100, 200]
    assert asm.stats["non_monotonic"] == {"/scan": 2, "/cam": 1}
    assert caplog.text.count("is not after the previous one") == 2  # once per topic


def test_silent_topic_forces_frames_after_max_pending() -> None:
    asm = FrameAssembler("/scan", {"/people": "preceding"}, tolerance_ns=0, max_pending=3)
    frames = []
    for k in range(10):
        frames += asm.push(msg("/scan", 100 * k))
    # The driver is more than two tolerances past each bound: frames go out without waiting.
    assert len(frames) >= 7
    asm2 = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=10**12, max_pending=3)
    out = []
    for k in range(10):
        out += asm2.push(msg("/scan", 100 * k))
    assert len(out) == 7 and all(f.forced for f in out) and asm2.stats["frames"]["forced"] == 7  # 3 still wait


def test_memory_does_not_grow_with_the_stream() -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest", "/odom": "interpolate"}, tolerance_ns=30 * MS)

    def feed(k0: int, n: int) -> None:
        for k in range(k0, k0 + n):
            asm.push(msg("/odom", 100 * k - 5))
            asm.push(msg("/cam", 100 * k + 3))
            asm.push(msg("/scan", 100 * k))

    feed(0, 2000)
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    feed(2000, 20000)
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename") if "sync.py" in str(s.traceback))
    assert grown < 20_000  # bytes; 20000 more frames, so < 1 byte per frame
    assert len(asm._pending) <= 2 and all(len(t.buffer) <= 3 for t in asm._topics.values())


def test_sync_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="sync policy of topic '/x'"):
        FrameAssembler("/scan", {"/x": "closest"}, tolerance_ns=0)
    with pytest.raises(ValueError, match="both the driver and a secondary"):
        FrameAssembler("/scan", {"/scan": "nearest"}, tolerance_ns=0)
    asm = FrameAssembler("/scan", {}, tolerance_ns=0)
    with pytest.raises(ValueError, match="topic '/other'"):
        asm.push(msg("/other", 0))
