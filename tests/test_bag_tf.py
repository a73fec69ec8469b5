"""The 2-D TF buffer (pfpeople.bag.tf): mounts composed along the tree."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfpeople.bag.tf import TfBuffer, TfLookupError, yaw_from_quaternion
from pfpeople.sensors import Pose2D


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
    from types import SimpleNamespace as NS

    from gridbridge.geometry import xy_from_translation

    tr = NS(x=0.2, y=0.1, z=0.3)
    setattr(tr, axis, bad)
    t = NS(
        header=NS(frame_id="base_link", stamp=NS(sec=1, nanosec=0)),
        child_frame_id="laser",
        transform=NS(translation=tr, rotation=NS(x=0.0, y=0.0, z=0.0, w=1.0)),
    )
    buf = TfBuffer()
    with pytest.raises(ValueError, match=r"topic '/tf': transform base_link -> laser: translation .* is not finite"):
        buf.add_message(NS(transforms=[t]), topic="/tf")
    assert buf.frames == []
    assert xy_from_translation(1.0, 2.0, 0.0, "here") == (1.0, 2.0)
