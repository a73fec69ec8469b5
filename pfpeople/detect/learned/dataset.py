"""Training arrays of the learned detector: every looked-at return of labelled scans, its input and its targets.

Each source's scans are visited in order with a :class:`~pfpeople.detect.learned.memory.ScanMemory`, so a temporal
model is trained on exactly the inputs it will see at run time (the same cut-outs, the same stand-ins where the
memory is empty or the ego-motion unknown). Per return: the input ``(points, channels)``, the targets of
:func:`pfpeople.detect.learned.targets.beam_targets` and a weight. Most returns are walls; the negatives of a
source are kept with probability ``negative_keep`` (its returns within :data:`NEAR_PERSON_M` of a person always:
the hard ones) and weighted ``1 / negative_keep``, so the kept set estimates the full one's loss with fewer rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pfpeople.detect.learned.cutouts import CutoutParams
from pfpeople.detect.learned.memory import ScanMemory
from pfpeople.detect.learned.samples import LabelledScan, motion_since_previous
from pfpeople.detect.learned.targets import beam_targets

__all__ = ["NEAR_PERSON_M", "TrainingArrays", "training_arrays"]

#: Negatives this close (m) to an annotated person are always kept: a neighbour, a passer-by's edge, the clutter
#: beside a person are where the detector must learn to say no.
NEAR_PERSON_M = 1.5


@dataclass(frozen=True, kw_only=True, eq=False)
class TrainingArrays:
    """Rows of looked-at returns.

    Attributes
    ----------
    x : ndarray, shape (N, points, channels), float32
    label : ndarray, shape (N,), float32
    offset : ndarray, shape (N, 2), float32
    weight : ndarray, shape (N,), float32
    source : ndarray, shape (N,), int
        Index of the row's source in ``sources``.
    sources : tuple of str
    """

    x: NDArray[np.float32]
    label: NDArray[np.float32]
    offset: NDArray[np.float32]
    weight: NDArray[np.float32]
    source: NDArray[np.int64]
    sources: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.label.shape[0])

    def subset(self, mask: NDArray[np.bool_]) -> TrainingArrays:
        """The rows where ``mask`` is True."""
        return TrainingArrays(
            x=self.x[mask],
            label=self.label[mask],
            offset=self.offset[mask],
            weight=self.weight[mask],
            source=self.source[mask],
            sources=self.sources,
        )


def _near_person(ls: LabelledScan, idx: NDArray[np.intp]) -> NDArray[np.bool_]:
    if ls.people.shape[0] == 0:
        return np.zeros(idx.size, dtype=bool)
    b, r = ls.scan.angles[idx], ls.scan.ranges[idx]
    pts = np.column_stack((r * np.cos(b), r * np.sin(b)))
    return np.linalg.norm(pts[:, None, :] - ls.people[None, :, :], axis=-1).min(axis=1) <= NEAR_PERSON_M


def training_arrays(
    scans: Sequence[LabelledScan],
    cut: CutoutParams,
    *,
    past_scans: int = 0,
    past_step: int = 1,
    motion: bool = False,
    negative_keep: float = 0.15,
    row_step: int = 1,
    rng: np.random.Generator,
) -> TrainingArrays:
    """Training rows of ``scans`` (in their order: a source's scans consecutive, as recorded).

    Parameters
    ----------
    scans : sequence of LabelledScan
    cut : CutoutParams
    past_scans, past_step : int
        The temporal input (:class:`~pfpeople.detect.learned.memory.ScanMemory`).
    motion : bool
        Whether the motion detector's moved returns are an input.
    negative_keep : float
        Fraction of the far negatives kept (module docstring), in (0, 1].
    row_step : int
        Rows of every ``row_step``-th scan of a source only (every scan still passes through the memory, so the
        temporal inputs are those of consecutive scans).
    rng : numpy.random.Generator
    """
    if not 0.0 < negative_keep <= 1.0:
        raise ValueError(f"negative_keep must be in (0, 1], got {negative_keep}")
    names = sorted({ls.source for ls in scans})
    code = {nm: k for k, nm in enumerate(names)}
    memory = ScanMemory(past_scans, past_step, motion=motion)
    parts: list[tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32], NDArray[np.float32], int]] = []
    previous: LabelledScan | None = None
    for ls in scans:
        step = motion_since_previous(ls, previous)
        if step is None:
            memory.clear()
        memory.advance(ls.scan, step)
        previous = ls
        if ls.index % row_step:
            continue
        idx, x = memory.inputs(ls.scan, cut)
        t = beam_targets(ls, idx)
        far_negative = (t.label == 0) & ~_near_person(ls, idx)
        keep = (t.weight > 0) & (~far_negative | (rng.random(idx.size) < negative_keep))
        w = np.where(far_negative, 1.0 / negative_keep, 1.0).astype(np.float32) * t.weight
        parts.append((x[keep], t.label[keep], t.offset[keep], w[keep], code[ls.source]))
    if not parts:
        raise ValueError("no labelled scans to train on")
    return TrainingArrays(
        x=np.concatenate([p[0] for p in parts]),
        label=np.concatenate([p[1] for p in parts]),
        offset=np.concatenate([p[2] for p in parts]),
        weight=np.concatenate([p[3] for p in parts]),
        source=np.concatenate([np.full(len(p[1]), p[4], dtype=np.int64) for p in parts]),
        sources=tuple(names),
    )
