"""A scored detector's precision as a function of its score: ``PPV(score)``, measured on held-out data.

A detector's PPV (Batista & Pereira 2015, Table 1) is the probability that one of its detections is a person. For a
detector that scores its detections (the learned laser detector's vote probability) it rises with the score: on the
shipped model's held-out data from about 0.5 just above the operating threshold to above 0.9 for the top scores.
Fusing every detection with the detector's pooled PPV throws that away; fusing each with ``PPV(score)`` (an ``(M,
3)`` detection entry, :func:`gridbridge.measurement.split_detections`) lets one confident detection count as
near-certain evidence and a doubtful one as weak evidence, in eqs. 13-14 and the independent fusion alike.

The fit: every held-out detection, labelled true (matched to a person within 0.5 m, one-to-one in descending score)
or false (a people-free recording's detections are all false), sorted by score; isotonic regression (scipy's
pool-adjacent-violators) gives the non-decreasing precision; adjacent pools are merged until each holds at least
``min_count`` detections, and each pool's PPV is the Beta(1, 1) posterior mean ``(true + 1) / (n + 2)`` (never 0
or 1, which eq. 12 cannot take; pools the prior puts out of order are pooled again). The result is a step
function: a score takes the PPV of the pool whose lowest score it reaches (below the first pool: the first pool's).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import isotonic_regression

__all__ = ["ScorePpv"]


@dataclass(frozen=True, eq=False)
class ScorePpv:
    """``PPV(score)`` as a step function (module docstring).

    Attributes
    ----------
    score_from : ndarray, shape (K,)
        Each pool's lowest score, increasing.
    ppv : ndarray, shape (K,)
        Each pool's PPV, non-decreasing, in (0, 1).
    detections : ndarray of int, shape (K,)
        The held-out detections in each pool.
    """

    score_from: NDArray[np.float64]
    ppv: NDArray[np.float64]
    detections: NDArray[np.int64]

    def __post_init__(self) -> None:
        k = self.score_from.shape
        if len(k) != 1 or k[0] == 0 or self.ppv.shape != k or self.detections.shape != k:
            raise ValueError("score_from, ppv and detections must be non-empty 1-D arrays of one length")
        if not (np.isfinite(self.score_from).all() and (np.diff(self.score_from) > 0).all()):
            raise ValueError(f"score_from must be finite and increasing, got {self.score_from.tolist()}")
        if not (np.isfinite(self.ppv).all() and (self.ppv > 0).all() and (self.ppv < 1).all()):
            raise ValueError(f"ppv must lie in (0, 1), got {self.ppv.tolist()}")
        if (np.diff(self.ppv) < 0).any():
            raise ValueError(f"ppv must not decrease with the score, got {self.ppv.tolist()}")

    def __call__(self, scores: ArrayLike) -> NDArray[np.float64]:
        """The PPV of each score, shape of ``scores``."""
        s = np.asarray(scores, dtype=float)
        k = np.searchsorted(self.score_from, s, side="right") - 1
        return self.ppv[np.clip(k, 0, self.ppv.size - 1)]

    @classmethod
    def fit(cls, scores: ArrayLike, true: ArrayLike, *, min_count: int = 200) -> ScorePpv:
        """The step function of held-out detections' ``scores`` ``(N,)`` and whether each was a person ``true``
        ``(N,)`` (module docstring).

        Raises
        ------
        ValueError
            Fewer than ``min_count`` detections, or arrays of different lengths or with non-finite scores.
        """
        s = np.asarray(scores, dtype=float).reshape(-1)
        y = np.asarray(true, dtype=float).reshape(-1)
        if s.shape != y.shape or not np.isfinite(s).all():
            raise ValueError(f"scores and true must be finite and of one length, got {s.shape} and {y.shape}")
        if s.size < max(min_count, 1):
            raise ValueError(f"PPV(score) needs at least {min_count} held-out detections, got {s.size}")
        order = np.argsort(s, kind="stable")
        s, y = s[order], y[order]
        blocks = list(isotonic_regression(y).blocks)  # pool starts, then N
        starts = _merged(blocks, s, min_count)
        ends = [*starts[1:], s.size]
        n = np.array([b - a for a, b in zip(starts, ends, strict=True)], dtype=np.int64)
        tp = np.array([y[a:b].sum() for a, b in zip(starts, ends, strict=True)])
        ppv = isotonic_regression((tp + 1.0) / (n + 2.0), weights=n.astype(float)).x  # the prior may bend the order
        return cls(score_from=s[starts], ppv=np.asarray(ppv, dtype=float), detections=n)

    def to_card(self) -> dict[str, Any]:
        """The JSON form of a model card (``calibration.ppv_by_score``)."""
        return {
            "score_from": [float(v) for v in self.score_from],
            "ppv": [float(v) for v in self.ppv],
            "detections": [int(v) for v in self.detections],
        }

    @classmethod
    def from_card(cls, entry: Mapping[str, Any], where: str) -> ScorePpv:
        """Read :meth:`to_card`'s form; ``ValueError`` naming ``where`` when it does not fit."""
        try:
            return cls(
                score_from=np.asarray(entry["score_from"], dtype=float),
                ppv=np.asarray(entry["ppv"], dtype=float),
                detections=np.asarray(entry["detections"], dtype=np.int64),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{where}: ppv_by_score does not fit ({exc})") from None


def _merged(blocks: list[int], scores: NDArray[np.float64], min_count: int) -> list[int]:
    """Pool starts (of ``blocks``: starts then the end) merged left to right until each pool holds ``min_count``
    detections (a short last pool joins the one before) and starts at a new score (a tie never straddles two)."""
    end = blocks[-1]
    starts: list[int] = []
    for a in blocks[:-1]:
        if starts and (a - starts[-1] < min_count or scores[a] == scores[a - 1]):
            continue
        starts.append(a)
    if len(starts) > 1 and end - starts[-1] < min_count:
        starts.pop()
    return starts
