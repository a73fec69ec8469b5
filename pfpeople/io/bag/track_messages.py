"""Tracks as result-bag messages: the track table, SPENCER's ``TrackedPersons`` with covariance, track colours.

A result bag (:mod:`pfpeople.io.bag.writer`) publishes the tracks twice:

- ``people_msgs/People`` (``/pfpeople/tracks``), the message of the ROS ``people`` stack that leg_tracker and
  most people trackers publish: id in ``name``, position, velocity, score in ``reliability``; it has no field
  for a covariance (the position covariance is kept in its tags ``cov_xx``, ``cov_xy``, ``cov_yy`` for readers of
  earlier bags);
- ``spencer_tracking_msgs/TrackedPersons`` (``/pfpeople/tracked_persons``), the message of the SPENCER people
  tracking stack (Linder et al., ICRA 2016; github spencer-project/spencer_messages), which carries the
  covariance: per track ``track_id``, ``is_occluded``, ``is_matched``, ``detection_id``, ``age`` and a
  ``geometry_msgs/PoseWithCovariance`` / ``TwistWithCovariance``. The definitions (:data:`SPENCER_MSG_DEFINITIONS`
  for ROS 1, :data:`SPENCER_MSG_DEFINITIONS_ROS2` for ROS 2) are written into the bag, so Foxglove and
  rosbags decode it without the package; they are SPENCER's field for field (the ROS 1 MD5 sums
  :data:`SPENCER_MD5` are those of spencer_tracking_msgs), so ``rosbag play`` feeds SPENCER's nodes and RViz
  plugins directly.

Covariance (:func:`pose_covariance`, :func:`twist_covariance`): the 6 x 6 row-major matrices of
``(x, y, z, rot x, rot y, rot z)`` and ``(vx, vy, vz, wx, wy, wz)`` hold the track's 2 x 2 position and velocity
blocks (m^2, m^2/s^2, in the message's frame); z and the rotations are not estimated and get
:data:`LARGE_VARIANCE` on the diagonal (SPENCER's convention: a variance above 99999 means "not set"; the
orientation is the identity). The position-velocity cross-covariance has no place in the message.

Track colours (:func:`track_colour`): the markers of track ``id`` take colour ``id mod 8`` of matplotlib's
``tab10`` without its red and grey (red is the people's), so a track keeps its colour all its life.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "LARGE_VARIANCE",
    "SPENCER_MD5",
    "SPENCER_MSG_DEFINITIONS",
    "SPENCER_MSG_DEFINITIONS_ROS2",
    "TRACKED_PERSONS_TYPE",
    "TRACKED_PERSON_TYPE",
    "TrackTable",
    "duration",
    "pose_covariance",
    "track_colour",
    "track_table",
    "twist_covariance",
]

TRACKED_PERSON_TYPE = "spencer_tracking_msgs/msg/TrackedPerson"
TRACKED_PERSONS_TYPE = "spencer_tracking_msgs/msg/TrackedPersons"
_TRACKED_PERSON_FIELDS = (
    "uint64 track_id\n"
    "bool is_occluded\n"
    "bool is_matched\n"
    "uint64 detection_id\n"
    "{duration} age\n"
    "geometry_msgs/PoseWithCovariance pose\n"
    "geometry_msgs/TwistWithCovariance twist\n"
)
#: ``spencer_tracking_msgs`` of ROS 1 (spencer_messages, branch master).
SPENCER_MSG_DEFINITIONS: dict[str, str] = {
    TRACKED_PERSON_TYPE: _TRACKED_PERSON_FIELDS.format(duration="duration"),
    TRACKED_PERSONS_TYPE: "std_msgs/Header header\nspencer_tracking_msgs/TrackedPerson[] tracks\n",
}
#: ``spencer_tracking_msgs`` of its ROS 2 port (``age`` a ``builtin_interfaces/Duration``).
SPENCER_MSG_DEFINITIONS_ROS2: dict[str, str] = {
    TRACKED_PERSON_TYPE: _TRACKED_PERSON_FIELDS.format(duration="builtin_interfaces/Duration"),
    TRACKED_PERSONS_TYPE: SPENCER_MSG_DEFINITIONS[TRACKED_PERSONS_TYPE],
}
#: ROS 1 MD5 sums of the definitions, as spencer_tracking_msgs' generated code has them.
SPENCER_MD5 = {
    TRACKED_PERSON_TYPE: "28bdd0d6d6551c668e4fde8aecdf1885",
    TRACKED_PERSONS_TYPE: "21c0b1a57c4933e68f39aa3802861828",
}
#: Variance (m^2, rad^2, ...) of what a track does not estimate: z and the rotations (SPENCER: above 99999 = not set).
LARGE_VARIANCE = 1e6

#: matplotlib's tab10 without red (the people's markers) and grey: RGB in [0, 1].
_PALETTE = (
    (0.122, 0.467, 0.706),
    (1.000, 0.498, 0.055),
    (0.173, 0.627, 0.173),
    (0.580, 0.404, 0.741),
    (0.549, 0.337, 0.294),
    (0.890, 0.467, 0.761),
    (0.737, 0.741, 0.133),
    (0.090, 0.745, 0.812),
)


def track_colour(track_id: int) -> tuple[float, float, float]:
    """The RGB colour (each in [0, 1]) of track ``track_id``'s markers: one of 8 distinct colours by id."""
    return _PALETTE[int(track_id) % len(_PALETTE)]


