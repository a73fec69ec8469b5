"""Building a run's filter, classifier and tracker from its configuration: the one place they are assembled.

:func:`build_filter` turns a :class:`pfpeople.config.FilterConfig` into a filter composed of components
(:mod:`gridbridge.components`, :mod:`gridbridge.likelihoods`), :func:`build_classifier` a
:class:`~pfpeople.config.ClassifierConfig` into a :class:`gridbridge.classifiers.Classifier`,
:func:`build_people_tracker` a :class:`~pfpeople.config.TrackingConfig` into the tracker and the people it
confirms (:class:`pfpeople.track.reported_people.PeopleTracker`), and :func:`grid_for_scan` gives the default grid of a
laser: the bounding box of its field of view.

Recommended mode (the product's default, chosen on ``pfpeople-eval benchmark`` across every scene; README
"Recommended mode"): linear people prediction (integrated kernel), appearance probability in observed cells,
beliefs bounded to ``[1e-4, belief_max]``, initial and border belief at the base rate, the calibrated
independent fusion of the detectors (:class:`gridbridge.likelihoods.IndependentLikelihood`) and laser detections
that fire the cells of the person's footprint (``laser_footprint``). Paper mode: Batista & Pereira as written.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from gridbridge.classifiers import BlobClassifier, Classifier, HysteresisPeaks, PeakClassifier, ThresholdClassifier
from gridbridge.components import Appearance, BeliefBounds, LinearPrediction, PaperPrediction, VelocityEgoMotion
from gridbridge.filter import GridFilter
from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from gridbridge.likelihoods import IndependentLikelihood
from gridbridge.params import DetectorModel, PeopleMotion
from pfpeople.config import ClassifierConfig, FilterConfig, TrackingConfig
from pfpeople.config.people import KIND_THRESHOLD

if TYPE_CHECKING:
    from pfpeople.particle.filter import ParticleFilter
    from pfpeople.track.reported_people import PeopleTracker

log = logging.getLogger(__name__)

__all__ = [
    "BELIEF_MIN",
    "PEAK_THRESHOLD",
    "build_classifier",
    "build_filter",
    "build_people_tracker",
    "grid_for_scan",
]

#: Lower bound of the belief in the recommended mode.
BELIEF_MIN = 1e-4
#: The peaks classifier's default threshold (:data:`pfpeople.config.people.KIND_THRESHOLD`).
PEAK_THRESHOLD = KIND_THRESHOLD["peaks"]


def grid_for_scan(
    angle_min: float,
    angle_max: float,
    range_max: float,
    *,
    mount: Pose2D | None = None,
    resolution: float,
    reach: float,
) -> GridSpec:
    """The grid covering a laser's field of view out to ``min(range_max, reach)``, in the grid frame.

    Parameters
    ----------
    angle_min, angle_max : float
        The scan's bearing range (rad, laser frame).
    range_max : float
        The scan's largest range (m); non-finite or non-positive values use ``reach``.
    mount : Pose2D, optional
        The laser's pose in the grid frame (identity when the grid is the laser's frame).
    resolution : float
        Cell side (m; ``[grid] resolution``).
    reach : float
        The grid reaches this far from the laser where its ``range_max`` is farther (m; ``[grid] max_range``).

    Returns
    -------
    GridSpec
        Axis-aligned bounding box of the sector (and the laser itself), snapped outwards to whole cells.
    """
    if not (math.isfinite(angle_min) and math.isfinite(angle_max) and angle_min < angle_max):
        raise ValueError(f"laser angles must be finite with angle_min < angle_max, got {angle_min}, {angle_max}")
    r = min(range_max, reach) if math.isfinite(range_max) and range_max > 0 else reach
    span = min(angle_max - angle_min, 2 * math.pi)
    a = angle_min + np.linspace(0.0, span, 721)
    pts = np.vstack(([0.0, 0.0], np.column_stack((r * np.cos(a), r * np.sin(a)))))
    if mount is not None:
        pts = mount.apply(pts)
    # whole cells outwards; 1e-6 cells of slack so that round-off (cos 90 deg = 6e-17) adds no cell
    i0 = math.floor(pts[:, 0].min() / resolution + 1e-6)
    j0 = math.floor(pts[:, 1].min() / resolution + 1e-6)
    i1 = math.ceil(pts[:, 0].max() / resolution - 1e-6)
    j1 = math.ceil(pts[:, 1].max() / resolution - 1e-6)
    return GridSpec(
        nx=max(i1 - i0, 1),
        ny=max(j1 - j0, 1),
        resolution=resolution,
        x0=round(i0 * resolution, 9),
        y0=round(j0 * resolution, 9),
    )


def recommended_models(config: FilterConfig, models: Sequence[DetectorModel]) -> tuple[DetectorModel, ...]:
    """The detector models of the recommended mode: laser (point) detections fire the person's footprint."""
    if config.mode != "recommended":
        return tuple(models)
    return tuple(
        replace(m, footprint_radius=max(m.footprint_radius, config.laser_footprint)) if m.uncertainty == "point" else m
        for m in models
    )


