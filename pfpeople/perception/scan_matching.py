"""Laser odometry: 2-D scan matching by point-to-line ICP, and per-frame ego-motion from consecutive scans.

Frames (REP-103): a scan's points are in its own sensor frame (x forward, y left, metres). The pose returned by
:func:`match_scans` is the **current** scan frame expressed in the **previous** (reference) scan frame, i.e. it
maps current-scan points into the reference frame: ``p_prev = pose.apply(p_cur)``. This is the ego-motion
``Pose2D`` that :class:`pfpeople.perception.clutter_map.StaticClutterMap.update` expects.

Method (Censi 2008 / Chen & Medioni 1992, point-to-line ICP):

* Reference normals: for every reference point, the principal axis of its ``k`` nearest neighbours within
  ``normal_radius`` (2-D PCA); the normal is the eigenvector of the smallest eigenvalue. Points without enough
  neighbours (isolated returns) are not used as targets.
* Each iteration maps the (subsampled) current points ``q_i = T(p_i)`` with the current estimate ``T``, finds
  the nearest reference point ``r_i`` (``scipy.spatial.cKDTree``) and keeps the pairs with
  ``|q_i - r_i| <= gate``; the gate shrinks geometrically from ``max_correspondence`` to
  ``min_correspondence`` (outlier rejection by distance). The residual of a pair is the point-to-line distance
  ``e_i = n_i . (q_i - r_i)``. Linearising a small left increment ``(dx, dy, dtheta)``,
  ``e_i + J_i d`` with ``J_i = [n_x, n_y, n_i . (-q_y, q_x)]``, the Gauss-Newton step solves
  ``(J^T W J) d = -J^T W e`` with Huber weights ``W`` (scale ``huber``). The step is taken only in the
  directions whose normalised eigenvalue (below) is above ``min_eigenvalue``: along an unobservable
  direction (a featureless corridor) the estimate keeps its initial guess instead of drifting.
* Degeneracy: with the rotation column scaled by the RMS radius ``rho`` of the matched points, the smallest
  eigenvalue of ``J^T J / n`` is in [0, 1] (translation rows are unit normals). A single straight wall has
  one eigenvalue ~ 0 (motion along the wall is unobservable); a room has all of them well above 0.02.

Speed: the current scan is subsampled to at most ``max_points`` points (uniform stride), the reference to
``max_reference_points``; a 768-beam scan matches in a few milliseconds (``python -m evaluation.bench.clutter``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from gridbridge.geometry import Pose2D
from gridbridge.validation import check_int, check_real

__all__ = [
    "EgoMatch",
    "LaserEgoMotion",
    "MatchResult",
    "OdometryStep",
    "ScanMatchConfig",
    "ScanOdometry",
    "ScanOdometryConfig",
    "match_scans",
]


def _points(points: ArrayLike, name: str) -> NDArray[np.float64]:
    """``(N, 2)`` float points with the non-finite rows (invalid beams) removed."""
    arr = np.asarray(points, dtype=float)
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2) of (x, y) points in metres, got {arr.shape}")
    return arr[np.isfinite(arr).all(axis=1)]


def _stride(points: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    if points.shape[0] <= n:
        return points
    idx = np.linspace(0, points.shape[0] - 1, n).round().astype(np.intp)
    return points[idx]


@dataclass(frozen=True, kw_only=True)
class ScanMatchConfig:
    """Parameters of :func:`match_scans` (lengths in m, angles in rad).

    Parameters
    ----------
    max_iterations : int
        Gauss-Newton iterations at most.
    gate_iterations : int
        Iterations over which the gate shrinks (convergence is tested only after them).
    max_correspondence, min_correspondence : float
        Distance gate of a point pair (m), shrinking geometrically from the first to the second over the
        first ``gate_iterations`` iterations.
    huber : float
        Huber scale of the point-to-line residual (m).
    normal_neighbours : int
        Neighbours used for a reference normal (including the point itself).
    normal_radius : float
        Neighbours farther than this (m) do not count; a reference point with fewer than 3 within it is not
        a target.
    max_points, max_reference_points : int
        Subsampling of the current and the reference scan.
    min_eigenvalue : float
        Smallest normalised eigenvalue of ``J^T J / n`` for a well-constrained match (see module docstring).
    max_rmse : float
        A match with a larger point-to-line RMS error (m) of its inliers is poor.
    min_inlier_fraction : float
        A match with fewer current points within ``min_correspondence`` of the reference is poor.
    tolerance : float
        Convergence: a step smaller than this (m, and rad) ends the iterations.
    """

    max_iterations: int = 20
    gate_iterations: int = 4
    max_correspondence: float = 0.5
    min_correspondence: float = 0.1
    huber: float = 0.03
    normal_neighbours: int = 6
    normal_radius: float = 0.3
    max_points: int = 160
    max_reference_points: int = 800
    min_eigenvalue: float = 0.02
    max_rmse: float = 0.05
    min_inlier_fraction: float = 0.4
    tolerance: float = 2e-4

    def __post_init__(self) -> None:
        for name, minimum in (
            ("max_iterations", 1),
            ("gate_iterations", 1),
            ("normal_neighbours", 3),
            ("max_points", 10),
            ("max_reference_points", 10),
        ):
            check_int(getattr(self, name), f"ScanMatchConfig.{name}", minimum=minimum)
        positive = ("max_correspondence", "min_correspondence", "huber", "normal_radius", "min_eigenvalue")
        for name in (*positive, "max_rmse", "tolerance"):
            check_real(getattr(self, name), f"ScanMatchConfig.{name}", low=0.0, low_open=True)
        if self.min_correspondence > self.max_correspondence:
            raise ValueError("ScanMatchConfig.min_correspondence must not exceed max_correspondence")
        check_real(self.min_inlier_fraction, "ScanMatchConfig.min_inlier_fraction", low=0.0, high=1.0)


@dataclass(frozen=True, kw_only=True)
class MatchResult:
    """The outcome of :func:`match_scans`.

    Attributes
    ----------
    pose : Pose2D
        The current scan frame in the reference (previous) scan frame.
    rmse : float
        RMS point-to-line distance (m) of the final inliers (``inf`` without any).
    inlier_fraction : float
        Fraction of the (subsampled) current points within ``min_correspondence`` of a reference point.
    converged : bool
        The last step was below the tolerance before ``max_iterations``.
    degenerate : bool
        Some direction of the motion is unobservable (smallest normalised eigenvalue below
        ``min_eigenvalue``); along it the pose keeps the initial guess.
    min_eigenvalue : float
        Smallest normalised eigenvalue of the final ``J^T J / n``.
    iterations : int
        Iterations run.
    ok : bool
        Not degenerate, ``rmse <= max_rmse`` and ``inlier_fraction >= min_inlier_fraction`` (convergence is
        not required: with noisy scans the nearest-neighbour pairs can flip between two near-equal solutions
        that are both good).
    """

    pose: Pose2D
    rmse: float
    inlier_fraction: float
    converged: bool
    degenerate: bool = False
    min_eigenvalue: float = 0.0
    iterations: int = 0
    ok: bool = False


@dataclass(frozen=True, eq=False)
class _Reference:
    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    tree: cKDTree


def _reference(points: NDArray[np.float64], config: ScanMatchConfig) -> _Reference:
    """Targets with PCA normals (points without 3 neighbours within ``normal_radius`` are dropped)."""
    pts = _stride(points, config.max_reference_points)
    if pts.shape[0] < 3:
        return _Reference(np.zeros((0, 2)), np.zeros((0, 2)), cKDTree(np.zeros((1, 2))))
    k = min(config.normal_neighbours, pts.shape[0])
    dist, idx = cKDTree(pts).query(pts, k=k, distance_upper_bound=config.normal_radius)
    ok = np.isfinite(dist)
    count = ok.sum(axis=1)
    idx = np.where(ok, idx, 0)
    nb = pts[idx]  # (N, k, 2)
    w = ok[..., None].astype(float)
    mean = (nb * w).sum(axis=1) / np.maximum(count, 1)[:, None]
    d = (nb - mean[:, None, :]) * w
    sxx = (d[..., 0] ** 2).sum(axis=1)
    syy = (d[..., 1] ** 2).sum(axis=1)
    sxy = (d[..., 0] * d[..., 1]).sum(axis=1)
    # principal direction angle of the 2x2 covariance; the normal is perpendicular to it
    phi = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    normals = np.column_stack((-np.sin(phi), np.cos(phi)))
    keep = count >= 3
    pts, normals = pts[keep], normals[keep]
    tree = cKDTree(pts if pts.shape[0] else np.zeros((1, 2)))
    return _Reference(pts, normals, tree)


def _match(ref: _Reference, cur: NDArray[np.float64], init: Pose2D, config: ScanMatchConfig) -> MatchResult:
    src = _stride(cur, config.max_points)
    if ref.points.shape[0] < 3 or src.shape[0] < 3:
        return MatchResult(pose=init, rmse=math.inf, inlier_fraction=0.0, converged=False, degenerate=True)
    pose = init
    n_half = config.gate_iterations
    ratio = config.min_correspondence / config.max_correspondence
    converged = False
    min_eig = 0.0
    it = 0
    for it in range(1, config.max_iterations + 1):
        gate = config.max_correspondence * ratio ** min(1.0, (it - 1) / n_half)
        q = pose.apply(src)
        dist, idx = ref.tree.query(q, k=1, distance_upper_bound=gate)
        inl = np.isfinite(dist)
        if inl.sum() < 3:
            break
        qi, ni, ri = q[inl], ref.normals[idx[inl]], ref.points[idx[inl]]
        e = np.einsum("ij,ij->i", ni, qi - ri)
        rho = max(float(np.sqrt(np.mean(np.sum(qi**2, axis=1)))), 1e-3)
        jac = np.column_stack((ni[:, 0], ni[:, 1], (ni[:, 1] * qi[:, 0] - ni[:, 0] * qi[:, 1]) / rho))
        a = np.abs(e)
        w = np.where(a <= config.huber, 1.0, config.huber / np.maximum(a, 1e-12))
        h = jac.T @ (jac * w[:, None])
        g = jac.T @ (w * e)
        evals, evecs = np.linalg.eigh(jac.T @ jac / jac.shape[0])
        min_eig = float(evals[0])
        # solve only in the directions that are constrained (normalised eigenvalue above the threshold)
        good = evals >= config.min_eigenvalue
        proj = evecs[:, good]
        hp = proj.T @ h @ proj
        d = -proj @ np.linalg.solve(hp, proj.T @ g) if good.any() else np.zeros(3)
        dx, dy, dth = float(d[0]), float(d[1]), float(d[2]) / rho
        pose = Pose2D(x=dx, y=dy, yaw=dth).compose(pose)  # left-compose the increment: T <- (dx, dy, dth) * T
        if it > n_half and math.hypot(dx, dy) < config.tolerance and abs(dth) < config.tolerance:
            converged = True
            break
    q = pose.apply(src)
    dist, idx = ref.tree.query(q, k=1, distance_upper_bound=config.min_correspondence)
    inl = np.isfinite(dist)
    frac = float(inl.mean())
    if inl.any():
        e = np.einsum("ij,ij->i", ref.normals[idx[inl]], q[inl] - ref.points[idx[inl]])
        rmse = float(np.sqrt(np.mean(e**2)))
    else:
        rmse = math.inf
    degenerate = min_eig < config.min_eigenvalue
    ok = not degenerate and rmse <= config.max_rmse and frac >= config.min_inlier_fraction
    return MatchResult(
        pose=pose,
        rmse=rmse,
        inlier_fraction=frac,
        converged=converged,
        degenerate=degenerate,
        min_eigenvalue=min_eig,
        iterations=it,
        ok=ok,
    )


def match_scans(
    prev_points: ArrayLike,
    cur_points: ArrayLike,
    *,
    init: Pose2D | None = None,
    config: ScanMatchConfig | None = None,
) -> MatchResult:
    """Align the current scan to the previous one by point-to-line ICP.

    Parameters
    ----------
    prev_points : array_like, shape (N, 2)
        Reference scan end points in the previous sensor frame (m); non-finite rows (invalid beams) are ignored.
    cur_points : array_like, shape (M, 2)
        Current scan end points in the current sensor frame (m); non-finite rows are ignored.
    init : Pose2D, optional
        Initial guess of the current frame in the previous one (identity when omitted).
    config : ScanMatchConfig, optional
        Parameters (defaults when omitted).

    Returns
    -------
    MatchResult
        ``pose`` maps current points into the previous frame (``prev ~ pose.apply(cur)``); check ``ok`` (or
        ``degenerate``, ``rmse``, ``inlier_fraction``) before trusting it.

    Raises
    ------
    ValueError
        If an input is not ``(N, 2)``.
    TypeError
        If ``init`` is not a :class:`Pose2D`.
    """
    if init is not None and not isinstance(init, Pose2D):
        raise TypeError(f"init must be a Pose2D, got {type(init).__name__}")
    cfg = config or ScanMatchConfig()
    prev = _points(prev_points, "prev_points")
    cur = _points(cur_points, "cur_points")
    return _match(_reference(prev, cfg), cur, init or Pose2D(), cfg)


@dataclass(frozen=True, kw_only=True)
class ScanOdometryConfig:
    """Parameters of :class:`ScanOdometry`.

    Parameters
    ----------
    match : ScanMatchConfig
        The scan matcher's parameters.
    keyframe_distance, keyframe_angle : float
        The current scan becomes the new keyframe once it is this far (m) or this much turned (rad) from the
        keyframe; below, scans are matched against the same keyframe (no drift while standing).
    min_keyframe_overlap : float
        A scan whose inlier fraction against the keyframe falls below this becomes the new keyframe too.
    constant_velocity : bool
        Initial guess = the previous frame's motion (else identity).
    """

    match: ScanMatchConfig = field(default_factory=ScanMatchConfig)
    keyframe_distance: float = 0.25
    keyframe_angle: float = math.radians(10.0)
    min_keyframe_overlap: float = 0.7
    constant_velocity: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.match, ScanMatchConfig):
            raise TypeError(f"ScanOdometryConfig.match must be a ScanMatchConfig, got {type(self.match).__name__}")
        check_real(self.keyframe_distance, "ScanOdometryConfig.keyframe_distance", low=0.0)
        check_real(self.keyframe_angle, "ScanOdometryConfig.keyframe_angle", low=0.0)
        check_real(self.min_keyframe_overlap, "ScanOdometryConfig.min_keyframe_overlap", low=0.0, high=1.0)


@dataclass(frozen=True, kw_only=True)
class OdometryStep:
    """One step of :class:`ScanOdometry`.

    Attributes
    ----------
    ego : Pose2D
        The current sensor frame in the previous scan's sensor frame (identity on the first scan and when the
        match failed).
    ok : bool
        False on the first scan and when the match was poor (then ``ego`` is the identity fallback).
    match : MatchResult or None
        The keyframe match behind ``ego`` (None on the first scan or an empty scan).
    new_keyframe : bool
        Whether this scan became the keyframe.
    """

    ego: Pose2D
    ok: bool
    match: MatchResult | None
    new_keyframe: bool


class ScanOdometry:
    """Ego-motion of a laser from its own scans (keyframe ICP).

    Feed every scan, in order, with :meth:`update`; each call returns the motion since the previous call.

    The keyframe ``K`` is an earlier scan; ``T_KP`` is the previous scan in it. A new scan ``C`` is matched
    against ``K`` with the initial guess ``T_KP * v`` (``v`` = the previous step's ego-motion, constant
    velocity), giving ``T_KC``; the step is ``ego = T_KP^-1 * T_KC``. ``C`` becomes the keyframe when it is
    ``keyframe_distance`` / ``keyframe_angle`` away from ``K`` or overlaps it poorly. A poor match (see
    :attr:`MatchResult.ok`) returns the identity with ``ok=False`` and restarts from ``C`` as keyframe.
    A scan that is not matched (to save time, :meth:`skip`) becomes the keyframe of the next :meth:`update`, so
    that one is matched against the scan just before it, not against an older one or none.

    Parameters
    ----------
    config : ScanOdometryConfig, optional
    """

    def __init__(self, config: ScanOdometryConfig | None = None) -> None:
        if config is not None and not isinstance(config, ScanOdometryConfig):
            raise TypeError(f"config must be a ScanOdometryConfig, got {type(config).__name__}")
        self.config = config or ScanOdometryConfig()
        self.reset()

    def reset(self) -> None:
        """Forget the keyframe (the next scan starts over) and the counts."""
        self._key: _Reference | None = None
        self._pending: NDArray[np.float64] | None = None
        self._t_kp = Pose2D()
        self._velocity = Pose2D()
        self.poor_matches = 0
        """Scans whose match was poor (``ok=False`` with a keyframe to match against)."""
        self.steps = 0
        """Scans passed to :meth:`update`."""
        self.skipped = 0
        """Scans passed to :meth:`skip`."""

    def _set_key(self, points: NDArray[np.float64]) -> None:
        self._key = _reference(points, self.config.match)
        self._t_kp = Pose2D()

    def skip(self, points: ArrayLike) -> None:
        """Take a scan without matching it: it replaces the keyframe, and the motion into it is unknown.

        The next :meth:`update` is matched against this scan (one scan period apart) from the identity, as after
        a poor match. The keyframe's normals are only computed if that :meth:`update` comes, so a run of skipped
        scans costs little more than copying their points.

        Parameters
        ----------
        points : array_like, shape (N, 2)
            Scan end points in the sensor frame (m); non-finite rows are ignored.
        """
        self._pending = _points(points, "points")
        self._key = None
        self._velocity = Pose2D()
        self.skipped += 1

    def update(self, points: ArrayLike) -> OdometryStep:
        """Match one scan and return the motion since the previous one.

        Parameters
        ----------
        points : array_like, shape (N, 2)
            Scan end points in the sensor frame (m); non-finite rows (invalid beams) are ignored, so
            ``LaserScan.points()`` can be passed as is.

        Returns
        -------
        OdometryStep
        """
        pts = _points(points, "points")
        self.steps += 1
        if self._pending is not None:  # the scan skipped just before is the keyframe
            self._set_key(self._pending)
            self._pending = None
        if self._key is None or self._key.points.shape[0] < 3:
            self._set_key(pts)
            self._velocity = Pose2D()
            return OdometryStep(ego=Pose2D(), ok=False, match=None, new_keyframe=True)
        cfg = self.config
        init = self._t_kp.compose(self._velocity) if cfg.constant_velocity else self._t_kp
        res = _match(self._key, pts, init, cfg.match)
        if not res.ok:
            self.poor_matches += 1
            self._set_key(pts)
            self._velocity = Pose2D()
            return OdometryStep(ego=Pose2D(), ok=False, match=res, new_keyframe=True)
        ego = self._t_kp.inverse().compose(res.pose)
        self._velocity = ego
        t = res.pose
        far = math.hypot(t.x, t.y) > cfg.keyframe_distance or abs(t.yaw) > cfg.keyframe_angle
        if far or res.inlier_fraction < cfg.min_keyframe_overlap:
            self._set_key(pts)
            return OdometryStep(ego=ego, ok=True, match=res, new_keyframe=True)
        self._t_kp = t
        return OdometryStep(ego=ego, ok=True, match=res, new_keyframe=False)


@dataclass(frozen=True)
class EgoMatch:
    """A laser's scan-matched motion into one scan (:meth:`LaserEgoMotion.match`).

    Attributes
    ----------
    ego : Pose2D
        The laser frame now in the laser frame of the previous scan (m, rad); when not ``ok``, the matcher's
        fallback (the identity on a skipped scan).
    ok : bool
        Whether ``ego`` is known.
    """

    ego: Pose2D
    ok: bool


class LaserEgoMotion:
    """A laser's ego-motion from its scan matcher, scan after scan, with a back-off after failed matches.

    After ``k`` consecutive failed matches the next ``min(2^(k-1), max_backoff) - 1`` scans skip the matcher (their
    ego-motion is unknown, as after a failure). Where matching does not work (outdoors with a short-range laser: 83 %
    of ``person_following_outdoor_1``) this saves most of its cost. A skipped scan becomes the matcher's keyframe
    (:meth:`ScanOdometry.skip`), so the next attempt matches two scans one period apart: the back-off bounds the cost,
    it never turns matching off.

    Parameters
    ----------
    odometry : ScanOdometry, optional
        The scan matcher (a default one when omitted).
    max_backoff : int
        The longest back-off (scans, including the failed one).
    """

    def __init__(self, odometry: ScanOdometry | None = None, *, max_backoff: int = 8) -> None:
        if odometry is not None and not isinstance(odometry, ScanOdometry):
            raise TypeError(f"odometry must be a ScanOdometry, got {type(odometry).__name__}")
        self.odometry = odometry or ScanOdometry()
        self.max_backoff = check_int(max_backoff, "max_backoff", minimum=1)
        self._failures = 0
        self._backoff = 0

    def match(self, points: ArrayLike, *, first: bool) -> tuple[Pose2D, bool]:
        """The laser frame of ``points`` in the laser frame of the previous scan, and whether it is known.

        Parameters
        ----------
        points : array_like, shape (N, 2)
            The scan's end points (m, laser frame; NaN rows ignored).
        first : bool
            True for the first scan of its user (a static-clutter map): that scan's motion counts as known (the
            identity), whatever the matcher says.

        Returns
        -------
        ego : Pose2D
            The matcher's motion (also when unknown: the identity on a skipped scan, the matcher's fallback on a
            failed match).
        ok : bool
            Whether ``ego`` is known (False on a failed or skipped match).
        """
        if self._backoff > 0:  # the matcher failed lately: skip it (ego unknown)
            self._backoff -= 1
            self.odometry.skip(points)  # the next attempt is matched against this scan
            return Pose2D(), False
        st = self.odometry.update(points)
        ok = st.ok or first
        if ok:
            self._failures = 0
        else:
            self._failures += 1
            self._backoff = min(2 ** (self._failures - 1), self.max_backoff) - 1
        return st.ego, ok
