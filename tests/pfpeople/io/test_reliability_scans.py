"""Issue 27: LaserScans inconsistent with their angles, and setups that would silently find nobody.

Each case gets a clear error naming the topic or setting, or a stated, logged (once per topic) and counted
handling. Bags are written as ``tests/pfpeople/io/test_reliability_bags.py`` writes them; ``write_laser_bag`` lets a
test change any field of any scan.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_fixtures import INC, PEOPLE, T0_NS, Msgs, legs, legs_only, typestore
from rosbags.rosbag1 import Writer as Writer1

from gridbridge.grid import GridSpec
from pfpeople.detect.legs import LegDetectorParams, leg_beam_range
from pfpeople.detect.synthetic import render_scan
from pfpeople.io.bag.reader import BadScanError, BagSource, laser_from_msg
from pfpeople.pipeline.runner import Pipeline

Fields = Callable[[int, dict[str, Any]], dict[str, Any]]


def _scan_fields(angle_min: float, angle_max: float, inc: float) -> dict[str, Any]:
    scan = render_scan(circles=legs(PEOPLE), angle_min=angle_min, angle_max=angle_max, angle_increment=inc)
    ranges = np.asarray(scan.ranges, dtype=np.float32)
    return {
        "angle_min": scan.angle_min,
        "angle_max": scan.angle_min + inc * (ranges.size - 1),
        "angle_increment": inc,
        "range_min": 0.05,
        "range_max": 10.0,
        "ranges": ranges,
    }


def write_laser_bag(
    path: Path,
    n: int,
    fields: Fields | None = None,
    *,
    angle_min: float = -math.pi / 2,
    angle_max: float = math.pi / 2,
    inc: float = INC,
) -> None:
    """``n`` scans at 10 Hz of the people of ``PEOPLE`` on ``/scan``; ``fields(k, f)`` returns scan k's fields."""
    ts = typestore(False)
    m = Msgs(ts, False)
    w = Writer1(path)
    w.open()
    conn = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
    for k in range(n):
        f = _scan_fields(angle_min, angle_max, inc)
        if fields is not None:
            f = fields(k, f)
        stamp = T0_NS + k * 100_000_000
        msg = m.T["sensor_msgs/msg/LaserScan"](
            header=m.header(stamp, "laser"),
            time_increment=0.0,
            scan_time=0.1,
            intensities=np.zeros(0, dtype=np.float32),
            **{**f, "ranges": np.asarray(f["ranges"], dtype=np.float32)},
        )
        w.write(conn, stamp + 3_000_000, ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan"))
    w.close()


def _run(bag: Path, caplog: pytest.LogCaptureFixture, **kw: Any) -> tuple[Any, list[Any]]:
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        return Pipeline(legs_only(**kw), front_process=False).run(src, None, keep=True)


def _msg(**changes: Any) -> Any:
    m = Msgs(typestore(False), False)
    msg = m.scan(T0_NS, np.full(100, 2.0), -0.5, 0.01)
    for name, value in changes.items():
        setattr(msg, name, np.asarray(value, dtype=np.float32) if name == "ranges" else value)
    return msg


# -- 1. len(ranges) inconsistent with the angles -----------------------------------------------------------------


def test_truncated_scan_is_bad_not_a_sector_seen_empty(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """Scans 2 and 4 lost their last 161 beams (the person at -20 deg is in the kept part, the other not): each
    is refused, counted, the detector has no data there (it covers no cell); warned once."""

    def cut(k: int, f: dict[str, Any]) -> dict[str, Any]:
        return {**f, "ranges": f["ranges"][:200]} if k in (2, 4) else f

    bag = tmp_path / "cut.bag"
    write_laser_bag(bag, 6, cut)
    summary, results = _run(bag, caplog)
    assert summary.bad_messages == {"legs": 2} and summary.no_data == {"legs": 2}
    assert summary.bad_scans == {"legs": {"beam_count": 2}}
    assert results[2].detections[0] is None and results[4].detections[0] is None
    assert all(len(results[k].detections[0]) == 2 for k in (0, 1, 3, 5))
    assert caplog.text.count("200 ranges, but angle_min") == 1
    assert "topic '/scan'" in caplog.text and "give 361.0 beams" in caplog.text


def test_one_beam_of_mismatch_is_accepted() -> None:
    """Drivers differ on whether angle_max is the last beam's bearing or one step past it: both are accepted."""
    past = _msg(angle_max=-0.5 + 0.01 * 100)
    assert laser_from_msg(past, stamp_ns=T0_NS, frame_id="laser").ranges.size == 100
    with pytest.raises(BadScanError, match=r"topic '/front'.* 98 ranges.* give 100.0 beams") as info:
        laser_from_msg(_msg(ranges=np.ones(98)), stamp_ns=T0_NS, frame_id="laser", topic="/front")
    assert info.value.reason == "beam_count"
    with pytest.raises(BadScanError, match=r"100 ranges.* give -98.0 beams"):  # angles against the increment
        laser_from_msg(_msg(angle_increment=-0.01), stamp_ns=T0_NS, frame_id="laser")
    with pytest.raises(BadScanError):
        laser_from_msg(_msg(angle_max=math.nan), stamp_ns=T0_NS, frame_id="laser")


# -- 2. no usable return -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("front_process", [False, True])
def test_all_negative_ranges_are_no_data_not_nobody(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, front_process: bool
) -> None:
    """Also with the front-end process: its counters (``bad_scans`` included) and its warning reach this one."""

    def dead(k: int, f: dict[str, Any]) -> dict[str, Any]:
        r = np.full_like(f["ranges"], -1.0)
        r[::7] = np.nan
        r[::11] = 0.01  # below range_min
        return {**f, "ranges": r} if k in (1, 3) else f

    bag = tmp_path / "dead.bag"
    write_laser_bag(bag, 5, dead)
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, results = Pipeline(legs_only(), front_process=front_process).run(src, None, keep=True)
    assert summary.bad_messages == {"legs": 2} and summary.no_data == {"legs": 2}
    assert summary.bad_scans == {"legs": {"no_return": 2}}
    assert results[1].detections[0] is None and results[3].detections[0] is None
    assert caplog.text.count("no usable range: all 361 ranges") == 1 and "'/scan'" in caplog.text


def test_a_scan_that_saw_nothing_in_range_is_still_an_empty_view() -> None:
    """+inf and beyond range_max are "no return": free space, a valid empty view (not refused)."""
    r = np.full(100, np.inf)
    r[:10] = 10.5  # beyond range_max
    r[10:20] = -1.0
    scan = laser_from_msg(_msg(ranges=r), stamp_ns=T0_NS, frame_id="laser")
    assert not scan.valid.any() and scan.no_return.sum() == 90
    with pytest.raises(BadScanError, match="NaN") as info:
        laser_from_msg(_msg(ranges=np.full(100, np.nan)), stamp_ns=T0_NS, frame_id="laser")
    assert info.value.reason == "no_return"


# -- 3. more than a full turn ---------------------------------------------------------------------------------------


def test_scan_spanning_more_than_a_full_turn_is_refused(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """Scan 2 has 361 beams at 1.5 deg (540 deg, angles consistent with it): refused, counted, warned."""

    def wide(k: int, f: dict[str, Any]) -> dict[str, Any]:
        if k != 2:
            return f
        inc = math.radians(1.5)
        return {**f, "angle_increment": inc, "angle_max": f["angle_min"] + inc * (f["ranges"].size - 1)}

    bag = tmp_path / "wide.bag"
    write_laser_bag(bag, 4, wide)
    summary, results = _run(bag, caplog)
    assert summary.bad_scans == {"legs": {"span": 1}} and summary.bad_messages == {"legs": 1}
    assert results[2].detections[0] is None and len(results[1].detections[0]) == 2
    assert "span 540.0 deg, more than a full turn" in caplog.text and "topic '/scan'" in caplog.text


def test_a_full_turn_with_the_first_bearing_repeated_is_accepted() -> None:
    n = 361
    inc = 2 * math.pi / (n - 1)
    full = _msg(ranges=np.full(n, 2.0), angle_min=-math.pi, angle_max=math.pi, angle_increment=inc)
    assert laser_from_msg(full, stamp_ns=T0_NS, frame_id="laser").ranges.size == n
    two = _msg(ranges=np.full(n, 2.0), angle_min=-math.pi, angle_max=math.pi, angle_increment=inc * 1.02)
    with pytest.raises(BadScanError, match="more than a full turn") as info:
        laser_from_msg(two, stamp_ns=T0_NS, frame_id="laser")
    assert info.value.reason == "span"


# -- 4. a grid no detector sees --------------------------------------------------------------------------------------


def test_grid_no_detector_sees_is_refused_naming_grid_and_views(tmp_path: Path) -> None:
    """The laser looks forward (-90..90 deg, 10 m); a grid behind it has no cell it covers: refused before any
    output, naming the grid and the field of view."""
    bag = tmp_path / "g.bag"
    write_laser_bag(bag, 2)
    behind = GridSpec(nx=10, ny=10, resolution=0.3, x0=-20.0, y0=-1.5)
    with BagSource(bag) as src, pytest.raises(ValueError, match=r"\[grid\] \(x -20.00..-17.00 m.*no cell") as info:
        Pipeline(legs_only(grid=behind), front_process=False).run(src, tmp_path / "run")
    assert "legs: bearings -90..90 deg, range 0..10 m" in str(info.value)
    assert not (tmp_path / "run").exists()
    ahead = replace(behind, x0=1.0)
    with BagSource(bag) as src:
        summary, _ = Pipeline(legs_only(grid=ahead), front_process=False).run(src, None)
    assert summary.frames == 2


# -- 5. beams too coarse for the leg detector --------------------------------------------------------------------------


def test_leg_beam_range_follows_far_leg_width() -> None:
    p = LegDetectorParams()
    assert leg_beam_range(p, math.radians(1.0)) == pytest.approx(0.10 / (3 * math.radians(1.0)))
    assert leg_beam_range(p, -math.radians(0.5)) == pytest.approx(3.82, abs=0.01)
    assert leg_beam_range(replace(p, far_leg_width=0.0), math.radians(1.0)) == pytest.approx(
        0.10 / (4 * math.radians(1.0))
    )


def test_coarse_360_laser_is_warned_once_at_the_start(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """A 1 deg, 360 deg low-cost laser: a 0.1 m leg gets under 3 returns beyond 1.91 m; warned once, naming the
    topic, its spacing and that range. A 0.5 deg laser (3.82 m) is not warned about."""
    bag = tmp_path / "coarse.bag"
    write_laser_bag(bag, 3, angle_min=-math.pi, angle_max=math.pi - math.radians(1.0), inc=math.radians(1.0))
    summary, _ = _run(bag, caplog)
    assert summary.frames == 3 and summary.bad_messages == {}
    text = caplog.text
    assert text.count("too coarse for the leg detector") == 1
    assert "topic /scan: beam spacing 1 deg" in text and "fewer than 3 returns beyond 1.91 m" in text
    caplog.clear()
    fine = tmp_path / "fine.bag"
    write_laser_bag(fine, 2)
    _run(fine, caplog)
    assert "too coarse" not in caplog.text
