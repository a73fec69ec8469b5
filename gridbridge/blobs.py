"""Classification of the belief grid into people: the paper's blob algorithm and a plain threshold.

Batista & Pereira (2015), Sect. 4 ("we propose a classification algorithm based on similar
probabilities"). The algorithm, as implemented here (every threshold is a :class:`BlobParams` field):

1. **Seeds.** Cells with probability ``> seed_threshold`` (0.26) are selected; selected cells that are
   neighbours (``connectivity`` 8 by default, 4 optional) form one blob (connected components,
   :func:`scipy.ndimage.label`).
2. **Growth.** Cells that are not in a blob but neighbour one are *visited*. "If the difference between
   the probability values of these cells and their neighboring cells in the blob is smaller than a
   threshold (0.40), the cell is also included in the blob": per neighbouring blob, the difference is taken
   to the most similar neighbouring cell of that blob (``growth_compare='closest'``, default), to the mean
   of its neighbouring cells in that blob (``'mean'``) or to the least similar one (``'all'``: every
   neighbouring blob cell within the threshold). The cell joins the blob with the smallest difference if it
   is ``< growth_threshold``; ties go to the lower blob label. (On filtered beliefs the three readings gave
   nearly the same detections; ``'closest'`` is the loosest.) The visit is one synchronous pass over
   the ring of cells around the seed blobs (``growth_passes = 1``): "in the next step, all cells that do
   not belong to a blob, but that are neighbors of a blob, are visited" describes one step, and we read it
   so. ``growth_passes = k`` repeats the pass k times (each pass visits the unassigned neighbours of the
   grown blobs), approaching region growing. Why not grow until nothing joins: a belief grid is smooth (the
   people motion model blurs it), so chains of steps below 0.40 lead from almost every peak down to the
   background; region growing then swallows every person into one background blob that fails the
   "all cells > 0.1" rule (checked: a 0.57 peak on a 0.05 background is lost that way, found with one pass).
3. **New blobs.** "Otherwise, a new blob is created" -- our reading: the visited cells that joined no blob
   form new blobs among themselves by the same similarity rule: the connected components of the graph whose
   nodes are the rejected cells and whose edges join neighbouring rejected cells differing by
   ``< growth_threshold``. Then "all cells visited are part of a blob". Cells never visited (farther from
   every seed blob) are in no blob (label 0); with no seed there are no blobs and nobody is classified.
4. **Selection.** A blob represents a person when all of

   - its mean probability is larger than the mean of the means of its neighbouring blobs (blobs with a cell
     adjacent under ``connectivity``); a blob with no neighbouring blob passes;
   - all its cells have probability ``> min_cell_probability`` (0.1);
   - it has at most ``small_blob_cells`` (3) cells, or, if larger, all of:
     (i) at most ``max_border_cells`` (3) of its cells lie on the grid border (first/last row/column);
     (ii) the height (extent along i, cells) and the width (extent along j, cells) of its bounding box are
     both ``< max_extent_cells`` (8);
     (iii) the aspect criterion ``min(h, w) / max(h, w) >= min_aspect_ratio`` (0.5).

   Reading of (iii): the paper says "the ratio between the height and width of the blob is smaller than a
   threshold (0.5)". Taken literally (``h / w < 0.5``) it would accept only blobs at least twice as wide
   (along y) as tall (along x) and reject every square blob -- a person's footprint is about round and the
   grid axes are not tied to how people move, so that cannot be meant. We read it as a bound on elongation:
   the blob's bounding box may not be more elongated than 2:1, i.e. ``min/max >= 0.5`` (equivalently the
   "ratio" ``1 - min/max`` is ``<= 0.5``). A 2 x 4 blob passes, a 2 x 5 blob fails.

The paper's blob centroid ("the cell whose coordinates are the average of the coordinates of the cells
with the higher probability in the blob") is :attr:`Blob.centroid_cells`: the mean cell index of the cells
whose probability equals the blob's maximum (within ``peak_atol``), converted to metres by
:meth:`GridSpec.cell_centre`.

:func:`classify_threshold` is the plain classifier the paper mentions: connected components of cells
above a fixed threshold, each a person.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from gridbridge.grid import GridSpec
from gridbridge.validation import check_int, check_positive, check_probability

__all__ = [
    "Blob",
    "BlobParams",
    "ClassificationResult",
    "classify_blobs",
    "classify_threshold",
]

#: Names of the selection rules, as they appear in :attr:`Blob.rejected_by`.
RULE_MEAN = "mean_not_above_neighbours"
RULE_MIN_CELL = "cell_not_above_min"
RULE_BORDER = "too_many_border_cells"
RULE_EXTENT = "too_high_or_wide"
RULE_ASPECT = "too_elongated"

_OFFSETS_8 = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))
_OFFSETS_4 = ((-1, 0), (0, -1), (0, 1), (1, 0))


@dataclass(frozen=True, kw_only=True)
class BlobParams:
    """Thresholds of the blob classification; defaults are the paper's (Sect. 4).

    Parameters
    ----------
    seed_threshold : float
        Cells with probability strictly above it seed blobs (paper 0.26).
    growth_threshold : float
        A visited cell joins a neighbouring blob when its absolute probability difference to the
        neighbouring blob cell is strictly below it (paper 0.40).
    min_cell_probability : float
        A person blob has all cells strictly above it (paper 0.1).
    small_blob_cells : int
        Blobs with at most this many cells skip the shape criteria (paper 3).
    max_border_cells : int
        Larger blobs may have at most this many cells on the grid border (paper 3).
    max_extent_cells : int
        Larger blobs must have bounding-box height and width strictly below it, in cells (paper 8).
    min_aspect_ratio : float
        Larger blobs need ``min(h, w) / max(h, w) >= min_aspect_ratio`` (paper's ratio threshold 0.5;
        see the module docstring for this reading).
    growth_compare : {'closest', 'mean', 'all'}
        What a visited cell is compared with, per neighbouring blob: its most similar neighbouring cell in
        the blob (``'closest'``, default), the mean of its neighbouring cells in the blob (``'mean'``), or
        every neighbouring cell in the blob must be within the threshold (``'all'``).
    growth_passes : int
        Number of growth passes (paper reading: 1; see the module docstring).
    connectivity : int
        4 or 8: which cells are neighbours, for seeds, growth and blob adjacency (default 8).
    peak_atol : float
        Cells within this of the blob's maximum probability count as "the cells with the highest
        probability" for the paper's centroid.
    """

    seed_threshold: float = 0.26
    growth_threshold: float = 0.40
    min_cell_probability: float = 0.1
    small_blob_cells: int = 3
    max_border_cells: int = 3
    max_extent_cells: int = 8
    min_aspect_ratio: float = 0.5
    growth_compare: Literal["closest", "mean", "all"] = "closest"
    growth_passes: int = 1
    connectivity: int = 8
    peak_atol: float = 1e-9

    def __post_init__(self) -> None:
        check_probability(self.seed_threshold, "BlobParams.seed_threshold")
        check_positive(self.growth_threshold, "BlobParams.growth_threshold")
        check_probability(self.min_cell_probability, "BlobParams.min_cell_probability")
        if self.growth_compare not in ("closest", "mean", "all"):
            raise ValueError(
                f"BlobParams.growth_compare must be 'closest', 'mean' or 'all', got {self.growth_compare!r}"
            )
        check_int(self.growth_passes, "BlobParams.growth_passes", minimum=1)
        for name in ("small_blob_cells", "max_border_cells", "max_extent_cells"):
            check_int(getattr(self, name), f"BlobParams.{name}", minimum=0)
        check_probability(self.min_aspect_ratio, "BlobParams.min_aspect_ratio")
        if self.connectivity not in (4, 8) or isinstance(self.connectivity, bool):
            raise ValueError(f"BlobParams.connectivity must be 4 or 8, got {self.connectivity!r}")
        check_positive(self.peak_atol, "BlobParams.peak_atol", allow_zero=True)


@dataclass(frozen=True, eq=False)
class Blob:
    """One blob of the classified grid.

    Attributes
    ----------
    label : int
        Its value in :attr:`ClassificationResult.labels` (1-based).
    cells : ndarray, shape (K, 2), int
        Cell indices ``[i, j]`` of its cells, row-major order.
    mean_probability, max_probability, min_probability : float
        Statistics of the belief over its cells.
    centroid_cells : ndarray, shape (2,)
        The paper's centroid in fractional cell indices ``(i, j)``: mean index of the cells whose
        probability is the blob's maximum.
    centroid : ndarray, shape (2,)
        The same point in metres, sensor frame ``(x, y)``, via :meth:`GridSpec.cell_centre`.
    mean_cell : ndarray, shape (2,)
        Mean cell index of all its cells (geometric centre), fractional ``(i, j)``.
    height, width : int
        Bounding-box extent along i (x) and along j (y), in cells.
    border_cells : int
        Number of its cells on the grid border.
    neighbours : tuple of int
        Labels of the adjacent blobs.
    selected : bool
        True when the blob is classified as a person.
    rejected_by : tuple of str
        Names of the selection rules it failed (empty when selected).
    """

    label: int
    cells: NDArray[np.intp]
    mean_probability: float
    max_probability: float
    min_probability: float
    centroid_cells: NDArray[np.float64]
    centroid: NDArray[np.float64]
    mean_cell: NDArray[np.float64]
    height: int
    width: int
    border_cells: int
    neighbours: tuple[int, ...] = ()
    selected: bool = False
    rejected_by: tuple[str, ...] = field(default_factory=tuple)

    @property
    def size(self) -> int:
        """Number of cells."""
        return int(self.cells.shape[0])

    def mask(self, shape: tuple[int, int]) -> NDArray[np.bool_]:
        """Boolean ``shape`` grid, True on the blob's cells."""
        out = np.zeros(shape, dtype=bool)
        out[self.cells[:, 0], self.cells[:, 1]] = True
        return out


