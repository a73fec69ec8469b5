"""What the pictures of a run read from its directory (:mod:`pfpeople.io.run_dir`): tracks, times, the path, the
ego-motion source of each frame, and where each frame's rows are in the per-frame records."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge.ego_motion import velocity_displacement
from gridbridge.geometry import Pose2D
from pfpeople.io.run_dir import RunData

__all__ = [
    "TRACK_COLUMNS",
    "FrameRows",
    "default_fps",
    "ego_sources",
    "frame_times_s",
    "laser_of",
    "read_tracks",
    "robot_path",
]

TRACK_COLUMNS = ("frame", "stamp_ns", "id", "x", "y", "vx", "vy", "cov_xx", "cov_xy", "cov_yy", "score")


def read_tracks(path: str | Path) -> dict[str, NDArray[Any]]:
    """Read a ``tracks.csv`` (columns :data:`TRACK_COLUMNS`, positions and velocities in the grid frame).

    Returns
    -------
    dict of str to ndarray
        One array per column (``frame``, ``stamp_ns``, ``id`` int64; the others float), rows in file order.
    """
    path = Path(path)
    with path.open(newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.reader(fh))
    if not rows or tuple(h.strip() for h in rows[0]) != TRACK_COLUMNS:
        raise ValueError(f"tracks file {str(path)!r}: expected columns {list(TRACK_COLUMNS)}, got {rows[:1]}")
    body = [r for r in rows[1:] if r]
    out: dict[str, NDArray[Any]] = {}
    for k, name in enumerate(TRACK_COLUMNS):
        try:
            vals = [r[k] for r in body]
            dtype = np.int64 if name in ("frame", "stamp_ns", "id") else float
            out[name] = np.array(vals, dtype=dtype).reshape(-1)
        except (IndexError, ValueError) as exc:
            raise ValueError(f"tracks file {str(path)!r}: column {name!r}: {exc}") from None
    return out


def frame_times_s(run: RunData) -> NDArray[np.float64]:
    """Time of every run frame (s) since the first frame's stamp, shape (N,)."""
    stamps = run.frames["stamp_ns"]
    return (stamps - stamps[0]).astype(float) / 1e9 if len(stamps) else np.zeros(0)


def robot_path(
    v_mps: NDArray[np.float64],
    omega_radps: NDArray[np.float64],
    dt_s: NDArray[np.float64],
    vy_mps: NDArray[np.float64] | None = None,
) -> NDArray:
    """Poses ``(N, 3)`` (x, y, yaw) of the grid frame integrated from the per-frame controls.

    Frame ``k`` moved with the constant body-frame velocity ``(v[k], vy[k], omega[k])`` (forward m/s, lateral
    m/s, rad/s; :func:`gridbridge.velocity_displacement`) for ``dt[k]`` s before its stamp; ``vy`` defaults to
    0 (arcs). The first frame is the origin (its own controls are not applied). Metres and radians in the frame
    of the first run frame (REP-103).
    """
    n = len(v_mps)
    lateral = np.zeros(n) if vy_mps is None else np.asarray(vy_mps, dtype=float)
    out = np.zeros((n, 3))
    pose = Pose2D()
    for k in range(1, n):
        v, w, dt = float(v_mps[k]), float(omega_radps[k]), float(dt_s[k])
        th = w * dt
        if abs(th) < 1e-9:
            step = Pose2D(x=v * dt, y=0.0, yaw=th)
        else:
            r = v / w
            step = Pose2D(x=r * math.sin(th), y=r * (1.0 - math.cos(th)), yaw=th)
        if lateral[k] != 0.0:
            dx, dy, _ = velocity_displacement(v, w, dt, vy=float(lateral[k]))
            step = Pose2D(x=float(dx), y=float(dy), yaw=th)
        pose = pose.compose(step)
        out[k] = (pose.x, pose.y, pose.yaw)
    return out


def default_fps(run: RunData, fallback: float = 10.0) -> float:
    """The run's frame rate: 1 / the median step between ``frames.csv`` stamps, rounded to 0.1 frames/s.

    A 7.5 Hz laser's run plays at 7.5 frames/s, in real time; ``fallback`` for runs of fewer than two frames or
    without increasing stamps.
    """
    steps = np.diff(np.asarray(run.frames["stamp_ns"], dtype=np.int64))
    steps = steps[steps > 0]
    if not len(steps):
        return fallback
    fps = round(1e9 / float(np.median(steps)), 1)
    return fps if fps > 0 else fallback


def ego_sources(run: RunData) -> NDArray[np.str_]:
    """Where each frame's ego-motion came from: ``"odometry"``, ``"scan matching"`` or ``"none"``, shape (N,).

    ``frames.csv`` ``odometry`` is 1 for both odometry and scan matching; a run without an odometry topic
    (``run.json`` ``config.odometry.topic`` empty) has its controls from scan matching the driving laser
    (:class:`pfpeople.run_state.RunSummary` ``ego_motion``).
    """
    config = run.meta.get("config")
    odo = config.get("odometry") if isinstance(config, dict) else None
    topic = odo.get("topic", "") if isinstance(odo, dict) else ""
    moved = np.asarray(run.frames["odometry"]) == 1
    return np.where(moved, "odometry" if topic else "scan matching", "none")


def laser_of(run: RunData) -> dict[str, str]:
    """Detector name -> its topic (``run.json`` ``config.detectors``); empty for runs that do not say."""
    config = run.meta.get("config")
    dets = config.get("detectors") if isinstance(config, dict) else None
    out: dict[str, str] = {}
    for d in dets if isinstance(dets, list) else []:
        if isinstance(d, dict) and isinstance(d.get("name"), str):
            out[d["name"]] = str(d.get("topic", ""))
    return out


class FrameRows:
    """Where each run frame's rows are in per-frame records (``detections.csv``, ``scans.npy``, ``tracks.csv``).

    The bounds are found once (one sort and one search over all frames), so a frame's rows cost a slice.

    Parameters
    ----------
    frames : ndarray (M,) of int, or None
        The run frame of every record (None: no records).
    n_frames : int
        Frames of the run.
    """

    def __init__(self, frames: NDArray[Any] | None, n_frames: int) -> None:
        f = np.zeros(0, dtype=np.int64) if frames is None else np.asarray(frames, dtype=np.int64)
        self.order = np.argsort(f, kind="stable")
        self.identity = bool(np.all(self.order == np.arange(len(f))))
        self.bounds = np.searchsorted(f[self.order], np.arange(n_frames + 1), "left")

    def __call__(self, k: int) -> slice | NDArray[np.intp]:
        """The rows of frame ``k``: a slice when the records are sorted by frame, else their indices."""
        lo, hi = int(self.bounds[k]), int(self.bounds[k + 1])
        return slice(lo, hi) if self.identity else self.order[lo:hi]
