"""What the learned detector is trained to say about each return of a labelled scan.

For each looked-at return (:func:`pfpeople.detect.learned.cutouts.centre_beams`) at point ``p`` (m, scan frame),
with ``d`` its distance to the nearest annotated centre ``c``:

* inside the annotation's region (:class:`~pfpeople.detect.learned.samples.Region`) and ``d <=``
  :data:`~pfpeople.detect.learned.samples.POSITIVE_RADIUS`: a person's return, class 1, voting for ``c`` (its
  canonical offset, :func:`pfpeople.detect.learned.votes.canonical_offsets`);
* inside the region and ``d >`` :data:`~pfpeople.detect.learned.samples.IGNORE_RADIUS`: class 0;
* otherwise weight 0 (neither a person's nor known background: out of the loss). A scan with a per-beam ``known``
  mask (weak labels) has its unknown returns masked too; the static ``background`` outside the region (a standing
  laser's recording) is class 0.

A person's return outside the region (a labelled leg just outside leg_tracker's box) still counts as a person's:
the label is known there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pfpeople.detect.learned.samples import IGNORE_RADIUS, POSITIVE_RADIUS, LabelledScan
from pfpeople.detect.learned.votes import canonical_offsets

__all__ = ["BeamTargets", "beam_targets"]


@dataclass(frozen=True, kw_only=True, eq=False)
class BeamTargets:
    """Per looked-at return: ``label`` (C,) 0/1, ``offset`` (C, 2) canonical offset of its centre (m; zero for
    class 0), ``weight`` (C,) 1 or 0 (masked)."""

    label: NDArray[np.float32]
    offset: NDArray[np.float32]
    weight: NDArray[np.float32]


def beam_targets(ls: LabelledScan, idx: NDArray[np.intp]) -> BeamTargets:
    """Targets of the returns ``idx`` (beam indices) of ``ls`` (module docstring)."""
    scan = ls.scan
    bearing, rng = scan.angles[idx], scan.ranges[idx]
    pts = np.column_stack((rng * np.cos(bearing), rng * np.sin(bearing)))
    n = idx.size
    label = np.zeros(n, dtype=np.float32)
    offset = np.zeros((n, 2), dtype=np.float32)
    known = ls.region.contains(pts, ls.people)
    if ls.known is not None:
        known &= ls.known[idx]
    if ls.background is not None:
        known |= ls.background[idx]
    weight = known.astype(np.float32)
    if ls.people.shape[0] and n:
        d = np.linalg.norm(pts[:, None, :] - ls.people[None, :, :], axis=-1)
        near = d.argmin(axis=1)
        dmin = d[np.arange(n), near]
        pos = dmin <= POSITIVE_RADIUS
        label[pos] = 1.0
        weight[pos] = 1.0
        weight[(dmin > POSITIVE_RADIUS) & (dmin <= IGNORE_RADIUS)] = 0.0
        if pos.any():
            offset[pos] = canonical_offsets(bearing[pos], rng[pos], ls.people[near[pos]])
    return BeamTargets(label=label, offset=offset, weight=weight)