@dataclass(frozen=True, eq=False)
class ClassificationResult:
    """Output of a classifier.

    Attributes
    ----------
    blobs : list of Blob
        Every blob, in label order.
    labels : ndarray, shape (nx, ny), int
        Blob label of each cell, 0 where no blob.
    spec : GridSpec
        The grid the belief was defined on.
    """

    blobs: list[Blob]
    labels: NDArray[np.intp]
    spec: GridSpec

    @property
    def people(self) -> list[Blob]:
        """The blobs classified as people."""
        return [b for b in self.blobs if b.selected]

    @property
    def mask(self) -> NDArray[np.bool_]:
        """``(nx, ny)`` bool: cells classified as people."""
        out = np.zeros(self.labels.shape, dtype=bool)
        for b in self.people:
            out[b.cells[:, 0], b.cells[:, 1]] = True
        return out

    @property
    def positions(self) -> NDArray[np.float64]:
        """``(K, 2)`` people positions (paper's centroids), metres, sensor frame."""
        people = self.people
        if not people:
            return np.zeros((0, 2))
        return np.stack([b.centroid for b in people])

    @property
    def masks(self) -> NDArray[np.bool_]:
        """``(K, nx, ny)`` bool: one cell mask per person blob."""
        shape = (int(self.labels.shape[0]), int(self.labels.shape[1]))
        if not self.people:
            return np.zeros((0, *shape), dtype=bool)
        return np.stack([b.mask(shape) for b in self.people])


