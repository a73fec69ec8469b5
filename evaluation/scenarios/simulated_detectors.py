"""Simulated people detectors: misses, clutter, position noise and laser occlusion, from the ground truth.

Each :class:`SimulatedDetector` wraps a :class:`gridbridge.params.DetectorModel` (field of view, range limits,
mount pose in the grid's sensor frame; by default the paper's three detectors of ``PAPER_DETECTORS``) and adds
how it fails. Per frame and detector, with people positions ``p`` in the sensor frame (REP-103):

1. *Visible* people: bearing from the detector's mount within ``[fov_min, fov_max]``, range within
   ``[min_range, max_range]``, and, when ``occlusion`` is on, not occluded. A person (disc of radius
   ``person_radius``) is *occluded* when at least ``occlusion_threshold`` of its angular interval
   ``[b - asin(R/d), b + asin(R/d)]`` seen from the mount is covered by the union of the intervals of people
   nearer to the mount. Lasers (0.29 m above the floor in the paper) are occluded by people; the camera
   (1.63 m up, looking over people) is not by default: ``occlusion = false`` for it.
2. Each visible person is missed independently with probability ``miss_rate`` (per frame); otherwise it is
   detected at ``p + e``: ``noise = "isotropic"`` draws ``e ~ N(0, sigma_range^2 I)``; ``"line_of_sight"``
   draws ``sigma_range`` along the line of sight from the mount and ``sigma_lateral`` across it (the paper's
   camera: 1.0 m lateral, 1.7 m range; its laser error is about 35 mm).
3. Clutter: a Poisson number (mean ``clutter_rate``) of false positives, uniform over the part of the grid
   inside the field of view and range limits.
4. With ``crop_to_grid`` (default) only detections inside the grid are reported: the filter's input covers
   the grid only. The number of cropped detections is kept in :class:`DetectorOutput`.

Expected confidence: with ``N`` people visible per frame on average, a detector reports ``(1 - m) N`` true
and ``lambda`` false positives per frame, so ``PPV = (1 - m) N / ((1 - m) N + lambda)`` and ``FNR = m``
among visible people (occluded people add to the FNR measured over all people in the field of view).
:func:`clutter_for_ppv` inverts this to set ``lambda`` for a wanted PPV.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.grid import GridSpec
from gridbridge.measurement import in_field_of_view as grid_in_field_of_view
from gridbridge.params import PAPER_DETECTORS, DetectorModel, current_detector_name
from gridbridge.validation import check_positive, check_probability

__all__ = [
    "LASER_SIGMA",
    "DetectorOutput",
    "SimulatedDetector",
    "clutter_for_ppv",
    "in_field_of_view",
    "occluded",
    "paper_simulated_detectors",
    "simulate_detections",
]

#: Laser position error (m): "about 35 mm according to SICK (2006)" (paper, Sect. 4).
LASER_SIGMA = 0.035


def clutter_for_ppv(ppv: float, miss_rate: float, people_in_view: float) -> float:
    """Mean false positives per frame that give ``ppv`` when ``people_in_view`` people are visible on average.

    ``lambda = (1 - m) N (1 - PPV) / PPV``.
    """
    ppv = check_probability(ppv, "ppv", open_low=True)
    miss_rate = check_probability(miss_rate, "miss_rate")
    people_in_view = check_positive(people_in_view, "people_in_view", allow_zero=True)
    return (1.0 - miss_rate) * people_in_view * (1.0 - ppv) / ppv


@dataclass(frozen=True, kw_only=True)
class SimulatedDetector:
    """How one simulated detector sees and fails.

    Parameters
    ----------
    model : DetectorModel
        Field of view, range limits and mount pose (its ``ppv``/``fnr`` are what the *filter* assumes; the
        simulated behaviour is set by the fields below).
    miss_rate : float
        Probability that a visible person is not detected in a frame.
    clutter_rate : float
        Mean number of false positives per frame (Poisson), uniform over the field of view inside the grid.
    noise : {"isotropic", "line_of_sight"}
        Position-noise shape (see module docstring).
    sigma_lateral, sigma_range : float
        Noise standard deviations (m) across / along the line of sight (``isotropic`` uses ``sigma_range``).
    occlusion : bool
        Whether people hide people behind them from this detector.
    occlusion_threshold : float
        Fraction of a person's angular interval that must be covered for it to be occluded, in (0, 1].
    crop_to_grid : bool
        Report only detections inside the grid.
    """

    model: DetectorModel
    miss_rate: float
    clutter_rate: float = 0.0
    noise: Literal["isotropic", "line_of_sight"] = "isotropic"
    sigma_lateral: float = LASER_SIGMA
    sigma_range: float = LASER_SIGMA
    occlusion: bool = True
    occlusion_threshold: float = 0.5
    crop_to_grid: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.model, DetectorModel):
            raise ValueError(f"SimulatedDetector.model must be a DetectorModel, got {type(self.model).__name__}")
        who = f"SimulatedDetector({self.model.name})"
        check_probability(self.miss_rate, f"{who}.miss_rate")
        check_positive(self.clutter_rate, f"{who}.clutter_rate", allow_zero=True)
        if self.noise not in ("isotropic", "line_of_sight"):
            raise ValueError(f"{who}.noise must be 'isotropic' or 'line_of_sight', got {self.noise!r}")
        check_positive(self.sigma_lateral, f"{who}.sigma_lateral", allow_zero=True)
        check_positive(self.sigma_range, f"{who}.sigma_range", allow_zero=True)
        if not isinstance(self.occlusion, bool):
            raise ValueError(f"{who}.occlusion must be a bool, got {self.occlusion!r}")
        check_probability(self.occlusion_threshold, f"{who}.occlusion_threshold", open_low=True)
        if not isinstance(self.crop_to_grid, bool):
            raise ValueError(f"{who}.crop_to_grid must be a bool, got {self.crop_to_grid!r}")

    @property
    def name(self) -> str:
        return self.model.name

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> SimulatedDetector:
        """Build from a TOML table.

        ``base`` names one of ``PAPER_DETECTORS`` (``laser_legs``, ``laser_boosted``, ``camera_hog``) whose
        model and paper-like failure settings are the starting point; ``model`` (a table) overrides fields
        of the :class:`DetectorModel` (FOV in degrees via ``fov_min_deg``/``fov_max_deg``); the other keys
        override fields of this class. ``people_in_view`` with ``ppv`` sets ``clutter_rate`` by
        :func:`clutter_for_ppv`.
        """
        data = dict(data)
        base_name = data.pop("base", None)
        people_in_view = data.pop("people_in_view", None)
        target_ppv = data.pop("ppv", None)
        model_over = dict(data.pop("model", {}))
        if base_name is not None:
            by_name = {d.name: d for d in paper_simulated_detectors()}
            base_name = current_detector_name(str(base_name))  # the old "laser-legs" reads as "laser_legs"
            if base_name not in by_name:
                raise ValueError(f"detector base must be one of {sorted(by_name)}, got {base_name!r}")
            base = by_name[base_name]
        else:
            if "name" not in model_over:
                raise ValueError("detector table needs 'base' or model.name")
            base = None
        for key in ("fov_min_deg", "fov_max_deg"):
            if key in model_over:
                model_over[key[:-4]] = math.radians(float(model_over.pop(key)))
        if base is not None:
            model = replace(base.model, **model_over)
            fields_ = {**_sim_fields(base), **data}
        else:
            model = DetectorModel(**model_over)
            fields_ = dict(data)
        known = set(_SIM_FIELDS)
        unknown = set(fields_) - known
        if unknown:
            raise ValueError(f"unknown detector field(s) {sorted(unknown)}; known: {sorted(known)}")
        if "miss_rate" not in fields_:
            raise ValueError(f"detector {model.name!r} needs 'miss_rate' (or a 'base' that sets it)")
        if people_in_view is not None:
            ppv = float(target_ppv) if target_ppv is not None else model.ppv
            fields_["clutter_rate"] = clutter_for_ppv(ppv, float(fields_["miss_rate"]), float(people_in_view))
        elif target_ppv is not None:
            raise ValueError("detector field 'ppv' needs 'people_in_view' to set the clutter rate")
        return cls(model=model, **fields_)


#: The fields of :class:`SimulatedDetector` a TOML detector table sets directly (all but ``model``).
_SIM_FIELDS = tuple(f.name for f in fields(SimulatedDetector) if f.name != "model")


def _sim_fields(det: SimulatedDetector) -> dict[str, Any]:
    return {name: getattr(det, name) for name in _SIM_FIELDS}


def paper_simulated_detectors(*, people_in_view: float = 3.0) -> tuple[SimulatedDetector, ...]:
    """The paper's three detectors, failing as Table 1 says.

    Miss rates are Table 1's FNR; clutter rates give Table 1's PPV when ``people_in_view`` people are
    visible per frame on average (:func:`clutter_for_ppv`). Lasers: 35 mm isotropic noise and occlusion;
    camera: 1.0 m lateral / 1.7 m range noise along the line of sight, no occlusion (it looks over people).
    """
    out = []
    for model in PAPER_DETECTORS:
        camera = model.uncertainty == "gaussian"
        out.append(
            SimulatedDetector(
                model=model,
                miss_rate=model.fnr,
                clutter_rate=clutter_for_ppv(model.ppv, model.fnr, people_in_view),
                noise="line_of_sight" if camera else "isotropic",
                sigma_lateral=model.sigma_lateral if camera else LASER_SIGMA,
                sigma_range=model.sigma_range if camera else LASER_SIGMA,
                occlusion=not camera,
            )
        )
    return tuple(out)


@dataclass(frozen=True)
class DetectorOutput:
    """One detector's output in one frame.

    Attributes
    ----------
    name : str
        Detector name.
    positions : ndarray, shape (M, 2)
        Detected positions (m), grid sensor frame: the array ``GridFilter.step`` takes.
    source : ndarray, shape (M,)
        Person id each detection came from, ``-1`` for a false positive.
    in_view_ids : ndarray, shape (V,)
        Ids of people inside the field of view and range limits (occluded or not).
    occluded_ids : ndarray, shape (O,)
        Ids of people in view but occluded (a subset of ``in_view_ids``).
    n_cropped : int
        Detections dropped because they fell outside the grid (``crop_to_grid``).
    """

    name: str
    positions: NDArray[np.float64]
    source: NDArray[np.int64]
    in_view_ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    occluded_ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    n_cropped: int = 0

    @property
    def is_true(self) -> NDArray[np.bool_]:
        """True positive flag per detection, shape (M,)."""
        return self.source >= 0


def in_field_of_view(model: DetectorModel, positions: ArrayLike) -> NDArray[np.bool_]:
    """Whether each sensor-frame point ``(N, 2)`` lies in the model's field of view and range limits.

    The test of :func:`gridbridge.measurement.in_field_of_view`, the one the filters' field-of-view masks use.
    """
    pts = np.asarray(positions, dtype=float).reshape(-1, 2)
    return grid_in_field_of_view(model, pts[:, 0], pts[:, 1])


def occluded(
    positions: ArrayLike,
    *,
    origin: tuple[float, float] = (0.0, 0.0),
    radius: float = 0.25,
    threshold: float = 0.5,
    candidates: ArrayLike | None = None,
) -> NDArray[np.bool_]:
    """Which people are hidden by nearer people, as seen from ``origin``.

    Parameters
    ----------
    positions : array_like, shape (N, 2)
        People positions (m), sensor frame.
    origin : tuple of float
        Viewpoint (m), sensor frame.
    radius : float
        Person disc radius (m).
    threshold : float
        Occluded when this fraction (or more) of the person's angular interval is covered by the union of
        the intervals of people strictly nearer to ``origin``.
    candidates : array_like of bool, shape (N,), optional
        Only these people are tested (all people still act as occluders). Default all.

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    pts = np.asarray(positions, dtype=float).reshape(-1, 2)
    n = pts.shape[0]
    out = np.zeros(n, dtype=bool)
    if n < 2:
        return out
    d = np.hypot(pts[:, 0] - origin[0], pts[:, 1] - origin[1])
    b = np.arctan2(pts[:, 1] - origin[1], pts[:, 0] - origin[0])
    half = np.arcsin(np.clip(radius / np.maximum(d, 1e-12), 0.0, 1.0))
    test = np.ones(n, dtype=bool) if candidates is None else np.asarray(candidates, dtype=bool)
    for i in np.flatnonzero(test):
        nearer = np.flatnonzero(d < d[i])
        if nearer.size == 0:
            continue
        rel = (b[nearer] - b[i] + math.pi) % (2 * math.pi) - math.pi
        lo = np.maximum(rel - half[nearer], -half[i])
        hi = np.minimum(rel + half[nearer], half[i])
        keep = hi > lo
        if not np.any(keep):
            continue
        order = np.argsort(lo[keep])
        covered = 0.0
        cur_lo = cur_hi = -math.inf
        for a, c in zip(lo[keep][order], hi[keep][order], strict=True):
            if a > cur_hi:
                if cur_hi > cur_lo:
                    covered += cur_hi - cur_lo
                cur_lo, cur_hi = a, c
            else:
                cur_hi = max(cur_hi, c)
        if cur_hi > cur_lo:
            covered += cur_hi - cur_lo
        out[i] = covered >= threshold * 2.0 * half[i] - 1e-12
    return out


