"""Detection likelihoods as components: the paper's De Morgan fusion and a calibrated independent fusion.

Both map one frame's detections to a per-cell ``L`` used by eq. 12 as ``odds' = odds * L / (1 - L)``, and both
take each detector's PPV and FNR (Table 1, or measured by ``pfpeople-eval calibrate``) and its field of view and
position uncertainty (:class:`gridbridge.params.DetectorModel`).

:class:`DeMorganLikelihood` is eqs. 13-14 (:func:`gridbridge.measurement.likelihood_from_detections`).

:class:`IndependentLikelihood` treats detectors as conditionally independent given the cell's state (the
inverse-sensor-model fusion of occupancy grids: log-odds add). Per detector i covering cell c:

* fired (firing weight ``q`` in [0, 1]):   ``LR_i = q * LR_fire_i + (1 - q) * LR_miss_i``
* ``LR_fire_i = PPV_i / (1 - PPV_i) * (1 - pi) / pi``   and   ``LR_miss_i = FNR_i``

where ``pi`` is the base rate of people per cell (``base_rate``). For a detector with Gaussian position
uncertainty (the camera) ``q`` is the detection's probability mass in the cell, ``r^2 N(d; 0, S)`` (at most 1),
rather than the peak-1 weight of :func:`gridbridge.measurement.detection_map`: one detection is evidence for one
person somewhere in its ellipse, not for every cell of it. The first factor is calibration: a
detector's PPV is the probability that a detection is a person at the base rate of people, so one detection
in a cell whose prior is ``pi`` gives exactly ``P(person) = PPV``. ``LR_miss`` is ``P(no detection | person) /
P(no detection | no person) = FNR / (1 - false alarms per cell)``, with false alarms per cell negligible. The
fused ``L = LR / (1 + LR)``, ``LR = prod_i LR_i``; a cell no detector covers gets ``L = 0.5``.

Compared with eq. 13, a detector that does not fire counts against a person (eq. 13 counts its FNR in favour),
two detectors that agree multiply their evidence, and a detector with PPV 0.5 adds none on its own.

Scored detections (an ``(M, 3)`` entry: positions and each detection's own PPV, such as the learned laser
detector's ``PPV(score)``): both likelihoods take ``PPV_i`` per cell from the detection that fired there
(:func:`gridbridge.measurement.detection_ppv_map`), so ``LR_fire_i`` is that detection's. A confident detection
is stronger evidence than a doubtful one of the same detector; the mean over its detections is the detector's PPV.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import jit, kernels
from gridbridge.components import Appearance, BeliefBounds
from gridbridge.grid import GridSpec
from gridbridge.measurement import (
    Likelihood,
    _detection_map,
    _likelihood,
    detection_ppv_map,
    fov_mask,
    split_detections,
)
from gridbridge.params import DetectorModel
from gridbridge.validation import check_probability

__all__ = ["DeMorganLikelihood", "DetectionLikelihood", "IndependentLikelihood", "update_components"]


@runtime_checkable
class DetectionLikelihood(Protocol):
    """Detections of D detectors -> :class:`gridbridge.measurement.Likelihood` (per-detector maps and ``L``)."""

    def __call__(
        self, spec: GridSpec, detectors: tuple[DetectorModel, ...], detections: list[ArrayLike | None]
    ) -> Likelihood: ...


class _DetectorArrays(NamedTuple):
    """What a likelihood needs of its detectors every frame: each one's field of view (nx, ny) and the ``ppv`` and
    ``fnr`` arrays (D,)."""

    fovs: list[NDArray[np.bool_]]
    ppv: NDArray[np.float64]
    fnr: NDArray[np.float64]


def _detector_arrays(
    component: DeMorganLikelihood | IndependentLikelihood, spec: GridSpec, detectors: Sequence[DetectorModel]
) -> _DetectorArrays:
    """:class:`_DetectorArrays` of ``detectors``, kept on the component for the last grid and detectors it was called
    with (a filter's: the same objects every frame; in its ``__dict__``, not a field, so neither compared nor
    hashed)."""
    last = component.__dict__.get("_detector_arrays")
    if last is not None and last[0] is spec and last[1] is detectors:
        arrays: _DetectorArrays = last[2]
        return arrays
    fovs = [fov_mask(spec, m) for m in detectors]
    arrays = _DetectorArrays(fovs, np.array([m.ppv for m in detectors]), np.array([m.fnr for m in detectors]))
    component.__dict__["_detector_arrays"] = (spec, detectors, arrays)
    return arrays


@dataclass(frozen=True, kw_only=True)
class DeMorganLikelihood:
    """The paper's fusion, eqs. 13-14 (see :mod:`gridbridge.measurement`; compiled and numpy forms there)."""

    def __call__(
        self, spec: GridSpec, detectors: tuple[DetectorModel, ...], detections: list[ArrayLike | None]
    ) -> Likelihood:
        arrays = _detector_arrays(self, spec, detectors)
        return _likelihood(spec, detectors, detections, arrays.fovs, (arrays.ppv, arrays.fnr))