def _shift(arr: NDArray, di: int, dj: int, fill: float | int) -> NDArray:
    """``out[i, j] = arr[i + di, j + dj]``, ``fill`` where that is outside the array."""
    nx, ny = arr.shape
    out = np.full_like(arr, fill)
    src_i = slice(max(di, 0), nx + min(di, 0))
    dst_i = slice(max(-di, 0), nx + min(-di, 0))
    src_j = slice(max(dj, 0), ny + min(dj, 0))
    dst_j = slice(max(-dj, 0), ny + min(-dj, 0))
    out[dst_i, dst_j] = arr[src_i, src_j]
    return out


def _structure(connectivity: int) -> NDArray[np.bool_]:
    return ndimage.generate_binary_structure(2, 1 if connectivity == 4 else 2)


def _grow(belief: NDArray[np.float64], labels: NDArray[np.intp], params: BlobParams) -> None:
    """Steps 2-3 of the module docstring, in place on ``labels``.

    Parameters
    ----------
    belief : ndarray, shape (nx, ny)
        Probability of a person per cell.
    labels : ndarray of int, shape (nx, ny)
        The seed blobs' labels (1, 2, ...; 0: no blob); the grown and the new blobs are written into it.
    params : BlobParams
    """
    offsets = _OFFSETS_8 if params.connectivity == 8 else _OFFSETS_4
    shifted_p = [_shift(belief, di, dj, np.nan) for di, dj in offsets]
    rejected = np.zeros(belief.shape, dtype=bool)
    for _ in range(params.growth_passes):
        unassigned = labels == 0
        best_d = np.full(belief.shape, np.inf)
        best_lab = np.zeros(belief.shape, dtype=np.intp)
        shifted_lab = [_shift(labels, di, dj, 0) for di, dj in offsets]
        touching = np.zeros(belief.shape, dtype=bool)
        for lab_n in shifted_lab:
            touching |= lab_n > 0
        for lab in np.unique(labels[ndimage.binary_dilation(unassigned & touching, structure=_structure(8))]):
            if lab == 0:
                continue
            has, d_lab = _blob_difference(belief, int(lab), unassigned, shifted_lab, shifted_p, params.growth_compare)
            better = has & (d_lab < best_d)  # labels ascend: ties stay with the lower label
            best_d = np.where(better, d_lab, best_d)
            best_lab = np.where(better, lab, best_lab)
        visited = best_lab > 0
        join = visited & (best_d < params.growth_threshold)
        labels[join] = best_lab[join]
        rejected = (rejected | visited) & ~join
        if not join.any():
            break
    rejected &= labels == 0
    if rejected.any():
        _new_blobs(belief, labels, rejected, offsets, shifted_p, params.growth_threshold)


