"""Multi-person tracking: every person with an id, a position, a velocity and an existence score.

The tracker runs on people positions in the current sensor (grid) frame, REP-103, metres: the fused output of
either filter (a classifier's people, each with an optional confidence) or raw detections (the
tracking-by-detection baseline). One call of :meth:`MultiPersonTracker.update` per frame:

1. **Ego-motion.** ``ego`` is the pose of the current sensor frame expressed in the previous one (the
   convention of :func:`gridbridge.velocity_displacement`). Every track is moved into the new frame: position
   ``p' = R(-yaw) (p - t)``, velocity ``v' = R(-yaw) v``, covariance ``P' = B P B^T`` with
   ``B = blockdiag(R(-yaw), R(-yaw))``. Odometry noise is not added (it is small against ``q`` at
   walking speeds; a caller with large odometry noise raises ``process_noise``).
2. **Prediction** with the constant-velocity model, state ``s = (x, y, vx, vy)``::

       s' = F s,   F = [[I, dt I], [0, I]]
       P' = F P F^T + Q,   Q = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]]

   (continuous white-noise acceleration of spectral density ``q`` m^2/s^3, as filterpy's
   ``Q_continuous_white_noise``; the equations are filterpy ``KalmanFilter.predict``/``update`` vectorised
   over all tracks, checked against filterpy in the tests).
3. **Gating and assignment.** Innovation ``y = z - H s``, ``S = H P H^T + R``, ``R = sigma_z^2 I``; a pair
   (track, measurement) is allowed when the Mahalanobis distance ``d^2 = y^T S^-1 y <= gate_mahalanobis``
   and the Euclidean distance ``|y| <= gate_distance``. The cost of an allowed pair is the negative
   log-likelihood ``d^2 + ln det S`` (a precise track near a detection wins over a vague one), plus a
   constant for a tentative track with ``prefer_confirmed`` (confirmed tracks take precedence: a clutter
   track born beside a person does not take over its detections); the optimal one-to-one assignment is
   :func:`scipy.optimize.linear_sum_assignment` over allowed pairs only. With ``contest_gate``, a track that
   missed the previous frame may take a measurement farther than ``contest_gate`` only when no other live
   track's prediction lies within ``contest_radius`` of it (a coasting track in a crowd does not take over a
   neighbour's detection that the neighbour's own, perhaps tentative, track is on).
4. **Update** of assigned tracks (Kalman update, ``P = (I - K H) P`` symmetrised); unassigned tracks coast
   (keep their prediction); every unassigned measurement with ``score >= birth_min_score`` starts a
   tentative track at its position with zero velocity and covariance ``diag(sz^2, sz^2, sv^2, sv^2)``.

   4c. **Support** (optional, ``support`` positions given to ``update``: weaker evidence than a position, such
   as the laser detectors' unpaired single legs): the confirmed tracks still without a hit are assigned to the
   support positions as in step 3 (same gates and cost, ``R = support_sigma^2 I``), leaving out support
   positions within ``support_exclusion`` of a position of this frame (the other leg of a person found). An
   assigned support position updates its track as a hit of confidence ``support_confidence``. Support never
   starts or confirms a track: this is the second association stage of ByteTrack (Zhang et al. 2022), whose
   low-score detections only continue tracks. A walking person whose far leg is hidden by the near one, or
   whose legs the detector cannot pair at range, stays tracked while clutter is not started from single legs.
5. **Existence score** ``r`` in [0, 1] (a confidence, not a calibrated probability): a hit with
   measurement confidence ``c`` (1 when ``scores`` is None) gives ``r <- r + hit_gain c (1 - r)``; a frame
   without a hit gives ``r <- r exp(-dt / score_tau)``. A new track starts at ``r = hit_gain c``.
6. **Confirmation and deletion.** A tentative track is confirmed when it has ``confirm_hits`` hits within
   its first ``confirm_window`` frames (M of N); it is deleted when that has become impossible or after
   ``tentative_max_misses`` consecutive misses. With ``confirm_evidence`` the evidence decides instead of the count:
   a tentative track is confirmed once its existence score (step 5) reaches ``confirm_evidence``, and deleted after
   ``tentative_max_misses`` consecutive misses or below ``delete_score``. The score adds each hit's confidence (the
   fused belief at the person, which carries the detectors' PPV, and a scored detector's PPV of its score), so two
   confident hits confirm a person seen for a fraction of a second, weak hits take more, and a person detected every
   other scan is confirmed as the misses' decay is slower than the hits' gain. A confirmed track is deleted after
   coasting longer than ``max_coast_s`` seconds without a hit, or when its score falls below ``delete_score``, or (with
   ``region``) when its position leaves the region by more than ``region_margin``. The output (the confirmed
   tracks) leaves out tracks coasting longer than ``report_coast_s``: they stay alive to keep their id. A
   confirmed track that has coasted longer than ``revive_after_s`` is *lost*: it is reported again only after
   a hit by a measurement that could start a track (confidence ``>= birth_min_score``); weaker hits (the
   belief's weaker peaks, support positions) update it unreported.

   6b. **Re-identification** (``reid_distance > 0``): a track confirmed in this frame takes the id of a *lost*
   track, a confirmed one that has had no hit since the new track was born (two tracks seen at once are two
   people), when their positions are within ``reid_distance`` and within the Mahalanobis gate of the two
   position covariances summed (the lost track's grows while it coasts); the optimal assignment (cost ``d^2 +
   ln det S``) pairs several. The new track keeps its state and takes the lost track's id, birth time and
   ``moved``; the lost track is removed. The constant-velocity prediction of a coasting track runs on while the
   person stops or turns behind an occluder, past the association gate: without this the person comes back
   under a new id.
7. **Motion.** Each track keeps its birth position, moved with the ego-motion like its state; it has *moved*
   (``Track.moved``, for good) once its position has been ``moved_distance`` or more from there. ``Track.age_s``
   is the time since its birth.

Time is the caller's: ``dt`` is the time since the previous update (s, > 0). Time going backwards is a
``dt <= 0`` and raises ``ValueError``; a caller that restarts (a gap, a rewound bag) calls :meth:`reset`.
Track ids are integers from 1, unique among the live tracks and never given to another person: a new track
takes a new id (ids keep counting up after :meth:`reset`), and re-identification (step 6b) passes a lost
track's id to the track that continues it as the lost track is removed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from gridbridge.validation import check_int, check_real, check_real_array
from pfpeople.sensors import Pose2D
from pfpeople.units import M2PerS3, Metres, MetresPerSecond, Ratio, Seconds

__all__ = ["TRACK_COLUMNS", "MultiPersonTracker", "Track", "TrackerConfig", "track_rows"]

#: Columns of a run directory's ``tracks.csv`` (see :func:`track_rows`).
TRACK_COLUMNS = ("frame", "stamp_ns", "id", "x", "y", "vx", "vy", "cov_xx", "cov_xy", "cov_yy", "score")

_INFEASIBLE = 1e9
#: Added to the cost of a tentative track's pairs with ``prefer_confirmed`` (above any allowed pair's cost:
#: ``d^2 <= gate_mahalanobis``, ``|ln det S|`` a few units).
_TENTATIVE = 1e3


@dataclass(frozen=True, kw_only=True)
class TrackerConfig:
    """Parameters of :class:`MultiPersonTracker` (see the module docstring for the equations).

    The defaults are for people walking (up to ~2 m/s, turning within a second) seen by a laser at 7.5-40 Hz
    through detections or a fused grid of 0.1-0.3 m cells.

    Parameters
    ----------
    process_noise : float
        ``q``, spectral density of the white-noise acceleration (m^2/s^3). 0.3: a walker's velocity changes by
        ~0.5 m/s (one sigma) within a second (see Notes for the choice).
    measurement_sigma : float
        ``sigma_z``, standard deviation of a measured position per axis (m).
    initial_velocity_sigma : float
        Standard deviation of a new track's velocity per axis (m/s).
    gate_mahalanobis : float
        Largest squared Mahalanobis distance of an allowed pair (9.21: the 99 % point of chi^2 with 2 dof).
    gate_distance : float
        Largest Euclidean distance (m) between a prediction and an allowed measurement.
    confirm_hits, confirm_window : int
        M of N: a tentative track needs ``confirm_hits`` hits within its first ``confirm_window`` frames (unless
        ``confirm_evidence`` is given).
    confirm_evidence : float or None
        Confirm a tentative track once its existence score reaches this, in (``hit_gain``, 1) (at least two hits),
        instead of M of N (step 6); None: M of N.
    tentative_max_misses : int
        Consecutive misses that delete a tentative track.
    max_coast_s : float
        Longest time (s) a confirmed track coasts without a hit before it is deleted (it keeps its id when
        seen again within this time). With the default score settings, the score falls below ``delete_score``
        after about 6 s of coasting (``score_tau ln(1 / delete_score)`` from a score near 1), which deletes it
        first.
    delete_score : float
        A track whose existence score falls below this is deleted (in [0, 1)).
    hit_gain : float
        Weight of a hit in the existence score, in (0, 1].
    score_tau : float
        Time constant (s) of the existence score's decay while a track coasts.
    birth_min_score : float
        Measurements with a confidence below this update tracks but do not start new ones (in [0, 1]).
    region : tuple of 4 floats or None
        ``(x_min, x_max, y_min, y_max)`` (m, sensor frame), e.g. the grid's extent: confirmed tracks that
        move more than ``region_margin`` outside are deleted. None: no region.
    region_margin : float
        Tolerance (m) around ``region``.
    report_coast_s : float or None
        Confirmed tracks coasting longer than this (s) stay alive (and keep their id when seen again) but are
        not reported by :meth:`MultiPersonTracker.confirmed` / ``update`` (SORT's rule); None reports every
        confirmed track up to its deletion.
    support_sigma : float
        Standard deviation per axis (m) of a support position as a measurement of a person's centre (step 4c);
        a single leg lies 0.1-0.2 m from it.
    support_exclusion : float
        Support positions within this distance (m) of a position of the same frame are left out (step 4c).
    support_confidence : float
        Confidence of a support hit in the existence score, in (0, 1].
    moved_distance : float
        Distance (m) from its birth position (ego-motion compensated) at which a track has moved (step 7).
    support_min_speed : float
        Only tracks whose speed estimate is at least this (m/s) take support positions (step 4c): a walker's far
        leg hides behind the near one, a chair taken for a person does not move.
    reid_distance : float
        Re-identification (step 6b): largest distance (m) between a newly confirmed track and a lost track that
        gives it the lost track's id; 0: no re-identification. Default 2.5 (see Notes).
    prefer_confirmed : bool
        In the assignment a confirmed track has precedence over a tentative one: the cost of a tentative
        track's pairs is raised by a constant larger than any allowed pair's cost, so a measurement that a
        confirmed track can take goes to a tentative one only when the optimum needs it to (step 3). Default
        True (MOT ablation: fewer identity switches on 5 of 7 scenes, none more).
    contest_gate : float or None
        Step 3: a track that missed the previous frame takes a measurement farther than this (m) only when no
        other live track lies within ``contest_radius`` of the measurement. None: ``gate_distance`` only.
        Default 0.75 (see Notes).
    contest_radius : float
        Distance (m) between a measurement and another track's prediction that makes the measurement contested.
    revive_after_s : float or None
        A confirmed track that has coasted longer than this (s) is lost: it is reported again only after a hit
        of confidence ``>= birth_min_score`` (step 6), and is not reported while it coasts whatever
        ``report_coast_s``; None: any hit revives it. With the default ``birth_min_score`` of 0 every hit does.
        Default 2.5 (see Notes).

    Notes
    -----
    How each default was chosen, with the ablation tables: ``docs/ablations.md``, "The multi-person tracker's
    defaults".
    """

    process_noise: M2PerS3 = 0.3
    measurement_sigma: Metres = 0.15
    initial_velocity_sigma: MetresPerSecond = 1.0
    gate_mahalanobis: float = 9.21
    gate_distance: Metres = 1.0
    confirm_hits: int = 3
    confirm_window: int = 5
    confirm_evidence: Ratio | None = None
    tentative_max_misses: int = 2
    max_coast_s: Seconds = 8.0
    delete_score: Ratio = 0.05
    hit_gain: Ratio = 0.4
    score_tau: Seconds = 2.0
    birth_min_score: Ratio = 0.0
    region: tuple[Metres, Metres, Metres, Metres] | None = None
    region_margin: Metres = 0.5
    report_coast_s: Seconds | None = 1.0
    support_sigma: Metres = 0.2
    support_exclusion: Metres = 0.4
    support_confidence: Ratio = 0.5
    support_min_speed: MetresPerSecond = 0.4
    moved_distance: Metres = 0.3
    reid_distance: Metres = 2.5
    prefer_confirmed: bool = True
    revive_after_s: Seconds | None = 2.5
    contest_gate: Metres | None = 0.75
    contest_radius: Metres = 0.5

    def __post_init__(self) -> None:
        positive = (
            "process_noise",
            "measurement_sigma",
            "initial_velocity_sigma",
            "gate_mahalanobis",
            "gate_distance",
            "max_coast_s",
            "score_tau",
            "support_sigma",
            "support_exclusion",
            "moved_distance",
            "contest_radius",
        )
        optional = ("report_coast_s", "revive_after_s", "contest_gate")  # None: off
        for name in (*positive, "region_margin", "reid_distance", "support_min_speed", *optional):
            value = getattr(self, name)
            if value is not None or name not in optional:
                v = check_real(value, f"TrackerConfig.{name}", low=0.0, low_open=name in positive)
                object.__setattr__(self, name, v)
        for name, lo_open, hi_open in (
            ("delete_score", False, True),
            ("hit_gain", True, False),
            ("birth_min_score", False, False),
            ("support_confidence", True, False),
        ):
            v = check_real(
                getattr(self, name), f"TrackerConfig.{name}", low=0.0, high=1.0, low_open=lo_open, high_open=hi_open
            )
            object.__setattr__(self, name, v)
        if not isinstance(self.prefer_confirmed, bool):
            raise TypeError(f"TrackerConfig.prefer_confirmed must be a bool, got {self.prefer_confirmed!r}")
        for name in ("confirm_hits", "confirm_window", "tentative_max_misses"):
            object.__setattr__(self, name, check_int(getattr(self, name), f"TrackerConfig.{name}", minimum=1))
        if self.confirm_evidence is not None:
            v = check_real(self.confirm_evidence, "TrackerConfig.confirm_evidence", low=0.0, high=1.0, high_open=True)
            if not v > self.hit_gain:
                raise ValueError(
                    f"TrackerConfig.confirm_evidence ({v}) must exceed hit_gain ({self.hit_gain}): "
                    "one hit never confirms"
                )
            object.__setattr__(self, "confirm_evidence", v)
        if self.confirm_hits > self.confirm_window:
            raise ValueError(
                f"TrackerConfig.confirm_hits ({self.confirm_hits}) must not exceed confirm_window "
                f"({self.confirm_window})"
            )
        if self.region is not None:
            reg = tuple(check_real(v, "TrackerConfig.region") for v in self.region)
            if len(reg) != 4 or not (reg[0] < reg[1] and reg[2] < reg[3]):
                raise ValueError(
                    f"TrackerConfig.region must be (x_min, x_max, y_min, y_max) with min < max, got {self.region!r}"
                )
            object.__setattr__(self, "region", reg)


@dataclass(frozen=True, kw_only=True, eq=False)
class Track:
    """A snapshot of one track after an update (current sensor frame, REP-103).

    Attributes
    ----------
    id : int
        Unique among the live tracks; a new track takes a new one, a re-identified track (step 6b) the id of the
        lost track it continues.
    x, y : float
        Position (m).
    vx, vy : float
        Velocity (m/s).
    covariance : ndarray, shape (4, 4)
        Covariance of ``(x, y, vx, vy)`` (m^2, m^2/s, m^2/s^2).
    score : float
        Existence score in [0, 1].
    hits : int
        Frames with an assigned measurement (the birth frame included).
    misses : int
        Consecutive frames without one, up to now (0 when this frame had a hit).
    age : int
        Frames since birth (1 in the birth frame).
    confirmed : bool
        Whether the track has passed the M-of-N confirmation.
    measurement : int
        Index (into this update's ``positions``) of the position assigned to the track in this frame, its
        birth's included; -1 when none was (a coasting track, or one updated from a support position, step 4c).
    supported : bool
        Whether a support position (step 4c) was this frame's hit.
    age_s : float
        Time since the track's birth (s; 0 in the birth frame).
    moved : bool
        Whether the track has been ``moved_distance`` or more from its birth position (step 7).
    """

    id: int
    x: float
    y: float
    vx: float
    vy: float
    covariance: NDArray[np.float64]
    score: float
    hits: int
    misses: int
    age: int
    confirmed: bool
    measurement: int = -1
    supported: bool = False
    age_s: float = 0.0
    moved: bool = False

    @property
    def position(self) -> NDArray[np.float64]:
        """``(2,)`` position (m)."""
        return np.array([self.x, self.y])

    @property
    def velocity(self) -> NDArray[np.float64]:
        """``(2,)`` velocity (m/s)."""
        return np.array([self.vx, self.vy])


@dataclass
class _State:
    """Per-track bookkeeping (the Kalman state lives in the tracker's arrays)."""

    id: int
    score: float
    hits: int = 1
    misses: int = 0
    age: int = 1
    confirmed: bool = False
    coast_s: float = 0.0
    measurement: int = -1
    supported: bool = False
    age_s: float = 0.0
    moved: bool = False
    lost: bool = False


def _confirms(cfg: TrackerConfig, m: _State) -> bool:
    """Whether a tentative track's evidence confirms it (step 6): its score reaches ``confirm_evidence``, or M of N."""
    if cfg.confirm_evidence is not None:
        return m.score >= cfg.confirm_evidence
    return m.age <= cfg.confirm_window and m.hits >= cfg.confirm_hits


def _check_ego(ego: object) -> None:
    """``ego`` is None or a finite :class:`pfpeople.sensors.Pose2D` (TypeError / ValueError otherwise)."""
    if ego is None:
        return
    if not isinstance(ego, Pose2D):
        raise TypeError(f"ego must be a pfpeople.sensors.Pose2D or None, got {type(ego).__name__}")
    if not all(math.isfinite(v) for v in (ego.x, ego.y, ego.yaw)):
        raise ValueError(f"ego must be finite, got {ego!r}")


def _check_positions(positions: ArrayLike, name: str = "positions") -> NDArray[np.float64]:
    z = check_real_array(positions, name)  # TypeError for complex, bool or string elements
    if z.size == 0:
        return np.zeros((0, 2))
    if z.ndim != 2 or z.shape[1] != 2:
        raise ValueError(f"{name} must have shape (M, 2), got {z.shape}")
    if not np.isfinite(z).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return z


def _check_scores(scores: ArrayLike | None, m: int) -> NDArray[np.float64]:
    if scores is None:
        return np.ones(m)
    s = check_real_array(scores, "scores")
    if s.size == 0 and m == 0:
        return np.zeros(0)
    if s.shape != (m,):
        raise ValueError(f"scores must have shape ({m},) like positions, got {s.shape}")
    if not ((s >= 0) & (s <= 1)).all():  # one pass: NaN fails both comparisons, +-inf one of them
        raise ValueError("scores must be finite and in [0, 1]")
    return s


def _hits_per_row(
    n_old: int, rows: NDArray[np.intp], cols: NDArray[np.intp], c: NDArray[np.float64]
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Per track row of the previous frame (``n_old``), its assigned measurement (-1: none) and that one's
    confidence (0: none), from the assignment ``rows`` -> ``cols`` and the confidences ``c`` (M,)."""
    meas_of = np.full(n_old, -1, dtype=np.intp)
    meas_of[rows] = cols
    conf = np.zeros(n_old)
    conf[rows] = c[cols]
    return meas_of, conf


class MultiPersonTracker:
    """Tracks many people with constant-velocity Kalman filters, gated optimal assignment and M-of-N rules.

    Parameters
    ----------
    config : TrackerConfig, optional
        Parameters (defaults when None).

    Examples
    --------
    >>> import numpy as np
    >>> tracker = MultiPersonTracker()
    >>> for k in range(10):
    ...     out = tracker.update(np.array([[2.0 + 0.1 * k, 0.0]]), 0.1)
    >>> [(t.id, round(t.vx, 1)) for t in out]
    [(1, 1.0)]
    """

    def __init__(self, config: TrackerConfig | None = None) -> None:
        if config is None:
            config = TrackerConfig()
        if not isinstance(config, TrackerConfig):
            raise TypeError(f"config must be a TrackerConfig, got {type(config).__name__}")
        self.config = config
        self._next_id = 1
        self._cached_dt = math.nan
        self._f = np.eye(4)
        self._q = np.zeros((4, 4))
        self.reset()

    def reset(self) -> None:
        """Forget every track (ids keep counting up: an id is never reused)."""
        self._s = np.zeros((0, 4))
        self._origin = np.zeros((0, 2))  # birth positions, current sensor frame (step 7)
        self._p = np.zeros((0, 4, 4))
        self._meta: list[_State] = []

    # -- public views -------------------------------------------------------------------------------------
    @property
    def tracks(self) -> list[Track]:
        """Every live track, tentative and confirmed, in order of birth."""
        return self._snapshots(list(range(len(self._meta))))

    def confirmed(self) -> list[Track]:
        """The confirmed live tracks, in order of birth: the tracker's output.

        Coasting tracks are included, up to ``config.report_coast_s`` of coasting when that is set.
        """
        return self._snapshots(self._confirmed_rows())

    def _confirmed_rows(self) -> list[int]:
        """The rows of :meth:`confirmed`'s tracks."""
        rc = self.config.report_coast_s
        rc = math.inf if rc is None else rc + 1e-9
        return [
            i for i, m in enumerate(self._meta) if m.confirmed and not m.lost and (m.misses == 0 or m.coast_s <= rc)
        ]

    def confirmed_and_live(self) -> tuple[list[Track], list[Track]]:
        """:meth:`confirmed` and :attr:`tracks` from one snapshot of the live tracks (the confirmed ones are the
        same :class:`Track` objects as in the live list; read them, do not change their arrays)."""
        live = self.tracks
        return [live[i] for i in self._confirmed_rows()], live

    def _snapshots(self, idx: list[int]) -> list[Track]:
        if not idx:
            return []
        states = self._s[idx].tolist()
        covs = self._p[idx]  # fancy indexing: already a copy
        new = object.__new__
        out = []
        for n, i in enumerate(idx):
            m = self._meta[i]
            x, y, vx, vy = states[n]
            # Track is a frozen dataclass without slots: filling __dict__ directly is what its __init__ does
            # field by field (3x faster; this runs for every track in every frame).
            t = new(Track)
            t.__dict__.update(
                id=m.id,
                x=x,
                y=y,
                vx=vx,
                vy=vy,
                covariance=covs[n],
                score=m.score,
                hits=m.hits,
                misses=m.misses,
                age=m.age,
                confirmed=m.confirmed,
                measurement=m.measurement,
                supported=m.supported,
                age_s=m.age_s,
                moved=m.moved,
            )
            out.append(t)
        return out

    # -- one frame ----------------------------------------------------------------------------------------
    def update(
        self,
        positions: ArrayLike,
        dt: float,
        *,
        scores: ArrayLike | None = None,
        ego: Pose2D | None = None,
        support: ArrayLike | None = None,
    ) -> list[Track]:
        """Advance the tracks by one frame.

        Parameters
        ----------
        positions : array_like, shape (M, 2)
            People positions (m) in the current sensor frame; ``M = 0`` (an empty frame) is fine.
        dt : float
            Time since the previous update (s), finite and > 0. Time going backwards (or a repeated stamp)
            is the caller's ``dt <= 0`` and raises ``ValueError``: call :meth:`reset` to restart.
        scores : array_like, shape (M,), optional
            Confidence of each position in [0, 1] (e.g. the belief at a grid peak); None counts each as 1.
        ego : Pose2D, optional
            Pose of the current sensor frame in the previous one (m, m, rad); None: the sensor stood still.
        support : array_like, shape (K, 2), optional
            Support positions (m, current sensor frame) for confirmed tracks left without a hit (step 4c).

        Returns
        -------
        list of Track
            The confirmed tracks after the update (as :meth:`confirmed`); :attr:`tracks` has all.

        Raises
        ------
        ValueError
            ``positions`` or ``support`` not (M, 2) or not finite; ``scores`` of the wrong shape or outside [0, 1];
            ``dt`` not finite and positive; ``ego`` not finite.
        TypeError
            ``ego`` not a Pose2D, ``dt`` not a number.
        """
        self.advance(positions, dt, scores=scores, ego=ego, support=support)
        return self.confirmed()

    def advance(
        self,
        positions: ArrayLike,
        dt: float,
        *,
        scores: ArrayLike | None = None,
        ego: Pose2D | None = None,
        support: ArrayLike | None = None,
    ) -> None:
        """:meth:`update` without the snapshot of the confirmed tracks (take :meth:`confirmed_and_live` after it:
        one snapshot for both); the same arguments and errors."""
        z = _check_positions(positions)
        c = _check_scores(scores, z.shape[0])
        sup = np.zeros((0, 2)) if support is None else _check_positions(support, "support")
        dt = check_real(dt, "dt", low=0.0, low_open=True)
        _check_ego(ego)
        if self._meta:
            self._move_and_predict(ego, dt)
        rows, cols = self._associate(z)
        self._correct(rows, cols, z)
        n_old = len(self._meta)
        meas_of, conf = _hits_per_row(n_old, rows, cols, c)
        assigned = meas_of.copy()  # before step 4c's support hits
        supported = self._support_hits(sup, z, meas_of, conf)
        was_confirmed = [m.confirmed for m in self._meta]
        self._score_and_confirm(dt, meas_of, assigned, conf, supported)
        if n_old:
            self._motion_and_reid(n_old, was_confirmed)
        self._delete()
        self._birth(z, c, cols)

    def _move_and_predict(self, ego: Pose2D | None, dt: float) -> None:
        """Steps 1-2: move the tracks into the current sensor frame (``ego``: it in the previous one; None or the
        identity: unmoved) and predict them ``dt`` s (> 0) ahead."""
        if ego is not None and (ego.x != 0.0 or ego.y != 0.0 or ego.yaw != 0.0):
            self._apply_ego(ego)
        self._predict(dt)

    def _motion_and_reid(self, n_old: int, was_confirmed: list[bool]) -> None:
        """Step 7 for the ``n_old`` tracks of the previous frame (``moved`` once ``moved_distance`` from their
        birth position), then step 6b for those confirmed in this frame (``was_confirmed``: per row, before)."""
        far = np.hypot(*(self._s[:n_old, :2] - self._origin[:n_old]).T) >= self.config.moved_distance
        for j in far.nonzero()[0].tolist():
            self._meta[j].moved = True
        if self.config.reid_distance > 0:
            self._reidentify([i for i, m in enumerate(self._meta) if m.confirmed and not was_confirmed[i]])

    def _support_hits(
        self, sup: NDArray[np.float64], z: NDArray[np.float64], meas_of: NDArray[np.intp], conf: NDArray[np.float64]
    ) -> NDArray[np.bool_]:
        """Step 4c: the confirmed tracks without a hit updated by support positions ``sup`` (K, 2); ``meas_of``
        and ``conf`` (per track row) marked for them. Returns which rows a support position continued."""
        n_old = len(meas_of)
        supported = np.zeros(n_old, dtype=bool)
        if not (sup.shape[0] and n_old):
            return supported
        s_rows, s_cols = self._support(sup, z, meas_of)
        if s_rows.size:
            self._correct(s_rows, s_cols, sup, sigma=self.config.support_sigma)
            meas_of[s_rows] = n_old  # any value >= 0: a hit
            conf[s_rows] = self.config.support_confidence
            supported[s_rows] = True
        return supported

    def _score_and_confirm(
        self,
        dt: float,
        meas_of: NDArray[np.intp],
        assigned: NDArray[np.intp],
        conf: NDArray[np.float64],
        supported: NDArray[np.bool_],
    ) -> None:
        """Steps 5-6 for the tracks of the previous frame: age, hits and misses, existence score, confirmation
        (M of N) and loss (``revive_after_s``)."""
        cfg = self.config
        decay = math.exp(-dt / cfg.score_tau)
        lose_after = math.inf if cfg.revive_after_s is None else cfg.revive_after_s + 1e-9
        for i, m in enumerate(self._meta):
            m.age += 1
            m.age_s += dt
            m.measurement = int(assigned[i])
            m.supported = bool(supported[i])
            if meas_of[i] >= 0:
                if m.lost and conf[i] >= cfg.birth_min_score:
                    m.lost = False
                m.hits += 1
                m.misses = 0
                m.coast_s = 0.0
                m.score += cfg.hit_gain * float(conf[i]) * (1.0 - m.score)
            else:
                m.misses += 1
                m.coast_s += dt
                m.score *= decay
                m.lost = m.lost or (m.confirmed and m.coast_s > lose_after)
            if not m.confirmed and _confirms(cfg, m):
                m.confirmed = True

    def _reidentify(self, new: list[int]) -> None:
        """Step 6b: give the tracks ``new`` (rows confirmed in this frame) the ids of lost tracks.

        A lost track is a confirmed one without a hit since the new track's birth (``misses >= age``). A pair
        is allowed within ``reid_distance`` and the Mahalanobis gate of the two position covariances summed;
        the optimal assignment (cost ``d^2 + ln det S``) pairs them. The new track takes the lost track's id,
        birth time and ``moved``; the lost track is removed.
        """
        if not new:
            return
        cfg = self.config
        meta = self._meta
        lost = np.array([j for j, m in enumerate(meta) if m.confirmed and m.misses > 0 and j not in new], dtype=np.intp)
        if lost.size == 0:
            return
        rows = np.array(new, dtype=np.intp)
        y = self._s[rows, None, :2] - self._s[None, lost, :2]  # (n, l, 2)
        cov = self._p[rows, None, :2, :2] + self._p[None, lost, :2, :2]  # (n, l, 2, 2)
        a, b, c = cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 1]
        det = a * c - b * b
        d2 = (c * y[..., 0] ** 2 - 2.0 * b * y[..., 0] * y[..., 1] + a * y[..., 1] ** 2) / det
        ages = np.array([meta[i].age for i in new])
        misses = np.array([meta[j].misses for j in lost])
        allowed = (
            (d2 <= cfg.gate_mahalanobis)
            & ((y**2).sum(axis=2) <= cfg.reid_distance**2)
            & (misses[None, :] >= ages[:, None])
        )
        if not allowed.any():
            return
        rr, cc = linear_sum_assignment(np.where(allowed, d2 + np.log(det), _INFEASIBLE))
        gone = []
        for r, k in zip(rr.tolist(), cc.tolist(), strict=True):
            if not allowed[r, k]:
                continue
            m, old = meta[rows[r]], meta[lost[k]]
            m.id, m.age_s, m.moved = old.id, max(m.age_s, old.age_s), m.moved or old.moved
            gone.append(int(lost[k]))
        self._drop(np.array(gone, dtype=np.intp))

    def _drop(self, rows: NDArray[np.intp]) -> None:
        """Remove the track rows ``rows``."""
        if rows.size == 0:
            return
        keep = np.ones(len(self._meta), dtype=bool)
        keep[rows] = False
        self._s = self._s[keep]
        self._p = self._p[keep]
        self._origin = self._origin[keep]
        self._meta = [m for m, k in zip(self._meta, keep, strict=True) if k]

    def _apply_ego(self, ego: Pose2D) -> None:
        c, sn = math.cos(ego.yaw), math.sin(ego.yaw)
        rot = np.array([[c, sn], [-sn, c]])  # R(-yaw); the products by its transpose view, as numpy's matmul has them
        shift = np.array([ego.x, ego.y])
        self._s[:, :2] -= shift
        self._s[:, :2] = self._s[:, :2] @ rot.T
        self._s[:, 2:] = self._s[:, 2:] @ rot.T
        self._origin = (self._origin - shift) @ rot.T
        b = np.array([[c, sn, 0.0, 0.0], [-sn, c, 0.0, 0.0], [0.0, 0.0, c, sn], [0.0, 0.0, -sn, c]])  # R(-yaw) twice
        self._p = b @ self._p @ b.T

    def _predict(self, dt: float) -> None:
        if dt != self._cached_dt:
            q = self.config.process_noise
            f = np.eye(4)
            f[0, 2] = f[1, 3] = dt
            qm = np.zeros((4, 4))
            qm[0, 0] = qm[1, 1] = dt**3 / 3.0
            qm[0, 2] = qm[2, 0] = qm[1, 3] = qm[3, 1] = dt**2 / 2.0
            qm[2, 2] = qm[3, 3] = dt
            self._cached_dt, self._f, self._q = dt, f, q * qm
        f = self._f
        self._s = self._s @ f.T
        self._p = f @ self._p @ f.T + self._q

    def _support(
        self, sup: NDArray[np.float64], z: NDArray[np.float64], meas_of: NDArray[np.intp]
    ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Step 4c: (track rows, indices into ``sup``) of the support hits of confirmed tracks without a hit."""
        cfg = self.config
        tracks = np.array([m.confirmed for m in self._meta]) & (meas_of < 0)
        if cfg.support_min_speed > 0:
            tracks &= np.hypot(self._s[:, 2], self._s[:, 3]) >= cfg.support_min_speed
        if not tracks.any():
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        cols = np.arange(sup.shape[0])
        if z.shape[0]:
            d2 = ((sup[:, None, :] - z[None, :, :]) ** 2).sum(axis=2).min(axis=1)
            cols = cols[d2 > cfg.support_exclusion**2]
        cand = tracks.nonzero()[0]
        # only the pairs within the distance gate can be assigned: most frames have none
        near = ((self._s[cand, None, :2] - sup[None, cols, :]) ** 2).sum(axis=2) <= cfg.gate_distance**2
        if not near.any():
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        cand, cols = cand[near.any(axis=1)], cols[near.any(axis=0)]
        rows, cc = self._associate(sup[cols], sigma=cfg.support_sigma, rows=cand)
        return rows, cols[cc]

    def _associate(
        self, z: NDArray[np.float64], *, sigma: float | None = None, rows: NDArray[np.intp] | None = None
    ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Step 3: the gated optimal assignment (track rows, measurement indices) of ``z``, with measurement
        noise ``sigma`` (default ``measurement_sigma``), among the track rows ``rows`` (default all)."""
        m = z.shape[0]
        s, p = (self._s, self._p) if rows is None else (self._s[rows], self._p[rows])
        if s.shape[0] == 0 or m == 0:
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        cfg = self.config
        r2 = (cfg.measurement_sigma if sigma is None else sigma) ** 2
        a = (p[:, 0, 0] + r2)[:, None]  # S = [[a, b], [b, c]] per track
        b = p[:, 0, 1][:, None]
        c = (p[:, 1, 1] + r2)[:, None]
        det = a * c - b * b
        y0 = z[None, :, 0] - s[:, 0:1]  # (n, m)
        y1 = z[None, :, 1] - s[:, 1:2]
        d2 = (c * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
        dist2 = y0 * y0 + y1 * y1
        allowed = (d2 <= cfg.gate_mahalanobis) & (dist2 <= cfg.gate_distance**2)
        if cfg.contest_gate is not None and allowed.any():
            allowed &= ~self._contested(z, rows, dist2)
        if not allowed.any():
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        cost = d2 + np.log(det)
        if cfg.prefer_confirmed:
            meta = self._meta if rows is None else [self._meta[i] for i in rows]
            cost = cost + np.array([0.0 if t.confirmed else _TENTATIVE for t in meta])[:, None]
        cost = np.where(allowed, cost, _INFEASIBLE)
        # Only rows/columns with an allowed pair take part (smaller problem, same optimum).
        r_idx = np.nonzero(allowed.any(axis=1))[0]  # (1-D: np.flatnonzero without its ravel)
        c_idx = np.nonzero(allowed.any(axis=0))[0]
        every = r_idx.size == cost.shape[0] and c_idx.size == cost.shape[1]
        rr, cc = linear_sum_assignment(cost if every else cost[r_idx[:, None], c_idx])
        ok = allowed[r_idx[rr], c_idx[cc]]
        out_rows = r_idx[rr[ok]] if rows is None else rows[r_idx[rr[ok]]]
        return out_rows.astype(np.intp), c_idx[cc[ok]].astype(np.intp)

    def _contested(
        self, z: NDArray[np.float64], rows: NDArray[np.intp] | None, dist2: NDArray[np.float64]
    ) -> NDArray[np.bool_]:
        """``(n, m)``: pairs (row, measurement) that step 3's contest rule forbids: the track missed the previous
        frame, the measurement lies farther than ``contest_gate`` from it, and another live track's prediction
        lies within ``contest_radius`` of the measurement."""
        cfg = self.config
        assert cfg.contest_gate is not None
        idx = np.arange(len(self._meta)) if rows is None else rows
        coasting = np.array([self._meta[i].misses > 0 for i in idx], dtype=bool)
        if not coasting.any():
            return np.zeros(dist2.shape, dtype=bool)
        if rows is None:  # dist2 holds every track already
            near = dist2 <= cfg.contest_radius**2  # (all tracks, m)
        else:
            every = self._s[:, :2]
            d2 = (every[:, None, 0] - z[None, :, 0]) ** 2 + (every[:, None, 1] - z[None, :, 1]) ** 2
            near = d2 <= cfg.contest_radius**2
        others = near.sum(axis=0)[None, :] - near[idx]  # other tracks near each measurement, per row
        return np.asarray(coasting[:, None] & (others > 0) & (dist2 > cfg.contest_gate**2))

    def _correct(
        self, rows: NDArray[np.intp], cols: NDArray[np.intp], z: NDArray[np.float64], *, sigma: float | None = None
    ) -> None:
        if rows.size == 0:
            return
        r2 = (self.config.measurement_sigma if sigma is None else sigma) ** 2
        p = self._p[rows]  # (k, 4, 4)
        a, b, c = p[:, 0, 0] + r2, p[:, 0, 1], p[:, 1, 1] + r2
        det = a * c - b * b
        s_inv = np.empty((rows.size, 2, 2))
        s_inv[:, 0, 0] = c / det
        s_inv[:, 1, 1] = a / det
        s_inv[:, 0, 1] = s_inv[:, 1, 0] = -b / det
        ph = p[:, :, :2]  # P H^T, (k, 4, 2)
        k = ph @ s_inv  # Kalman gain (k, 4, 2)
        y = z[cols] - self._s[rows, :2]
        self._s[rows] += (k @ y[:, :, None])[:, :, 0]
        p_new = p - k @ p[:, :2, :]
        self._p[rows] = 0.5 * (p_new + p_new.transpose(0, 2, 1))

    def _delete(self) -> None:
        cfg = self.config
        keep = np.ones(len(self._meta), dtype=bool)
        reg = cfg.region
        for i, m in enumerate(self._meta):
            if m.confirmed:
                gone = m.coast_s > cfg.max_coast_s + 1e-9 or m.score < cfg.delete_score
                if reg is not None and not gone:
                    x, y = self._s[i, 0], self._s[i, 1]
                    e = cfg.region_margin
                    gone = not (reg[0] - e <= x <= reg[1] + e and reg[2] - e <= y <= reg[3] + e)
            else:
                can_confirm = cfg.confirm_evidence is not None or (
                    m.hits + max(0, cfg.confirm_window - m.age) >= cfg.confirm_hits
                )
                gone = m.misses >= cfg.tentative_max_misses or not can_confirm or m.score < cfg.delete_score
            keep[i] = not gone
        self._drop((~keep).nonzero()[0])

    def _birth(self, z: NDArray[np.float64], c: NDArray[np.float64], used: NDArray[np.intp]) -> None:
        cfg = self.config
        free = np.ones(z.shape[0], dtype=bool)
        free[used] = False
        free &= c >= cfg.birth_min_score
        new = free.nonzero()[0]
        if new.size == 0:
            return
        s0 = np.zeros((new.size, 4))
        s0[:, :2] = z[new]
        p0 = np.diag([cfg.measurement_sigma**2] * 2 + [cfg.initial_velocity_sigma**2] * 2)
        self._s = np.concatenate([self._s, s0])
        self._p = np.concatenate([self._p, np.broadcast_to(p0, (new.size, 4, 4))])
        self._origin = np.concatenate([self._origin, z[new]])
        for j in new:
            st = _State(id=self._next_id, score=cfg.hit_gain * float(c[j]), measurement=int(j))
            st.confirmed = cfg.confirm_evidence is None and cfg.confirm_hits <= 1
            self._meta.append(st)
            self._next_id += 1


def track_rows(frame: int, stamp_ns: int, tracks: Sequence[Track]) -> list[tuple[Any, ...]]:
    """Rows of ``tracks.csv`` (columns :data:`TRACK_COLUMNS`) for one frame.

    Parameters
    ----------
    frame : int
        Run frame number.
    stamp_ns : int
        Frame stamp (ns).
    tracks : sequence of Track
        Usually :meth:`MultiPersonTracker.confirmed`.

    Returns
    -------
    list of tuple
        ``(frame, stamp_ns, id, x, y, vx, vy, cov_xx, cov_xy, cov_yy, score)`` per track (ints and floats;
        positions in m and velocities in m/s in the frame's sensor/grid frame, covariance of the position in
        m^2).
    """
    return [
        (
            int(frame),
            int(stamp_ns),
            int(t.id),
            float(t.x),
            float(t.y),
            float(t.vx),
            float(t.vy),
            float(t.covariance[0, 0]),
            float(t.covariance[0, 1]),
            float(t.covariance[1, 1]),
            float(t.score),
        )
        for t in tracks
    ]
