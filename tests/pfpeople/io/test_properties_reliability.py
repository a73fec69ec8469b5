"""Property-based tests (Hypothesis) of issue 27's handlings: TF trees, odometry with jumps, scan geometry.

- Random TF trees (each frame's parent one of the frames before it; static and dynamic topics): a look-up
  composes the poses along the tree, the reverse look-up is its inverse, a second parent is refused naming the
  frame, a loop is refused at look-up; a :class:`~pfpeople.io.bag.tf.MountFollower` fed a random stream of one
  edge's transforms gives, at every stamp, the latest transform at or before it.
- Random odometry streams (slow motion with jumps of 20-100 m at random frames) through the run's
  :class:`~pfpeople.perception.odometry.OdometryIntegrator` and a grid filter: every jump counted and restarting, no
  NaN.
- Random LaserScan geometry (angle_min, increment, beams, angle_max off by a random number of beams): consistent
  scans (at most one beam off) are accepted, others refused as bad scans with a reason (beams without an
  increment: unusable data), never another exception.

Deterministic and small: ``derandomize=True``, ``deadline=None``, a few dozen examples each.
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gridbridge import GridFilter, GridSpec
from gridbridge.params import DetectorModel
from pfpeople.io.bag.reader import BadScanError, BagMessage, MessageDataError, laser_from_msg
from pfpeople.io.bag.sync import Frame
from pfpeople.io.bag.tf import MountFollower, TfBuffer, TfLookupError
from pfpeople.perception.odometry import OdometryIntegrator
from pfpeople.run_state import RunSummary
from pfpeople.sensors import Pose2D

SETTINGS = settings(
    max_examples=30, derandomize=True, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow]
)
_pose = st.builds(
    Pose2D,
    x=st.floats(-5.0, 5.0),
    y=st.floats(-5.0, 5.0),
    yaw=st.floats(-math.pi, math.pi),
)


@st.composite
def tf_trees(draw: st.DrawFn) -> tuple[list[int], list[Pose2D], list[bool]]:
    """``(parents, poses, static)``: frame ``f{i}`` (i >= 1) has parent ``f{parents[i-1]}``, an earlier frame."""
    n = draw(st.integers(2, 7))
    parents = [draw(st.integers(0, i - 1)) for i in range(1, n)]
    poses = [draw(_pose) for _ in parents]
    static = [draw(st.booleans()) for _ in parents]
    return parents, poses, static


def _build(parents: list[int], poses: list[Pose2D], static: list[bool]) -> TfBuffer:
    tf = TfBuffer()
    for i, (p, pose, st_) in enumerate(zip(parents, poses, static, strict=True), start=1):
        tf.set_transform(f"f{p}", f"f{i}", pose, 0, topic="/tf_static" if st_ else "/tf")
    return tf


def _in_root(parents: list[int], poses: list[Pose2D], i: int) -> Pose2D:
    out = Pose2D()
    while i:
        out = poses[i - 1].compose(out)
        i = parents[i - 1]
    return out


def _close(a: Pose2D, b: Pose2D) -> bool:
    turn = math.atan2(math.sin(a.yaw - b.yaw), math.cos(a.yaw - b.yaw))
    return math.hypot(a.x - b.x, a.y - b.y) < 1e-6 and abs(turn) < 1e-9


@SETTINGS
@given(tree=tf_trees(), data=st.data())
def test_tf_lookups_compose_and_invert(tree: tuple[list[int], list[Pose2D], list[bool]], data: st.DataObject) -> None:
    parents, poses, static = tree
    tf = _build(parents, poses, static)
    n = len(parents) + 1
    a, b = data.draw(st.integers(0, n - 1)), data.draw(st.integers(0, n - 1))
    got = tf.lookup(f"f{a}", f"f{b}")
    assert _close(got, _in_root(parents, poses, a).inverse().compose(_in_root(parents, poses, b)))
    assert _close(got.compose(tf.lookup(f"f{b}", f"f{a}")), Pose2D())
    child = data.draw(st.integers(1, n - 1))
    with pytest.raises(ValueError, match=rf"TF frame 'f{child}' has two parents: 'f{parents[child - 1]}'"):
        tf.set_transform("elsewhere", f"f{child}", Pose2D(), 1, topic="/tf")
    tf.set_transform(f"f{n - 1}", "f0", Pose2D(), 1, topic="/tf")  # the root under a descendant: a loop
    with pytest.raises(TfLookupError, match="TF cycle"):
        tf.lookup("f0", f"f{n - 1}")


@SETTINGS
@given(
    stamps=st.lists(st.integers(1, 50), min_size=1, max_size=12),
    yaws=st.lists(st.floats(-3.0, 3.0), min_size=12, max_size=12),
    at=st.lists(st.integers(0, 60), min_size=1, max_size=6),
)
def test_the_mount_at_a_stamp_is_the_latest_transform_before_it(
    stamps: list[int], yaws: list[float], at: list[int]
) -> None:
    tf = TfBuffer()
    tf.set_transform("base", "laser", Pose2D(yaw=0.0), 0, topic="/tf")
    follow = MountFollower(tf, "base")
    msg = [
        NS(
            header=NS(frame_id="base", stamp=NS(sec=s, nanosec=0)),
            child_frame_id="laser",
            transform=NS(
                translation=NS(x=0.0, y=0.0, z=0.0), rotation=NS(x=0.0, y=0.0, z=math.sin(y / 2), w=math.cos(y / 2))
            ),
        )
        for s, y in zip(stamps, yaws, strict=False)
    ]
    follow.add(NS(transforms=msg))
    for t in sorted(at):
        follow.advance(t * 10**9)
        before = [(s, k) for k, s in enumerate(stamps) if s <= t]
        want = yaws[max(before)[1]] if before else 0.0  # the latest stamp (the last of equal stamps) wins
        assert (
            abs(math.atan2(math.sin(follow.mount("laser").yaw - want), math.cos(follow.mount("laser").yaw - want)))
            < 1e-9
        )


def _odom_frame(k: int, pose: Pose2D) -> Frame:
    q = NS(x=0.0, y=0.0, z=math.sin(pose.yaw / 2), w=math.cos(pose.yaw / 2))
    msg = NS(pose=NS(pose=NS(position=NS(x=pose.x, y=pose.y, z=0.0), orientation=q)), child_frame_id="base_link")
    stamp = 10**9 + k * 100_000_000
    om = BagMessage("/odom", "nav_msgs/msg/Odometry", k, stamp, stamp, "odom", msg)
    drv = BagMessage("/scan", "sensor_msgs/msg/LaserScan", k, stamp, stamp, "laser", None)
    return Frame(index=k, driver=drv, stamp_ns=stamp, inputs={"/odom": [om]})


@SETTINGS
@given(
    n=st.integers(5, 25),
    v=st.floats(-1.0, 1.0),
    w=st.floats(-1.0, 1.0),
    jumps=st.sets(st.integers(1, 24), max_size=4),
    size=st.floats(20.0, 100.0),
)
def test_odometry_jumps_are_counted_and_restart_the_filter_without_nan(
    n: int, v: float, w: float, jumps: set[int], size: float
) -> None:
    summary = RunSummary()
    odo = OdometryIntegrator("/odom", Pose2D(), base_frame="base_link", summary=summary)
    filt = GridFilter(
        GridSpec(nx=8, ny=8, resolution=0.5, x0=0.0, y0=-2.0), detectors=[DetectorModel(name="d", ppv=0.9, fnr=0.2)]
    )
    pose, restarts = Pose2D(), []
    for k in range(n):
        pose = pose.compose(Pose2D(x=v * 0.1, yaw=w * 0.1))
        if k in jumps:
            pose = Pose2D(x=pose.x + size, y=pose.y - size / 2, yaw=pose.yaw)
        motion = odo.begin(_odom_frame(k, pose))
        if motion.restarted:
            filt.reset()
            restarts.append(k)
        step = filt.step([np.array([[1.0, 0.0]])], motion.odometry, motion.dt)
        odo.end(_odom_frame(k, pose), motion)
        assert np.all(np.isfinite(step.posterior)) and 0.0 <= step.posterior.min() <= step.posterior.max() <= 1.0
    expected = sorted(j for j in jumps if j < n)
    assert summary.odometry_jumps == len(expected) and restarts == expected


@SETTINGS
@given(
    a0=st.floats(-math.pi, math.pi),
    inc=st.one_of(st.floats(-0.1, -1e-3), st.floats(1e-3, 0.1), st.just(0.0)),
    n=st.integers(1, 400),
    off=st.integers(-5, 5),
)
def test_scan_geometry_is_accepted_when_consistent_else_refused_with_a_reason(
    a0: float, inc: float, n: int, off: int
) -> None:
    a1 = a0 + inc * (n - 1 + off)
    msg = NS(
        ranges=np.full(n, 2.0, dtype=np.float32),
        angle_min=a0,
        angle_max=a1,
        angle_increment=inc,
        range_min=0.05,
        range_max=10.0,
    )
    span_ok = abs(inc) * (n - 1) <= 2 * math.pi + abs(inc)
    count_ok = n == 1 or inc == 0.0 or abs(off) <= 1
    try:
        scan = laser_from_msg(msg, stamp_ns=0, frame_id="laser", topic="/scan")
    except BadScanError as exc:  # counted per reason in stats.bad_scans
        assert not (span_ok and count_ok) and exc.reason in ("span", "beam_count")
        assert "topic '/scan'" in str(exc)
        return
    except MessageDataError as exc:  # beams without an increment: no data in the frame
        assert n > 1 and inc == 0.0 and "angle_increment must be non-zero" in str(exc)
        return
    assert span_ok and count_ok and not (n > 1 and inc == 0.0) and scan.ranges.size == n