def _blob_difference(
    belief: NDArray[np.float64],
    lab: int,
    unassigned: NDArray[np.bool_],
    shifted_lab: list[NDArray[np.intp]],
    shifted_p: list[NDArray[np.float64]],
    compare: str,
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """One growth pass's difference of each unassigned cell to its neighbouring cells of blob ``lab`` (step 2).

    Parameters
    ----------
    belief : ndarray, shape (nx, ny)
        Probability of a person per cell.
    lab : int
        The blob's label.
    unassigned : ndarray of bool, shape (nx, ny)
        Cells in no blob yet.
    shifted_lab, shifted_p : list of ndarray, each (nx, ny)
        Per neighbour offset, the labels (0 outside the grid) and the beliefs (NaN outside) of that neighbour.
    compare : {'closest', 'mean', 'all'}
        ``BlobParams.growth_compare``.

    Returns
    -------
    has : ndarray of bool, shape (nx, ny)
        Unassigned cells with a neighbour in the blob.
    d_lab : ndarray, shape (nx, ny)
        Their probability difference to the blob (meaningful where ``has``).
    """
    d_min = np.full(belief.shape, np.inf)
    d_max = np.zeros(belief.shape)
    p_sum = np.zeros(belief.shape)
    count = np.zeros(belief.shape)
    for lab_n, p_n in zip(shifted_lab, shifted_p, strict=True):
        adj = unassigned & (lab_n == lab)
        d = np.abs(belief - np.where(adj, p_n, 0.0))
        d_min = np.where(adj, np.minimum(d_min, d), d_min)
        d_max = np.where(adj, np.maximum(d_max, d), d_max)
        p_sum += np.where(adj, p_n, 0.0)
        count += adj
    has = count > 0
    if compare == "closest":
        return has, d_min
    if compare == "all":
        return has, d_max
    return has, np.abs(belief - p_sum / np.maximum(count, 1))


def _new_blobs(
    belief: NDArray[np.float64],
    labels: NDArray[np.intp],
    rejected: NDArray[np.bool_],
    offsets: tuple[tuple[int, int], ...],
    shifted_p: list[NDArray[np.float64]],
    threshold: float,
) -> None:
    """Step 3, in place on ``labels``: the rejected cells' new blobs, numbered after the existing labels.

    Parameters
    ----------
    belief : ndarray, shape (nx, ny)
        Probability of a person per cell.
    labels : ndarray of int, shape (nx, ny)
        The grown blobs' labels.
    rejected : ndarray of bool, shape (nx, ny)
        Visited cells that joined no blob.
    offsets : tuple of (di, dj)
        The neighbour offsets of ``connectivity``.
    shifted_p : list of ndarray, each (nx, ny)
        Per offset, the neighbour's belief (NaN outside the grid).
    threshold : float
        ``BlobParams.growth_threshold``: neighbouring rejected cells differing by less are linked.
    """
    flat = np.flatnonzero(rejected)
    index = np.full(belief.size, -1, dtype=np.intp)
    index[flat] = np.arange(flat.size)
    index_grid = index.reshape(belief.shape)
    rows: list[NDArray[np.intp]] = []
    cols: list[NDArray[np.intp]] = []
    for (di, dj), p_n in zip(offsets, shifted_p, strict=True):
        other = _shift(index_grid, di, dj, -1)
        edge = rejected & (other >= 0) & (np.abs(belief - np.nan_to_num(p_n)) < threshold)
        rows.append(index_grid[edge])
        cols.append(other[edge])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(r.size), (r, c)), shape=(flat.size, flat.size))
    _, component = connected_components(graph, directed=False)
    labels.flat[flat] = int(labels.max()) + 1 + component


