"""Votes of returns for person centres, and the detections they make (DROW3: Beyer et al. 2018, Sect. III-B).

Each return ``i`` (bearing ``phi_i``, range ``r_i``; m, rad, scan frame) votes for a person centre as an offset in
its *canonical* frame: the origin at the return, ``y`` along the beam (away from the laser) and ``x`` across it
(counter-clockwise, REP-103). A centre at ``(phi_c, r_c)`` is, from return ``i``,

    dx = r_c sin(phi_c - phi_i),     dy = r_c cos(phi_c - phi_i) - r_i,

so an offset does not depend on where the return lies around the laser; back to the scan frame,
``phi_c = phi_i + atan2(dx, r_i + dy)``, ``r_c = hypot(dx, r_i + dy)``.

Grouping (:func:`group_votes`): the votes scoring at least ``min_score`` are taken in descending score; the best
unclaimed vote claims every unclaimed vote within ``radius`` (m) of it and makes one detection, at the
score-weighted mean of the claimed votes, with the best vote's score (DR-SPAAM's non-maximum suppression, with
DROW's vote averaging).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from pfpeople.detect.learned.kernels import claim_votes

__all__ = ["canonical_offsets", "group_votes", "vote_positions"]


def canonical_offsets(
    bearing: NDArray[np.float64], rng: NDArray[np.float64], centres: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Offsets ``(N, 2)`` (m) of ``centres`` ``(N, 2)`` (x, y; m, scan frame) in the canonical frames of the returns
    at ``(bearing, rng)`` ``(N,)`` each (module docstring)."""
    phi_c = np.arctan2(centres[:, 1], centres[:, 0])
    r_c = np.hypot(centres[:, 0], centres[:, 1])
    d = phi_c - bearing
    return np.column_stack((r_c * np.sin(d), r_c * np.cos(d) - rng))


def vote_positions(
    bearing: NDArray[np.float64], rng: NDArray[np.float64], offsets: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Voted centres ``(N, 2)`` (x, y; m, scan frame) of the returns ``(bearing, rng)`` ``(N,)`` with canonical
    ``offsets`` ``(N, 2)``; the inverse of :func:`canonical_offsets`."""
    along = rng + offsets[:, 1]
    phi = bearing + np.arctan2(offsets[:, 0], along)
    r = np.hypot(offsets[:, 0], along)
    return np.column_stack((r * np.cos(phi), r * np.sin(phi)))


def group_votes(
    positions: NDArray[np.float64], scores: NDArray[np.float64], *, radius: float, min_score: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Detections from votes (module docstring).

    Parameters
    ----------
    positions : ndarray, shape (N, 2)
        Voted centres (m).
    scores : ndarray, shape (N,)
        The votes' scores in [0, 1].
    radius : float
        A detection claims the votes within this distance of its best vote (m).
    min_score : float
        Votes below this score are not counted.

    Returns
    -------
    centres : ndarray, shape (M, 2)
        Detected person centres (m), best first.
    det_scores : ndarray, shape (M,)
        Their scores (the best vote's), descending.
    """
    keep = scores >= min_score
    pos, sc = positions[keep], scores[keep]
    if sc.size == 0:
        return np.zeros((0, 2)), np.zeros(0)
    order = np.argsort(-sc, kind="mergesort")
    pos, sc = np.ascontiguousarray(pos[order]), sc[order]
    owner = claim_votes(pos, radius) if _jit.enabled("pfpeople") else _claim_votes_numpy(pos, radius)
    m = int(owner.max()) + 1
    w = np.bincount(owner, weights=sc, minlength=m)
    cx = np.bincount(owner, weights=sc * pos[:, 0], minlength=m) / w
    cy = np.bincount(owner, weights=sc * pos[:, 1], minlength=m) / w
    first = _first_of(owner, m)
    return np.column_stack((cx, cy)), sc[first]


def _first_of(owner: NDArray[np.int64], m: int) -> NDArray[np.intp]:
    """Index of each detection's best vote (its first, in descending score)."""
    first = np.full(m, owner.size, dtype=np.intp)
    np.minimum.at(first, owner, np.arange(owner.size))
    return first


def _claim_votes_numpy(pos: NDArray[np.float64], radius: float) -> NDArray[np.int64]:
    """The numpy twin of :func:`pfpeople.detect.learned.kernels.claim_votes`."""
    near = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1) <= radius
    owner = np.full(pos.shape[0], -1, dtype=np.int64)
    m = 0
    for i in range(pos.shape[0]):
        if owner[i] < 0:
            owner[near[i] & (owner < 0)] = m
            m += 1
    return owner
