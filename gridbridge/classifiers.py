"""Classifiers: belief grid -> people, as components with one interface.

==========================  ==================================================================================
component                   what it does
==========================  ==================================================================================
:class:`BlobClassifier`     the paper's blob algorithm (Sect. 4; :func:`gridbridge.blobs.classify_blobs`)
:class:`ThresholdClassifier` connected cells above a threshold, each one person (the paper's "plain" classifier)
:class:`PeakClassifier`     local maxima above a threshold with non-maximum suppression; the position is the
                            belief-weighted mean of the cells around the peak (sub-cell); separates people
                            standing or walking close together, which connected components merge
:class:`HysteresisPeaks`    peaks with hysteresis (stateful): a person starts at a peak above ``threshold`` and
                            continues while a peak near where it was stays above ``keep``
==========================  ==================================================================================

Every classifier returns :class:`People`: positions (m, grid's sensor frame), a score per person (its peak
belief), its size in cells and the mask of cells it classified as people (for FPCPF).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from gridbridge import jit, kernels
from gridbridge.blobs import BlobParams, ClassificationResult, classify_blobs, classify_threshold
from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from gridbridge.limits import check_smooth
from gridbridge.validation import check_positive, check_probability

__all__ = [
    "BlobClassifier",
    "Classifier",
    "HysteresisPeaks",
    "PeakClassifier",
    "People",
    "ThresholdClassifier",
    "classify_frame",
    "classify_peaks",
    "ordered_candidates",
    "peak_maxima",
    "people_cells",
]


@dataclass(frozen=True, eq=False)
class People:
    """People classified in one belief grid.

    Attributes
    ----------
    positions : ndarray, shape (K, 2)
        (x, y) in metres, the grid's sensor frame.
    scores : ndarray, shape (K,)
        Confidence of each person in [0, 1] (peak or mean belief, see the classifier).
    sizes : ndarray of int, shape (K,)
        Cells of each person.
    mask : ndarray of bool, shape (nx, ny)
        Cells classified as people.
    """

    positions: NDArray[np.float64]
    scores: NDArray[np.float64]
    sizes: NDArray[np.int64]
    mask: NDArray[np.bool_]

    def __len__(self) -> int:
        return len(self.positions)

    def __repr__(self) -> str:
        """A short summary: count, positions and scores rounded, and the mask's shape and cell count.

        Returns
        -------
        str
            E.g. ``People(n=2, positions=[(3.00, 0.45), (1.20, -0.60)], scores=[0.90, 0.75], sizes=[4, 3],
            mask=(30, 30) 7 cells)``; more than 5 people end in ``...``.
        """
        n = len(self.positions)
        xy = np.round(np.asarray(self.positions, dtype=float)[:5], 2) + 0.0  # + 0.0: no "-0.00"
        pos = ", ".join(f"({x:.2f}, {y:.2f})" for x, y in xy.tolist())
        scores = ", ".join(f"{s:.2f}" for s in np.asarray(self.scores, dtype=float)[:5].tolist())
        sizes = ", ".join(str(int(s)) for s in np.asarray(self.sizes)[:5].tolist())
        more = ", ..." if n > 5 else ""
        mask = np.asarray(self.mask)
        return (
            f"People(n={n}, positions=[{pos}{more}], scores=[{scores}{more}], sizes=[{sizes}{more}], "
            f"mask={tuple(mask.shape)} {int(np.count_nonzero(mask))} cells)"
        )


def _from_blobs(result: ClassificationResult) -> People:
    sel = result.people
    return People(
        positions=result.positions.reshape(-1, 2),
        scores=np.array([b.mean_probability for b in sel], dtype=float),
        sizes=np.array([b.size for b in sel], dtype=np.int64),
        mask=result.mask,
    )


@runtime_checkable
class Classifier(Protocol):
    """What a classifier does: ``classify(belief (nx, ny), spec) -> People``."""

    def classify(self, belief: ArrayLike, spec: GridSpec, *, observed: ArrayLike | None = None) -> People: ...


@dataclass(frozen=True, kw_only=True)
class BlobClassifier:
    """The paper's blob classification (Sect. 4) with :class:`~gridbridge.blobs.BlobParams`."""

    params: BlobParams = field(default_factory=BlobParams)

    def classify(self, belief: ArrayLike, spec: GridSpec, *, observed: ArrayLike | None = None) -> People:
        """People in ``belief``; ``observed`` is ignored (the paper classifies the whole grid)."""
        return _from_blobs(classify_blobs(belief, spec=spec, params=self.params))


