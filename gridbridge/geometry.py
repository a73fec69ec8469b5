"""Planar rigid transforms: the one 2-D pose type and the functions that compose, invert and apply poses.

A pose ``(x, y, yaw)`` (m, m, rad; REP-103, yaw counter-clockwise) is the pose of a child frame in a parent frame.
With ``R(yaw) = [[c, -s], [s, c]]`` (``c = cos yaw``, ``s = sin yaw``) and ``t = (x, y)``:

    from_frame:  p_parent = R(yaw) p_child + t              (child -> parent; :meth:`Pose2D.apply`)
    to_frame:    p_child  = R(yaw)^T (p_parent - t)         (parent -> child)
    compose:     a * b = (t_a + R(yaw_a) t_b,  yaw_a + yaw_b)   (b's child in a's parent frame)
    inverse:     a^-1  = (-R(yaw_a)^T t_a,  -yaw_a)
    rotate:      v' = R(yaw) v                              (directions, velocities, offsets)

A pose is a :class:`Pose2D` or an array whose last axis is ``(x, y, yaw)``. A single pose (a :class:`Pose2D` or
shape ``(3,)``) uses :func:`math.cos` / :func:`math.sin`; arrays of poses broadcast against the points' leading
axes and use NumPy. Every formula is written once, here, in the order the modules that now call it used, so
their results are unchanged bit for bit.

The bottom layer: ``pfpeople`` and ``evaluation`` import these (``pfpeople.sensors.Pose2D`` is this class).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypeAlias, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "Pose2D",
    "PoseLike",
    "compose",
    "from_frame",
    "from_frame_xy",
    "inverse",
    "near_any",
    "quaternion_from_yaw",
    "rotate",
    "to_frame",
    "to_frame_xy",
    "xy_from_translation",
    "yaw_from_orientation",
    "yaw_from_quaternion",
]


@dataclass(frozen=True, kw_only=True)
class Pose2D:
    """A planar pose: position (m) and yaw (rad) of a child frame in a parent frame."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def apply(self, points: ArrayLike) -> NDArray[np.float64]:
        """Map ``(N, 2)`` points (or one ``(2,)`` point, giving ``(1, 2)``) from the child to the parent frame."""
        return from_frame(np.asarray(points, dtype=float).reshape(-1, 2), self)

    def compose(self, other: Pose2D) -> Pose2D:
        """``self * other``: the pose of ``other``'s child in ``self``'s parent frame (yaw wrapped to (-pi, pi])."""
        return compose(self, other)

    def inverse(self) -> Pose2D:
        """The pose of the parent frame in the child frame."""
        return inverse(self)

    def as_array(self) -> NDArray[np.float64]:
        """``(x, y, yaw)`` as a ``(3,)`` array."""
        return np.array([self.x, self.y, self.yaw], dtype=float)


#: A pose: :class:`Pose2D` or an array ``(..., 3)`` of ``(x, y, yaw)``.
PoseLike: TypeAlias = Pose2D | ArrayLike


def _xyyaw(pose: PoseLike) -> tuple[Any, Any, Any]:
    """``(x, y, yaw)``: floats for one pose, arrays (the pose array's leading shape) for several."""
    if isinstance(pose, Pose2D):
        return pose.x, pose.y, pose.yaw
    p = np.asarray(pose, dtype=float)
    if p.ndim == 0 or p.shape[-1] != 3:
        raise ValueError(f"pose must be a Pose2D or an array (..., 3) of (x, y, yaw), got shape {p.shape}")
    if p.shape == (3,):
        return float(p[0]), float(p[1]), float(p[2])
    return p[..., 0], p[..., 1], p[..., 2]


def _cos_sin(yaw: Any) -> tuple[Any, Any]:
    if isinstance(yaw, np.ndarray):
        return np.cos(yaw), np.sin(yaw)
    return math.cos(yaw), math.sin(yaw)


def _points(points: ArrayLike) -> NDArray[np.float64]:
    pts = np.asarray(points, dtype=float)
    if pts.ndim == 0 or pts.shape[-1] != 2:
        raise ValueError(f"points must be an array (..., 2) of (x, y) in metres, got shape {pts.shape}")
    return pts


