"""Tracking one person on the final grid by blob centroids (Batista & Pereira 2015, Sect. 4, Figs. 8-9).

The paper's rule: "The criterion for selecting a blob is based on its position relative to the centroid of
the blob selected at the previous instant of time. If there are more than one blob near the centroid, the
one with the highest posterior probability is chosen. [...] If there is no blob close to the centroid of
the previous blob, a blob that overlaps any of the cells of the previous blob is chosen or, as the last
option, a blob in the 8-neighborhood of some cell of the previous blob is chosen."

Per frame, among the candidate blobs (the classified people by default, :attr:`TrackerParams.candidates`),
the tracker picks, in order:

1. ``nearest``: blobs whose paper centroid (:attr:`gridbridge.blobs.Blob.centroid`) is within
   ``gate`` metres of the previous centroid; of several, the highest posterior (the blob's maximum
   probability; ties to the nearer);
2. ``overlap``: blobs sharing a cell with the previous blob; of several, the highest posterior;
3. ``neighbour``: blobs with a cell in the 8-neighbourhood of a cell of the previous blob; likewise;
4. otherwise the person is *lost* in this frame: the previous blob and centroid are kept as the reference
   (``held``) for up to ``max_lost_frames`` consecutive frames; one more miss ends the track (``ended``).

Starting is automatic (the paper selects the first blob by hand): with ``start_point`` the candidate blob
nearest to it within ``start_radius`` (m) and with maximum probability ``>= start_threshold``; otherwise the
candidate with the highest maximum probability ``>= start_threshold``. After a track ends, a new one starts
(new ``track_id``) when ``restart`` is true.

Ego-motion: beliefs from the grid filter are already warped into the current sensor frame, so comparing
with the previous centroid as it is is approximately right. When the per-frame rigid transform is known,
pass it as ``(dx, dy, dtheta)``: the current sensor frame expressed in the previous one (m, m, rad; the
convention of :func:`gridbridge.velocity_displacement`). The previous centroid is then moved to
``R(-dtheta) (p - t)`` and the previous blob's cells by moving their centres and re-binning them with
:class:`GridSpec` (cells leaving the grid are dropped).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from gridbridge.blobs import Blob, BlobParams, ClassificationResult, classify_blobs
from gridbridge.geometry import to_frame
from gridbridge.grid import GridSpec
from gridbridge.validation import check_int, check_real

__all__ = ["BlobTracker", "TrackFrame", "TrackResult", "TrackerParams", "TrackingError", "track_sequence"]

Rule = Literal["start", "nearest", "overlap", "neighbour", "held", "ended", "idle"]


@dataclass(frozen=True, kw_only=True)
class TrackerParams:
    """Parameters of the blob tracker.

    Parameters
    ----------
    gate : float
        Distance (m) within which a blob's centroid is "near" the previous centroid (the paper gives no
        value; default 0.6 m = two cells, four frames of walking at the paper's mean speed 1.46 m/s).
    max_lost_frames : int
        Consecutive frames without a blob during which the track is held; one more ends it.
    start_threshold : float
        Smallest maximum probability of a blob to start a track on.
    start_point : tuple of float, optional
        ``(x, y)`` (m, sensor frame): start on the blob nearest to it (within ``start_radius``).
    start_radius : float
        Distance (m) from ``start_point`` within which a blob may start the track.
    restart : bool
        Start a new track after one ends.
    candidates : {'people', 'all'}
        Track over the blobs classified as people (default) or over every blob.
    """

    gate: float = 0.6
    max_lost_frames: int = 5
    start_threshold: float = 0.5
    start_point: tuple[float, float] | None = None
    start_radius: float = 1.0
    restart: bool = True
    candidates: Literal["people", "all"] = "people"

    def __post_init__(self) -> None:
        for name in ("gate", "start_radius"):
            check_real(getattr(self, name), f"TrackerParams.{name}", low=0.0, low_open=True)
        check_int(self.max_lost_frames, "TrackerParams.max_lost_frames", minimum=0)
        check_real(self.start_threshold, "TrackerParams.start_threshold", low=0.0, high=1.0)
        if self.start_point is not None:
            sp = self.start_point
            if len(sp) != 2:
                raise ValueError(f"TrackerParams.start_point must be a finite (x, y) pair (m), got {sp!r}")
            for v in sp:
                check_real(v, "TrackerParams.start_point")
        if self.candidates not in ("people", "all"):
            raise ValueError(f"TrackerParams.candidates must be 'people' or 'all', got {self.candidates!r}")


@dataclass(frozen=True, eq=False)
class TrackFrame:
    """The tracker's output for one frame.

    Attributes
    ----------
    index : int
        Frame number (0-based, since the last reset).
    tracked : bool
        A blob was selected for the person in this frame.
    centroid : ndarray, shape (2,)
        The selected blob's paper centroid (m, current sensor frame); NaN when not tracked.
    blob : Blob or None
        The selected blob.
    rule : str
        How: ``start``, ``nearest``, ``overlap``, ``neighbour`` (tracked); ``held`` (track alive, no blob),
        ``ended`` (the track ended in this frame), ``idle`` (no track).
    track_id : int
        Number of the track (0, 1, ... in start order); -1 when there is no track.
    """

    index: int
    tracked: bool
    centroid: NDArray[np.float64]
    blob: Blob | None
    rule: Rule
    track_id: int

    @property
    def held(self) -> bool:
        """The track is alive but had no blob in this frame."""
        return self.rule == "held"


@dataclass(frozen=True, eq=False)
class TrackResult:
    """A tracking run: its frames and per-frame arrays."""

    frames: list[TrackFrame]

    @property
    def tracked(self) -> NDArray[np.bool_]:
        """``(F,)`` bool."""
        return np.array([f.tracked for f in self.frames], dtype=bool)

    @property
    def centroids(self) -> NDArray[np.float64]:
        """``(F, 2)`` centroids (m, sensor frame of each frame), NaN where not tracked."""
        if not self.frames:
            return np.zeros((0, 2))
        return np.stack([f.centroid for f in self.frames])

    @property
    def rules(self) -> list[str]:
        return [f.rule for f in self.frames]


class TrackingError(ValueError):
    """Bad input in frame ``index`` of :func:`track_sequence`; ``partial`` holds the frames done before it."""

    def __init__(self, message: str, *, index: int, partial: TrackResult) -> None:
        super().__init__(message)
        self.index = index
        self.partial = partial


def _check_transform(transform: ArrayLike | None) -> NDArray[np.float64] | None:
    if transform is None:
        return None
    t = np.asarray(transform, dtype=float)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise ValueError(f"transform must be a finite (dx, dy, dtheta) triple, got {transform!r}")
    return t


class BlobTracker:
    """Follow one person through a sequence of classified grids (module docstring).

    Parameters
    ----------
    spec : GridSpec
        Geometry of the grids.
    params : TrackerParams
        Gate, hold and start parameters.
    """

    def __init__(self, spec: GridSpec | None = None, *, params: TrackerParams | None = None) -> None:
        self.spec = GridSpec() if spec is None else spec
        if not isinstance(self.spec, GridSpec):
            raise ValueError(f"spec must be a GridSpec, got {type(self.spec).__name__}")
        self.params = TrackerParams() if params is None else params
        if not isinstance(self.params, TrackerParams):
            raise ValueError(f"params must be a TrackerParams, got {type(self.params).__name__}")
        self.reset()

    def reset(self) -> None:
        """Forget the track and restart frame numbering."""
        self._index = 0
        self._n_tracks = 0
        self._track_id = -1
        self._ref_centroid: NDArray[np.float64] | None = None
        self._ref_mask: NDArray[np.bool_] | None = None
        self._lost = 0

    @property
    def active(self) -> bool:
        """A track is alive (tracked or held)."""
        return self._ref_centroid is not None

    def _move_reference(self, t: NDArray[np.float64]) -> None:
        assert self._ref_centroid is not None and self._ref_mask is not None
        # t = (dx, dy, dtheta) is the current sensor frame in the previous one: points move into it.
        self._ref_centroid = to_frame(self._ref_centroid, t)
        ii, jj = np.nonzero(self._ref_mask)
        moved = to_frame(np.column_stack(self.spec.cell_centre(ii, jj)), t)
        flat = self.spec.flat_index(moved[:, 0], moved[:, 1])
        mask = np.zeros(self.spec.shape, dtype=bool)
        mask.flat[flat[flat >= 0]] = True
        self._ref_mask = mask

    def _start(self, cands: list[Blob]) -> Blob | None:
        p = self.params
        strong = [b for b in cands if b.max_probability >= p.start_threshold]
        if not strong:
            return None
        if p.start_point is not None:
            sp = np.asarray(p.start_point, dtype=float)
            dist = [float(np.linalg.norm(b.centroid - sp)) for b in strong]
            k = int(np.argmin(dist))
            return strong[k] if dist[k] <= p.start_radius else None
        return max(strong, key=lambda b: (b.max_probability, -b.label))

    @staticmethod
    def _best(blobs: list[Blob], ref: NDArray[np.float64]) -> Blob:
        return max(blobs, key=lambda b: (b.max_probability, -float(np.linalg.norm(b.centroid - ref))))

    def _follow(self, cands: list[Blob], labels: NDArray[np.intp]) -> tuple[Blob | None, Rule]:
        """Rules 1-3 of the module docstring: the candidate that continues the track, and the rule that chose it.

        Parameters
        ----------
        cands : list of Blob
            The frame's candidate blobs.
        labels : ndarray of int, shape (nx, ny)
            The frame's blob label image (the result's ``labels``).

        Returns
        -------
        chosen : Blob or None
            None: no candidate continues the track (rule 4).
        rule : str
            ``"nearest"``, ``"overlap"`` or ``"neighbour"``; ``"idle"`` with no blob chosen.
        """
        assert self._ref_centroid is not None and self._ref_mask is not None
        ref = self._ref_centroid
        near = [b for b in cands if float(np.linalg.norm(b.centroid - ref)) <= self.params.gate]
        if near:
            return self._best(near, ref), "nearest"
        # Blobs are the labels of the result's label image: read the labels under the previous blob.
        under = set(np.unique(labels[self._ref_mask]).tolist())
        over = [b for b in cands if b.label in under]
        if over:
            return self._best(over, ref), "overlap"
        ring = ndimage.binary_dilation(self._ref_mask, structure=np.ones((3, 3), dtype=bool))
        near_ring = set(np.unique(labels[ring]).tolist())
        adj = [b for b in cands if b.label in near_ring]
        if adj:
            return self._best(adj, ref), "neighbour"
        return None, "idle"

    def update(self, result: ClassificationResult, *, transform: ArrayLike | None = None) -> TrackFrame:
        """Process one classified grid.

        Parameters
        ----------
        result : ClassificationResult
            Classification of the current belief grid (on this tracker's grid shape).
        transform : array_like, shape (3,), optional
            ``(dx, dy, dtheta)``: the current sensor frame in the previous one (m, m, rad).

        Returns
        -------
        TrackFrame
        """
        if not isinstance(result, ClassificationResult):
            raise ValueError(f"result must be a ClassificationResult, got {type(result).__name__}")
        if tuple(result.labels.shape) != self.spec.shape:
            raise ValueError(f"result grid shape {result.labels.shape} differs from the tracker's {self.spec.shape}")
        t = _check_transform(transform)
        index = self._index
        self._index += 1
        cands = result.people if self.params.candidates == "people" else list(result.blobs)
        shape = self.spec.shape

        chosen: Blob | None = None
        rule: Rule = "idle"
        ended = False
        if self.active:
            if t is not None:
                self._move_reference(t)
            chosen, rule = self._follow(cands, result.labels)
            if chosen is None:
                self._lost += 1
                if self._lost > self.params.max_lost_frames:
                    ended = True
                    self._ref_centroid = None
                    self._ref_mask = None
                    rule = "ended"
                else:
                    rule = "held"
        if not self.active and (self._n_tracks == 0 or self.params.restart):
            chosen = self._start(cands)
            if chosen is not None:
                rule = "start"
                self._track_id = self._n_tracks
                self._n_tracks += 1
        if chosen is not None:
            self._ref_centroid = chosen.centroid.copy()
            self._ref_mask = chosen.mask(shape)
            self._lost = 0
            return TrackFrame(index, True, chosen.centroid.copy(), chosen, rule, self._track_id)
        track_id = self._track_id if (self.active or ended) else -1
        if not self.active:
            self._track_id = -1
        return TrackFrame(index, False, np.full(2, np.nan), None, rule, track_id)


def track_sequence(
    beliefs: Sequence[ArrayLike] | None = None,
    *,
    results: Sequence[ClassificationResult] | None = None,
    spec: GridSpec | None = None,
    params: TrackerParams | None = None,
    blob_params: BlobParams | None = None,
    transforms: Sequence[ArrayLike | None] | None = None,
) -> TrackResult:
    """Track one person through a sequence of belief grids.

    Parameters
    ----------
    beliefs : sequence of array_like, each (nx, ny), optional
        Belief grids; classified with :func:`gridbridge.blobs.classify_blobs` when ``results`` is None.
    results : sequence of ClassificationResult, optional
        Precomputed classifications (one per frame); used instead of classifying ``beliefs``.
    spec : GridSpec, optional
        Grid geometry (default the paper's).
    params : TrackerParams, optional
        Tracker parameters.
    blob_params : BlobParams, optional
        Classification thresholds when classifying ``beliefs``.
    transforms : sequence of (dx, dy, dtheta) or None, optional
        Per frame, the current sensor frame in the previous one (see :meth:`BlobTracker.update`).

    Returns
    -------
    TrackResult

    Raises
    ------
    TrackingError
        (a ValueError) naming the frame (``beliefs[k]``, ``results[k]``, ``transforms[k]``) whose input is
        bad; its ``partial`` attribute holds the frames tracked before it.
    """
    spec = GridSpec() if spec is None else spec
    n, source = _sequence_length(beliefs, results, transforms)
    tracker = BlobTracker(spec, params=params)
    frames: list[TrackFrame] = []
    for k in range(n):
        try:
            if results is not None:
                res = results[k]
            else:
                assert beliefs is not None
                res = classify_blobs(beliefs[k], spec=spec, params=blob_params)
            transform = None if transforms is None else transforms[k]
            frames.append(tracker.update(res, transform=transform))
        except ValueError as err:
            partial = TrackResult(frames=frames)
            raise TrackingError(f"{source}[{k}] (or transforms[{k}]): {err}", index=k, partial=partial) from err
    return TrackResult(frames=frames)


def _sequence_length(
    beliefs: Sequence[ArrayLike] | None,
    results: Sequence[ClassificationResult] | None,
    transforms: Sequence[ArrayLike | None] | None,
) -> tuple[int, str]:
    """The number of frames of :func:`track_sequence`'s inputs, and which of them is tracked.

    Returns
    -------
    n : int
        The number of frames.
    source : str
        ``"results"`` when given, else ``"beliefs"``.

    Raises
    ------
    ValueError
        Neither ``beliefs`` nor ``results`` given, or the inputs' lengths differ.
    """
    if results is None:
        if beliefs is None:
            raise ValueError("beliefs or results is required")
        n = len(beliefs)
        source = "beliefs"
    else:
        n = len(results)
        source = "results"
        if beliefs is not None and len(beliefs) != n:
            raise ValueError(f"beliefs has {len(beliefs)} frames but results has {n}")
    if transforms is not None and len(transforms) != n:
        raise ValueError(f"transforms has {len(transforms)} entries for {n} frames")
    return n, source
