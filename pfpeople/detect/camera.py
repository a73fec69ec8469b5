"""Camera detector 3: OpenCV's HOG people detector with a flat-ground range (Stein, Mano & Shashua 2003).

Detection: ``cv2.HOGDescriptor`` with ``HOGDescriptor_getDefaultPeopleDetector()`` (Dalal & Triggs 2005,
64 x 128 px window) run with ``detectMultiScale``; boxes ``(u, v, w, h)`` in pixels.

Range from the foot row (Stein et al. 2003, generalised for pitch). Camera axes: x right, y down, z forward;
the camera is ``H`` m above a flat ground and pitched down by ``theta``. The pixel ``(u, v)`` has the ray
``(x_c, y_c, 1)`` with ``x_c = (u - c_x) / f_x`` and ``y_c = (v - c_y) / f_y``. In the level camera frame
(REP-103: X forward, Y left, Z up) the ray is

    d = (cos(theta) - y_c sin(theta),  -x_c,  -(y_c cos(theta) + sin(theta)))

and it meets the ground (Z = -H) at ``t = H / (y_c cos(theta) + sin(theta))``, so the foot point is

    X = H (cos(theta) - y_c sin(theta)) / (y_c cos(theta) + sin(theta)),   Y = -x_c H / (y_c cos(theta) + sin(theta)).

For ``theta = 0`` this is Stein's ``Z = f H / (v - c_y)``. The horizon is the row ``v_h = c_y - f_y tan(theta)``;
a box whose foot row ``v`` (its bottom edge) is at or above the horizon (``v <= v_h``: the ray never meets the
ground ahead) is rejected, and so is a foot point beyond ``max_range``; rejections are counted per reason in
:attr:`HogCameraDetector.last_rejected`. The column is the box centre ``u = x + w / 2``.

The foot point is then mapped from the level camera frame to the grid's sensor frame with the camera's
``mounting`` (:class:`~pfpeople.sensors.Pose2D`). Position uncertainty is the grid model's Gaussian (sd 1.0 m
across and 1.7 m along the line of sight, the paper's values) held in :attr:`HogCameraDetector.model`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from gridbridge.params import PAPER_DETECTORS, DetectorModel
from gridbridge.validation import check_int, check_positive, check_real
from pfpeople.sensors import CameraImage, CameraIntrinsics, Pose2D
from pfpeople.units import PixelCount

__all__ = [
    "HogCameraDetector",
    "HogParams",
    "default_intrinsics",
    "foot_points",
    "horizon_row",
]

#: Height (px) of a person inside the 64 x 128 HOG window (Dalal & Triggs 2005 leave a margin of 16 px).
HOG_PERSON_HEIGHT_PX = 96.0
#: Nominal person height (m) used to bound the range at which HOG can see a person.
NOMINAL_PERSON_HEIGHT = 1.75


def default_intrinsics(
    *, width: int = 640, height: int = 480, hfov: float = math.radians(62.0), height_above_ground: float = 1.63
) -> CameraIntrinsics:
    """A level pinhole camera with the paper's 62 deg horizontal field of view at 1.63 m (square pixels)."""
    f = (width / 2.0) / math.tan(hfov / 2.0)
    return CameraIntrinsics(
        fx=f,
        fy=f,
        cx=width / 2.0,
        cy=height / 2.0,
        width=width,
        height=height,
        height_above_ground=height_above_ground,
    )


def horizon_row(intrinsics: CameraIntrinsics) -> float:
    """Image row (px) of the horizon: ``c_y - f_y tan(pitch)``."""
    return intrinsics.cy - intrinsics.fy * math.tan(intrinsics.pitch)


