"""Filter components: the parts a grid (or particle) filter is composed of, as small objects.

A filter step is ``prediction (people, ego-motion) -> appearance -> likelihood -> update -> bounds``
(see :class:`gridbridge.filter.GridFilter`). Each part is an object chosen by composition, not a string:

========================  =========================================================================
component                 what it does
========================  =========================================================================
:class:`PaperPrediction`  people motion, eqs. 5-9: the paper's speed-density kernel with eq. 8's
                          colonisation (``P = S / (1 + S)``); the kernel belongs to the prediction
:class:`LinearPrediction` people motion as the Chapman-Kolmogorov sum with the integrated kernel (sums
                          to 1: nothing leaks); what the particle filter samples without bias
:class:`VelocityEgoMotion` sensor motion, eqs. 10-11: expected bilinear warp over sigma points of
                          Thrun's velocity motion model (:func:`gridbridge.ego_motion.predict_sensor`)
:class:`Appearance`       people appearing: ``bel' <- bel' + b (1 - bel')`` with ``b = 1 - exp(-rate dt)``
                          per cell (a birth probability; not in the paper)
:class:`BeliefBounds`     bounded log-odds: the posterior is clamped to ``[low, high]`` (occupancy
                          mapping's clamping; not in the paper)
========================  =========================================================================

Each component owns both of its forms: the numpy reference (the public functions of :mod:`gridbridge.people_motion`
and :mod:`gridbridge.ego_motion`) and the compiled one (:mod:`gridbridge.kernels`; the motion kernel of a step computed
once per component, resolution and step), chosen by :func:`gridbridge.jit.enabled`: the same results (bit for bit,
``tests/gridbridge/test_components.py``). A component of your own needs only the protocol's methods.

Because a kernel belongs to its prediction, the paper-kernel/linear-sum pair (whose kernel sums to 0.87 and
leaks 13 % of the belief every step) cannot be built.

Why appearance and bounds (measured in the benchmark, see README "Recommended mode"): with the paper's
update alone, a cell seen empty for a few seconds reaches odds of about ``(FNR / (1 - FNR))^k`` (1e-13 after
a minute at 7.5 Hz), so a person walking into it needs four or five consistent hits in the same cell before
its belief rises; a walker moving half a cell per frame never gets them. A birth probability keeps every
cell's prior at or above ``b``, so one confident detection raises it within one or two frames, and the upper
bound keeps a cell that a person left from needing as many misses to fall as it had hits to rise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import jit, kernels
from gridbridge.ego_motion import Odometry, ego_motion_sigma_points, predict_sensor
from gridbridge.grid import GridSpec
from gridbridge.params import PeopleMotion, SensorMotionNoise
from gridbridge.people_motion import _check_paper_kernel, people_motion_kernel, predict_people
from gridbridge.validation import check_grid_array, check_positive, check_probability

__all__ = [
    "Appearance",
    "BeliefBounds",
    "EgoMotionModel",
    "LinearPrediction",
    "PaperPrediction",
    "PeoplePrediction",
    "VelocityEgoMotion",
]


@runtime_checkable
class PeoplePrediction(Protocol):
    """People-motion prediction of a belief grid (eqs. 5-9 or a variant)."""

    @property
    def motion(self) -> PeopleMotion: ...

    @property
    def outside(self) -> float: ...

    def kernel(self, spec: GridSpec, dt: float) -> NDArray[np.float64]: ...

    def predict(self, belief: NDArray[np.float64], spec: GridSpec, dt: float) -> NDArray[np.float64]: ...


@runtime_checkable
class EgoMotionModel(Protocol):
    """Sensor-motion prediction (eqs. 10-11 or a variant)."""

    def predict(
        self, belief: NDArray[np.float64], spec: GridSpec, odometry: Odometry | None, dt: float
    ) -> NDArray[np.float64]: ...


def _check_motion(motion: object) -> None:
    if not isinstance(motion, PeopleMotion):
        raise TypeError(f"motion must be a PeopleMotion, got {type(motion).__name__}")


_F64 = np.dtype(np.float64)


def _compiled(
    kernel: Callable[..., tuple[NDArray[np.float64], bool]],
    belief: ArrayLike,
    shape: tuple[int, int] | None,
    *args: object,
) -> NDArray[np.float64]:
    """``kernel(belief, *args)``, one of the ``*_checked`` kernels of :mod:`gridbridge.kernels`, on a belief that
    must be a 2-D array of probabilities (of ``shape`` if given): a C-contiguous float64 array goes as it is (the
    kernel checks its values in a compiled pass), another is converted first; a bad one is refused by name
    (:func:`~gridbridge.validation.check_grid_array`)."""
    good = type(belief) is np.ndarray and belief.dtype == _F64 and belief.ndim == 2 and belief.flags.c_contiguous
    if not (good and (shape is None or belief.shape == shape)):  # type: ignore[union-attr]
        belief = np.ascontiguousarray(check_grid_array(belief, "belief", shape=shape))
    out, ok = kernel(belief, *args)
    if not ok:
        check_grid_array(belief, "belief", shape=shape)  # raises, naming what is wrong
    return out


def _memo(component: object) -> dict[object, object]:
    """The component's cache of what its compiled form computes once (motion kernels, warp arguments): kept in its
    ``__dict__``, not a field, so neither compared nor hashed; copied and pickled with it."""
    memo: dict[object, object] = component.__dict__.setdefault("_compiled_memo", {})
    if len(memo) >= 64:
        memo.clear()
    return memo


def _compiled_kernel(prediction: PaperPrediction | LinearPrediction, spec: GridSpec, dt: float) -> NDArray[np.float64]:
    """The prediction's motion kernel of a step of ``dt`` s (and the border belief) as the compiled kernels take
    them: C-contiguous and checked, computed once per resolution and step."""
    memo, key = _memo(prediction), (dt, spec.resolution)
    kernel = memo.get(key)
    if kernel is None:
        if not 0.0 < dt < math.inf:
            check_positive(dt, "dt")  # raises
        kernel = np.ascontiguousarray(prediction.kernel(spec, dt), dtype=np.float64)
        if prediction.form == "paper":
            _check_paper_kernel(kernel)
        memo[key] = kernel
    return kernel  # type: ignore[return-value]


def _warp_args(
    ego: VelocityEgoMotion, spec: GridSpec, poses: NDArray[np.float64], w: NDArray[np.float64]
) -> tuple[tuple[float, float, float], NDArray[np.float64], NDArray[np.float64], float]:
    """:func:`gridbridge.kernels.warp_bilinear`'s arguments after the belief for these sigma points: the grid's
    origin and resolution, the poses, the normalised weights and the border belief (kept per sigma points: a
    robot's odometry, and so its cached sigma points, repeat)."""
    memo = _memo(ego)
    last = memo.get("warp")
    if last is not None and last[0] is poses and last[1] is w and last[2] is spec:  # type: ignore[index]
        return last[3]  # type: ignore[index]
    args = ((float(spec.x0), float(spec.y0), float(spec.resolution)), np.ascontiguousarray(poses), w / w.sum(),
            float(ego.outside))  # fmt: skip
    memo["warp"] = (poses, w, spec, args)
    return args


@dataclass(frozen=True, kw_only=True)
class PaperPrediction:
    """The paper's people-motion prediction: speed-density kernel p_k and eq. 6 with eq. 8 (colonisation).

    Parameters
    ----------
    motion : PeopleMotion
        Table 1 model (stay with ``p_stationary``, else walk at N(mu, sigma)).
    outside : float
        Belief assumed beyond the grid border (the paper: 0.5).
    """

    motion: PeopleMotion = field(default_factory=PeopleMotion)
    outside: float = 0.5
    form: Literal["paper"] = field(default="paper", init=False)

    def __post_init__(self) -> None:
        _check_motion(self.motion)
        check_probability(self.outside, "PaperPrediction.outside")

    def kernel(self, spec: GridSpec, dt: float) -> NDArray[np.float64]:
        """The paper kernel (speed density at cell-centre distances) for a step of ``dt`` s."""
        return people_motion_kernel(spec, self.motion, dt=dt, form="paper")

    def predict(self, belief: NDArray[np.float64], spec: GridSpec, dt: float) -> NDArray[np.float64]:
        """bel'(x_t) from bel(x_{t-1}), ``(nx, ny)`` -> ``(nx, ny)``: :func:`~gridbridge.people_motion.predict_people`
        (numpy), or compiled :func:`gridbridge.kernels.predict_paper` on the kernel of this step (the same bits)."""
        if not jit.enabled():
            return predict_people(belief, self.kernel(spec, dt), outside=self.outside, form="paper")
        kernel = _compiled_kernel(self, spec, dt)
        return _compiled(kernels.predict_people_checked, belief, None, kernel, float(self.outside), True)


@dataclass(frozen=True, kw_only=True)
class LinearPrediction:
    """Chapman-Kolmogorov prediction with the integrated kernel (the probability that a person uniform in cell
    k is in cell c after ``dt``); it sums to 1, so belief is conserved apart from the border inflow.

    Parameters
    ----------
    motion : PeopleMotion
    outside : float
        Belief assumed beyond the grid border.
    """

    motion: PeopleMotion = field(default_factory=PeopleMotion)
    outside: float = 0.5
    form: Literal["linear"] = field(default="linear", init=False)

    def __post_init__(self) -> None:
        _check_motion(self.motion)
        check_probability(self.outside, "LinearPrediction.outside")

    def kernel(self, spec: GridSpec, dt: float) -> NDArray[np.float64]:
        """The integrated kernel for a step of ``dt`` s."""
        return people_motion_kernel(spec, self.motion, dt=dt, form="integrated")

    def predict(self, belief: NDArray[np.float64], spec: GridSpec, dt: float) -> NDArray[np.float64]:
        """bel'(x_t) = sum_k T(c <- k) bel(x_{t-1} = k), ``(nx, ny)`` -> ``(nx, ny)``:
        :func:`~gridbridge.people_motion.predict_people` (numpy), or compiled :func:`gridbridge.kernels.convolve_const`
        on the kernel of this step (the same bits)."""
        if not jit.enabled():
            return predict_people(belief, self.kernel(spec, dt), outside=self.outside, form="linear")
        kernel = _compiled_kernel(self, spec, dt)
        return _compiled(kernels.predict_people_checked, belief, None, kernel, float(self.outside), False)


@dataclass(frozen=True, kw_only=True)
class VelocityEgoMotion:
    """Sensor-motion prediction (eqs. 10-11): :func:`gridbridge.ego_motion.predict_sensor`.

    Parameters
    ----------
    noise : SensorMotionNoise
        Odometry noise of the velocity motion model.
    outside : float
        Belief of cells that arrive from beyond the grid.
    """

    noise: SensorMotionNoise = field(default_factory=SensorMotionNoise)
    outside: float = 0.5

    def __post_init__(self) -> None:
        if not isinstance(self.noise, SensorMotionNoise):
            raise TypeError(f"noise must be a SensorMotionNoise, got {type(self.noise).__name__}")
        check_probability(self.outside, "VelocityEgoMotion.outside")

    def predict(
        self, belief: NDArray[np.float64], spec: GridSpec, odometry: Odometry | None, dt: float
    ) -> NDArray[np.float64]:
        """The belief warped into the new sensor frame, ``(nx, ny)`` -> ``(nx, ny)``:
        :func:`~gridbridge.ego_motion.predict_sensor` (numpy), or compiled :func:`gridbridge.kernels.warp_bilinear`
        over the same sigma points (the same bits)."""
        if not jit.enabled():
            return predict_sensor(belief, spec, odometry, dt, noise=self.noise, outside=self.outside)
        poses, w = ego_motion_sigma_points(odometry, dt, self.noise)
        if len(poses) == 1 and np.all(poses[0] == 0.0):  # a standing robot: the identity (a copy)
            return spec.check_grid(belief, "belief").copy()
        return _compiled(kernels.warp_bilinear_checked, belief, spec.shape, *_warp_args(self, spec, poses, w))


@dataclass(frozen=True, kw_only=True)
class Appearance:
    """People appearing in a cell between two frames (a birth probability per cell).

    ``bel' <- bel' + b (1 - bel')`` with ``b = 1 - exp(-rate * dt)``: the probability that a person who was not
    in the cell is there now without having been seen arriving (someone stepping out from behind an obstacle,
    from outside the field of view, or missed by the prediction). It keeps every prior at or above ``b``, so a
    cell seen empty for a long time can rise on one or two detections.

    Parameters
    ----------
    rate : float
        Appearance rate per cell (1/s).
    """

    rate: float = 0.1

    def __post_init__(self) -> None:
        check_positive(self.rate, "Appearance.rate", allow_zero=True)

    def probability(self, dt: float) -> float:
        """``b`` for a step of ``dt`` seconds."""
        return 1.0 - math.exp(-self.rate * check_positive(dt, "dt"))

    def apply(self, prior: ArrayLike, dt: float, *, where: ArrayLike | None = None) -> NDArray[np.float64]:
        """The prior with appearances, same shape, values in [0, 1].

        ``where`` (bool, the prior's shape) limits appearances to the cells some detector observes: a cell
        nobody observes keeps its belief (otherwise appearances alone would drive it to 1).
        """
        p = check_grid_array(prior, "prior", ndim=None)
        b = self.probability(dt)
        if where is not None and jit.enabled() and p.ndim == 2:
            mask = np.asarray(where, dtype=bool)
            if mask.shape == p.shape:  # the same operations in one compiled pass
                return kernels.appear(np.ascontiguousarray(p), b, np.ascontiguousarray(mask))
        out = p + b * (1.0 - p)
        if where is not None:
            out = np.where(np.asarray(where, dtype=bool), out, p)
        return out


@dataclass(frozen=True, kw_only=True)
class BeliefBounds:
    """Bounded log-odds: the posterior is clamped to ``[low, high]`` (as occupancy maps clamp, e.g. OctoMap).

    Parameters
    ----------
    low, high : float
        Bounds, ``0 <= low < high <= 1``.
    """

    low: float = 0.001
    high: float = 0.99

    def __post_init__(self) -> None:
        check_probability(self.low, "BeliefBounds.low")
        check_probability(self.high, "BeliefBounds.high")
        if not self.low < self.high:
            raise ValueError(f"BeliefBounds needs low < high, got low={self.low!r}, high={self.high!r}")

    def apply(self, belief: ArrayLike) -> NDArray[np.float64]:
        """``belief`` clamped, same shape."""
        b = check_grid_array(belief, "belief", ndim=None)
        return np.clip(b, self.low, self.high)