@dataclass(frozen=True)
class TrackTable:
    """The tracks of one frame, checked.

    Attributes
    ----------
    rows : ndarray (K, 9)
        ``[id, x, y, vx, vy, cov_xx, cov_xy, cov_yy, score]`` (m, m/s, m^2; NaN: not known).
    covariance : ndarray (K, 4, 4)
        Covariance of ``(x, y, vx, vy)`` (NaN where not known).
    age_s : ndarray (K,)
        Time since each track's birth (s; 0 when not known).
    matched : ndarray (K,) of bool
        Whether a detection updated the track in this frame (True when not known).
    detection : ndarray (K,) of int
        Index of that detection among the frame's (0 when none or not known).
    """

    rows: NDArray[np.float64]
    covariance: NDArray[np.float64]
    age_s: NDArray[np.float64]
    matched: NDArray[np.bool_]
    detection: NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.rows)


def track_table(tracks: NDArray[np.float64] | Sequence[Any]) -> TrackTable:
    """The :class:`TrackTable` of an array ``(K, 5)`` ``[id, x, y, vx, vy]`` or ``(K, 9)`` (with ``cov_xx, cov_xy,
    cov_yy, score``; NaN: not known), or of track objects (``id``, ``x``, ``y``, ``vx``, ``vy``, optionally
    ``covariance`` (2, 2) or (4, 4) of ``(x, y, vx, vy)``, ``score``, ``age_s``, ``measurement``, ``supported``,
    as :class:`pfpeople.track.multi_person.Track` has).

    Raises
    ------
    ValueError
        A wrong shape, a non-finite id, position or velocity, ids that are not unique non-negative int32.
    """
    objects = not isinstance(tracks, np.ndarray) and all(
        hasattr(t, a) for t in tracks for a in ("id", "x", "y", "vx", "vy")
    )
    if objects and len(tracks):
        rows, cov = np.array([_row(t) for t in tracks]), np.array([_covariance(t) for t in tracks])
        age = np.array([float(getattr(t, "age_s", 0.0)) for t in tracks])
        found = [int(getattr(t, "measurement", -1)) for t in tracks]
        matched = np.array([m >= 0 or bool(getattr(t, "supported", False)) for t, m in zip(tracks, found, strict=True)])
        detection = np.array([max(m, 0) for m in found], dtype=np.int64)
    else:
        rows = np.zeros((0, 9)) if objects else _rows_of_array(tracks)
        cov = np.full((len(rows), 4, 4), np.nan)
        cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 0], cov[:, 1, 1] = rows[:, 5], rows[:, 6], rows[:, 6], rows[:, 7]
        age, matched, detection = np.zeros(len(rows)), np.ones(len(rows), bool), np.zeros(len(rows), np.int64)
    _check_rows(rows)
    return TrackTable(rows, cov, age, matched, detection)