@dataclass(frozen=True, kw_only=True)
class ThresholdClassifier:
    """Connected components of cells above ``threshold``, each one person."""

    threshold: float = 0.5

    def __post_init__(self) -> None:
        check_probability(self.threshold, "ThresholdClassifier.threshold")

    def classify(self, belief: ArrayLike, spec: GridSpec, *, observed: ArrayLike | None = None) -> People:
        """People in ``belief``; ``observed`` is ignored."""
        return _from_blobs(classify_threshold(belief, self.threshold, spec=spec))


def peak_maxima(
    grid: NDArray[np.float64], spec: GridSpec, min_separation: float, smooth: float = 0.0
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Step 1 of :func:`classify_peaks` before the threshold: which cells are local maxima, and their values.

    Parameters
    ----------
    grid : ndarray, shape (nx, ny)
        A checked belief grid.
    spec : GridSpec
    min_separation : float
        A cell is a maximum when no cell of :func:`maximum_window` (the cells closer than it, and the 8
        neighbours) is higher.
    smooth : float
        Standard deviation (cells) of the Gaussian the maxima are found on; 0: the grid itself.

    Returns
    -------
    is_max : ndarray of bool, shape (nx, ny)
        Cells that are the maximum of their window (of the smoothed grid with ``smooth > 0``).
    value : ndarray, shape (nx, ny)
        Each cell's belief: the grid itself, or with ``smooth > 0`` the largest belief within one cell.
    """
    window = maximum_window(min_separation, spec.resolution)
    if smooth > 0:
        found = ndimage.gaussian_filter(grid, smooth, mode="constant", cval=0.0)
        value = ndimage.maximum_filter(grid, size=3, mode="constant", cval=0.0)
    else:
        found = value = grid
    local_max = ndimage.maximum_filter(found, footprint=window, mode="constant", cval=0.0)
    return found >= local_max, value


@functools.lru_cache(maxsize=16)
def maximum_window(min_separation: float, resolution: float) -> NDArray[np.bool_]:
    """The local-maximum window of :func:`peak_maxima`, shape ``(2 h + 1, 2 h + 1)`` (``h >= 1`` cells): the cells
    whose centres are closer than ``min_separation`` (m) to the middle one, and its 8 neighbours (read-only, shared
    between calls).

    A peak is suppressed only by a higher belief closer than ``min_separation``: two people that far apart keep a
    peak each (a square window of half-width ``h`` would also suppress a peak ``h`` cells away diagonally, 0.85 m
    for 0.6 m and 0.3 m cells: two people standing side by side in a group).
    """
    reach, block = _block_kernel(min_separation, resolution)
    di, dj = np.nonzero(block)
    half = max(1, int(np.max(np.abs(di - reach))), int(np.max(np.abs(dj - reach))))
    window = np.zeros((2 * half + 1, 2 * half + 1), dtype=bool)
    window[di - reach + half, dj - reach + half] = True
    window[half - 1 : half + 2, half - 1 : half + 2] = True
    window.setflags(write=False)
    return window


def classify_peaks(
    belief: ArrayLike,
    spec: GridSpec,
    *,
    threshold: float = 0.5,
    min_separation: float = 0.6,
    centroid_radius: float = 0.35,
    smooth: float = 0.0,
) -> People:
    """People at local maxima of the belief, with non-maximum suppression.

    1. Candidates: cells with belief ``> threshold`` that are the maximum of the cells whose centres are closer
       than ``min_separation`` and of their 8 neighbours (:func:`maximum_window`). With ``smooth = s > 0`` the
       maxima are those of the belief convolved with a Gaussian of ``s`` cells (``scipy.ndimage.gaussian_filter``,
       zero outside the grid: a kernel density estimate of a noisy grid such as the particle filter's rasterised
       mass, whose person is a ragged blob with several separate cells at the bound), and a candidate's belief is
       the largest belief within one cell of it (the threshold keeps its meaning).
    2. Non-maximum suppression: candidates in decreasing belief order (ties: row-major cell order); a candidate
       closer than ``min_separation`` (centre to centre) to a kept one is dropped (plateaus give one person).
    3. Position: the belief-weighted mean of the cell centres within ``centroid_radius`` of the peak cell whose
       belief is at least half the threshold; score: the peak belief; size: those cells.

    Parameters
    ----------
    belief : array_like, shape (nx, ny)
        Probability of a person per cell.
    spec : GridSpec
    threshold : float
        A peak's belief must be strictly above it.
    min_separation : float
        Two people are at least this far apart (m).
    centroid_radius : float
        Radius (m) of the cells averaged into the position.
    smooth : float
        Standard deviation (cells) of the Gaussian the maxima are found on; 0: the belief itself.

    Returns
    -------
    People
    """
    if not isinstance(spec, GridSpec):
        raise TypeError(f"spec must be a GridSpec, got {type(spec).__name__}")
    grid = spec.check_grid(belief, "belief")
    check_probability(threshold, "threshold")
    check_positive(min_separation, "min_separation")
    check_positive(centroid_radius, "centroid_radius", allow_zero=True)
    smooth = check_smooth(smooth, "smooth")
    return _classify_checked(grid, spec, threshold, min_separation, centroid_radius, smooth)


def _classify_checked(
    grid: NDArray[np.float64],
    spec: GridSpec,
    threshold: float,
    min_separation: float,
    centroid_radius: float,
    smooth: float,
) -> People:
    """:func:`classify_peaks` of a checked belief grid ``(nx, ny)`` with checked settings (as there)."""
    cand, values = ordered_candidates(grid, spec, threshold, min_separation, smooth)
    if len(cand) == 0:
        return People(
            positions=np.zeros((0, 2)),
            scores=np.zeros(0),
            sizes=np.zeros(0, dtype=np.int64),
            mask=np.zeros(spec.shape, dtype=bool),
        )
    kept = _suppress_non_maxima(cand, spec, min_separation)
    return _peak_people(grid, spec, cand[kept], values[kept], threshold, centroid_radius)


def ordered_candidates(
    grid: NDArray[np.float64], spec: GridSpec, threshold: float, min_separation: float, smooth: float
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Step 1 of :func:`classify_peaks`: the candidate peaks in decreasing belief order (also the weaker peaks
    of :func:`pfpeople.track.belief_inputs.tracker_inputs`).

    Compiled (:func:`gridbridge.kernels.peak_candidates`, only the cells above ``threshold`` are looked at) when
    ``smooth = 0``; otherwise by :func:`peak_maxima`'s maximum filters. The two give the same cells.

    Parameters
    ----------
    grid : ndarray, shape (nx, ny)
        The checked belief grid.
    spec : GridSpec
    threshold : float
        A candidate's belief must be strictly above it.
    min_separation : float
        Sets the local-maximum window (m, :func:`peak_maxima`).
    smooth : float
        Standard deviation (cells) of the Gaussian the maxima are found on; 0: the belief itself.

    Returns
    -------
    cand : ndarray of int, shape (K, 2)
        The candidates' cells ``(i, j)``, by decreasing belief (ties: row-major cell order).
    values : ndarray, shape (K,)
        Their beliefs (with ``smooth > 0`` the largest belief within one cell), in the same order.
    """
    if smooth == 0 and threshold >= 0 and jit.enabled():  # the maxima of the belief itself: only where it is high
        window = maximum_window(min_separation, spec.resolution)  # peak_maxima's window
        value, cand = (
            grid,
            kernels.peak_candidates(np.ascontiguousarray(grid, dtype=np.float64), window, float(threshold)),
        )
    else:
        is_max, value = peak_maxima(grid, spec, min_separation, smooth)
        cand = np.argwhere((value > threshold) & is_max)
    values = value[cand[:, 0], cand[:, 1]]
    order = np.lexsort((cand[:, 1], cand[:, 0], -values))
    return cand[order], values[order]


@functools.lru_cache(maxsize=16)
def _block_kernel(min_separation: float, resolution: float) -> tuple[int, NDArray[np.bool_]]:
    """The non-maximum suppression window of :func:`_suppress_non_maxima`: its reach (cells) and the cells
    ``(2 reach + 1, 2 reach + 1)`` whose centres are closer than ``min_separation`` (m) to the middle one
    (read-only, shared between calls)."""
    sep = min_separation / resolution
    reach_s = math.ceil(sep - 1e-9)
    si, sj = np.mgrid[-reach_s : reach_s + 1, -reach_s : reach_s + 1]
    block = (si**2 + sj**2) < sep**2 - 1e-9
    block.setflags(write=False)
    return reach_s, block


@functools.lru_cache(maxsize=16)
def _disk_offsets(centroid_radius: float, resolution: float) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The cell offsets ``(di, dj)``, each shape (D,), whose centres are within ``centroid_radius`` (m) of a
    cell's centre (:func:`_peak_people`; read-only, shared between calls)."""
    r = resolution
    reach = math.floor(centroid_radius / r + 1e-9)
    di, dj = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    disk = (di**2 + dj**2) * r * r <= centroid_radius**2 + 1e-12
    di, dj = di[disk], dj[disk]
    di.setflags(write=False)
    dj.setflags(write=False)
    return di, dj


def _suppress_non_maxima(cand: NDArray[np.intp], spec: GridSpec, min_separation: float) -> list[int]:
    """Greedy non-maximum suppression on the grid (step 2 of :func:`classify_peaks`): the indices of the kept
    candidates ``(K, 2)`` (cells, in decreasing belief order), each blocking every cell centre within
    ``min_separation`` (m)."""
    reach_s, block = _block_kernel(min_separation, spec.resolution)
    blocked = np.zeros(spec.shape, dtype=bool)
    kept: list[int] = []
    for k in range(len(cand)):
        i, j = int(cand[k, 0]), int(cand[k, 1])
        if blocked[i, j]:
            continue
        kept.append(k)
        i0, i1 = max(i - reach_s, 0), min(i + reach_s + 1, spec.nx)
        j0, j1 = max(j - reach_s, 0), min(j + reach_s + 1, spec.ny)
        blocked[i0:i1, j0:j1] |= block[i0 - i + reach_s : i1 - i + reach_s, j0 - j + reach_s : j1 - j + reach_s]
    return kept


def _peak_people(
    grid: NDArray[np.float64],
    spec: GridSpec,
    peaks: NDArray[np.intp],
    values: NDArray[np.float64],
    threshold: float,
    centroid_radius: float,
) -> People:
    """Step 3 of :func:`classify_peaks`: each kept peak's position (belief-weighted mean of the cells within
    ``centroid_radius`` m whose belief is at least half the threshold), score and size."""
    di, dj = _disk_offsets(centroid_radius, spec.resolution)
    x0, y0, r = spec.x0, spec.y0, spec.resolution
    mask = np.zeros(spec.shape, dtype=bool)
    if jit.enabled() and len(peaks):  # the same sums, compiled (gridbridge.kernels.peak_centroids)
        g = np.ascontiguousarray(grid, dtype=np.float64)
        cells = np.ascontiguousarray(peaks, dtype=np.intp)
        centres, counts = kernels.peak_centroids(g, cells, di, dj, 0.5 * threshold, mask)
        xy = [(x0 + (ci + 0.5) * r, y0 + (cj + 0.5) * r) for ci, cj in centres.tolist()]  # GridSpec.cell_centre
        return People(
            positions=np.asarray(xy, dtype=float).reshape(-1, 2),
            scores=np.asarray(values.tolist(), dtype=float),
            sizes=counts,
            mask=mask,
        )
    positions, scores, sizes = [], [], []
    for (i, j), v in zip(peaks.tolist(), values.tolist(), strict=True):
        ii, jj = i + di, j + dj
        ok = (ii >= 0) & (ii < spec.nx) & (jj >= 0) & (jj < spec.ny)
        ii, jj = ii[ok], jj[ok]
        w = grid[ii, jj]
        use = w >= 0.5 * threshold
        ii, jj, w = ii[use], jj[use], w[use]
        total = w.sum()
        ci = float((w * ii).sum() / total)
        cj = float((w * jj).sum() / total)
        positions.append((x0 + (ci + 0.5) * r, y0 + (cj + 0.5) * r))  # GridSpec.cell_centre, in Python floats
        scores.append(float(v))
        sizes.append(len(w))
        mask[ii, jj] = True
    return People(
        positions=np.asarray(positions, dtype=float).reshape(-1, 2),
        scores=np.asarray(scores, dtype=float),
        sizes=np.asarray(sizes, dtype=np.int64),
        mask=mask,
    )


@dataclass(frozen=True, kw_only=True)
class PeakClassifier:
    """:func:`classify_peaks` as a component (parameters as there).

    ``only_observed``: only cells some detector observes in the frame can be people (a person who walked out of
    every field of view is still in the belief, for when they come back, but is not reported).
    """

    threshold: float = 0.5
    min_separation: float = 0.6
    centroid_radius: float = 0.35
    only_observed: bool = True
    smooth: float = 0.0

    def __post_init__(self) -> None:
        check_probability(self.threshold, "PeakClassifier.threshold")
        check_positive(self.min_separation, "PeakClassifier.min_separation")
        check_positive(self.centroid_radius, "PeakClassifier.centroid_radius", allow_zero=True)
        check_smooth(self.smooth, "PeakClassifier.smooth")

    def classify(self, belief: ArrayLike, spec: GridSpec, *, observed: ArrayLike | None = None) -> People:
        """People at the peaks of ``belief``; with ``only_observed``, cells outside ``observed`` (bool
        ``(nx, ny)``: the cells some detector covered this frame) are not people."""
        if self.only_observed and observed is not None:
            belief = np.where(np.asarray(observed, dtype=bool), spec.check_grid(belief, "belief"), 0.0)
            if belief.shape == spec.shape:  # the checked grid, zero outside: classify_peaks without checking it again
                args = (self.threshold, self.min_separation, self.centroid_radius, float(self.smooth))
                return _classify_checked(belief, spec, *args)
        return classify_peaks(
            belief,
            spec,
            threshold=self.threshold,
            min_separation=self.min_separation,
            centroid_radius=self.centroid_radius,
            smooth=self.smooth,
        )


class HysteresisPeaks:
    """Peaks with hysteresis: what was a person in the previous frame needs less belief to stay one.

    A peak (:func:`classify_peaks`, non-maximum suppression ``min_separation``) is a person when its belief is
    above ``threshold``, or above ``keep`` (< ``threshold``) and within ``gate`` of a person of the previous frame
    (moved into this frame by ``ego``). One miss of both laser detectors multiplies a person's odds by
    FNR_legs x FNR_boosted (0.60 x 0.55 = 0.33) while the prediction spreads the peak: a walker found at P = 0.8 falls
    to about 0.55 at the next miss, and without hysteresis is lost for that frame. The two thresholds are
    the usual start / continue pair of trackers; with ``keep = threshold`` it is :class:`PeakClassifier`.

    It is stateful: call :meth:`reset` when the filter restarts, and pass ``ego`` (the current grid frame in
    the previous one; None: the grid did not move) to :meth:`classify` once per frame, in order.

    Parameters
    ----------
    threshold, keep : float
        Thresholds on a peak's belief, ``0 <= keep <= threshold <= 1`` (strictly above, as :func:`classify_peaks`).
    gate : float
        Largest distance (m) from a person of the previous frame for a peak above ``keep`` to continue it.
    min_separation, centroid_radius, only_observed, smooth
        As :class:`PeakClassifier`.
    """

    stateful = True

    def __init__(
        self,
        *,
        threshold: float = 0.7,
        keep: float = 0.5,
        gate: float = 0.5,
        min_separation: float = 0.6,
        centroid_radius: float = 0.35,
        only_observed: bool = True,
        smooth: float = 0.0,
    ) -> None:
        check_probability(threshold, "HysteresisPeaks.threshold")
        check_probability(keep, "HysteresisPeaks.keep")
        if keep > threshold:
            raise ValueError(f"HysteresisPeaks.keep must be <= threshold, got keep={keep!r} > threshold={threshold!r}")
        self.threshold, self.keep = float(threshold), float(keep)
        self.gate = check_positive(gate, "HysteresisPeaks.gate", allow_zero=True)
        self.peaks = PeakClassifier(
            threshold=keep,
            min_separation=min_separation,
            centroid_radius=centroid_radius,
            only_observed=only_observed,
            smooth=smooth,
        )
        self.previous = np.zeros((0, 2))
        """People of the latest frame (m, its grid frame), shape (K, 2)."""
        self.rejected: People | None = None
        """The latest frame's peaks above ``keep`` that were not people (no previous person near them): the
        weaker peaks, already separated from the people by ``min_separation`` (e.g. for a tracker)."""

    def reset(self) -> None:
        """Forget the previous frame's people."""
        self.previous = np.zeros((0, 2))

    def classify(
        self, belief: ArrayLike, spec: GridSpec, *, observed: ArrayLike | None = None, ego: Pose2D | None = None
    ) -> People:
        """People of this frame (see the class docstring); ``ego`` moves the previous frame's people."""
        if ego is not None and not isinstance(ego, Pose2D):
            raise TypeError(f"ego must be a Pose2D or None, got {type(ego).__name__}")
        cand = self.peaks.classify(belief, spec, observed=observed)
        prev = self.previous
        if ego is not None and prev.shape[0]:
            prev = ego.inverse().apply(prev)
        ok = cand.scores > self.threshold
        if prev.shape[0] and cand.positions.shape[0] and self.keep < self.threshold:
            d = np.hypot(cand.positions[:, None, 0] - prev[None, :, 0], cand.positions[:, None, 1] - prev[None, :, 1])
            ok |= d.min(axis=1) <= self.gate
        mask = cand.mask if ok.all() else people_cells(cand.mask, spec, cand.positions, ok)
        found = People(positions=cand.positions[ok], scores=cand.scores[ok], sizes=cand.sizes[ok], mask=mask)
        self.previous = found.positions.copy()
        self.rejected = People(
            positions=cand.positions[~ok], scores=cand.scores[~ok], sizes=cand.sizes[~ok], mask=np.zeros_like(mask)
        )
        return found


def people_cells(mask: ArrayLike, spec: GridSpec, positions: ArrayLike, keep: ArrayLike) -> NDArray[np.bool_]:
    """The cells of ``mask`` that belong to the kept people: each cell belongs to its nearest person.

    Parameters
    ----------
    mask : array_like of bool, shape (nx, ny)
        Cells classified as people (of every person in ``positions``).
    spec : GridSpec
    positions : array_like, shape (K, 2)
        The people (m, grid frame).
    keep : array_like of bool, shape (K,)
        Which people stay.

    Returns
    -------
    ndarray of bool, shape (nx, ny)
    """
    mask = np.asarray(mask, dtype=bool)
    pos = np.asarray(positions, dtype=float).reshape(-1, 2)
    keep = np.asarray(keep, dtype=bool).reshape(-1)
    if keep.shape[0] != pos.shape[0]:
        raise ValueError(f"keep has {keep.shape[0]} entries for {pos.shape[0]} people")
    out = np.zeros(spec.shape, dtype=bool)
    cells = np.flatnonzero(mask)
    if not cells.size or not keep.any():
        return out
    gx, gy = _flat_centres(spec)
    d = np.hypot(gx[cells, None] - pos[None, :, 0], gy[cells, None] - pos[None, :, 1])
    out.ravel()[cells[keep[np.argmin(d, axis=1)]]] = True
    return out


@functools.lru_cache(maxsize=16)
def _flat_centres(spec: GridSpec) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:meth:`GridSpec.cell_centres` raveled (row-major, ``(nx ny,)`` each; read-only, shared between calls)."""
    gx, gy = (np.ascontiguousarray(g).ravel() for g in spec.cell_centres())
    gx.setflags(write=False)
    gy.setflags(write=False)
    return gx, gy


def classify_frame(
    classifier: Classifier | HysteresisPeaks,
    belief: ArrayLike,
    spec: GridSpec,
    *,
    observed: ArrayLike | None = None,
    ego: Pose2D | None = None,
) -> People:
    """``classifier.classify`` for one frame of a sequence: a stateful classifier (:class:`HysteresisPeaks`)
    also gets ``ego`` (the current grid frame in the previous one), a stateless one does not need it."""
    if getattr(classifier, "stateful", False):
        return classifier.classify(belief, spec, observed=observed, ego=ego)  # type: ignore[call-arg]
    return classifier.classify(belief, spec, observed=observed)