def _adjacency(labels: NDArray[np.intp], connectivity: int) -> dict[int, set[int]]:
    offsets = _OFFSETS_8 if connectivity == 8 else _OFFSETS_4
    adj: dict[int, set[int]] = {int(lab): set() for lab in np.unique(labels) if lab > 0}
    for di, dj in offsets:
        other = _shift(labels, di, dj, 0)
        pairs = (labels > 0) & (other > 0) & (labels != other)
        if pairs.any():
            for a, b in np.unique(np.stack([labels[pairs], other[pairs]], axis=1), axis=0):
                adj[int(a)].add(int(b))
    return adj


def _make_blobs(
    belief: NDArray[np.float64],
    labels: NDArray[np.intp],
    spec: GridSpec,
    params: BlobParams,
    *,
    select_all: bool,
) -> list[Blob]:
    """Step 4: one :class:`Blob` per label ``1 .. labels.max()`` of ``labels`` ``(nx, ny)``, with the selection
    rules it fails (none with ``select_all``); positions in metres, ``spec``'s sensor frame."""
    n_labels = int(labels.max())
    if n_labels == 0:
        return []
    adj = _adjacency(labels, params.connectivity)
    idx = np.arange(1, n_labels + 1)
    means = np.asarray(ndimage.mean(belief, labels, idx), dtype=float)
    nx, ny = belief.shape
    blobs: list[Blob] = []
    for k, lab in enumerate(idx):
        cells = np.argwhere(labels == lab).astype(np.intp)
        if cells.shape[0] == 0:  # cannot happen: labels are consecutive
            raise RuntimeError(f"blob {lab} has no cells")
        p = belief[cells[:, 0], cells[:, 1]]
        pmax = float(p.max())
        peak = cells[p >= pmax - params.peak_atol]
        centroid_cells = peak.mean(axis=0).astype(float)
        cx, cy = spec.cell_centre(centroid_cells[0], centroid_cells[1])
        height = int(cells[:, 0].max() - cells[:, 0].min() + 1)
        width = int(cells[:, 1].max() - cells[:, 1].min() + 1)
        on_border = (cells[:, 0] == 0) | (cells[:, 0] == nx - 1) | (cells[:, 1] == 0) | (cells[:, 1] == ny - 1)
        neighbours = tuple(sorted(adj[int(lab)]))
        mean = float(means[k])
        rejected: list[str] = []
        if not select_all:
            neighbour_means = [means[n - 1] for n in neighbours]
            rejected = _failed_rules(params, mean, neighbour_means, p, int(on_border.sum()), height, width)
        blobs.append(
            Blob(
                label=int(lab),
                cells=cells,
                mean_probability=mean,
                max_probability=pmax,
                min_probability=float(p.min()),
                centroid_cells=centroid_cells,
                centroid=np.array([float(cx), float(cy)]),
                mean_cell=cells.mean(axis=0).astype(float),
                height=height,
                width=width,
                border_cells=int(on_border.sum()),
                neighbours=neighbours,
                selected=not rejected,
                rejected_by=tuple(rejected),
            )
        )
    return blobs


