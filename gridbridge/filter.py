"""The reference grid filter of Batista & Pereira (2015): one recursive Bayes step per frame.

Per frame (Fig. 1 of the paper):

1. people-motion prediction, eqs. 5-9 (:func:`gridbridge.people_motion.predict_people`);
2. sensor-motion prediction, eqs. 10-11 (:func:`gridbridge.ego_motion.predict_sensor`);
3. detections -> per-detector maps -> De Morgan fusion, eqs. 13-14, and the Bayes update, eq. 12
   (:mod:`gridbridge.measurement`).

``form="paper"`` uses the paper's kernel and eq. 6 with eq. 8; ``form="linear"`` uses the integrated kernel
and the Chapman-Kolmogorov sum (the filter the particle filter estimates without bias).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge._validate import check_choice, check_positive, check_probability
from gridbridge.components import (
    Appearance,
    BeliefBounds,
    EgoMotionModel,
    LinearPrediction,
    PaperPrediction,
    PeoplePrediction,
    VelocityEgoMotion,
)
from gridbridge.ego_motion import Odometry
from gridbridge.grid import GridSpec
from gridbridge.likelihoods import DetectionLikelihood, update_components
from gridbridge.measurement import Likelihood, bayes_update, fov_mask
from gridbridge.params import PAPER_DETECTORS, DetectorModel, PeopleMotion, SensorMotionNoise

__all__ = ["BeliefFilter", "FilterStep", "GridFilter", "as_odometry", "filter_models"]


@dataclass(frozen=True, eq=False)
class FilterStep:
    """Every stage of one filter step (the panels d-j of the paper's Fig. 6). Grids are (nx, ny).

    Attributes
    ----------
    people_prior : ndarray
        After the people-motion prediction (Fig. 6d).
    sensor_prior : ndarray
        After the sensor-motion prediction (Fig. 6e): the prior of the update.
    fired, covered, detector_likelihoods : ndarray, shape (D, nx, ny)
        Per-detector firing maps, fields of view and P(D_i | p) (Fig. 6f-h).
    likelihood : ndarray
        Fused P(D_1..D_N | p) (Fig. 6i).
    posterior : ndarray
        bel(x_t = p) (Fig. 6j).
    """

    people_prior: NDArray[np.float64]
    sensor_prior: NDArray[np.float64]
    fired: NDArray[np.float64]
    covered: NDArray[np.bool_]
    detector_likelihoods: NDArray[np.float64]
    likelihood: NDArray[np.float64]
    posterior: NDArray[np.float64]


@runtime_checkable
class BeliefFilter(Protocol):
    """The one filter interface: :class:`GridFilter` and :class:`pfpeople.ParticleFilter` both follow it, and the
    pipeline, the A/B harness, the replay, the benchmark and the notebooks use filters only through it.

    ``belief`` is the current ``(nx, ny)`` posterior; ``reset(belief=None)`` restarts (from the initial belief or
    the one given); ``step(detections, odometry, dt)`` is one recursive Bayes step returning a
    :class:`FilterStep` (the stages of Fig. 6). Bad input raises ``ValueError`` naming it and changes nothing.
    """

    belief: NDArray[np.float64]

    def reset(self, belief: ArrayLike | None = None) -> None: ...

    def step(
        self,
        detections: Sequence[ArrayLike | None],
        odometry: Odometry | tuple[float, float] | None,
        dt: float,
    ) -> FilterStep: ...


def as_odometry(odometry: Odometry | tuple[float, float] | None) -> Odometry | None:
    """Accept ``Odometry``, a ``(v, omega)`` pair or ``None`` (robot standing)."""
    if odometry is None or isinstance(odometry, Odometry):
        return odometry
    try:
        v, omega = (float(c) for c in odometry)
    except (TypeError, ValueError):
        raise ValueError(f"odometry must be Odometry, a (v, omega) pair or None, got {odometry!r}") from None
    return Odometry(v=v, omega=omega)


def filter_models(
    spec: GridSpec | None,
    detectors: Sequence[DetectorModel],
    motion: PeopleMotion | None,
    noise: SensorMotionNoise | None,
) -> tuple[GridSpec, tuple[DetectorModel, ...], PeopleMotion, SensorMotionNoise]:
    """A filter's grid, detectors and models with the defaults filled in; ValueError naming a wrong type.

    Shared by :class:`GridFilter` and the particle filter, which take the same arguments.
    """
    spec_ = GridSpec() if spec is None else spec
    if not isinstance(spec_, GridSpec):
        raise ValueError(f"spec must be a GridSpec, got {type(spec).__name__}")
    dets = tuple(detectors)
    if not dets or not all(isinstance(d, DetectorModel) for d in dets):
        raise ValueError("detectors must be a non-empty sequence of DetectorModel")
    motion_ = PeopleMotion() if motion is None else motion
    if not isinstance(motion_, PeopleMotion):
        raise ValueError(f"motion must be a PeopleMotion, got {type(motion).__name__}")
    noise_ = SensorMotionNoise() if noise is None else noise
    if not isinstance(noise_, SensorMotionNoise):
        raise ValueError(f"noise must be a SensorMotionNoise, got {type(noise).__name__}")
    return spec_, dets, motion_, noise_


class GridFilter:
    """The paper's recursive Bayes filter on a local semantic grid, composed of components.

    One step: people-motion prediction -> sensor-motion prediction -> [appearance] -> De Morgan likelihood and
    Bayes update -> [bounds]. With neither appearance nor bounds it is the paper's filter, bit for bit.

    Parameters
    ----------
    spec : GridSpec
        The grid (default: the paper's 30 x 30 cells of 0.3 m).
    detectors : sequence of DetectorModel
        Detector models, in the order of the detections passed to :meth:`step`.
    motion : PeopleMotion
        People motion model (Table 1), used when ``prediction`` is not given.
    noise : SensorMotionNoise
        Odometry noise of the velocity motion model, used when ``ego_motion`` is not given.
    form : {"paper", "linear"}
        Shorthand for the people prediction when ``prediction`` is not given: ``"paper"`` ->
        :class:`~gridbridge.components.PaperPrediction` (paper kernel, eq. 8), ``"linear"`` ->
        :class:`~gridbridge.components.LinearPrediction` (integrated kernel). The kernel follows the form.
    initial : float
        Initial belief of every cell (0.5: nothing known).
    outside : float
        Belief outside the grid (0.5 in the paper), used by the default prediction and ego-motion.
    prediction : PeoplePrediction, optional
        The people-motion component (overrides ``form``, ``motion`` and ``outside`` for it).
    ego_motion : EgoMotionModel, optional
        The sensor-motion component (default :class:`~gridbridge.components.VelocityEgoMotion`).
    appearance : Appearance, optional
        Birth probability applied to the prior of the update (not in the paper).
    bounds : BeliefBounds, optional
        Clamp of the posterior (not in the paper).
    likelihood : DetectionLikelihood, optional
        Detections -> per-cell likelihood (default :class:`~gridbridge.likelihoods.DeMorganLikelihood`, eqs. 13-14).
    """

    def __init__(
        self,
        spec: GridSpec | None = None,
        *,
        detectors: Sequence[DetectorModel] = PAPER_DETECTORS,
        motion: PeopleMotion | None = None,
        noise: SensorMotionNoise | None = None,
        form: Literal["paper", "linear"] = "paper",
        initial: float = 0.5,
        outside: float = 0.5,
        prediction: PeoplePrediction | None = None,
        ego_motion: EgoMotionModel | None = None,
        appearance: Appearance | None = None,
        bounds: BeliefBounds | None = None,
        likelihood: DetectionLikelihood | None = None,
    ) -> None:
        self.spec, self.detectors, self.motion, self.noise = filter_models(spec, detectors, motion, noise)
        check_choice(form, "form", ("paper", "linear"))
        self.initial = check_probability(initial, "initial")
        self.outside = check_probability(outside, "outside")
        if prediction is None:
            cls = PaperPrediction if form == "paper" else LinearPrediction
            prediction = cls(motion=self.motion, outside=self.outside)
        if not isinstance(prediction, PeoplePrediction):
            raise TypeError(f"prediction must be a PeoplePrediction component, got {type(prediction).__name__}")
        if ego_motion is None:
            ego_motion = VelocityEgoMotion(noise=self.noise, outside=self.outside)
        if not isinstance(ego_motion, EgoMotionModel):
            raise TypeError(f"ego_motion must be an EgoMotionModel component, got {type(ego_motion).__name__}")
        self.likelihood, self.appearance, self.bounds = update_components(likelihood, appearance, bounds)
        self.prediction = prediction
        self.motion = prediction.motion
        self.form = str(getattr(prediction, "form", "custom"))
        self.ego_motion = ego_motion
        self.belief: NDArray[np.float64] = np.full(self.spec.shape, self.initial)
        self._observed: NDArray[np.bool_] | None = None

    @property
    def observed(self) -> NDArray[np.bool_]:
        """Cells in some detector's field of view, ``(nx, ny)`` bool."""
        if self._observed is None:
            self._observed = np.logical_or.reduce([fov_mask(self.spec, m) for m in self.detectors])
        return self._observed

    def reset(self, belief: ArrayLike | None = None) -> None:
        """Restart from ``belief`` (default: the initial belief everywhere)."""
        if belief is None:
            self.belief = np.full(self.spec.shape, self.initial)
        else:
            self.belief = self.spec.check_grid(belief, "belief").copy()

    def kernel(self, dt: float) -> NDArray[np.float64]:
        """The people-motion kernel used for a step of ``dt`` seconds."""
        return self.prediction.kernel(self.spec, dt)

    def predict(self, odometry: Odometry | tuple[float, float] | None, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Both predictions; returns ``(people_prior, prior)`` without changing the belief.

        ``prior`` is the sensor-motion prediction with appearances added (when the filter has an
        :class:`~gridbridge.components.Appearance`): the prior of the update.
        """
        dt = check_positive(dt, "dt")
        odo = as_odometry(odometry)
        people = self.prediction.predict(self.belief, self.spec, dt)
        sensor = self.ego_motion.predict(people, self.spec, odo, dt)
        if self.appearance is not None:
            sensor = self.appearance.apply(sensor, dt, where=self.observed)
        return people, sensor

    def update(
        self, prior: ArrayLike, detections: Sequence[ArrayLike | None]
    ) -> tuple[Likelihood, NDArray[np.float64]]:
        """Measurement update (eqs. 12-14) of ``prior`` (then the bounds); sets and returns the belief.

        Returns ``(likelihood, posterior)``; on bad input nothing changes.
        """
        prior_ = self.spec.check_grid(prior, "prior")
        lik = self.likelihood(self.spec, self.detectors, list(detections))
        posterior = bayes_update(prior_, lik.likelihood)
        if self.bounds is not None:
            posterior = self.bounds.apply(posterior)
        self.belief = posterior
        return lik, posterior

    def step(
        self,
        detections: Sequence[ArrayLike | None],
        odometry: Odometry | tuple[float, float] | None,
        dt: float,
    ) -> FilterStep:
        """One recursive Bayes step.

        Parameters
        ----------
        detections : sequence, one entry per detector
            ``(M_i, 2)`` person positions (x, y) in the grid's sensor frame (m), or ``None`` when detector i
            has no data this frame.
        odometry : Odometry, (v, omega) or None
            Robot controls over the step (m/s, rad/s); None: standing.
        dt : float
            Time since the previous frame (s), > 0.

        Returns
        -------
        FilterStep
            All stages; ``self.belief`` becomes the posterior. On bad input nothing changes.
        """
        people, sensor = self.predict(odometry, dt)
        lik, posterior = self.update(sensor, detections)
        return FilterStep(
            people_prior=people,
            sensor_prior=sensor,
            fired=lik.fired,
            covered=lik.covered,
            detector_likelihoods=lik.detector_likelihoods,
            likelihood=lik.likelihood,
            posterior=posterior,
        )
