"""Measurement update (Batista & Pereira 2015, Sect. 3.2, eqs. 12-14): the likelihood code both filters share.

Per detector i and cell c the detector either fires (a detection maps to c) or not; the paper's
confidence is ``P(D_i | p) = PPV_i`` where it fires and ``FNR_i`` where it does not. The fusion is

    P(D_1..D_N | p) = 1 - prod_i (1 - P(D_i | p))      if at least one detector fires     (eq. 13)
    P(D_1..D_N | p) = min_i FNR_i                        if none fires                     (eq. 14)

and the update (eq. 12) with the usual reading ``P(D | np) = 1 - P(D | p)``:

    bel(p) = L bel'(p) / (L bel'(p) + (1 - L)(1 - bel'(p))),

so each update multiplies a cell's odds by ``L / (1 - L)``.

Decisions the paper leaves open (tested in ``tests/gridbridge/test_measurement.py``):

* Soft detections. A detector may fire with probability ``q`` in a cell (the camera's Gaussian position
  uncertainty). The fused likelihood is then the expectation of eqs. 13-14 over independent firing events:
  ``L = 1 - A - N0 (1 - B) + N0 min FNR`` with ``A = prod_i [q_i (1 - PPV_i) + (1 - q_i)(1 - FNR_i)]``,
  ``N0 = prod_i (1 - q_i)`` and ``B = prod_i (1 - FNR_i)``. For 0/1 values this is exactly eqs. 13-14.
* Camera (``uncertainty="gaussian"``): a detection at bearing phi fires in cell c with
  ``q_c = exp(-d^T S^-1 d / 2)``, ``S = R(phi) diag(sigma_range^2, sigma_lateral^2) R(phi)^T``, d from the
  detection to the cell centre; ``q < exp(-4.5)`` (beyond 3 sd) is set to 0. Several detections of one
  detector combine by the maximum.
* Point detections (lasers) fire in the cell that contains them, plus cells whose centre lies within
  ``footprint_radius``.
* Fields of view. Only detectors that cover a cell take part in its fusion (the min-FNR of eq. 14 runs over
  them). A cell covered by no detector gets ``L = 0.5``, which leaves its belief unchanged (odds x 1): nothing
  observed it. A cell where a point detection lands counts as covered by that detector.
* ``L = 1`` with prior 0 (or ``L = 0`` with prior 1) makes eq. 12 0/0; the prior is kept there.
* Scored detections. A detector's entry may be ``(M, 3)``: positions with each detection's own PPV in the third
  column (a detector calibrated by score, ``PPV(score)``, such as the learned laser detector). ``PPV_i`` is then
  per cell: the PPV of the detection whose footprint weighs most in the cell (ties: the larger PPV), the same
  detection whose weight is the cell's ``q`` (:func:`detection_ppv_map`). With every detection's PPV equal to the
  detector's, this is the constant-PPV fusion.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import jit, kernels
from gridbridge.geometry import to_frame_xy
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from gridbridge.validation import check_grid_array, check_positions, check_real_array

__all__ = [
    "Likelihood",
    "bayes_update",
    "detection_map",
    "detection_ppv_map",
    "detector_likelihood",
    "fov_mask",
    "fuse_detectors",
    "in_field_of_view",
    "likelihood_from_detections",
    "rasterise",
    "split_detections",
]

#: Gaussian firing weights below exp(-3^2 / 2) (beyond 3 standard deviations) count as not firing.
GAUSSIAN_CUTOFF = math.exp(-4.5)


def rasterise(spec: GridSpec, positions: ArrayLike, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """Sum of point weights per cell.

    Parameters
    ----------
    spec : GridSpec
    positions : array_like, shape (N, 2)
        Points (x, y) in the grid's sensor frame (m); points outside the grid are not counted.
    weights : array_like, shape (N,), optional
        Weight of each point (1 by default).

    Returns
    -------
    ndarray, shape (nx, ny)
    """
    pts = check_positions(positions, "positions")
    w = np.ones(len(pts)) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != (len(pts),):
        raise ValueError(f"weights must have shape ({len(pts)},), got {w.shape}")
    flat = spec.flat_index(pts[:, 0], pts[:, 1])
    inside = flat >= 0
    grid = np.bincount(flat[inside], weights=w[inside], minlength=spec.n_cells)
    return np.asarray(grid, dtype=np.float64).reshape(spec.shape)


def fov_mask(spec: GridSpec, model: DetectorModel) -> NDArray[np.bool_]:
    """Cells whose centre lies in the detector's field of view (bearing range and range interval).

    Returns a read-only ``(nx, ny)`` bool array (cached per grid and model).
    """
    return _fov_mask_cached(spec, model)


@lru_cache(maxsize=128)
def _fov_mask_cached(spec: GridSpec, model: DetectorModel) -> NDArray[np.bool_]:
    gx, gy = spec.cell_centres()
    mask = in_field_of_view(model, gx, gy)
    mask.setflags(write=False)
    return mask


def in_field_of_view(model: DetectorModel, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
    """True where points (m, grid's sensor frame; any broadcastable shape) lie in the detector's field of view:
    bearing in [fov_min, fov_max] and range in [min_range, max_range], both seen from the detector's mount."""
    lx, ly = to_frame_xy(x, y, (model.mount_x, model.mount_y, model.mount_yaw))  # in the detector's mount frame
    rng = np.hypot(lx, ly)
    rel = np.mod(np.arctan2(ly, lx) - model.fov_min, 2 * math.pi)
    in_bearing = rel <= (model.fov_max - model.fov_min) + 1e-12
    return np.asarray(in_bearing & (rng >= model.min_range) & (rng <= model.max_range), dtype=bool)


def detection_map(spec: GridSpec, model: DetectorModel, positions: ArrayLike) -> NDArray[np.float64]:
    """Where a detector fires: ``(nx, ny)`` values in [0, 1] (1 = fired) from its detections.

    Parameters
    ----------
    spec : GridSpec
    model : DetectorModel
        Sets point or Gaussian uncertainty and the footprint.
    positions : array_like, shape (M, 2)
        Detected person positions (x, y) in the grid's sensor frame (m). M may be 0.
    """
    return _detection_map(spec, model, check_positions(positions, f"detections of {model.name}"))


def _detection_map(spec: GridSpec, model: DetectorModel, pts: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`detection_map` of positions already checked (``(M, 2)`` finite floats)."""
    fired = np.zeros(spec.shape)
    if len(pts) == 0:
        return fired
    if jit.enabled():
        grid = (float(spec.x0), float(spec.y0), float(spec.resolution))
        xs, ys = np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1])
        if model.uncertainty == "point":
            kernels.point_map(fired, xs, ys, grid, float(model.footprint_radius))
        else:
            mount, sigmas = (model.mount_x, model.mount_y), (model.sigma_range, model.sigma_lateral)
            cells, args = kernels.gaussian_args(xs, ys, grid, spec.shape, mount, sigmas)
            kernels.scatter_max(fired, cells, np.exp(args), GAUSSIAN_CUTOFF)  # numpy's exp, as the numpy path
        return fired
    if model.uncertainty == "point":
        flat = spec.flat_index(pts[:, 0], pts[:, 1])
        fired.ravel()[flat[flat >= 0]] = 1.0
        if model.footprint_radius > 0.0:
            gx, gy = spec.cell_centres()
            for px, py in pts:
                fired[(gx - px) ** 2 + (gy - py) ** 2 <= model.footprint_radius**2] = 1.0
        return fired
    # Gaussian: evaluate each detection in the window of cells within 3 sd (beyond it q = 0).
    reach = 3.0 * max(model.sigma_range, model.sigma_lateral)
    r = spec.resolution
    for px, py in pts:
        lo_u, lo_v = spec.to_fractional(px - reach, py - reach)
        hi_u, hi_v = spec.to_fractional(px + reach, py + reach)
        i0, j0 = max(math.floor(lo_u), 0), max(math.floor(lo_v), 0)
        i1, j1 = min(math.floor(hi_u), spec.nx - 1), min(math.floor(hi_v), spec.ny - 1)
        if i0 > i1 or j0 > j1:
            continue
        xs = spec.x0 + (np.arange(i0, i1 + 1) + 0.5) * r - px
        ys = spec.y0 + (np.arange(j0, j1 + 1) + 0.5) * r - py
        phi = math.atan2(py - model.mount_y, px - model.mount_x)
        c, s = math.cos(phi), math.sin(phi)
        along = (c * xs[:, None] + s * ys[None, :]) / model.sigma_range
        across = (-s * xs[:, None] + c * ys[None, :]) / model.sigma_lateral
        window = fired[i0 : i1 + 1, j0 : j1 + 1]
        np.maximum(window, np.exp(-0.5 * (along**2 + across**2)), out=window)
    fired[fired < GAUSSIAN_CUTOFF] = 0.0
    return fired


def split_detections(detections: ArrayLike, name: str) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """One detector's entry of a frame, checked: positions ``(M, 2)`` (m), and each detection's own PPV ``(M,)`` when
    the entry is ``(M, 3)`` (None for ``(M, 2)``: the detector's PPV holds for all).

    Raises ``ValueError`` naming ``name`` for another shape, non-finite positions or a PPV outside (0, 1), and
    ``TypeError`` for values that are not real numbers.
    """
    arr = check_real_array(detections, name)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        return check_positions(arr, name), None
    pts = check_positions(arr[:, :2], name)
    ppv = np.ascontiguousarray(arr[:, 2])
    if not (np.isfinite(ppv).all() and (ppv > 0.0).all() and (ppv < 1.0).all()):
        raise ValueError(f"{name}: the third column (each detection's PPV) must lie in (0, 1), got {ppv.tolist()}")
    return pts, ppv


def detection_ppv_map(
    spec: GridSpec, model: DetectorModel, positions: ArrayLike, ppv: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where a scored detector fired, and each cell's PPV: that of the detection that fired there.

    Parameters
    ----------
    spec : GridSpec
    model : DetectorModel
        Sets point or Gaussian uncertainty and the footprint; ``model.ppv`` is the PPV of cells no detection reaches.
    positions : array_like, shape (M, 2)
        Detected person positions (x, y) in the grid's sensor frame (m).
    ppv : array_like, shape (M,)
        Each detection's PPV, in (0, 1).

    Returns
    -------
    fired : ndarray, shape (nx, ny)
        :func:`detection_map` of all the detections (the largest weight of any detection in each cell).
    ppv_map : ndarray, shape (nx, ny)
        The PPV of the detection whose weight is ``fired`` in each cell (ties: the larger PPV); ``model.ppv`` where
        ``fired`` is 0.
    """
    pts = check_positions(positions, f"detections of {model.name}")
    own = np.asarray(ppv, dtype=float).reshape(-1)
    if own.shape != (len(pts),):
        raise ValueError(f"ppv must have one value per detection of {model.name} ({len(pts)}), got {own.shape}")
    fired = np.zeros(spec.shape)
    ppv_map = np.full(spec.shape, float(model.ppv))
    for j in np.argsort(own, kind="stable"):  # ascending PPV: a tie in weight goes to the later, larger PPV
        w = _detection_map(spec, model, pts[j : j + 1])
        wins = (w > 0.0) & (w >= fired)
        fired[wins] = w[wins]
        ppv_map[wins] = own[j]
    return fired, ppv_map


def detector_likelihood(fired: ArrayLike, ppv: ArrayLike, fnr: ArrayLike) -> NDArray[np.float64]:
    """P(D_i | p) per cell: PPV where the detector fired, FNR where not (expectation for soft firing).

    ``ppv`` and ``fnr`` are one detector's numbers, or arrays broadcasting against ``fired``.
    """
    q = check_grid_array(fired, "fired", ndim=None)
    return q * np.asarray(ppv, dtype=float) + (1.0 - q) * np.asarray(fnr, dtype=float)


def fuse_detectors(
    fired: ArrayLike,
    ppv: ArrayLike,
    fnr: ArrayLike,
    *,
    covered: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """De Morgan fusion of N detectors (eqs. 13-14), with fields of view.

    Parameters
    ----------
    fired : array_like, shape (D, nx, ny)
        Bool (fired or not) or per-cell firing probabilities in [0, 1].
    ppv : array_like, shape (D,) or (D, nx, ny)
        Each detector's precision, or per cell (scored detections, :func:`detection_ppv_map`).
    fnr : array_like, shape (D,)
        Each detector's false-negative rate.
    covered : array_like of bool, shape (D, nx, ny), optional
        Field-of-view masks: detector i takes part in cell c only where ``covered[i, c]``. All True by default.

    Returns
    -------
    ndarray, shape (nx, ny)
        P(D_1..D_N | p) per cell; 0.5 where no detector covers the cell.
    """
    q = check_grid_array(fired, "fired", ndim=3)
    d = q.shape[0]
    per_cell = np.ndim(ppv) == 3
    ppv_ = (
        check_grid_array(ppv, "ppv", ndim=3, shape=q.shape)
        if per_cell
        else check_grid_array(ppv, "ppv", ndim=1, shape=(d,))
    )
    fnr_ = check_grid_array(fnr, "fnr", ndim=1, shape=(d,))
    if covered is None:
        cov = np.ones(q.shape, dtype=bool)
    else:
        cov = np.asarray(covered)
        if cov.dtype != bool:
            raise ValueError(f"covered must be a bool array, got dtype {cov.dtype}")
        if cov.shape != q.shape:
            raise ValueError(f"covered must have the shape of fired {q.shape}, got {cov.shape}")
    if jit.enabled() and not per_cell:
        return kernels.fuse_update(np.ascontiguousarray(q), np.ascontiguousarray(cov), ppv_, fnr_)[1]
    ppv3, fnr3 = (ppv_ if per_cell else ppv_[:, None, None]), fnr_[:, None, None]
    q = np.where(cov, q, 0.0)
    factor_a = np.where(cov, q * (1.0 - ppv3) + (1.0 - q) * (1.0 - fnr3), 1.0)
    a = factor_a.prod(axis=0)
    n0 = (1.0 - q).prod(axis=0)
    b = np.where(cov, 1.0 - fnr3, 1.0).prod(axis=0)
    min_fnr = np.where(cov, fnr3, np.inf).min(axis=0)
    any_cov = cov.any(axis=0)
    fused = (1.0 - a) - n0 * (1.0 - b) + n0 * np.where(any_cov, min_fnr, 0.0)
    fused = np.where(any_cov, fused, 0.5)
    return np.clip(fused, 0.0, 1.0, out=fused)


def bayes_update(prior: ArrayLike, likelihood: ArrayLike) -> NDArray[np.float64]:
    """Binary Bayes update of eq. 12 with P(D | np) = 1 - P(D | p).

    Parameters
    ----------
    prior, likelihood : array_like, shape (nx, ny)
        The predicted belief and P(D_1..D_N | p), both in [0, 1].

    Returns
    -------
    ndarray, shape (nx, ny)
        The posterior; where eq. 12 is 0/0 (L = 1 with prior 0, or L = 0 with prior 1) the prior is kept.
    """
    if jit.enabled() and _float_arrays(prior, likelihood):
        out, ok = kernels.bayes_update_checked(prior, likelihood)  # type: ignore[arg-type]
        if ok:
            return out
    p = check_grid_array(prior, "prior", ndim=None)
    lik = check_grid_array(likelihood, "likelihood", ndim=None)
    if p.shape != lik.shape:
        raise ValueError(f"prior and likelihood shapes differ: {p.shape} vs {lik.shape}")
    return bayes_update_unchecked(p, lik)


_F64 = np.dtype(np.float64)


def _float_arrays(a: ArrayLike, b: ArrayLike) -> bool:
    """Whether ``a`` and ``b`` are C-contiguous float64 arrays of one shape, which the compiled update takes as they
    are (checking their values itself); anything else is checked, converted or refused by name first."""
    return (
        type(a) is np.ndarray
        and type(b) is np.ndarray
        and a.dtype == _F64
        and b.dtype == _F64
        and a.shape == b.shape
        and a.flags.c_contiguous
        and b.flags.c_contiguous
    )


def bayes_update_unchecked(p: NDArray[np.float64], lik: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`bayes_update` of float arrays of one shape already known to hold probabilities (a filter's own)."""
    num = lik * p
    den = num + (1.0 - lik) * (1.0 - p)
    safe = den > 0.0
    return np.where(safe, num / np.where(safe, den, 1.0), p)


@dataclass(frozen=True, eq=False)
class Likelihood:
    """Every stage of the measurement model for one frame (the panels f-i of the paper's Fig. 6).

    Attributes
    ----------
    fired : ndarray, shape (D, nx, ny)
        Where each detector fired (in [0, 1]).
    covered : ndarray of bool, shape (D, nx, ny)
        Each detector's field of view this frame (all False for a detector without data this frame).
    detector_likelihoods : ndarray, shape (D, nx, ny)
        P(D_i | p) per detector (PPV / FNR; 0.5 outside its field of view).
    likelihood : ndarray, shape (nx, ny)
        The fused P(D_1..D_N | p) of eqs. 13-14.
    """

    fired: NDArray[np.float64]
    covered: NDArray[np.bool_]
    detector_likelihoods: NDArray[np.float64]
    likelihood: NDArray[np.float64]


def likelihood_from_detections(
    spec: GridSpec,
    detectors: Sequence[DetectorModel],
    detections: Sequence[ArrayLike | None],
) -> Likelihood:
    """Detections of N detectors -> per-detector maps and the fused likelihood.

    Parameters
    ----------
    spec : GridSpec
    detectors : sequence of DetectorModel, length D
    detections : sequence, length D
        Entry i is an ``(M_i, 2)`` array of positions (m, grid's sensor frame), or ``(M_i, 3)`` with each
        detection's own PPV in the third column (module docstring), or ``None`` when detector i has no data this
        frame (it then covers no cell).
    """
    return _likelihood(spec, detectors, detections, None)


def _likelihood(
    spec: GridSpec,
    detectors: Sequence[DetectorModel],
    detections: Sequence[ArrayLike | None],
    fovs: Sequence[NDArray[np.bool_]] | None,
    rates: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> Likelihood:
    """:func:`likelihood_from_detections`, with the detectors' fields of view and their ``(ppv, fnr)`` arrays given
    (a filter's, computed once) or looked up."""
    if len(detections) != len(detectors):
        raise ValueError(f"detections must have one entry per detector ({len(detectors)}), got {len(detections)}")
    d = len(detectors)
    fired = np.zeros((d, *spec.shape))
    covered = np.zeros((d, *spec.shape), dtype=bool)
    ppv, fnr = (np.array([m.ppv for m in detectors]), np.array([m.fnr for m in detectors])) if rates is None else rates
    ppv_cells: NDArray[np.float64] | None = None  # per cell, once a detector gives its detections' own PPV
    for i, (model, det) in enumerate(zip(detectors, detections, strict=True)):
        if det is None:
            continue
        pts, own = split_detections(det, f"detections of {model.name}")
        if own is None:
            fired[i] = _detection_map(spec, model, pts)
        else:
            if ppv_cells is None:
                ppv_cells = np.repeat(np.asarray(ppv, dtype=float)[:, None, None], spec.nx, axis=1).repeat(spec.ny, 2)
            fired[i], ppv_cells[i] = detection_ppv_map(spec, model, pts, own)
        covered[i] = fov_mask(spec, model) if fovs is None else fovs[i]
        if model.uncertainty == "point":
            covered[i] |= fired[i] > 0.0
    if ppv_cells is not None:
        per_det = np.where(covered, detector_likelihood(fired, ppv_cells, fnr[:, None, None]), 0.5)
        fused = fuse_detectors(fired, ppv_cells, fnr, covered=covered)
        return Likelihood(fired=fired, covered=covered, detector_likelihoods=per_det, likelihood=fused)
    if jit.enabled():
        per_det, fused = kernels.fuse_update(fired, covered, ppv, fnr)
        return Likelihood(fired=fired, covered=covered, detector_likelihoods=per_det, likelihood=fused)
    per_det = np.where(covered, detector_likelihood(fired, ppv[:, None, None], fnr[:, None, None]), 0.5)
    fused = fuse_detectors(fired, ppv, fnr, covered=covered)
    return Likelihood(fired=fired, covered=covered, detector_likelihoods=per_det, likelihood=fused)
