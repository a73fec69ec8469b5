"""HOG camera detector (detector 3): flat-ground geometry against hand-computed values, HOG path, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfpeople.detect.camera import (
    HogCameraDetector,
    HogParams,
    default_intrinsics,
    foot_points,
    horizon_row,
)
from pfpeople.sensors import CameraImage, CameraIntrinsics, Pose2D

# f = 500 px, H = 1.5 m, 640 x 480, principal point at the centre
CAM = CameraIntrinsics(fx=500.0, fy=500.0, cx=320.0, cy=240.0, width=640, height=480, height_above_ground=1.5)


def _box(u_centre: float, foot_row: float, w: float = 40.0, h: float = 120.0) -> list[float]:
    return [u_centre - w / 2, foot_row - h, w, h]


def test_stein_range_level_camera() -> None:
    # foot row 100 px below the horizon: Z = f H / 100 = 500 * 1.5 / 100 = 7.5 m (Stein et al. 2003)
    det = HogCameraDetector(CAM)
    pos, ok = det.boxes_to_positions(np.array([_box(320.0, 340.0), _box(420.0, 340.0), _box(320.0, 490.0)]))
    assert ok.tolist() == [True, True, True]
    np.testing.assert_allclose(pos[0], [7.5, 0.0], atol=1e-12)
    # 100 px right of centre: Y = -(100 / 500) * 7.5 = -1.5 m (REP-103: right is negative y)
    np.testing.assert_allclose(pos[1], [7.5, -1.5], atol=1e-12)
    # 250 px below the horizon: 3.0 m
    np.testing.assert_allclose(pos[2], [3.0, 0.0], atol=1e-12)


def test_pitched_camera_and_horizon_rejection() -> None:
    cam = CameraIntrinsics(
        fx=500.0, fy=500.0, cx=320.0, cy=240.0, width=640, height=480, height_above_ground=1.5, pitch=0.2
    )
    v_h = horizon_row(cam)
    assert v_h == pytest.approx(240.0 - 500.0 * math.tan(0.2))
    # the optical axis (row cy) meets the ground at H / tan(pitch) = 7.40 m
    pts, valid = foot_points(np.array([320.0, 320.0, 320.0]), np.array([240.0, v_h, v_h - 5.0]), cam)
    assert valid.tolist() == [True, False, False]
    assert pts[0, 0] == pytest.approx(1.5 / math.tan(0.2), rel=1e-12)
    assert np.all(np.isnan(pts[1:]))
    det = HogCameraDetector(cam)
    _pos, ok = det.boxes_to_positions(np.array([_box(320.0, 240.0), _box(320.0, v_h - 1.0)]))
    assert ok.tolist() == [True, False]
    assert det.last_rejected == {"foot_at_or_above_horizon": 1, "beyond_max_range": 0}
    # a ray 10 px below the horizon: brute force intersection of the rotated ray with the ground
    v = v_h + 10.0
    yc = (v - cam.cy) / cam.fy
    ang = 0.2 + math.atan(yc)  # depression angle of the ray below horizontal
    assert foot_points(np.array([320.0]), np.array([v]), cam)[0][0, 0] == pytest.approx(1.5 / math.tan(ang))


def test_max_range_and_mounting() -> None:
    mount = Pose2D(x=0.2, y=0.1, yaw=math.pi / 2)
    det = HogCameraDetector(CAM, mounting=mount)
    assert det.model.max_range == pytest.approx(500.0 * 1.75 / 96.0)  # 9.11 m
    assert (det.model.mount_x, det.model.mount_y, det.model.mount_yaw) == (0.2, 0.1, math.pi / 2)
    pos, ok = det.boxes_to_positions(np.array([_box(320.0, 340.0), _box(320.0, 300.0)]))  # 7.5 m, 12.5 m
    assert ok.tolist() == [True, False]
    assert det.last_rejected["beyond_max_range"] == 1
    np.testing.assert_allclose(pos[0], [0.2, 0.1 + 7.5], atol=1e-12)  # rotated +90 deg, then shifted


def test_default_model_is_paper_camera() -> None:
    det = HogCameraDetector()
    m = det.model
    assert m.uncertainty == "gaussian" and (m.sigma_lateral, m.sigma_range) == (1.0, 1.7)
    assert (m.ppv, m.fnr) == (0.95, 0.50)
    assert math.degrees(m.fov_max - m.fov_min) == pytest.approx(62.0)
    assert default_intrinsics().horizontal_fov == pytest.approx(math.radians(62.0))


def test_blank_image_gives_no_detections() -> None:
    det = HogCameraDetector()
    for px in (np.zeros((480, 640, 3), np.uint8), np.full((480, 640), 128, np.uint8)):
        assert det.detect(px).shape == (0, 2)
        assert det.detect(CameraImage(pixels=px)).shape == (0, 2)
        boxes, scores = det.detect_boxes(px)
        assert boxes.shape == (0, 4) and scores.shape == (0,)
    tiny = HogCameraDetector(default_intrinsics(width=60, height=100))
    assert tiny.detect(np.zeros((100, 60, 3), np.uint8)).shape == (0, 2)


@pytest.mark.parametrize(
    ("pixels", "match"),
    [
        (np.zeros((100, 100, 3), np.uint8), "image has shape"),
        (np.zeros((480, 640, 2), np.uint8), "image must have shape"),
        (np.zeros((480,), np.uint8), "image must have shape"),
        (np.zeros((480, 640, 3), np.float32), "image must be uint8"),
    ],
)
def test_bad_images_raise(pixels: np.ndarray, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        HogCameraDetector().detect(pixels)


def test_param_validation() -> None:
    with pytest.raises(ValueError, match="scale"):
        HogParams(scale=1.0)
    with pytest.raises(ValueError, match="win_stride"):
        HogParams(win_stride=0)
    with pytest.raises(ValueError, match="same length"):
        foot_points(np.zeros(2), np.zeros(3), CAM)