def _sample_clutter(det: SimulatedDetector, spec: GridSpec, rng: np.random.Generator) -> NDArray[np.float64]:
    n = int(rng.poisson(det.clutter_rate)) if det.clutter_rate > 0 else 0
    if n == 0:
        return np.zeros((0, 2))
    x0, x1, y0, y1 = spec.extent
    got: list[NDArray[np.float64]] = []
    need = n
    for _ in range(1000):
        cand = np.column_stack((rng.uniform(x0, x1, 4 * need + 8), rng.uniform(y0, y1, 4 * need + 8)))
        ok = cand[in_field_of_view(det.model, cand) & spec.contains(cand[:, 0], cand[:, 1])]
        got.append(ok[:need])
        need -= min(need, ok.shape[0])
        if need == 0:
            return np.concatenate(got)
    raise ValueError(
        f"detector {det.name!r}: its field of view does not overlap the grid, cannot place clutter "
        f"(set clutter_rate = 0)"
    )


def simulate_detections(
    positions: ArrayLike,
    ids: ArrayLike,
    *,
    detectors: Sequence[SimulatedDetector],
    spec: GridSpec,
    rng: np.random.Generator,
    person_radius: float = 0.25,
) -> list[DetectorOutput]:
    """Simulate every detector on one frame of ground truth.

    Parameters
    ----------
    positions : array_like, shape (P, 2)
        True people positions (m), grid sensor frame.
    ids : array_like, shape (P,)
        Their person ids (>= 0).
    detectors : sequence of SimulatedDetector
        The detectors, in the order the filter expects.
    spec : GridSpec
        The grid (clutter placement and cropping).
    rng : numpy.random.Generator
        Source of randomness.
    person_radius : float
        Person disc radius (m) for occlusion.

    Returns
    -------
    list of DetectorOutput
        One per detector.
    """
    pts = np.asarray(positions, dtype=float).reshape(-1, 2)
    pid = np.asarray(ids, dtype=np.int64).reshape(-1)
    if pid.shape[0] != pts.shape[0]:
        raise ValueError(f"ids must have one entry per position ({pts.shape[0]}), got {pid.shape[0]}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("positions contains NaN or infinite values")
    outputs = []
    for det in detectors:
        model = det.model
        view = in_field_of_view(model, pts)
        hidden = np.zeros(pts.shape[0], dtype=bool)
        if det.occlusion and np.count_nonzero(view) > 0:
            hidden = occluded(
                pts,
                origin=(model.mount_x, model.mount_y),
                radius=person_radius,
                threshold=det.occlusion_threshold,
                candidates=view,
            )
        visible = view & ~hidden
        hit = visible & (rng.random(pts.shape[0]) >= det.miss_rate)
        true_pts = pts[hit]
        if true_pts.shape[0] and (det.sigma_range > 0 or det.sigma_lateral > 0):
            e = rng.standard_normal(true_pts.shape)
            if det.noise == "isotropic":
                true_pts = true_pts + det.sigma_range * e
            else:
                los = true_pts - np.array([model.mount_x, model.mount_y])
                u = los / np.maximum(np.hypot(los[:, 0], los[:, 1]), 1e-12)[:, None]
                n_ = np.column_stack((-u[:, 1], u[:, 0]))
                true_pts = true_pts + det.sigma_range * e[:, :1] * u + det.sigma_lateral * e[:, 1:] * n_
        clutter = _sample_clutter(det, spec, rng)
        all_pts = np.concatenate((true_pts, clutter))
        source = np.concatenate((pid[hit], np.full(clutter.shape[0], -1, dtype=np.int64)))
        n_cropped = 0
        if det.crop_to_grid:
            inside = spec.contains(all_pts[:, 0], all_pts[:, 1])
            n_cropped = int(np.count_nonzero(~inside))
            all_pts, source = all_pts[inside], source[inside]
        outputs.append(
            DetectorOutput(
                name=det.name,
                positions=all_pts,
                source=source,
                in_view_ids=pid[view],
                occluded_ids=pid[view & hidden],
                n_cropped=n_cropped,
            )
        )
    return outputs
