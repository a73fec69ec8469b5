"""Sensor data as the detectors and the pipeline see it, independent of ROS message classes.

Frames follow ROS REP-103. Stamps are integer nanoseconds (``stamp_ns``), as in ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D  # re-exported: the one pose type
from pfpeople.units import Metres, PixelCount, Pixels, Radians

__all__ = ["CameraImage", "CameraIntrinsics", "LaserScan", "Pose2D"]


@dataclass(frozen=True, kw_only=True, eq=False)
class LaserScan:
    """One planar laser scan (the content of ``sensor_msgs/LaserScan``).

    Parameters
    ----------
    ranges : ndarray, shape (B,)
        Range of each beam (m); NaN / inf / values outside [range_min, range_max] are invalid returns.
    angle_min, angle_increment : float
        Bearing of beam 0 and the step between beams (rad, CCW, in the scan's frame).
    range_min, range_max : float
        Valid range interval (m).
    stamp_ns : int
        Acquisition time (ns).
    frame_id : str
        The scan's frame.
    """

    ranges: NDArray[np.float64]
    angle_min: float
    angle_increment: float
    range_min: float = 0.0
    range_max: float = math.inf
    stamp_ns: int = 0
    frame_id: str = "laser"

    def __post_init__(self) -> None:
        r = np.asarray(self.ranges, dtype=float)
        if r.ndim != 1:
            raise ValueError(f"LaserScan.ranges must be 1-D, got shape {r.shape}")
        object.__setattr__(self, "ranges", r)
        if not (math.isfinite(self.angle_min) and math.isfinite(self.angle_increment)):
            raise ValueError("LaserScan.angle_min and angle_increment must be finite")
        if self.angle_increment == 0.0 and r.size > 1:
            raise ValueError("LaserScan.angle_increment must be non-zero for a scan with more than one beam")

    @property
    def angles(self) -> NDArray[np.float64]:
        """Bearing of every beam (rad), shape (B,)."""
        return np.asarray(self.angle_min + self.angle_increment * np.arange(self.ranges.size), dtype=np.float64)

    @property
    def valid(self) -> NDArray[np.bool_]:
        """True for beams with a finite range inside [range_min, range_max], shape (B,); computed once per scan
        (read only)."""
        v = self.__dict__.get("_valid")
        if v is None:
            r = self.ranges
            with np.errstate(invalid="ignore"):
                v = np.isfinite(r) & (r >= self.range_min) & (r <= self.range_max)
            v.flags.writeable = False
            object.__setattr__(self, "_valid", v)
        return v

    @property
    def no_return(self) -> NDArray[np.bool_]:
        """True for beams that saw nothing within range: ``+inf`` (REP-117), or ``range_max`` and above (the
        drivers that write "max range" or "max range and more"), shape (B,). NaN (an erroneous reading) and values below
        ``range_min`` (``-inf``: too close) are neither returns nor free space. Computed once per scan (read
        only)."""
        m = self.__dict__.get("_no_return")
        if m is None:
            r = self.ranges
            with np.errstate(invalid="ignore"):
                m = np.asarray((r >= self.range_max) | np.isposinf(r), dtype=bool)
            m.flags.writeable = False
            object.__setattr__(self, "_no_return", m)
        return m

    def free_rays(self, max_range: float) -> NDArray[np.float64]:
        """End points ``(F, 2)`` (m, scan frame) of the :attr:`no_return` beams, cut at ``min(range_max,
        max_range)``: the beam saw nothing up to there, free-space evidence for a map."""
        length = min(self.range_max, max_range)
        if not math.isfinite(length) or length <= 0.0:
            return np.zeros((0, 2))
        c, s = _beam_cos_sin(self.angle_min, self.angle_increment, self.ranges.size)
        m = self.no_return
        return np.column_stack((length * c[m], length * s[m]))

    def points(self) -> NDArray[np.float64]:
        """Cartesian end points ``(B, 2)`` in the scan's frame (m); invalid beams give NaN rows.

        Computed once per scan (a new array at every call: the caller may change it); the beams' cosines and
        sines are shared by the scans of one geometry (:func:`_beam_cos_sin`)."""
        pts = self.__dict__.get("_points")
        if pts is None:
            r = np.where(self.valid, self.ranges, np.nan)
            c, s = _beam_cos_sin(self.angle_min, self.angle_increment, self.ranges.size)
            pts = np.column_stack((r * c, r * s))
            object.__setattr__(self, "_points", pts)
        return pts.copy()


#: Cosines and sines of the beams of the latest scan geometries (a few lasers per run).
_TRIG: dict[tuple[float, float, int], tuple[NDArray[np.float64], NDArray[np.float64]]] = {}


def _beam_cos_sin(angle_min: float, angle_increment: float, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``np.cos`` and ``np.sin`` of the bearings ``angle_min + angle_increment * arange(n)`` (rad), shape (n,)
    each, kept per geometry (read only; the same floats as computed afresh)."""
    key = (angle_min, angle_increment, n)
    cs = _TRIG.get(key)
    if cs is None:
        if len(_TRIG) >= 16:
            _TRIG.clear()
        a = np.asarray(angle_min + angle_increment * np.arange(n), dtype=np.float64)
        c, s = np.cos(a), np.sin(a)
        c.flags.writeable = False
        s.flags.writeable = False
        cs = _TRIG[key] = (c, s)
    return cs


@dataclass(frozen=True, kw_only=True)
class CameraIntrinsics:
    """Pinhole intrinsics (pixels) and the camera's mounting for the flat-ground range of Stein et al. (2003).

    Parameters
    ----------
    fx, fy, cx, cy : float
        Focal lengths and principal point (px).
    width, height : int
        Image size (px).
    height_above_ground : float
        Optical centre above the ground plane (m); the paper's camera sits at 1.63 m.
    pitch : float
        Downward tilt of the optical axis (rad, positive looking down).
    """

    fx: Pixels
    fy: Pixels
    cx: Pixels
    cy: Pixels
    width: PixelCount
    height: PixelCount
    height_above_ground: Metres = 1.63
    pitch: Radians = 0.0

    def __post_init__(self) -> None:
        for name in ("fx", "fy"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"CameraIntrinsics.{name} must be positive, got {v!r}")
        if self.width < 1 or self.height < 1:
            raise ValueError("CameraIntrinsics.width and height must be positive")
        if not (math.isfinite(self.height_above_ground) and self.height_above_ground > 0):
            raise ValueError("CameraIntrinsics.height_above_ground must be positive")

    @property
    def horizontal_fov(self) -> float:
        """Horizontal field of view (rad)."""
        return 2.0 * math.atan2(self.width / 2.0, self.fx)


@dataclass(frozen=True, kw_only=True, eq=False)
class CameraImage:
    """One camera image: ``pixels`` of shape (H, W, 3) uint8 BGR or (H, W) mono8 ((H, W, 1) and BGRA (H, W, 4)
    are accepted too)."""

    pixels: NDArray[np.uint8]
    stamp_ns: int = 0
    frame_id: str = "camera"
    extra: dict[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        p = np.asarray(self.pixels)
        if p.ndim not in (2, 3) or (p.ndim == 3 and p.shape[2] not in (1, 3, 4)):
            raise ValueError(f"CameraImage.pixels must be (H, W) or (H, W, 1 | 3 | 4), got shape {p.shape}")
        object.__setattr__(self, "pixels", p)