def _rows_of_array(tracks: Any) -> NDArray[np.float64]:
    """``(K, 9)`` rows of an array ``(K, 5)`` or ``(K, 9)`` (the missing columns NaN)."""
    arr = np.asarray(tracks, dtype=float)
    if arr.ndim != 2 or arr.shape[1] not in (5, 9):
        raise ValueError(f"tracks must have shape (K, 5) [id, x, y, vx, vy] or (K, 9), got {arr.shape}")
    if arr.shape[1] == 5:
        arr = np.hstack([arr, np.full((len(arr), 4), np.nan)])
    return arr


def _check_rows(arr: NDArray[np.float64]) -> None:
    if not np.all(np.isfinite(arr[:, :5])):
        raise ValueError("tracks must be finite")
    ids = arr[:, 0]
    if np.any(ids != np.rint(ids)) or np.any(ids < 0) or np.any(ids > np.iinfo(np.int32).max):
        raise ValueError(f"tracks: ids (column 0) must be integers in [0, 2**31 - 1], got {ids.tolist()}")
    if len(np.unique(ids)) != len(ids):
        raise ValueError(f"tracks: ids (column 0) must be unique in a frame, got {ids.tolist()}")


def _covariance(t: Any) -> NDArray[np.float64]:
    """The (4, 4) covariance of ``(x, y, vx, vy)`` of a track object (NaN for what it lacks)."""
    out = np.full((4, 4), np.nan)
    c = np.asarray(getattr(t, "covariance", None), dtype=float)
    if c.ndim == 2 and c.shape[0] == c.shape[1] and c.shape[0] in (2, 4):
        out[: c.shape[0], : c.shape[0]] = c
    return out


def _row(t: Any) -> list[float]:
    """``[id, x, y, vx, vy, cov_xx, cov_xy, cov_yy, score]`` of a track object (NaN for what it lacks)."""
    c = _covariance(t)
    return [t.id, t.x, t.y, t.vx, t.vy, c[0, 0], c[0, 1], c[1, 1], float(getattr(t, "score", np.nan))]


def _six_by_six(block: NDArray[np.float64]) -> NDArray[np.float64]:
    """A 6 x 6 covariance (row-major, 36 values) with ``block`` (2, 2) upper left, the other diagonal entries
    :data:`LARGE_VARIANCE`; an unknown (NaN) block entry becomes 0 off the diagonal, LARGE_VARIANCE on it."""
    out = np.diag(np.full(6, LARGE_VARIANCE))
    b = np.asarray(block, dtype=float)
    out[:2, :2] = np.where(np.isfinite(b), b, np.diag([LARGE_VARIANCE] * 2))
    return out.ravel()


def pose_covariance(covariance: NDArray[np.float64]) -> NDArray[np.float64]:
    """``PoseWithCovariance.covariance`` (36,) of a track's (4, 4) covariance of ``(x, y, vx, vy)``."""
    return _six_by_six(np.asarray(covariance)[:2, :2])


def twist_covariance(covariance: NDArray[np.float64]) -> NDArray[np.float64]:
    """``TwistWithCovariance.covariance`` (36,) of a track's (4, 4) covariance of ``(x, y, vx, vy)``."""
    return _six_by_six(np.asarray(covariance)[2:, 2:])


def duration(seconds: float) -> tuple[int, int]:
    """``(sec, nanosec)`` of a non-negative duration (s), as ``builtin_interfaces/Duration`` holds it."""
    ns = max(0, round(seconds * 1e9)) if math.isfinite(seconds) else 0
    return ns // 1_000_000_000, ns % 1_000_000_000