def foot_points(
    columns: NDArray[np.float64], foot_rows: NDArray[np.float64], intrinsics: CameraIntrinsics
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Ground points of pixels on a flat floor (module docstring), in the level camera frame.

    Parameters
    ----------
    columns, foot_rows : ndarray, shape (N,)
        Pixel column ``u`` and row ``v`` (px) of each foot point.
    intrinsics : CameraIntrinsics
        Focal lengths, principal point, height above ground (m) and pitch (rad, positive down).

    Returns
    -------
    points : ndarray, shape (N, 2)
        ``(X, Y)`` (m) in the level camera frame (X forward, Y left); NaN where ``valid`` is False.
    valid : ndarray, shape (N,)
        False for rows at or above the horizon.
    """
    u = np.asarray(columns, dtype=float).reshape(-1)
    v = np.asarray(foot_rows, dtype=float).reshape(-1)
    if u.shape != v.shape:
        raise ValueError(f"columns and foot_rows must have the same length, got {u.shape} and {v.shape}")
    th = intrinsics.pitch
    xc = (u - intrinsics.cx) / intrinsics.fx
    yc = (v - intrinsics.cy) / intrinsics.fy
    down = yc * math.cos(th) + math.sin(th)
    valid = down > 1e-9
    t = np.where(valid, intrinsics.height_above_ground / np.where(valid, down, 1.0), np.nan)
    pts = np.column_stack((t * (math.cos(th) - yc * math.sin(th)), -xc * t))
    return pts, valid


@dataclass(frozen=True, kw_only=True)
class HogParams:
    """``detectMultiScale`` settings of the HOG people detector.

    Parameters
    ----------
    hit_threshold : float
        SVM score threshold (OpenCV's ``hitThreshold``).
    win_stride : int
        Window stride (px).
    padding : int
        Image padding (px).
    scale : float
        Pyramid scale step (> 1).
    group_threshold : float
        Box grouping (OpenCV's ``finalThreshold``).
    """

    hit_threshold: float = 0.0
    win_stride: PixelCount = 8
    padding: PixelCount = 8
    scale: float = 1.05
    group_threshold: float = 2.0

    def __post_init__(self) -> None:
        check_real(self.hit_threshold, "HogParams.hit_threshold")
        check_int(self.win_stride, "HogParams.win_stride", minimum=1)
        check_int(self.padding, "HogParams.padding", minimum=0)
        check_real(self.scale, "HogParams.scale", low=1.0, low_open=True)
        check_positive(self.group_threshold, "HogParams.group_threshold", allow_zero=True)


class HogCameraDetector:
    """Camera detector 3: HOG people boxes -> flat-ground positions in the grid's sensor frame.

    Parameters
    ----------
    intrinsics : CameraIntrinsics, optional
        The camera; default :func:`default_intrinsics` (640 x 480, 62 deg, 1.63 m, level).
    mounting : Pose2D, optional
        Pose of the (level) camera frame in the grid's sensor frame (m, rad); default identity.
    params : HogParams, optional
        ``detectMultiScale`` settings.
    model : DetectorModel, optional
        Grid model. Default: the paper's detector 3 (PPV 0.95, FNR 0.50, Gaussian sd 1.0 m lateral, 1.7 m
        range) with the field of view of ``intrinsics`` (62 deg by default), the mounting of ``mounting`` and
        ``max_range`` where a 1.75 m person still fills the 96 px of the HOG window: ``f_y 1.75 / 96``
        (9.7 m for the default camera).
    """

    def __init__(
        self,
        intrinsics: CameraIntrinsics | None = None,
        *,
        mounting: Pose2D | None = None,
        params: HogParams | None = None,
        model: DetectorModel | None = None,
    ) -> None:
        self.intrinsics = intrinsics if intrinsics is not None else default_intrinsics()
        if not isinstance(self.intrinsics, CameraIntrinsics):
            raise TypeError(f"intrinsics must be a CameraIntrinsics, got {type(self.intrinsics).__name__}")
        self.mounting = mounting if mounting is not None else Pose2D()
        self.params = params if params is not None else HogParams()
        if model is None:
            half = self.intrinsics.horizontal_fov / 2.0
            model = replace(
                PAPER_DETECTORS[2],
                fov_min=-half,
                fov_max=half,
                max_range=self.intrinsics.fy * NOMINAL_PERSON_HEIGHT / HOG_PERSON_HEIGHT_PX,
                mount_x=self.mounting.x,
                mount_y=self.mounting.y,
                mount_yaw=self.mounting.yaw,
            )
        self.model = model
        self._hog = cv2.HOGDescriptor()
        self._hog.setSVMDetector(np.asarray(cv2.HOGDescriptor.getDefaultPeopleDetector(), dtype=np.float32))
        self.last_rejected: dict[str, int] = {"foot_at_or_above_horizon": 0, "beyond_max_range": 0}

    def _pixels(self, image: CameraImage | NDArray[np.uint8]) -> NDArray[np.uint8]:
        px: NDArray[Any] = image.pixels if isinstance(image, CameraImage) else np.asarray(image)
        h, w = self.intrinsics.height, self.intrinsics.width
        if px.ndim == 3 and px.shape[2] == 1:
            px = px[:, :, 0]
        if px.ndim not in (2, 3) or (px.ndim == 3 and px.shape[2] not in (3, 4)):
            raise ValueError(f"image must have shape (H, W), (H, W, 3) or (H, W, 4), got {px.shape}")
        if px.shape[:2] != (h, w):
            raise ValueError(f"image has shape {px.shape[:2]} (H, W) but the intrinsics are for ({h}, {w})")
        if px.dtype != np.uint8:
            raise ValueError(f"image must be uint8, got dtype {px.dtype}")
        if px.ndim == 3 and px.shape[2] == 4:
            px = cv2.cvtColor(px, cv2.COLOR_BGRA2BGR)
        return np.ascontiguousarray(px)

    def detect_boxes(self, image: CameraImage | NDArray[np.uint8]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """HOG boxes of an image.

        Returns
        -------
        boxes : ndarray, shape (M, 4)
            ``(u, v, w, h)`` of each box (px, top-left corner and size).
        scores : ndarray, shape (M,)
            SVM scores.
        """
        px = self._pixels(image)
        p = self.params
        if px.shape[0] < 128 or px.shape[1] < 64:  # smaller than one HOG window: nothing to find
            return np.zeros((0, 4)), np.zeros(0)
        rects, weights = self._hog.detectMultiScale(
            px,
            hitThreshold=p.hit_threshold,
            winStride=(p.win_stride, p.win_stride),
            padding=(p.padding, p.padding),
            scale=p.scale,
            groupThreshold=p.group_threshold,
        )
        boxes = np.asarray(rects, dtype=float).reshape(-1, 4)
        scores = np.asarray(weights, dtype=float).reshape(-1)
        return boxes, scores

    def boxes_to_positions(self, boxes: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Flat-ground positions of boxes ``(M, 4)`` ``(u, v, w, h)`` in the grid's sensor frame.

        Returns
        -------
        positions : ndarray, shape (M, 2)
            ``(x, y)`` (m) in the grid's sensor frame; NaN for rejected boxes.
        accepted : ndarray, shape (M,)
            False for boxes whose foot row is at or above the horizon or whose foot point is beyond
            ``model.max_range`` (counted in :attr:`last_rejected`).
        """
        b = np.asarray(boxes, dtype=float).reshape(-1, 4)
        pts, valid = foot_points(b[:, 0] + b[:, 2] / 2.0, b[:, 1] + b[:, 3], self.intrinsics)
        rng = np.hypot(pts[:, 0], pts[:, 1])
        with np.errstate(invalid="ignore"):
            far = valid & (rng > self.model.max_range)
        self.last_rejected = {
            "foot_at_or_above_horizon": int(np.count_nonzero(~valid)),
            "beyond_max_range": int(np.count_nonzero(far)),
        }
        accepted = valid & ~far
        out = np.full_like(pts, np.nan)
        if np.any(accepted):
            out[accepted] = self.mounting.apply(pts[accepted])
        return out, accepted

    def detect(self, image: CameraImage | NDArray[np.uint8]) -> NDArray[np.float64]:
        """Person positions ``(M, 2)`` (m) in the grid's sensor frame for one image.

        Raises
        ------
        ValueError
            If ``image`` is not a uint8 (H, W[, 3|4]) array of the intrinsics' size.
        """
        boxes, _ = self.detect_boxes(image)
        pos, ok = self.boxes_to_positions(boxes)
        return pos[ok]