def _failed_rules(
    params: BlobParams,
    mean: float,
    neighbour_means: list[np.float64],
    p: NDArray[np.float64],
    border_cells: int,
    height: int,
    width: int,
) -> list[str]:
    """The selection rules (step 4 of the module docstring) a blob fails, in the order of the module docstring.

    Parameters
    ----------
    params : BlobParams
    mean : float
        The blob's mean probability.
    neighbour_means : list of float
        The mean probabilities of its neighbouring blobs (may be empty).
    p : ndarray, shape (n,)
        The probabilities of its ``n`` cells.
    border_cells : int
        Its cells on the grid border.
    height, width : int
        Its bounding box's extents along i and j (cells).

    Returns
    -------
    list of str
        The ``RULE_*`` names of the failed rules (empty: the blob is a person).
    """
    rejected: list[str] = []
    if neighbour_means and not mean > float(np.mean(neighbour_means)):
        rejected.append(RULE_MEAN)
    if not float(p.min()) > params.min_cell_probability:
        rejected.append(RULE_MIN_CELL)
    if p.shape[0] > params.small_blob_cells:
        if border_cells > params.max_border_cells:
            rejected.append(RULE_BORDER)
        if not (height < params.max_extent_cells and width < params.max_extent_cells):
            rejected.append(RULE_EXTENT)
        if min(height, width) / max(height, width) < params.min_aspect_ratio:
            rejected.append(RULE_ASPECT)
    return rejected


def _check_spec(belief: ArrayLike, spec: GridSpec | None) -> tuple[NDArray[np.float64], GridSpec]:
    arr = np.asarray(belief)
    if arr.ndim != 2:
        raise ValueError(f"belief must be a 2-D (nx, ny) grid, got shape {arr.shape}")
    if spec is None:
        spec = GridSpec(nx=int(arr.shape[0]), ny=int(arr.shape[1]))
    if not isinstance(spec, GridSpec):
        raise ValueError(f"spec must be a GridSpec, got {type(spec).__name__}")
    return spec.check_grid(arr, "belief"), spec


def classify_blobs(
    belief: ArrayLike, *, spec: GridSpec | None = None, params: BlobParams | None = None
) -> ClassificationResult:
    """Classify a belief grid into people with the paper's blob algorithm (Sect. 4).

    Parameters
    ----------
    belief : array_like, shape (nx, ny)
        Probability of a person per cell, in [0, 1].
    spec : GridSpec, optional
        Geometry of the grid (for centroids in metres); default: the paper's geometry with the belief's shape.
    params : BlobParams, optional
        Thresholds; default the paper's.

    Returns
    -------
    ClassificationResult
        All blobs (with :attr:`Blob.selected` and :attr:`Blob.rejected_by`), the label image, and the
        people (``.people``, ``.mask``, ``.positions``).

    Raises
    ------
    ValueError
        If ``belief`` is not an ``(nx, ny)`` grid of probabilities, or ``params`` or ``spec`` is of the
        wrong type.
    """
    grid, spec = _check_spec(belief, spec)
    if params is None:
        params = BlobParams()
    if not isinstance(params, BlobParams):
        raise ValueError(f"params must be a BlobParams, got {type(params).__name__}")
    labels, _ = ndimage.label(grid > params.seed_threshold, structure=_structure(params.connectivity))
    labels = labels.astype(np.intp)
    _grow(grid, labels, params)
    blobs = _make_blobs(grid, labels, spec, params, select_all=False)
    return ClassificationResult(blobs=blobs, labels=labels, spec=spec)


def classify_threshold(
    belief: ArrayLike, threshold: float = 0.5, *, spec: GridSpec | None = None, connectivity: int = 8
) -> ClassificationResult:
    """Plain threshold classifier: each connected component of cells ``> threshold`` is a person.

    Parameters
    ----------
    belief : array_like, shape (nx, ny)
        Probability of a person per cell, in [0, 1].
    threshold : float
        Cells with probability strictly above it are people cells.
    spec : GridSpec, optional
        Geometry of the grid; default: the paper's geometry with the belief's shape.
    connectivity : int
        4 or 8 (default): which cells are neighbours.

    Returns
    -------
    ClassificationResult
        Every component is a selected blob; the paper's centroid as in :func:`classify_blobs`.
    """
    grid, spec = _check_spec(belief, spec)
    check_probability(threshold, "threshold")
    params = BlobParams(connectivity=connectivity)
    labels, _ = ndimage.label(grid > threshold, structure=_structure(connectivity))
    labels = labels.astype(np.intp)
    blobs = _make_blobs(grid, labels, spec, params, select_all=True)
    return ClassificationResult(blobs=blobs, labels=labels, spec=spec)
