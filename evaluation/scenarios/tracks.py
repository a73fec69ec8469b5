"""People trajectories in the world frame: piecewise-linear tracks sampled at frame times.

A :class:`Track` is a person's knots ``(t_k, x_k, y_k)`` (s, m, world frame); between knots the position is
linearly interpolated and the person exists from the first to the last knot (inclusive). Synthetic walkers
(:mod:`evaluation.scenarios.walkers`) and replayed real trajectories (:mod:`evaluation.scenarios.eth_ucy`)
both produce tracks, so the rest of the simulator does not care where people came from.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Track", "sample_tracks", "track_speeds"]


@dataclass(frozen=True, eq=False)
class Track:
    """One person's world trajectory.

    Parameters
    ----------
    person_id : int
        Identifier, unique within a scenario (>= 0).
    t : ndarray, shape (K,)
        Knot times (s), non-decreasing, K >= 1.
    xy : ndarray, shape (K, 2)
        Knot positions (m), world frame.
    """

    person_id: int
    t: NDArray[np.float64]
    xy: NDArray[np.float64]

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float).reshape(-1)
        xy = np.asarray(self.xy, dtype=float)
        if t.size < 1:
            raise ValueError(f"Track {self.person_id}: t must hold at least one knot")
        if xy.shape != (t.size, 2):
            raise ValueError(f"Track {self.person_id}: xy must have shape ({t.size}, 2), got {xy.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(xy))):
            raise ValueError(f"Track {self.person_id}: t and xy must be finite")
        if np.any(np.diff(t) < 0):
            raise ValueError(f"Track {self.person_id}: knot times t must be non-decreasing")
        if int(self.person_id) < 0:
            raise ValueError(f"Track person_id must be >= 0, got {self.person_id!r}")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "xy", xy)

    @property
    def t_start(self) -> float:
        return float(self.t[0])

    @property
    def t_end(self) -> float:
        return float(self.t[-1])

    def sample(self, times: ArrayLike) -> NDArray[np.float64]:
        """Positions ``(T, 2)`` (m, world) at ``times`` (s); NaN where the person does not exist."""
        times = np.asarray(times, dtype=float).reshape(-1)
        out = np.full((times.size, 2), np.nan)
        alive = (times >= self.t[0]) & (times <= self.t[-1])
        if np.any(alive):
            if self.t.size == 1:
                out[alive] = self.xy[0]
            else:
                out[alive, 0] = np.interp(times[alive], self.t, self.xy[:, 0])
                out[alive, 1] = np.interp(times[alive], self.t, self.xy[:, 1])
        return out


def sample_tracks(tracks: Sequence[Track], times: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Sample all tracks at the frame times.

    Returns
    -------
    ids : ndarray, shape (N,)
        Person ids, in the order of ``tracks``.
    positions : ndarray, shape (T, N, 2)
        World positions (m); NaN where a person does not exist at that frame.
    """
    times = np.asarray(times, dtype=float).reshape(-1)
    ids = np.array([int(tr.person_id) for tr in tracks], dtype=np.int64)
    if np.unique(ids).size != ids.size:
        raise ValueError("tracks: person ids must be unique")
    positions = np.full((times.size, len(tracks), 2), np.nan)
    for n, tr in enumerate(tracks):
        positions[:, n, :] = tr.sample(times)
    return ids, positions


def track_speeds(tracks: Sequence[Track]) -> NDArray[np.float64]:
    """Speeds (m/s) of every knot-to-knot segment with positive duration, all tracks concatenated."""
    parts = []
    for tr in tracks:
        dt = np.diff(tr.t)
        ok = dt > 0
        if np.any(ok):
            parts.append(np.hypot(*np.diff(tr.xy, axis=0)[ok].T) / dt[ok])
    return np.concatenate(parts) if parts else np.zeros(0)