#: Up to this many points :func:`from_frame` maps in Python floats (fewer calls than numpy's on a handful).
_FEW = 8


def from_frame(points: ArrayLike, pose: PoseLike) -> NDArray[np.float64]:
    """Points ``(..., 2)`` given in the frame at ``pose``, expressed in its parent frame: ``R p + t``.

    ``pose`` is one pose or an array ``(..., 3)`` broadcast against the points' leading axes.
    """
    pts = _points(points)
    if pts.ndim == 2 and isinstance(pose, Pose2D):  # the common case, without the stacking (same arithmetic)
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        if pts.shape[0] <= _FEW:  # a few points (detections): Python floats, the same operations in the same order
            x, y = pose.x, pose.y
            rows = [(x + c * px - s * py, y + s * px + c * py) for px, py in pts.tolist()]
            return np.array(rows, dtype=float).reshape(-1, 2)
        px, py = pts[:, 0], pts[:, 1]
        out = np.empty(pts.shape)
        out[:, 0] = pose.x + c * px - s * py
        out[:, 1] = pose.y + s * px + c * py
        return out
    return np.stack(from_frame_xy(pts[..., 0], pts[..., 1], pose), axis=-1)


def to_frame(points: ArrayLike, pose: PoseLike) -> NDArray[np.float64]:
    """Points ``(..., 2)`` of the parent frame expressed in the frame at ``pose``: ``R^T (p - t)``.

    The inverse of :func:`from_frame`; ``pose`` broadcasts as there.
    """
    pts = _points(points)
    return np.stack(to_frame_xy(pts[..., 0], pts[..., 1], pose), axis=-1)


def from_frame_xy(px: ArrayLike, py: ArrayLike, pose: PoseLike) -> tuple[Any, Any]:
    """:func:`from_frame` on coordinates kept apart: ``(x, y)`` in the parent frame of ``(px, py)`` given in the
    frame at ``pose`` (everything broadcast; no stacking, for grids of points such as cell centres)."""
    x, y, yaw = _xyyaw(pose)
    c, s = _cos_sin(yaw)
    px_, py_ = np.asarray(px, dtype=float), np.asarray(py, dtype=float)
    return x + c * px_ - s * py_, y + s * px_ + c * py_


def to_frame_xy(px: ArrayLike, py: ArrayLike, pose: PoseLike) -> tuple[Any, Any]:
    """:func:`to_frame` on coordinates kept apart (see :func:`from_frame_xy`)."""
    x, y, yaw = _xyyaw(pose)
    c, s = _cos_sin(yaw)
    dx, dy = np.asarray(px, dtype=float) - x, np.asarray(py, dtype=float) - y
    return c * dx + s * dy, -s * dx + c * dy


def rotate(vectors: ArrayLike, yaw: ArrayLike) -> NDArray[np.float64]:
    """Vectors ``(..., 2)`` rotated by ``yaw`` (rad, counter-clockwise; a number or an array broadcast against the
    vectors' leading axes): ``R(yaw) v``."""
    angle = np.asarray(yaw, dtype=float)
    c, s = _cos_sin(float(angle) if angle.ndim == 0 else angle)
    v = _points(vectors)
    vx, vy = v[..., 0], v[..., 1]
    return np.stack((c * vx - s * vy, s * vx + c * vy), axis=-1)


@overload
def compose(a: Pose2D, b: PoseLike, *, wrap: bool = True) -> Pose2D: ...
@overload
def compose(a: ArrayLike, b: PoseLike, *, wrap: bool = True) -> NDArray[np.float64]: ...
def compose(a: PoseLike, b: PoseLike, *, wrap: bool = True) -> Pose2D | NDArray[np.float64]:
    """``a * b``: the pose of ``b``'s child frame in ``a``'s parent frame.

    Parameters
    ----------
    a, b : Pose2D or array (..., 3)
        Poses (arrays broadcast against each other).
    wrap : bool
        Wrap the yaw into (-pi, pi] (``atan2(sin, cos)``); False keeps ``yaw_a + yaw_b`` (paths, unwrapped).

    Returns
    -------
    Pose2D when ``a`` is a :class:`Pose2D`, else an array ``(..., 3)``.
    """
    ax, ay, ayaw = _xyyaw(a)
    bx, by, byaw = _xyyaw(b)
    c, s = _cos_sin(ayaw)
    x, y, yaw = ax + c * bx - s * by, ay + s * bx + c * by, ayaw + byaw
    if wrap:
        yaw = math.atan2(math.sin(yaw), math.cos(yaw)) if isinstance(yaw, float) else np.arctan2(*_cos_sin(yaw)[::-1])
    if isinstance(a, Pose2D):
        return Pose2D(x=float(x), y=float(y), yaw=float(yaw))
    return np.stack(np.broadcast_arrays(x, y, yaw), axis=-1).astype(float, copy=False)


