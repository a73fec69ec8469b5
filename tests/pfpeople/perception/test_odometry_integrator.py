"""The odometry integrator (pfpeople.perception.odometry): frame timing and the grid frame's ego-motion, hand-computed.

Frames are built directly (no bag): a driver message and ``nav_msgs/Odometry``-like namespaces on ``/odom``.
"""

from __future__ import annotations

import logging
import math
from types import SimpleNamespace

import pytest

import pfpeople.pipeline.runner as pipeline
from pfpeople.io.bag.reader import BagMessage
from pfpeople.io.bag.sync import Frame
from pfpeople.perception.odometry import FIRST_DT_S, OdometryIntegrator, interpolate_pose, odometry_between
from pfpeople.run_state import RunSummary, WarnOnce
from pfpeople.sensors import Pose2D

S = 1_000_000_000  # ns per s


def _odom(stamp_ns: int, x: float, y: float = 0.0, yaw: float = 0.0) -> BagMessage:
    q = SimpleNamespace(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
    pose = SimpleNamespace(pose=SimpleNamespace(position=SimpleNamespace(x=x, y=y, z=0.0), orientation=q))
    msg = SimpleNamespace(pose=pose, child_frame_id="base_link")
    return BagMessage("/odom", "nav_msgs/msg/Odometry", 0, stamp_ns, stamp_ns, "odom", msg)


def _frame(index: int, t_s: float, *odom: BagMessage) -> Frame:
    stamp = round(t_s * S)
    driver = BagMessage("/scan", "sensor_msgs/msg/LaserScan", index, stamp, stamp, "laser", None)
    return Frame(index=index, driver=driver, stamp_ns=stamp, inputs={"/odom": list(odom)})


def _step(integ: OdometryIntegrator, frame: Frame):  # type: ignore[no-untyped-def]
    m = integ.begin(frame)
    integ.end(frame, m)
    return m


def test_rotation_about_the_base_gives_no_forward_speed_and_the_chord_as_lateral_motion() -> None:
    # The grid frame 0.5 m ahead of base_link; the base turns 0.1 rad on the spot in 0.1 s. The grid origin
    # moves on a circle of 0.5 m: chord 2 * 0.5 * sin(0.05), perpendicular to the mean heading (pure lateral).
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(x=0.5), summary=summary)
    first = _step(integ, _frame(0, 0.0, _odom(0, 0.0)))
    assert (first.dt, first.first, first.odometry, first.pose) == (FIRST_DT_S, True, None, Pose2D(x=0.5))
    m = _step(integ, _frame(1, 0.1, _odom(round(0.1 * S), 0.0, yaw=0.1)))
    assert m.dt == pytest.approx(0.1, abs=1e-12) and not m.first
    assert m.odometry is not None
    assert m.odometry.omega == pytest.approx(1.0, abs=1e-9)
    assert m.odometry.v == pytest.approx(0.0, abs=1e-9)
    assert summary.max_lateral_m == pytest.approx(math.sin(0.05), abs=1e-12)
    assert m.ego is not None and m.motion == m.ego
    assert (m.ego.x, m.ego.y, m.ego.yaw) == pytest.approx((0.5 * math.cos(0.1) - 0.5, 0.5 * math.sin(0.1), 0.1))


def test_pose_is_interpolated_to_the_frame_stamp_and_motion_since_the_last_odometry_is_kept() -> None:
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(), summary=summary)
    _step(integ, _frame(0, 0.0, _odom(0, 0.0)))
    # Odometry at 0.05 s (x 0.05) and 0.15 s (x 0.25): at 0.1 s, x = 0.15; v = 0.15 / 0.1.
    m1 = _step(integ, _frame(1, 0.1, _odom(round(0.05 * S), 0.05), _odom(round(0.15 * S), 0.25)))
    assert m1.pose == Pose2D(x=pytest.approx(0.15), y=0.0, yaw=0.0)
    assert m1.odometry is not None and m1.odometry.v == pytest.approx(1.5) and m1.odometry.omega == 0.0
    m2 = _step(integ, _frame(2, 0.2))  # no odometry: standing, counted
    assert m2.odometry is None and m2.pose is None and m2.motion is None
    assert summary.frames_without_odometry == 1
    # Next frame: the whole displacement since frame 1 (0.15 -> 0.45 m) over this frame's dt (0.1 s).
    m3 = _step(integ, _frame(3, 0.3, _odom(round(0.3 * S), 0.45)))
    assert m3.odometry is not None and m3.odometry.v == pytest.approx(3.0)
    assert interpolate_pose((0, Pose2D(yaw=3.0)), (10, Pose2D(yaw=-3.0)), 5).yaw == pytest.approx(
        3.0 + (2 * math.pi - 6) / 2
    )


