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
from dataclasses import dataclass, replace
from typing import Literal, NamedTuple, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

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
from gridbridge.limits import check_dt, check_grid_size, check_memory
from gridbridge.measurement import Likelihood, bayes_update, fov_mask
from gridbridge.params import PAPER_DETECTORS, DetectorModel, PeopleMotion, SensorMotionNoise
from gridbridge.people_motion import check_people_step
from gridbridge.validation import check_choice, check_number, check_probability

__all__ = ["BeliefFilter", "FilterStep", "GridFilter", "Prediction", "as_odometry", "filter_models", "remounted"]


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


class Prediction(NamedTuple):
    """The two prediction stages of one filter step (Fig. 6d-e), ``(nx, ny)`` each.

    Attributes
    ----------
    people_prior : ndarray
        After the people-motion prediction (eqs. 5-9).
    sensor_prior : ndarray
        After the sensor-motion prediction (eqs. 10-11): the prior of the update, as
        :attr:`FilterStep.sensor_prior` records it.
    """

    people_prior: NDArray[np.float64]
    sensor_prior: NDArray[np.float64]


@runtime_checkable
class BeliefFilter(Protocol):
    """The one filter interface: :class:`GridFilter` and :class:`pfpeople.ParticleFilter` both follow it, and the
    pipeline, the A/B harness, the replay, the benchmark and the notebooks use filters only through it.

    ``belief`` is the current ``(nx, ny)`` belief; ``reset(belief=None)`` restarts (from the initial belief or
    the one given). One recursive Bayes step is ``predict(odometry, dt)`` (both predictions, eqs. 5-11: the belief
    becomes the prior bel-bar, returned as a :class:`Prediction`) then ``update(detections)`` (eqs. 12-14: the
    belief becomes the posterior; returns the :class:`FilterStep` of the whole step, the stages of Fig. 6).
    ``step(detections, odometry, dt)`` is the two in one call, with the same result bit for bit. ``update``
    without a ``predict`` before it updates the current belief (a step of zero length). Bad input raises
    ``ValueError`` naming it and changes nothing.
    """

    belief: NDArray[np.float64]

    def reset(self, belief: ArrayLike | None = None) -> None: ...

    def predict(self, odometry: Odometry | tuple[float, float] | None, dt: float) -> Prediction: ...

    def update(self, detections: Sequence[ArrayLike | None]) -> FilterStep: ...

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
        if isinstance(odometry, str | bytes):
            raise TypeError("a string is not a pair")
        v, omega = odometry
    except (TypeError, ValueError):
        raise ValueError(f"odometry must be Odometry, a (v, omega) pair or None, got {odometry!r}") from None
    return Odometry(v=check_number(v, "odometry v"), omega=check_number(omega, "odometry omega"))


def remounted(
    detectors: Sequence[DetectorModel], mounts: Sequence[tuple[float, float, float]]
) -> tuple[DetectorModel, ...]:
    """``detectors`` with the mounts ``(mount_x, mount_y, mount_yaw)`` (one per detector; ValueError otherwise)."""
    if len(mounts) != len(detectors):
        raise ValueError(f"mounts must give one (x, y, yaw) per detector ({len(detectors)}), got {len(mounts)}")
    out = []
    for d, (x, y, yaw) in zip(detectors, mounts, strict=True):
        same = (d.mount_x, d.mount_y, d.mount_yaw) == (x, y, yaw)
        out.append(d if same else replace(d, mount_x=x, mount_y=y, mount_yaw=yaw))
    return tuple(out)


def with_fields_of_view(
    detectors: Sequence[DetectorModel], views: Sequence[tuple[float, float]]
) -> tuple[DetectorModel, ...]:
    """``detectors`` with the fields of view ``(fov_min, fov_max)`` (rad; one per detector, ValueError otherwise; a
    detector whose view is unchanged is kept as it is)."""
    if len(views) != len(detectors):
        raise ValueError(f"views must give one (fov_min, fov_max) per detector ({len(detectors)}), got {len(views)}")
    out = []
    for d, (lo, hi) in zip(detectors, views, strict=True):
        same = (d.fov_min, d.fov_max) == (lo, hi)
        out.append(d if same else replace(d, fov_min=lo, fov_max=hi))
    return tuple(out)


def filter_models(
    spec: GridSpec | None,
    detectors: Sequence[DetectorModel],
    motion: PeopleMotion | None,
    noise: SensorMotionNoise | None,
) -> tuple[GridSpec, tuple[DetectorModel, ...], PeopleMotion, SensorMotionNoise]:
    """A filter's grid, detectors and models with the defaults filled in; TypeError naming a wrong type,
    ValueError for no detectors.

    Shared by :class:`GridFilter` and the particle filter, which take the same arguments.
    """
    spec_ = GridSpec() if spec is None else spec
    if not isinstance(spec_, GridSpec):
        raise TypeError(f"spec must be a GridSpec, got {type(spec).__name__}")
    dets = tuple(detectors)
    if not dets:
        raise ValueError("detectors must be a non-empty sequence of DetectorModel")
    if not all(isinstance(d, DetectorModel) for d in dets):
        raise TypeError("detectors must be a non-empty sequence of DetectorModel")
    motion_ = PeopleMotion() if motion is None else motion
    if not isinstance(motion_, PeopleMotion):
        raise TypeError(f"motion must be a PeopleMotion, got {type(motion).__name__}")
    noise_ = SensorMotionNoise() if noise is None else noise
    if not isinstance(noise_, SensorMotionNoise):
        raise TypeError(f"noise must be a SensorMotionNoise, got {type(noise).__name__}")
    return spec_, dets, motion_, noise_


