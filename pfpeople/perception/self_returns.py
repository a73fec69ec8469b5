"""The robot's own body in its laser scans: returns that keep their place in the laser frame while the robot moves.

A laser mounted low on a robot often sees part of the robot (a bumper, a wheel, a caster, a bracket) a few
tens of centimetres away. Those returns are fixed in the laser frame, so in the odometry frame they move with
the robot: the static-clutter map (:mod:`pfpeople.perception.clutter_map`) never calls them static, and a leg detector
that takes them for a leg sees a leg walking at the robot's speed (on ``negative_2``'s right laser a return 0.32 m
from the laser continued a false track for 4 s). leg_tracker's users remove them with a footprint filter
configured by hand; :class:`SelfReturns` finds them from the scans and the ego-motion.

Per beam ``i`` (laser frame, REP-103, m) it keeps the beam's return ``p_ref`` when its current *streak* began
and the *travel* ``T_i`` of the streak: the sum over the scans since of ``|E^-1 p_i - p_i|``, how far a
world-fixed point at the return would have moved in the laser frame with that scan's ego-motion ``E`` (the
laser frame now in the previous one). A streak continues while the return is valid, within ``max_range`` of the
laser and within ``tolerance`` of ``p_ref``; otherwise it restarts at the new return with ``T_i = 0``. The
beam's return is the robot's own (*self*) once ``T_i >= travel``: a world-fixed object would have moved that
far, the return did not. A person walking beside the robot keeps no streak (the legs swing by more than the
tolerance within a step); while the robot stands still nothing accumulates (and the static-clutter map calls a
return that keeps its place static anyway). A scan with an unknown ego-motion adds no travel; a scan with a
different number of beams restarts every streak. A straight wall within ``max_range`` that the robot drives
along also keeps its place in the laser frame and is called the robot's: it is no person either, and
:meth:`SelfReturns.is_self` looks at the return nearest to a detection, so a leg beside it (whose own returns are
nearer) is not affected.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import jit as _jit
from gridbridge.geometry import Pose2D
from gridbridge.validation import check_real
from pfpeople.perception.clutter_kernels import self_update

__all__ = ["SelfReturns"]


class SelfReturns:
    """Which returns of a laser are the robot's own body (module docstring).

    Parameters
    ----------
    max_range : float
        Only returns within this distance of the laser (m) can be the robot's.
    tolerance : float
        Largest distance (m) between a beam's return and the return that began its streak.
    travel : float
        Travel (m) of a streak after which its return is the robot's.
    radius : float
        :meth:`is_self`: a position whose nearest return is the robot's and lies within this distance (m) of it is
        on the robot.
    """

    def __init__(
        self, *, max_range: float = 1.0, tolerance: float = 0.05, travel: float = 0.5, radius: float = 0.2
    ) -> None:
        self.max_range = check_real(max_range, "SelfReturns.max_range", low=0.0, low_open=True)
        self.tolerance = check_real(tolerance, "SelfReturns.tolerance", low=0.0, low_open=True)
        self.travel = check_real(travel, "SelfReturns.travel", low=0.0, low_open=True)
        self.radius = check_real(radius, "SelfReturns.radius", low=0.0, low_open=True)
        self.reset()

    def reset(self) -> None:
        """Forget every streak."""
        self._ref = np.zeros((0, 2))
        self._travel = np.zeros(0)
        self._mask = np.zeros(0, dtype=bool)
        self._returns = np.zeros((0, 2))
        self._returns_self = np.zeros(0, dtype=bool)

    def update(self, points: ArrayLike, ego: Pose2D | None) -> NDArray[np.bool_]:
        """Add one scan.

        Parameters
        ----------
        points : array_like, shape (N, 2)
            The scan's end points in beam order, laser frame (m); NaN rows for beams without a return.
        ego : Pose2D or None
            The laser frame now in the laser frame of the previous scan; None when unknown (no travel is
            added).

        Returns
        -------
        ndarray of bool, shape (N,)
            Which beams' returns are the robot's (:attr:`mask`).
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        n = p.shape[0]
        if _jit.enabled("pfpeople"):  # the same as below, compiled (pfpeople.perception.clutter_kernels.self_update)
            return self._update_compiled(p, ego)
        finite = np.isfinite(p).all(axis=1)
        with np.errstate(invalid="ignore"):
            valid = finite & (np.hypot(p[:, 0], p[:, 1]) <= self.max_range)
        if self._ref.shape[0] != n:
            self._ref = np.full((n, 2), np.nan)
            self._travel = np.zeros(n)
        with np.errstate(invalid="ignore"):
            same = valid & (np.hypot(*(p - self._ref).T) <= self.tolerance)
        if ego is not None and same.any():
            moved = ego.inverse().apply(p[same])
            self._travel[same] += np.hypot(*(moved - p[same]).T)
        restart = ~same
        self._ref[restart] = np.where(valid[restart, None], p[restart], np.nan)
        self._travel[restart] = 0.0
        self._mask = same & (self._travel >= self.travel)
        self._returns, self._returns_self = p[finite], self._mask[finite]
        return self.mask

    def _update_compiled(self, p: NDArray[np.float64], ego: Pose2D | None) -> NDArray[np.bool_]:
        """:meth:`update` of the end points ``p`` (N, 2) by :func:`pfpeople.perception.clutter_kernels.self_update`."""
        if self._ref.shape[0] != p.shape[0]:
            self._ref = np.full((p.shape[0], 2), np.nan)
            self._travel = np.zeros(p.shape[0])
        inv = Pose2D() if ego is None else ego.inverse()
        c, s = math.cos(inv.yaw), math.sin(inv.yaw)
        lim = (self.max_range, self.tolerance, self.travel)
        p = np.ascontiguousarray(p)
        self._mask, finite = self_update(p, self._ref, self._travel, lim, ego is not None, inv.x, inv.y, c, s)
        self._returns, self._returns_self = p[finite], self._mask[finite]
        return self.mask

    @property
    def mask(self) -> NDArray[np.bool_]:
        """``(N,)`` which beams of the latest scan returned from the robot."""
        return self._mask

    @property
    def points(self) -> NDArray[np.float64]:
        """``(S, 2)`` the latest scan's returns from the robot (laser frame, m)."""
        return self._returns[self._returns_self]

    def is_self(self, positions: ArrayLike) -> NDArray[np.bool_]:
        """``(M,)`` which positions (laser frame, m) are on the robot: the latest scan's return nearest to the
        position is the robot's and lies within ``radius`` of it.

        The nearest return, not any return within ``radius``: a leg beside a return of the robot (or of a wall
        that a robot driving along it sees unchanged) has its own returns nearer.
        """
        q = np.asarray(positions, dtype=float).reshape(-1, 2)
        r = self._returns
        if not len(q) or not self._returns_self.any():
            return np.zeros(len(q), dtype=bool)
        d2 = (q[:, None, 0] - r[None, :, 0]) ** 2 + (q[:, None, 1] - r[None, :, 1]) ** 2
        k = d2.argmin(axis=1)
        return np.asarray(self._returns_self[k] & (d2[np.arange(len(q)), k] <= self.radius**2))