@overload
def inverse(pose: Pose2D) -> Pose2D: ...
@overload
def inverse(pose: ArrayLike) -> NDArray[np.float64]: ...
def inverse(pose: PoseLike) -> Pose2D | NDArray[np.float64]:
    """The inverse pose (the parent frame in the child frame): ``(-R^T t, -yaw)``."""
    x, y, yaw = _xyyaw(pose)
    c, s = _cos_sin(yaw)
    ix, iy = -(c * x + s * y), -(-s * x + c * y)
    if isinstance(pose, Pose2D):
        return Pose2D(x=ix, y=iy, yaw=-yaw)
    return np.stack(np.broadcast_arrays(ix, iy, -yaw), axis=-1).astype(float, copy=False)


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw (rad, CCW about z) of a unit quaternion: ``atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))`` (ZYX Euler)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


#: A quaternion whose norm is below this has no orientation (an unset ``(0, 0, 0, 0)``).
MIN_QUATERNION_NORM = 1e-6


def yaw_from_orientation(x: float, y: float, z: float, w: float, where: str) -> float:
    """:func:`yaw_from_quaternion` of a message's orientation, refusing a zero or non-finite quaternion.

    A zero quaternion ``(0, 0, 0, 0)`` (an orientation never set) would read as yaw 0.

    Raises
    ------
    ValueError
        Naming ``where`` (e.g. the topic) and the quaternion.
    """
    q = (float(x), float(y), float(z), float(w))
    if not all(math.isfinite(v) for v in q):
        raise ValueError(f"{where}: orientation quaternion {q} is not finite")
    if math.sqrt(sum(v * v for v in q)) < MIN_QUATERNION_NORM:
        raise ValueError(f"{where}: orientation quaternion {q} is zero (never set): it has no yaw")
    return yaw_from_quaternion(*q)


def quaternion_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """The unit quaternion ``(x, y, z, w)`` of a rotation by ``yaw`` (rad) about z."""
    return 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)


def near_any(points: ArrayLike, others: ArrayLike, radius: float) -> NDArray[np.bool_]:
    """``(N,)``: whether each of ``points`` ``(N, 2)`` lies within ``radius`` (inclusive) of some row of
    ``others`` ``(K, 2)``; all False when ``others`` is empty. A dense ``N x K`` distance test: for the few
    people or detections of a frame it beats building a k-d tree."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    o = np.asarray(others, dtype=float).reshape(-1, 2)
    if not p.shape[0] or not o.shape[0]:
        return np.zeros(p.shape[0], dtype=bool)
    d2 = (p[:, None, 0] - o[None, :, 0]) ** 2 + (p[:, None, 1] - o[None, :, 1]) ** 2
    return np.asarray(d2.min(axis=1) <= radius * radius, dtype=bool)


def xy_from_translation(x: float, y: float, z: float, where: str) -> tuple[float, float]:
    """The planar part ``(x, y)`` of a message's translation or position, refusing a non-finite one.

    ``z`` is not used but is checked too: a NaN anywhere means the transform was never computed, and a NaN in
    ``x`` or ``y`` would otherwise surface far from its source (e.g. as a non-finite ego-motion).

    Raises
    ------
    ValueError
        Naming ``where`` (e.g. the topic and ``parent -> child``) and the translation.
    """
    t = (float(x), float(y), float(z))
    if not all(math.isfinite(v) for v in t):
        raise ValueError(f"{where}: translation {t} is not finite")
    return t[0], t[1]