def check_filter_size(spec: GridSpec, motion: PeopleMotion, n_detectors: int, *, where: str) -> None:
    """The limits a run's configuration is held to (:func:`pfpeople.config.check_run_limits`), for a filter built in
    the library: the prediction's work at the motion's own step (``motion.dt``) and the memory of the grid's arrays
    (:mod:`gridbridge.limits`); a step of another ``dt`` is checked when its kernel is made
    (:func:`gridbridge.people_motion.people_motion_kernel`)."""
    check_grid_size(spec.nx, spec.ny, spec.resolution, v_max=motion.v_max, dt=motion.dt, where=where)
    check_memory(spec.n_cells, n_detectors=n_detectors, where=where)


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
        check_filter_size(self.spec, self.motion, len(self.detectors), where="GridFilter")
        self.form = str(getattr(prediction, "form", "custom"))
        self.ego_motion = ego_motion
        self.belief: NDArray[np.float64] = np.full(self.spec.shape, self.initial)
        self._observed: NDArray[np.bool_] | None = None
        #: The people prior of a :meth:`predict` not yet followed by :meth:`update`.
        self._people_prior: NDArray[np.float64] | None = None

    def set_detector_mounts(self, mounts: Sequence[tuple[float, float, float]]) -> None:
        """Move the detectors: ``(mount_x, mount_y, mount_yaw)`` per detector (m, rad; a panning laser's mount
        at this frame). Their fields of view follow from the next update."""
        self.detectors = remounted(self.detectors, mounts)
        self._observed = None

    def set_detector_fields_of_view(self, views: Sequence[tuple[float, float]]) -> None:
        """Narrow or restore the detectors' fields of view: ``(fov_min, fov_max)`` per detector (rad; what a laser's
        scan covered in this frame, :mod:`pfpeople.detect.coverage`). Cells outside get no update from the next one."""
        self.detectors = with_fields_of_view(self.detectors, views)
        self._observed = None

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
        self._people_prior = None

    def kernel(self, dt: float) -> NDArray[np.float64]:
        """The people-motion kernel used for a step of ``dt`` seconds."""
        return self.prediction.kernel(self.spec, dt)

    def predict(self, odometry: Odometry | tuple[float, float] | None, dt: float) -> Prediction:
        """Both predictions (eqs. 5-11); the belief becomes the prior of the update.

        The prior is the sensor-motion prediction with appearances added (when the filter has an
        :class:`~gridbridge.components.Appearance`). Arguments as in :meth:`step`; on bad input nothing changes.

        Returns
        -------
        Prediction
            ``(people_prior, sensor_prior)``, ``(nx, ny)`` each; ``sensor_prior`` is the new ``belief``.
        """
        dt = check_dt(dt)  # a number in (0, MAX_DT_S], before anything is allocated
        check_people_step(self.spec, self.motion, dt)
        odo = as_odometry(odometry)
        people = self.prediction.predict(self.belief, self.spec, dt)
        sensor = self.ego_motion.predict(people, self.spec, odo, dt)
        if self.appearance is not None:
            sensor = self.appearance.apply(sensor, dt, where=self.observed)
        self.belief = sensor
        self._people_prior = people
        return Prediction(people, sensor)

    def update(self, detections: Sequence[ArrayLike | None]) -> FilterStep:
        """Measurement update (eqs. 12-14) of the belief (the prior), then the bounds; sets the posterior.

        Without a :meth:`predict` since the last update the current belief is the prior (and both priors of the
        returned record). ``detections`` as in :meth:`step`; on bad input nothing changes.

        Returns
        -------
        FilterStep
            The stages of the step (the priors of the last :meth:`predict`).
        """
        return self._update(self.likelihood(self.spec, self.detectors, list(detections)))

    def _update(self, lik: Likelihood) -> FilterStep:
        prior = self.belief
        people = prior if self._people_prior is None else self._people_prior
        posterior = bayes_update(prior, lik.likelihood)
        if self.bounds is not None:
            posterior = self.bounds.apply(posterior)
        self.belief = posterior
        self._people_prior = None
        return FilterStep(
            people_prior=people,
            sensor_prior=prior,
            fired=lik.fired,
            covered=lik.covered,
            detector_likelihoods=lik.detector_likelihoods,
            likelihood=lik.likelihood,
            posterior=posterior,
        )

    def step(
        self,
        detections: Sequence[ArrayLike | None],
        odometry: Odometry | tuple[float, float] | None,
        dt: float,
    ) -> FilterStep:
        """One recursive Bayes step: :meth:`predict` then :meth:`update`.

        Parameters
        ----------
        detections : sequence, one entry per detector
            ``(M_i, 2)`` person positions (x, y) in the grid's sensor frame (m), ``(M_i, 3)`` with each detection's
            own PPV in the third column (:func:`gridbridge.measurement.split_detections`), or ``None`` when
            detector i has no data this frame.
        odometry : Odometry, (v, omega) or None
            Robot controls over the step (m/s, rad/s); None: standing.
        dt : float
            Time since the previous frame (s), in (0, :data:`gridbridge.limits.MAX_DT_S`] (10 s).

        Returns
        -------
        FilterStep
            All stages; ``self.belief`` becomes the posterior. On bad input nothing changes (the detections are
            checked before the prediction).
        """
        check_dt(dt)  # before the likelihoods are computed
        lik = self.likelihood(self.spec, self.detectors, list(detections))
        self.predict(odometry, dt)
        return self._update(lik)