def build_filter(
    config: FilterConfig, spec: GridSpec, detectors: Sequence[DetectorModel]
) -> GridFilter | ParticleFilter:
    """The filter of ``config`` on ``spec`` for ``detectors`` (a :class:`gridbridge.GridFilter` or a
    :class:`pfpeople.ParticleFilter`; both follow the same ``step``/``reset``/``belief`` interface)."""
    if not isinstance(config, FilterConfig):
        raise TypeError(f"config must be a FilterConfig, got {type(config).__name__}")
    models = recommended_models(config, detectors)
    kwargs: dict[str, Any] = {"initial": config.initial_belief}
    if config.mode == "paper":
        _warn_paper_fnr(models)
        outside = 0.5
    else:
        outside = config.base_rate
        kwargs |= {
            "outside": outside,
            "appearance": Appearance(rate=config.appearance_rate),
            "bounds": BeliefBounds(low=BELIEF_MIN, high=config.belief_max),
            "likelihood": IndependentLikelihood(base_rate=outside),
        }
    if config.kind == "grid":
        pred = (PaperPrediction if config.form == "paper" else LinearPrediction)(motion=PeopleMotion(), outside=outside)
        ego = VelocityEgoMotion(outside=outside)
        return GridFilter(spec, detectors=models, prediction=pred, ego_motion=ego, **kwargs)
    return _particle_filter(config, spec, models, kwargs)


def _warn_paper_fnr(models: Sequence[DetectorModel]) -> None:
    high = [m.name for m in models if m.fnr >= 0.5]
    if high:
        log.warning(
            "paper mode with detectors %s of FNR >= 0.5: in the paper's update (P(D|np) = 1 - P(D|p)) a "
            "non-detection then raises the belief; give them the paper's values or use the recommended mode",
            high,
        )


def _particle_filter(
    config: FilterConfig, spec: GridSpec, models: Sequence[DetectorModel], kwargs: dict[str, Any]
) -> ParticleFilter:
    """The particle filter of ``config`` (it samples the integrated people-motion kernel whatever ``form``)."""
    from pfpeople.particle.filter import ParticleFilter
    from pfpeople.particle.predictor import PEOPLE_SAMPLERS, PaperSampling, PersistentSampling
    from pfpeople.particle.resampler import Resampling

    sampler = PEOPLE_SAMPLERS[config.motion_model]
    people: PaperSampling | PersistentSampling
    if sampler is PersistentSampling:
        people = PersistentSampling(motion=PeopleMotion(), compiled_draws=config.compiled_draws)
    else:
        people = sampler(motion=PeopleMotion())
    return ParticleFilter(
        spec,
        detectors=models,
        n_particles=config.particles_for(spec.n_cells),
        rng=np.random.default_rng(config.seed),
        people_motion=people,
        resampling=Resampling(max_overflow=config.max_overflow),
        **kwargs,
    )


def build_people_tracker(tracking: TrackingConfig, classifier: Any) -> PeopleTracker | None:
    """The multi-person tracker of ``tracking`` on ``classifier``'s people (a
    :class:`pfpeople.track.reported_people.PeopleTracker`), or None when tracking is off.

    With ``peak_threshold`` feeding the tracker weaker peaks, tracks start only from the classifier's people:
    ``birth_min_score`` is the classifier's threshold unless ``tracking.params`` gives it. Tracks are confirmed by
    their evidence (``tracking.confirm_evidence``) unless ``tracking.params`` gives ``confirm_evidence`` or it is
    ``"off"``.

    Raises
    ------
    ValueError
        A ``[tracking.params]`` entry that is not a :class:`pfpeople.track.TrackerConfig` field or is invalid.
    """
    if not tracking.enabled:
        return None
    from pfpeople.track import TrackerConfig
    from pfpeople.track.reported_people import PeopleTracker

    params = dict(tracking.params)
    if tracking.confirm_evidence != "off":
        params.setdefault("confirm_evidence", float(tracking.confirm_evidence))
    high = getattr(classifier, "threshold", None)
    if tracking.peaks_above is not None and high is not None:
        params.setdefault("birth_min_score", float(high))
    try:
        config = TrackerConfig(**params)
    except TypeError as exc:
        raise ValueError(f"[tracking.params]: {exc}") from None
    base = getattr(classifier, "peaks", classifier)
    return PeopleTracker(
        classifier,
        config=config,
        peak_threshold=tracking.peaks_above,
        people=tracking.people,
        coast_frames=tracking.coast_frames,
        min_separation=float(getattr(base, "min_separation", 0.6)),
        use_support=tracking.single_legs,
        snap_radius=float(tracking.snap_radius),
        static_confirm_s=float(tracking.static_confirm_s),
        observed_tracks_only=tracking.observed_tracks_only,
        see_through=tracking.see_through,
    )


def build_classifier(config: ClassifierConfig) -> Classifier | HysteresisPeaks:
    """The classifier of ``config``: peaks (with hysteresis where ``keep`` is below ``threshold``), the paper's
    blobs, or a threshold."""
    if config.kind == "blobs":
        return BlobClassifier()
    if config.kind == "threshold":
        return ThresholdClassifier(threshold=config.threshold)
    thr = config.threshold
    if config.keep >= thr:
        return PeakClassifier(threshold=thr, min_separation=config.min_separation, smooth=config.smooth)
    return HysteresisPeaks(threshold=thr, keep=config.keep, min_separation=config.min_separation, smooth=config.smooth)
