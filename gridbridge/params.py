"""Model parameters as frozen, keyword-only dataclasses; defaults are the paper's Table 1.

Batista & Pereira (2015), Table 1:

=================  ========
mu                 1.46 m/s
sigma              0.63 m/s
p_stationary       0.85
dt                 0.1 s
PPV / FNR det. 1   0.95 / 0.30   (laser, Bellotto & Hu 2009)
PPV / FNR det. 2   0.50 / 0.40   (laser, Spinello & Siegwart 2008)
PPV / FNR det. 3   0.95 / 0.50   (camera, Dollar et al. 2014)
=================  ========

One model, two forms: :class:`PeopleMotion` is used by the grid (as a kernel, see
:mod:`gridbridge.people_motion`) and by the particles (as a sampler); :class:`DetectorModel` is used by
both filters' shared likelihood code (:mod:`gridbridge.measurement`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Literal

from gridbridge.validation import check_finite, check_positive, check_probability, check_real

__all__ = [
    "CALIBRATED_LASER_DETECTORS",
    "LEGACY_DETECTOR_NAMES",
    "PAPER_DETECTORS",
    "DetectorModel",
    "PeopleMotion",
    "SensorMotionNoise",
    "current_detector_name",
]

#: Usain Bolt's average speed over his 100 m world record (100 m / 9.58 s), the paper's bound on human speed.
BOLT_AVERAGE_SPEED = 100.0 / 9.58


@dataclass(frozen=True, kw_only=True)
class PeopleMotion:
    """People motion model (eqs. 7-9 and the p_k model of Sect. 3.1.1).

    A person stays in place with probability ``p_stationary``; otherwise they walk for ``dt`` at a speed
    drawn from N(mu, sigma) truncated to [0, v_max], in a uniformly distributed direction.

    Parameters
    ----------
    mu, sigma : float
        Mean and standard deviation of walking speed (m/s); Daamen & Hoogendoorn (2007).
    p_stationary : float
        Probability that a person does not move between two frames.
    dt : float
        Default time step (s); a filter step may pass its own.
    v_max : float
        Largest human speed (m/s); it bounds the neighbourhood G of eqs. 8-9. The paper takes the average
        speed of the fastest athlete, 100 m / 9.58 s = 10.44 m/s.
    """

    mu: float = 1.46
    sigma: float = 0.63
    p_stationary: float = 0.85
    dt: float = 0.1
    v_max: float = BOLT_AVERAGE_SPEED

    def __post_init__(self) -> None:
        check_positive(self.mu, "PeopleMotion.mu", allow_zero=True)
        check_positive(self.sigma, "PeopleMotion.sigma")
        check_probability(self.p_stationary, "PeopleMotion.p_stationary")
        check_positive(self.dt, "PeopleMotion.dt")
        check_positive(self.v_max, "PeopleMotion.v_max")


@dataclass(frozen=True, kw_only=True)
class DetectorModel:
    """One people detector: its confidence (PPV, FNR), field of view and position uncertainty.

    Parameters
    ----------
    name : str
        Human-readable name, used in tables and figures.
    ppv : float
        Precision: P(D_i | p) where the detector fires (Sect. 3.2). In (0, 1): with ``ppv = 1`` a cell the
        detector fires on becomes certain (P(D|np) = 0) and no later evidence can lower it; with ``ppv = 0``
        it becomes 0 and can never rise again, in both filters.
    fnr : float
        False-negative rate: P(D_i | p) where it does not fire. In (0, 1) for the same reason: ``fnr = 0``
        (a detector that never misses) sets every covered cell it does not fire on to 0 for good.
    fov_min, fov_max : float
        Bearing range of the field of view (rad, counter-clockwise from the detector's x axis).
    max_range : float
        Largest range (m) at which the detector sees people; ``inf`` for unbounded.
    min_range : float
        Smallest range (m) at which it sees people.
    mount_x, mount_y, mount_yaw : float
        Pose of the detector's sensor in the grid's sensor frame (m, m, rad); zero for the laser itself.
    uncertainty : {"point", "gaussian"}
        ``"point"``: a detection marks the cell that contains it (plus cells whose centre lies within
        ``footprint_radius``). ``"gaussian"``: a detection marks cells with weight
        ``exp(-d^T S^-1 d / 2)`` for the Gaussian of ``sigma_lateral`` / ``sigma_range`` aligned with the
        detection's bearing (see :func:`gridbridge.measurement.detection_map`).
    footprint_radius : float
        Radius (m) around a point detection whose cell centres are also marked.
    sigma_lateral, sigma_range : float
        Standard deviations (m) of a ``"gaussian"`` detection across and along the line of sight.
    """

    name: str
    ppv: float
    fnr: float
    fov_min: float = -math.pi / 2
    fov_max: float = math.pi / 2
    max_range: float = math.inf
    min_range: float = 0.0
    mount_x: float = 0.0
    mount_y: float = 0.0
    mount_yaw: float = 0.0
    uncertainty: Literal["point", "gaussian"] = "point"
    footprint_radius: float = 0.0
    sigma_lateral: float = 1.0
    sigma_range: float = 1.7

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"DetectorModel.name must be a non-empty string, got {self.name!r}")
        for attr in ("ppv", "fnr"):
            value = check_real(getattr(self, attr), f"DetectorModel({self.name}).{attr}")
            check_probability(value, f"DetectorModel({self.name}).{attr}")
            if value in (0.0, 1.0):
                raise ValueError(
                    f"DetectorModel({self.name}).{attr} must be strictly between 0 and 1, got {value!r}: at 0 or 1 "
                    "a cell's belief reaches 0 or 1 and no later evidence can move it (Bayes' rule multiplies by "
                    "it), in both filters; use a small margin such as 0.01 / 0.99 for a near-perfect detector"
                )
        check_finite(self.fov_min, f"DetectorModel({self.name}).fov_min")
        check_finite(self.fov_max, f"DetectorModel({self.name}).fov_max")
        if not self.fov_min < self.fov_max or self.fov_max - self.fov_min > 2 * math.pi + 1e-12:
            raise ValueError(
                f"DetectorModel({self.name}): need fov_min < fov_max and a span of at most 2 pi, "
                f"got fov_min={self.fov_min!r}, fov_max={self.fov_max!r}"
            )
        if math.isnan(self.max_range) or self.max_range <= 0:
            raise ValueError(f"DetectorModel({self.name}).max_range must be positive, got {self.max_range!r}")
        check_positive(self.min_range, f"DetectorModel({self.name}).min_range", allow_zero=True)
        if self.min_range >= self.max_range:
            raise ValueError(f"DetectorModel({self.name}): min_range must be below max_range")
        for attr in ("mount_x", "mount_y", "mount_yaw"):
            check_finite(getattr(self, attr), f"DetectorModel({self.name}).{attr}")
        if self.uncertainty not in ("point", "gaussian"):
            raise ValueError(
                f"DetectorModel({self.name}).uncertainty must be 'point' or 'gaussian', got {self.uncertainty!r}"
            )
        check_positive(self.footprint_radius, f"DetectorModel({self.name}).footprint_radius", allow_zero=True)
        check_positive(self.sigma_lateral, f"DetectorModel({self.name}).sigma_lateral")
        check_positive(self.sigma_range, f"DetectorModel({self.name}).sigma_range")


#: The paper's three detectors (Table 1): two lasers with a 180 deg field of view, one camera with 62 deg.
PAPER_DETECTORS: tuple[DetectorModel, ...] = (
    DetectorModel(name="laser_legs", ppv=0.95, fnr=0.30),
    DetectorModel(name="laser_boosted", ppv=0.50, fnr=0.40),
    DetectorModel(
        name="camera_hog",
        ppv=0.95,
        fnr=0.50,
        fov_min=-math.radians(31.0),
        fov_max=math.radians(31.0),
        uncertainty="gaussian",
        sigma_lateral=1.0,
        sigma_range=1.7,
    ),
)


#: The built-in laser detectors (:class:`pfpeople.detect.LegDetector`, ``BoostedSegmentDetector``,
#: ``SingleLegDetector``) with PPV and FNR measured on every labelled recording we have, pooled (2026-12-02, the
#: boosted model on the segments' shape and context features, trained on the leg_tracker bags and the simulated
#: bags of ``make model``): ``pfpeople-eval calibrate --run`` on the scan-level scenes lobby / wheelchair / corridor
#: / crowd (2 cm range noise, seed 0), on the real negative_2 (its three lasers in one run: nobody there, every
#: detection is false) and, FNR only, on the real person_following_outdoor_1. PPV is the pooled count of true over
#: all detections of the four scenes and negative_2 (legs 3266 / 6090 = 0.54, boosted 6252 / 6824 = 0.92, single
#: legs 3773 / 6231 = 0.61; the scenes alone 0.72 / 0.95 / 0.68). FNR is the mean of the scenes' pooled miss rate
#: and the real one (legs 0.83 and 0.54: 0.69; boosted 0.67 and 0.18: 0.42; single legs 0.80 and 0.93: 0.87).
#: Table 1's values (0.95 / 0.30 and 0.50 / 0.40) are the paper's detectors, not these. Field of view and range
#: come from the LaserScan in a run (see :mod:`pfpeople.pipeline.runner`).
CALIBRATED_LASER_DETECTORS: tuple[DetectorModel, ...] = (
    DetectorModel(name="laser_legs", ppv=0.54, fnr=0.69),
    DetectorModel(name="laser_boosted", ppv=0.92, fnr=0.42),
    DetectorModel(name="laser_single_legs", ppv=0.61, fnr=0.87),
)


#: The default detector names of earlier versions (not valid ROS names, so result bags renamed their topics)
#: -> today's (:func:`current_detector_name`).
LEGACY_DETECTOR_NAMES: dict[str, str] = {
    "laser-legs": "laser_legs",
    "laser-boosted": "laser_boosted",
    "laser-single-legs": "laser_single_legs",
    "camera-hog": "camera_hog",
}


def current_detector_name(name: str) -> str:
    """Today's name of a default detector name of earlier versions, else ``name`` unchanged.

    The old defaults (:data:`LEGACY_DETECTOR_NAMES`) and their forms on other lasers, ``NAME:TOPIC``
    (``laser-legs:rear_scan``), become valid ROS names: ``laser_legs`` and ``laser_legs_rear_scan`` (every
    character of the topic but ``[A-Za-z0-9_]`` as ``_``), the names result bags gave their detection topics.
    """
    base, sep, topic = name.partition(":")
    if base not in LEGACY_DETECTOR_NAMES or (sep and not topic):
        return name
    new = LEGACY_DETECTOR_NAMES[base]
    return f"{new}_{re.sub(r'[^A-Za-z0-9_]', '_', topic.lstrip('/'))}" if sep else new


@dataclass(frozen=True, kw_only=True)
class SensorMotionNoise:
    """Noise of Thrun's velocity motion model (Probabilistic Robotics, Table 5.3).

    The executed controls are ``v_hat = v + e1``, ``w_hat = w + e2`` and a final rotation
    ``gamma_hat = e3`` with zero-mean Gaussians of variance

        var(e1) = alpha1 v^2 + alpha2 w^2,  var(e2) = alpha3 v^2 + alpha4 w^2,
        var(e3) = alpha5 v^2 + alpha6 w^2.

    The paper gives no values; the defaults are a modest wheeled-robot odometry (about 5 % speed error).
    All zero means noise-free ego-motion.
    """

    alpha1: float = 0.0025
    alpha2: float = 0.0005
    alpha3: float = 0.0005
    alpha4: float = 0.0025
    alpha5: float = 0.0005
    alpha6: float = 0.0005

    def __post_init__(self) -> None:
        for k in range(1, 7):
            check_positive(getattr(self, f"alpha{k}"), f"SensorMotionNoise.alpha{k}", allow_zero=True)

    @classmethod
    def noiseless(cls) -> SensorMotionNoise:
        return cls(alpha1=0.0, alpha2=0.0, alpha3=0.0, alpha4=0.0, alpha5=0.0, alpha6=0.0)

    def variances(self, v: Any, w: Any) -> tuple[Any, Any, Any]:
        """Variances of (v_hat, w_hat, gamma_hat) for controls ``v`` (m/s), ``w`` (rad/s): floats or arrays."""
        v2, w2 = v * v, w * w
        return (
            self.alpha1 * v2 + self.alpha2 * w2,
            self.alpha3 * v2 + self.alpha4 * w2,
            self.alpha5 * v2 + self.alpha6 * w2,
        )
