"""Detector calibration: each detector's PPV and FNR measured against ground truth.

The paper found PPV and FNR "experimentally" (Batista & Pereira 2015, Sect. 3.2, Table 1); they enter the
filter as P(D_i | p) = PPV where detector i fires and FNR where it does not (eqs. 13-14). Here:

- detections and true people of one frame are matched one-to-one by the Hungarian algorithm
  (:func:`evaluation.metrics.detection.assign_one_to_one`: most pairs, then least total distance); pairs farther than a
  gate are refused; ``metric = "euclidean"`` gates in metres (default 0.5 m, for lasers); ``metric = "mahalanobis"``
  gates in standard deviations of the model's line-of-sight Gaussian (``sigma_lateral`` across, ``sigma_range``
  along the ray from the detector to the true person; default 3.0), for the camera's large range error;
- only people inside the detector's field of view and range limits (:class:`gridbridge.params.DetectorModel`)
  are candidates; with a ``region`` (a :class:`GridSpec`), recall counts people inside the region and
  precision counts detections inside it (a pair with one end outside is neither a hit nor a miss);
- ``PPV = TP / detections`` (matched detections / detections in the region) and
  ``FNR = missed / people`` (unmatched people in view / people in view), with Wilson score intervals.

Matching can only approximate the truth when detections are noisy: a false positive that lands within
the gate of a missed person counts as a hit. :func:`oracle_calibration` counts from the simulator's labels
instead and shows the size of that bias.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import norm

from evaluation.metrics.detection import assign_one_to_one
from evaluation.scenarios.simulated_detectors import in_field_of_view
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from gridbridge.validation import check_positions, check_positive, check_probability

__all__ = [
    "CalibrationCounts",
    "CalibrationResult",
    "calibrate_detector",
    "calibrate_frames",
    "match_detections",
    "oracle_calibration",
    "wilson_interval",
]

log = logging.getLogger(__name__)

#: A calibrated PPV / FNR of 0 or 1 is clamped this far inside (0, 1) by :meth:`CalibrationResult.to_model`.
PROBABILITY_MARGIN = 0.01
#: Largest frame number range :func:`calibrate_sparse` accepts (frames are indices 0, 1, ..., not stamps).
MAX_CALIBRATION_FRAMES = 100_000_000

DEFAULT_GATE_M = 0.5
DEFAULT_GATE_SIGMAS = 3.0


def wilson_interval(successes: int, trials: int, *, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion; ``(0, 1)`` when ``trials == 0``."""
    if trials < 0 or successes < 0 or successes > trials:
        raise ValueError(f"need 0 <= successes <= trials, got successes={successes}, trials={trials}")
    check_probability(confidence, "confidence", open_low=True, open_high=True)
    if trials == 0:
        return (0.0, 1.0)
    z = float(norm.ppf(0.5 + 0.5 * confidence))
    p = successes / trials
    denom = 1.0 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denom
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


@dataclass(frozen=True)
class CalibrationCounts:
    """Counts behind a calibration.

    Attributes
    ----------
    n_frames : int
        Frames used.
    n_detections : int
        Detections counted for precision (inside the region).
    n_true_positives : int
        Of those, matched to a person.
    n_people : int
        People in view counted for recall (inside the region), summed over frames.
    n_detected_people : int
        Of those, matched to a detection.
    """

    n_frames: int
    n_detections: int
    n_true_positives: int
    n_people: int
    n_detected_people: int

    @property
    def n_false_positives(self) -> int:
        return self.n_detections - self.n_true_positives

    @property
    def n_missed(self) -> int:
        return self.n_people - self.n_detected_people

    def __add__(self, other: CalibrationCounts) -> CalibrationCounts:
        return CalibrationCounts(
            self.n_frames + other.n_frames,
            self.n_detections + other.n_detections,
            self.n_true_positives + other.n_true_positives,
            self.n_people + other.n_people,
            self.n_detected_people + other.n_detected_people,
        )