def test_a_long_gap_restarts_and_bad_odometry_is_counted(caplog: pytest.LogCaptureFixture) -> None:
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(), summary=summary)
    _step(integ, _frame(0, 0.0, _odom(0, 0.0)))
    with caplog.at_level(logging.WARNING):
        m = _step(integ, _frame(1, 2.5, _odom(round(2.5 * S), 1.0)))
    assert m.restarted and m.dt == FIRST_DT_S and m.odometry is None  # no motion across the restart
    assert summary.filter_restarts == 1 and "gap of 2.500 s before frame 1: restarting the filter" in caplog.text
    m = _step(integ, _frame(2, 2.6, _odom(round(2.6 * S), math.nan)))
    assert m.pose is None and m.odometry is None
    assert summary.bad_messages == {"/odom": 1} and summary.frames_without_odometry == 1
    assert "odometry pose has NaN" in caplog.text
    m = _step(integ, _frame(3, 2.7, _odom(round(2.7 * S), 1.2)))
    assert m.odometry is not None and m.odometry.v == pytest.approx(2.0)  # 1.0 -> 1.2 m over 0.1 s


def test_laser_odometry_moves_the_grid_without_an_odometry_topic() -> None:
    summary = RunSummary()
    integ = OdometryIntegrator(None, laser_odometry=True, summary=summary)
    step = Pose2D(x=0.1, yaw=0.02)
    m0 = integ.begin(_frame(0, 0.0))
    assert integ.from_laser(m0, step) is m0  # first frame: no previous scan to match
    integ.end(_frame(0, 0.0), m0)
    m1 = integ.from_laser(integ.begin(_frame(1, 0.1)), step)
    expect, lateral = odometry_between(Pose2D(), step, 0.1)
    assert m1.odometry == expect and m1.motion == step and summary.laser_odometry_frames == 1
    assert summary.max_lateral_m == pytest.approx(abs(lateral))
    off = OdometryIntegrator(None, laser_odometry=False)
    off.end(_frame(0, 0.0), off.begin(_frame(0, 0.0)))
    m = off.begin(_frame(1, 0.1))
    assert off.from_laser(m, step) is m and m.odometry is None
    with pytest.raises(ValueError, match="needs base_to_grid"):
        OdometryIntegrator("/odom")


def test_frames_are_counted_by_the_source_of_their_ego_motion() -> None:
    """``ego_motion``: odometry topic, scan matching, none (first frame, a frame without odometry, a failed
    match); the counts add up to the frames."""
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(), summary=summary)
    for k, odom in enumerate([True, True, False, True]):
        _step(integ, _frame(k, 0.1 * k, *([_odom(round(0.1 * k * S), 0.05 * k)] if odom else [])))
    assert summary.ego_motion == {"odometry": 2, "scan_matching": 0, "none": 2}
    laser = RunSummary()
    integ = OdometryIntegrator(None, laser_odometry=True, summary=laser)
    for k, ego in enumerate([Pose2D(x=0.1), Pose2D(x=0.1), None, Pose2D(x=0.1)]):
        f = _frame(k, 0.1 * k)
        integ.end(f, integ.from_laser(integ.begin(f), ego))
    assert laser.ego_motion == {"odometry": 0, "scan_matching": 2, "none": 2} and laser.laser_odometry_frames == 2
    assert sum(laser.ego_motion.values()) == 4 and RunSummary().as_dict()["ego_motion"]["none"] == 0


def test_pipeline_module_still_exports_the_odometry_helpers() -> None:
    assert pipeline.odometry_between is odometry_between
    assert (pipeline.FIRST_DT_S, pipeline.MAX_GAP_S) == (0.1, 2.0)


def test_frames_faster_than_a_laser_warn_once_about_the_clock(caplog: pytest.LogCaptureFixture) -> None:
    # leg_tracker's positive_*_extracted.bag on bag time: 197 scans recorded within 0.5 s (2.4 ms apart)
    integ = OdometryIntegrator(None, summary=RunSummary())
    with caplog.at_level(logging.WARNING, logger="pfpeople.perception.odometry"):
        dts = [_step(integ, _frame(k, 0.0024 * k)).dt for k in range(5)]
    fast = [r for r in caplog.records if "faster than a laser scans" in r.getMessage()]
    assert len(fast) == 1 and "frame 1 comes 2.40 ms after the previous one (417 Hz)" in fast[0].getMessage()
    assert 'time_source = "header"' in fast[0].getMessage()
    assert dts[1:] == pytest.approx([0.0024] * 4)  # the run goes on with the clock it was given
    caplog.clear()
    integ = OdometryIntegrator(None, summary=RunSummary())
    with caplog.at_level(logging.WARNING, logger="pfpeople.perception.odometry"):
        for k in range(5):
            _step(integ, _frame(k, 0.025 * k))  # a 40 Hz laser: no warning
    assert not [r for r in caplog.records if "faster than a laser" in r.getMessage()]


