"""The 2-D TF buffer (pfpeople.io.bag.tf): mounts composed along the tree."""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest

from gridbridge.geometry import xy_from_translation
from pfpeople.io.bag.tf import MountWatch, TfBuffer, TfLookupError, yaw_from_quaternion
from pfpeople.sensors import Pose2D


def _tf_msg(parent: str, child: str, x: float = 0.2, y: float = 0.1, yaw: float = 0.0, sec: int = 1) -> NS:
    """A ``tf2_msgs/TFMessage``-like namespace with one transform."""
    return NS(
        transforms=[
            NS(
                header=NS(frame_id=parent, stamp=NS(sec=sec, nanosec=0)),
                child_frame_id=child,
                transform=NS(
                    translation=NS(x=x, y=y, z=0.3),
                    rotation=NS(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
                ),
            )
        ]
    )


def test_tf_composes_mounts_along_the_tree() -> None:
    tf = TfBuffer(fallback_parent="base_link", fallback={"camera": (0.5, 0.0, 0.0)})
    tf.set_transform("base_link", "laser", Pose2D(x=0.2, y=0.1, yaw=math.pi / 2))
    tf.set_transform("/laser", "/laser_child", Pose2D(x=1.0, y=0.0, yaw=0.0))
    p = tf.lookup("base_link", "laser_child")  # 1 m along the laser's x = +y of base_link
    assert (p.x, p.y, p.yaw) == pytest.approx((0.2, 1.1, math.pi / 2))
    q = tf.lookup("laser", "camera")  # camera at (0.5, 0) in base_link, seen from the rotated laser
    np.testing.assert_allclose(q.apply(np.zeros((1, 2))), [[-0.1, -0.3]], atol=1e-12)
    np.testing.assert_allclose(tf.lookup("camera", "laser").compose(q).yaw, 0.0, atol=1e-12)
    with pytest.raises(TfLookupError, match=r"no transform from frame 'map' to frame 'laser'; known frames: \["):
        tf.lookup("laser", "map")
    assert yaw_from_quaternion(0.0, 0.0, math.sin(0.35), math.cos(0.35)) == pytest.approx(0.7)


@pytest.mark.parametrize("axis", ["x", "y", "z"])
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_tf_translation_is_refused_naming_the_topic_and_the_transform(axis: str, bad: float) -> None:
    """Issue 27: a NaN translation failed later as "Odometry.v must be finite", naming no TF."""
    msg = _tf_msg("base_link", "laser")
    setattr(msg.transforms[0].transform.translation, axis, bad)
    buf = TfBuffer()
    with pytest.raises(ValueError, match=r"topic '/tf': transform base_link -> laser: translation .* is not finite"):
        buf.add_message(msg, topic="/tf")
    assert buf.frames == []
    assert xy_from_translation(1.0, 2.0, 0.0, "here") == (1.0, 2.0)


def test_a_frame_with_two_parents_is_named_with_both_parents_and_topics() -> None:
    """Issue 27: the second parent replaced the first, and the mount was then reported as missing."""
    buf = TfBuffer(fallback_parent="base_link", fallback={"camera": (0.5, 0.0, 0.0)})
    buf.add_message(_tf_msg("base_link", "laser"), topic="/tf_static")
    buf.add_message(_tf_msg("/base_link", "laser", x=0.3, sec=2), topic="/tf")  # the same parent: updated
    assert buf.lookup("base_link", "laser").x == pytest.approx(0.3)
    with pytest.raises(
        ValueError,
        match=r"TF frame 'laser' has two parents: 'base_link' \(topic '/tf'\) and 'mast' \(topic '/tf_static'\)",
    ):
        buf.add_message(_tf_msg("mast", "laser"), topic="/tf_static")
    assert buf.lookup("base_link", "laser").x == pytest.approx(0.3)  # unchanged
    buf.add_message(_tf_msg("mast", "camera"), topic="/tf")  # TF replaces a [mounts] fallback: not two parents
    assert buf.lookup("mast", "camera").x == pytest.approx(0.2)


def test_the_edges_of_a_lookup_leave_out_the_shared_ones_and_the_fallbacks() -> None:
    """``odom -> base_link`` is above both the laser and the camera: it cancels in their mount, is not an edge."""
    buf = TfBuffer(fallback_parent="base_link", fallback={"camera": (0.5, 0.0, 0.0)})
    buf.add_message(_tf_msg("odom", "base_link", x=3.0), topic="/tf")
    buf.add_message(_tf_msg("base_link", "mast"), topic="/tf_static")
    buf.add_message(_tf_msg("mast", "laser", yaw=0.2), topic="/tf")
    assert [(e.name, e.topic) for e in buf.edges("laser", "camera")] == [
        ("mast -> laser", "/tf"),
        ("base_link -> mast", "/tf_static"),
    ]
    assert buf.edges("laser", "laser") == [] and buf.edges("laser", "map") == []
    watch = MountWatch(buf.edges("camera", "laser"))
    assert watch.topics == ["/tf", "/tf_static"]
    assert watch.check(_tf_msg("mast", "laser", yaw=0.205)) == []  # within 0.01 rad
    (moved,) = watch.check(_tf_msg("/mast", "laser", x=0.25, yaw=0.2))
    assert moved.edge.name == "mast -> laser" and moved.distance_m == pytest.approx(0.05)
    assert watch.check(_tf_msg("odom", "base_link", x=9.0)) == []  # not a mount edge


def test_planar_pose_is_the_checked_conversions() -> None:
    """``_planar_pose`` accepts what ``xy_from_translation`` and ``yaw_from_orientation`` accept, with their floats,
    and refuses (None) what they refuse: non-finite translations, non-finite or zero quaternions."""
    from gridbridge.geometry import yaw_from_orientation
    from pfpeople.io.bag.tf import _planar_pose

    rng = np.random.default_rng(4)
    special = [0.0, -0.0, 1e-7, 4e-7, 5e-7, 1e-6, np.nan, np.inf, -np.inf, 1e300]
    for _ in range(3000):
        tr = [float(v) if rng.random() < 0.8 else float(rng.choice(special)) for v in rng.normal(0, 2, 3)]
        q = [float(v) if rng.random() < 0.7 else float(rng.choice(special)) for v in rng.normal(0, 1, 4)]
        if rng.random() < 0.1:
            q = [float(v) for v in rng.choice(special[:6], 4)]  # norms around MIN_QUATERNION_NORM
        got = _planar_pose(NS(x=tr[0], y=tr[1], z=tr[2]), NS(x=q[0], y=q[1], z=q[2], w=q[3]))
        try:
            x, y = xy_from_translation(*tr, "t")
            want = Pose2D(x=x, y=y, yaw=yaw_from_orientation(*q, "t"))
        except ValueError:
            assert got is None
            continue
        assert got is not None and (got.x, got.y, got.yaw) == (want.x, want.y, want.yaw)