@dataclass(frozen=True)
class CalibrationResult:
    """A detector's measured PPV and FNR with Wilson intervals.

    ``ppv`` is NaN without detections and ``fnr`` NaN without people in view (nothing to measure).
    """

    name: str
    ppv: float
    fnr: float
    ppv_interval: tuple[float, float]
    fnr_interval: tuple[float, float]
    counts: CalibrationCounts
    confidence: float
    metric: str
    gate: float

    @classmethod
    def from_counts(
        cls, name: str, counts: CalibrationCounts, *, confidence: float = 0.95, metric: str = "", gate: float = 0.0
    ) -> CalibrationResult:
        c = counts
        ppv = c.n_true_positives / c.n_detections if c.n_detections else math.nan
        fnr = c.n_missed / c.n_people if c.n_people else math.nan
        return cls(
            name=name,
            ppv=ppv,
            fnr=fnr,
            ppv_interval=wilson_interval(c.n_true_positives, c.n_detections, confidence=confidence),
            fnr_interval=wilson_interval(c.n_missed, c.n_people, confidence=confidence),
            counts=c,
            confidence=confidence,
            metric=metric,
            gate=gate,
        )

    def to_model(self, model: DetectorModel) -> DetectorModel:
        """``model`` with this calibration's PPV and FNR (raises if either could not be measured).

        A measured 0 or 1 (no miss or no false positive seen) is clamped into
        ``[PROBABILITY_MARGIN, 1 - PROBABILITY_MARGIN]`` and logged: a DetectorModel at 0 or 1 would pin cells
        at 0 or 1 for good (see :class:`gridbridge.params.DetectorModel`).
        """
        if math.isnan(self.ppv) or math.isnan(self.fnr):
            raise ValueError(f"calibration of {self.name!r} has no detections or no people: cannot set PPV/FNR")
        values: dict[str, float] = {}
        for attr in ("ppv", "fnr"):
            v = float(getattr(self, attr))
            clamped = min(max(v, PROBABILITY_MARGIN), 1.0 - PROBABILITY_MARGIN)
            if clamped != v:
                log.warning(
                    "calibration of %s: measured %s = %.3g clamped to %.3g (at 0 or 1 a model pins cells for good)",
                    self.name,
                    attr.upper(),
                    v,
                    clamped,
                )
            values[attr] = clamped
        return replace(model, ppv=values["ppv"], fnr=values["fnr"])

    def summary(self) -> str:
        c = self.counts
        return (
            f"{self.name}: PPV {self.ppv:.3f} [{self.ppv_interval[0]:.3f}, {self.ppv_interval[1]:.3f}] "
            f"({c.n_true_positives}/{c.n_detections}), FNR {self.fnr:.3f} "
            f"[{self.fnr_interval[0]:.3f}, {self.fnr_interval[1]:.3f}] ({c.n_missed}/{c.n_people}), "
            f"{c.n_frames} frames"
        )


def _distances(
    det: NDArray[np.float64],
    truth: NDArray[np.float64],
    metric: str,
    model: DetectorModel | None,
) -> NDArray[np.float64]:
    diff = det[:, None, :] - truth[None, :, :]
    if metric == "euclidean":
        return np.hypot(diff[..., 0], diff[..., 1])
    assert model is not None
    origin = np.array([model.mount_x, model.mount_y])
    los = truth - origin
    u = los / np.maximum(np.hypot(los[:, 0], los[:, 1]), 1e-12)[:, None]
    along = diff[..., 0] * u[None, :, 0] + diff[..., 1] * u[None, :, 1]
    across = -diff[..., 0] * u[None, :, 1] + diff[..., 1] * u[None, :, 0]
    return np.hypot(along / model.sigma_range, across / model.sigma_lateral)


