"""Bag messages to filter input: odometry poses to (v, omega), images to BGR pixels."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge.ego_motion import velocity_displacement
from pfpeople.pipeline.runner import odometry_between
from pfpeople.sensors import Pose2D


@pytest.mark.parametrize(("v", "w"), [(0.5, 0.0), (0.8, 0.6), (-0.3, -1.2), (0.0, 0.9)])
def test_odometry_between_inverts_the_velocity_model(v: float, w: float) -> None:
    dt = 0.1
    dx, dy, dth = velocity_displacement(v, w, dt)
    p0 = Pose2D(x=3.0, y=-1.0, yaw=2.5)
    p1 = p0.compose(Pose2D(x=float(dx), y=float(dy), yaw=float(dth)))
    odo, lateral = odometry_between(p0, p1, dt)
    assert odo.v == pytest.approx(v, abs=1e-9) and odo.omega == pytest.approx(w, abs=1e-9)
    assert lateral == pytest.approx(0.0, abs=1e-12)
    _, lat = odometry_between(Pose2D(), Pose2D(y=0.05), dt)  # pure sideways motion: all lateral
    assert lat == pytest.approx(0.05)


def test_image_messages_decode_to_bgr() -> None:
    import cv2
    from rosbags.typesys import Stores, get_typestore

    from pfpeople.io.bag.reader import image_from_msg

    T = get_typestore(Stores.ROS2_HUMBLE).types
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="cam")
    rgb = np.zeros((4, 5, 3), dtype=np.uint8)
    rgb[..., 0] = 200  # red in RGB
    padded = np.zeros((4, 16), dtype=np.uint8)  # step 16 > 5 * 3: row padding is dropped
    padded[:, :15] = rgb.reshape(4, 15)
    msg = T["sensor_msgs/msg/Image"](
        header=header, height=4, width=5, encoding="rgb8", is_bigendian=0, step=16, data=padded.ravel()
    )
    img = image_from_msg(msg, "sensor_msgs/msg/Image", stamp_ns=1, frame_id="cam", topic="/img")
    assert img.pixels.shape == (4, 5, 3) and img.pixels[0, 0].tolist() == [0, 0, 200]  # BGR
    ok, png = cv2.imencode(".png", img.pixels)
    assert ok
    cmsg = T["sensor_msgs/msg/CompressedImage"](header=header, format="png", data=png.ravel())
    dec = image_from_msg(cmsg, "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="cam", topic="/img")
    np.testing.assert_array_equal(dec.pixels, img.pixels)
    bad = T["sensor_msgs/msg/CompressedImage"](header=header, format="jpeg", data=np.arange(50, dtype=np.uint8))
    with pytest.raises(ValueError, match=r"topic '/img': CompressedImage at stamp 1 ns: not a PNG or JPEG image"):
        image_from_msg(bad, "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="cam", topic="/img")
    cut = T["sensor_msgs/msg/CompressedImage"](header=header, format="png", data=png.ravel()[:40])  # header only
    with pytest.raises(ValueError, match=r"topic '/img': CompressedImage .* cannot be decoded"):
        image_from_msg(cut, "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="cam", topic="/img")
    msg16 = T["sensor_msgs/msg/Image"](
        header=header, height=1, width=1, encoding="16UC1", is_bigendian=0, step=2, data=np.zeros(2, np.uint8)
    )
    with pytest.raises(ValueError, match=r"image encoding '16UC1' not supported"):
        image_from_msg(msg16, "sensor_msgs/msg/Image", stamp_ns=1, frame_id="cam", topic="/img")