@dataclass(frozen=True, kw_only=True)
class IndependentLikelihood:
    """Calibrated independent fusion (see the module docstring).

    Parameters
    ----------
    base_rate : float
        ``pi``: the probability that a cell holds a person, at which the detectors' PPV was measured
        (0 < pi < 1). Set it equal to the filter's appearance prior so that one detection of a cell at the prior
        gives ``P = PPV``.
    miss_weight : float
        ``alpha`` in (0, 1]: a miss counts as ``FNR ** alpha``. Misses of one person are correlated over frames
        (an occlusion or a pose the detector cannot see lasts), so the frames are not independent evidence;
        ``alpha < 1`` discounts them (1: independent frames).
    """

    base_rate: float = 0.01
    miss_weight: float = 1.0

    def __post_init__(self) -> None:
        check_probability(self.base_rate, "IndependentLikelihood.base_rate", open_low=True, open_high=True)
        check_probability(self.miss_weight, "IndependentLikelihood.miss_weight", open_low=True)

    def __call__(
        self, spec: GridSpec, detectors: tuple[DetectorModel, ...], detections: list[ArrayLike | None]
    ) -> Likelihood:
        if len(detections) != len(detectors):
            raise ValueError(f"detections must have one entry per detector ({len(detectors)}), got {len(detections)}")
        d = len(detectors)
        fired = np.zeros((d, *spec.shape))
        covered = np.zeros((d, *spec.shape), dtype=bool)
        per_det = np.full((d, *spec.shape), 0.5)
        log_lr = np.zeros(spec.shape)
        prior_odds = self.base_rate / (1.0 - self.base_rate)
        compiled, fovs = jit.enabled(), _detector_arrays(self, spec, detectors).fovs
        for i, (model, det) in enumerate(zip(detectors, detections, strict=True)):
            if det is None:
                continue
            pts, own = split_detections(det, f"detections of {model.name}")
            ppv: float | NDArray[np.float64] = model.ppv
            if own is None:
                q = _detection_map(spec, model, pts)  # split_detections checked them
            else:
                q, ppv = detection_ppv_map(spec, model, pts, own)
            if model.uncertainty == "gaussian":  # the detection's probability mass per cell, not a peak of 1
                q = q * min(1.0, spec.resolution**2 / (2.0 * np.pi * model.sigma_lateral * model.sigma_range))
            fired[i] = q
            lr_fire, miss = ppv / (1.0 - ppv) / prior_odds, model.fnr**self.miss_weight
            if compiled and isinstance(lr_fire, float):
                lr = kernels.independent_terms(q, fovs[i], (lr_fire, miss), covered[i], per_det[i])
                kernels.add_where(log_lr, np.log(lr), covered[i])
            else:  # numpy, and LR_fire per cell (scored detections: the compiled pass takes one number)
                self._terms_numpy(q, fovs[i], (lr_fire, miss), covered[i], per_det[i], log_lr)
        fused = 1.0 / (1.0 + np.exp(-log_lr))
        return Likelihood(fired=fired, covered=covered, detector_likelihoods=per_det, likelihood=fused)

    @staticmethod
    def _terms_numpy(
        q: NDArray[np.float64],
        fov: NDArray[np.bool_],
        odds: tuple[float | NDArray[np.float64], float],
        covered: NDArray[np.bool_],
        per_det: NDArray[np.float64],
        log_lr: NDArray[np.float64],
    ) -> None:
        """One detector's terms (:func:`gridbridge.kernels.independent_terms`' numpy twin): its field of view,
        likelihood and log likelihood ratio written into ``covered``, ``per_det`` and ``log_lr``. ``odds`` is
        ``(LR_fire, LR_miss)``; ``LR_fire`` may be per cell ``(nx, ny)`` (scored detections)."""
        lr_fire, miss = odds
        cov = fov | (q > 0.0)
        lr = q * lr_fire + (1.0 - q) * miss
        covered[...] = cov
        per_det[...] = np.where(cov, lr / (1.0 + lr), 0.5)
        log_lr += np.where(cov, np.log(lr), 0.0)


def update_components(
    likelihood: object, appearance: object, bounds: object
) -> tuple[DetectionLikelihood, Appearance | None, BeliefBounds | None]:
    """The update components of a filter, checked: a likelihood (default :class:`DeMorganLikelihood`), an optional
    :class:`~gridbridge.components.Appearance` and optional :class:`~gridbridge.components.BeliefBounds`.

    Raises ``TypeError`` naming the argument. Shared by :class:`gridbridge.GridFilter` and the particle filter.
    """
    lik = DeMorganLikelihood() if likelihood is None else likelihood
    if not isinstance(lik, DetectionLikelihood):
        raise TypeError(f"likelihood must be a DetectionLikelihood component, got {type(lik).__name__}")
    if appearance is not None and not isinstance(appearance, Appearance):
        raise TypeError(f"appearance must be an Appearance or None, got {type(appearance).__name__}")
    if bounds is not None and not isinstance(bounds, BeliefBounds):
        raise TypeError(f"bounds must be a BeliefBounds or None, got {type(bounds).__name__}")
    return lik, appearance, bounds