def match_detections(
    detections: ArrayLike,
    truth: ArrayLike,
    *,
    gate: float,
    metric: Literal["euclidean", "mahalanobis"] = "euclidean",
    model: DetectorModel | None = None,
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """One-to-one matching of detections to true people within a gate (most pairs, then minimum total distance).

    Parameters
    ----------
    detections : array_like, shape (M, 2)
        Detected positions (m), sensor frame.
    truth : array_like, shape (P, 2)
        True positions (m), same frame.
    gate : float
        Largest accepted distance: metres (``euclidean``) or standard deviations (``mahalanobis``).
    metric : {"euclidean", "mahalanobis"}
        Distance; ``mahalanobis`` uses ``model``'s line-of-sight Gaussian around each true person.
    model : DetectorModel, optional
        Needed for ``mahalanobis``.

    Returns
    -------
    det_index, truth_index : ndarray of int, shape (K,)
        Matched pairs.
    """
    det = check_positions(detections, "detections")
    tru = check_positions(truth, "truth")
    gate = check_positive(gate, "gate")
    if metric not in ("euclidean", "mahalanobis"):
        raise ValueError(f"metric must be 'euclidean' or 'mahalanobis', got {metric!r}")
    if metric == "mahalanobis" and model is None:
        raise ValueError("metric='mahalanobis' needs a model (its sigma_lateral / sigma_range)")
    dist = _distances(det, tru, metric, model)
    return assign_one_to_one(dist, dist <= gate)


def _in_view(model: DetectorModel | None, pts: NDArray[np.float64]) -> NDArray[np.bool_]:
    if model is None:
        return np.ones(pts.shape[0], dtype=bool)
    return in_field_of_view(model, pts)


def _in_region(region: GridSpec | None, pts: NDArray[np.float64]) -> NDArray[np.bool_]:
    if region is None:
        return np.ones(pts.shape[0], dtype=bool)
    return region.contains(pts[:, 0], pts[:, 1])


def _resolve_metric(
    metric: str, gate: float | None, model: DetectorModel | None
) -> tuple[Literal["euclidean", "mahalanobis"], float]:
    if metric == "auto":
        metric = "mahalanobis" if model is not None and model.uncertainty == "gaussian" else "euclidean"
    if metric not in ("euclidean", "mahalanobis"):
        raise ValueError(f"metric must be 'auto', 'euclidean' or 'mahalanobis', got {metric!r}")
    if gate is None:
        gate = DEFAULT_GATE_SIGMAS if metric == "mahalanobis" else DEFAULT_GATE_M
    return metric, check_positive(gate, "gate")  # type: ignore[return-value]


def frame_counts(
    detections: ArrayLike,
    truth: ArrayLike,
    *,
    model: DetectorModel | None = None,
    gate: float | None = None,
    metric: str = "auto",
    region: GridSpec | None = None,
) -> CalibrationCounts:
    """Counts of one frame (see :func:`calibrate_detector`)."""
    metric_, gate_ = _resolve_metric(metric, gate, model)
    det = check_positions(detections, "detections")
    tru = check_positions(truth, "truth")
    tru = tru[_in_view(model, tru)]
    di, ti = match_detections(det, tru, gate=gate_, metric=metric_, model=model)
    det_in = _in_region(region, det)
    tru_in = _in_region(region, tru)
    det_matched = np.zeros(det.shape[0], dtype=bool)
    det_matched[di] = True
    tru_matched = np.zeros(tru.shape[0], dtype=bool)
    tru_matched[ti] = True
    return CalibrationCounts(
        n_frames=1,
        n_detections=int(np.count_nonzero(det_in)),
        n_true_positives=int(np.count_nonzero(det_in & det_matched)),
        n_people=int(np.count_nonzero(tru_in)),
        n_detected_people=int(np.count_nonzero(tru_in & tru_matched)),
    )


def calibrate_detector(
    detections_per_frame: Sequence[ArrayLike],
    truth_per_frame: Sequence[ArrayLike],
    *,
    model: DetectorModel | None = None,
    gate: float | None = None,
    metric: Literal["auto", "euclidean", "mahalanobis"] = "auto",
    region: GridSpec | None = None,
    confidence: float = 0.95,
    name: str | None = None,
) -> CalibrationResult:
    """Measure one detector's PPV and FNR over frames with ground truth.

    Parameters
    ----------
    detections_per_frame : sequence of array_like, each shape (M_t, 2)
        The detector's positions (m) per frame, in the frame of ``truth`` (the grid's sensor frame).
    truth_per_frame : sequence of array_like, each shape (P_t, 2)
        True people positions (m) per frame; same length.
    model : DetectorModel, optional
        Field of view, range limits and mount (only people in view count) and, for ``mahalanobis``, the
        position uncertainty. None: every person counts.
    gate : float, optional
        Matching gate: metres (euclidean, default 0.5) or standard deviations (mahalanobis, default 3.0).
    metric : {"auto", "euclidean", "mahalanobis"}
        ``auto``: mahalanobis for a ``"gaussian"`` model, euclidean otherwise.
    region : GridSpec, optional
        Count only people and detections inside this grid.
    confidence : float
        Level of the Wilson intervals.
    name : str, optional
        Label; default the model's name.

    Returns
    -------
    CalibrationResult
    """
    if len(detections_per_frame) != len(truth_per_frame):
        raise ValueError(
            f"detections_per_frame and truth_per_frame must have the same length, got "
            f"{len(detections_per_frame)} and {len(truth_per_frame)}"
        )
    metric_, gate_ = _resolve_metric(metric, gate, model)
    total = CalibrationCounts(0, 0, 0, 0, 0)
    for t, (det, tru) in enumerate(zip(detections_per_frame, truth_per_frame, strict=True)):
        try:
            total = total + frame_counts(det, tru, model=model, gate=gate_, metric=metric_, region=region)
        except ValueError as exc:
            raise ValueError(f"frame {t}: {exc}") from exc
    label = name if name is not None else (model.name if model is not None else "detector")
    return CalibrationResult.from_counts(label, total, confidence=confidence, metric=metric_, gate=gate_)


def calibrate_sparse(
    detections: Mapping[int, ArrayLike],
    truth: Mapping[int, ArrayLike],
    *,
    n_frames: int | None = None,
    max_frames: int = MAX_CALIBRATION_FRAMES,
    **options: object,
) -> CalibrationResult:
    """:func:`calibrate_detector` over frames given by number; frames without rows are empty.

    Only the frames that have rows are matched (no list up to the largest frame number is built), and the
    frame range is checked first: a frame number above ``max_frames`` (typically a stamp written as a frame
    number) raises ``ValueError`` naming it.

    Parameters
    ----------
    detections, truth : mapping of int to array_like (M, 2)
        Positions (m) per frame number (>= 0).
    n_frames : int, optional
        Number of frames of the sequence (default: largest frame number + 1).
    max_frames : int
        Largest accepted frame range.
    **options
        Passed to :func:`calibrate_detector` (``model``, ``gate``, ``metric``, ``region``, ...).
    """
    keys = sorted(set(detections) | set(truth))
    if keys and keys[0] < 0:
        raise ValueError(f"frame numbers must be >= 0, got {keys[0]}")
    top = keys[-1] + 1 if keys else 0
    n = top if n_frames is None else int(n_frames)
    if n < top:
        raise ValueError(f"n_frames={n} is below the largest frame number + 1 ({top})")
    if n > max_frames:
        raise ValueError(
            f"frame numbers run up to {n - 1}, more than {max_frames} frames: frame numbers must be frame "
            "indices (0, 1, ...), not stamps"
        )
    empty = np.zeros((0, 2))
    dets = [detections.get(k, empty) for k in keys]
    tru = [truth.get(k, empty) for k in keys]
    res = calibrate_detector(dets, tru, **options)  # type: ignore[arg-type]
    c = res.counts
    counts = CalibrationCounts(n, c.n_detections, c.n_true_positives, c.n_people, c.n_detected_people)
    return CalibrationResult.from_counts(res.name, counts, confidence=res.confidence, metric=res.metric, gate=res.gate)


def calibrate_frames(
    frames: Iterable[object],
    models: Sequence[DetectorModel],
    *,
    gates: Mapping[str, float] | None = None,
    region: GridSpec | None = None,
    confidence: float = 0.95,
) -> dict[str, CalibrationResult]:
    """Calibrate every detector of simulated frames (:class:`evaluation.scenarios.Frame`) by matching.

    ``gates`` maps detector name to gate (units as :func:`calibrate_detector` with ``metric="auto"``); a name
    that is not one of ``models`` raises ``ValueError``. Frames are consumed once (works with a lazy
    :class:`~evaluation.scenarios.Scenario`).
    """
    gates = dict(gates or {})
    unknown = set(gates) - {m.name for m in models}
    if unknown:
        raise ValueError(f"gates names unknown detector(s) {sorted(unknown)}")
    resolved = {m.name: _resolve_metric("auto", gates.get(m.name), m) for m in models}
    totals = {m.name: CalibrationCounts(0, 0, 0, 0, 0) for m in models}
    for t, frame in enumerate(frames):
        detections = frame.detections  # type: ignore[attr-defined]
        people = frame.people  # type: ignore[attr-defined]
        if len(detections) != len(models):
            raise ValueError(f"frame {t}: has {len(detections)} detectors, models has {len(models)}")
        for model, det in zip(models, detections, strict=True):
            metric, gate = resolved[model.name]
            try:
                counts = frame_counts(det, people, model=model, gate=gate, metric=metric, region=region)
            except ValueError as exc:
                raise ValueError(f"frame {t}, detector {model.name!r}: {exc}") from exc
            totals[model.name] = totals[model.name] + counts
    return {
        m.name: CalibrationResult.from_counts(
            m.name, totals[m.name], confidence=confidence, metric=resolved[m.name][0], gate=resolved[m.name][1]
        )
        for m in models
    }


def oracle_calibration(
    frames: Iterable[object],
    *,
    region: GridSpec | None = None,
    confidence: float = 0.95,
) -> dict[str, CalibrationResult]:
    """PPV and FNR from the simulator's labels (no matching): the values matching should recover.

    A detection is a true positive when it came from a person (``source >= 0``); a person in view (occluded
    or not) counts as detected when some detection came from them. ``region`` restricts both counts to
    detections / people inside the grid (by their reported / true position).
    """
    totals: dict[str, CalibrationCounts] = {}
    for frame in frames:
        ids = frame.person_ids  # type: ignore[attr-defined]
        people = frame.people  # type: ignore[attr-defined]
        for out in frame.outputs:  # type: ignore[attr-defined]
            det_in = _in_region(region, check_positions(out.positions, "positions"))
            in_view = np.isin(ids, out.in_view_ids)
            tru_in = in_view & _in_region(region, people)
            found = np.isin(ids, out.source[out.source >= 0])
            counts = CalibrationCounts(
                1,
                int(np.count_nonzero(det_in)),
                int(np.count_nonzero(det_in & (out.source >= 0))),
                int(np.count_nonzero(tru_in)),
                int(np.count_nonzero(tru_in & found)),
            )
            totals[out.name] = totals.get(out.name, CalibrationCounts(0, 0, 0, 0, 0)) + counts
    return {
        name: CalibrationResult.from_counts(name, c, confidence=confidence, metric="labels", gate=0.0)
        for name, c in totals.items()
    }