@pytest.mark.parametrize(("dx", "dyaw"), [(100.0, 0.0), (0.0, math.pi)])
def test_an_odometry_jump_restarts_the_filter_warned_once_and_counted(
    dx: float, dyaw: float, caplog: pytest.LogCaptureFixture
) -> None:
    """Issue 27: a reset or relocalised odometry (x += 100 m, or yaw += pi, in one step) is not motion."""
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(), summary=summary)
    _step(integ, _frame(0, 0.0, _odom(0, 0.0)))
    _step(integ, _frame(1, 0.1, _odom(round(0.1 * S), 0.1)))
    with caplog.at_level(logging.WARNING, logger="pfpeople.perception.odometry"):
        m = _step(integ, _frame(2, 0.2, _odom(round(0.2 * S), 0.2 + dx, yaw=dyaw)))
        m3 = _step(integ, _frame(3, 0.3, _odom(round(0.3 * S), 0.3 + dx, yaw=dyaw)))
        again = _step(integ, _frame(4, 0.4, _odom(round(0.4 * S), 0.4, yaw=0.0)))  # and back: a second jump
    assert m.restarted and m.odometry is None and m.ego is None and m.dt == FIRST_DT_S
    assert m3.odometry is not None and abs(m3.odometry.v) == pytest.approx(1.0)  # goes on from the new pose
    assert again.restarted and summary.odometry_jumps == 2 and summary.filter_restarts == 2
    assert summary.as_dict()["odometry_jumps"] == 2  # run.json stats
    jumps = [r.getMessage() for r in caplog.records if "jump" in r.getMessage()]
    assert len(jumps) == 1 and "topic '/odom'" in jumps[0] and "frame 2" in jumps[0]
    assert "restarting the filter" in jumps[0] and "counted" in jumps[0]


def test_a_jump_between_the_two_messages_of_a_frame_is_one_jump(caplog: pytest.LogCaptureFixture) -> None:
    """The frame's bracketing messages straddle the jump: not interpolated across it (one restart, not two)."""
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(), summary=summary)
    _step(integ, _frame(0, 0.0, _odom(0, 0.0)))
    with caplog.at_level(logging.WARNING, logger="pfpeople.perception.odometry"):
        m1 = _step(integ, _frame(1, 0.1, _odom(round(0.09 * S), 0.09), _odom(round(0.12 * S), 100.12)))
        m2 = _step(integ, _frame(2, 0.2, _odom(round(0.19 * S), 100.19), _odom(round(0.21 * S), 100.21)))
    assert m1.pose == Pose2D(x=pytest.approx(0.09)) and not m1.restarted  # the nearer message: before the jump
    assert m2.restarted and summary.odometry_jumps == 1 and summary.filter_restarts == 1


def test_fast_but_plausible_odometry_is_motion() -> None:
    """4 m/s and 5 rad/s are below the bounds; a 2 cm step 4 ms apart is judged over 0.1 s (not 5 m/s)."""
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(), summary=summary)
    _step(integ, _frame(0, 0.0, _odom(0, 0.0)))
    m = _step(integ, _frame(1, 0.1, _odom(round(0.1 * S), 0.4, yaw=0.5)))
    m2 = _step(integ, _frame(2, 0.104, _odom(round(0.104 * S), 0.43, yaw=0.5)))
    assert not m.restarted and not m2.restarted and summary.odometry_jumps == 0
    assert m.odometry is not None and m.odometry.omega == pytest.approx(5.0)


def test_an_odometry_child_frame_other_than_the_base_frame_is_warned_once_and_counted(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Issue 27: odometry of ``base_footprint`` while the mounts hang from ``base_link`` was used silently."""
    summary = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(x=0.5), base_frame="base_footprint", summary=summary)
    with caplog.at_level(logging.WARNING, logger="pfpeople.perception.odometry"):
        m = [_step(integ, _frame(k, 0.1 * k, _odom(round(0.1 * k * S), 0.1 * k))) for k in range(3)]
    got = [r.getMessage() for r in caplog.records if "child frame" in r.getMessage()]
    assert len(got) == 1 and "topic '/odom'" in got[0]
    assert "'base_link'" in got[0] and "'base_footprint'" in got[0] and "takes the odometry pose" in got[0]
    assert summary.odometry_other_child == 3 and summary.as_dict()["odometry_other_child"] == 3
    assert m[2].odometry is not None and m[2].odometry.v == pytest.approx(1.0)  # still used, as stated
    caplog.clear()
    same = RunSummary()
    integ = OdometryIntegrator("/odom", Pose2D(), base_frame="/base_link", summary=same)
    with caplog.at_level(logging.WARNING, logger="pfpeople.perception.odometry"):
        _step(integ, _frame(0, 0.0, _odom(0, 0.0)))
    assert same.odometry_other_child == 0 and not caplog.records
    cfg = SimpleNamespace(odometry="/odom", base_frame="base_footprint", clutter=SimpleNamespace(laser_odometry=False))
    built = pipeline.default_odometry(cfg, Pose2D(), RunSummary(), WarnOnce(logging.getLogger("t")))  # type: ignore[arg-type]
    assert built.base_frame == "base_footprint"
