"""CLEAR-MOT scores of a multi-person tracker (Bernardin & Stiefelhagen 2008) with py-motmetrics.

Per frame the ground-truth people and the hypotheses (tracks) are given as ids and positions (m, one frame
for both, e.g. the grid/sensor frame). The distance matrix is computed here: Euclidean distance in metres,
NaN (not allowed) beyond ``gate`` (0.75 m by default, as leg_tracker's benchmark). It is fed to
``motmetrics.MOTAccumulator.update``, which does the CLEAR-MOT matching (keep last frame's correspondences
while within the gate, then an optimal assignment, counting switches), and ``motmetrics.metrics`` computes::

    MOTA = 1 - (FN + FP + IDSW) / GT      MOTP = sum of matched distances / matches   (m, lower is better)

with GT the number of ground-truth objects over all frames. ``mostly_tracked`` / ``mostly_lost``: ground-truth
people matched in >= 80 % / < 20 % of the frames where they are present; ``fragmentations``: times a
ground-truth trajectory goes from matched to unmatched and back.

Optional region (``sector`` as ``(bearing_min, bearing_max)`` rad, bearing ``atan2(y, x)``; ``max_range`` m):
ground truth and hypotheses outside are dropped before matching, so neither counts.

Compatibility with numpy 2 / pandas 3 (motmetrics 1.4.0 under numpy 2.4 / pandas 3.1): ``distances.iou_matrix``
fails (it calls ``np.asfarray``, removed in numpy 2) and ``distances.norm2squared_matrix`` gives squared
distances (MOTP would be in m^2); neither is used, the Euclidean distances are computed here
(:func:`distance_matrix`). ``MOTAccumulator.update`` and ``metrics.create().compute`` are what is used, and they
run without warnings (checked in ``tests/evaluation/test_mot_metrics.py`` with warnings as errors). The scores are also
recomputed from the accumulator's event table (:func:`scores_from_events`) as a check independent of
motmetrics' metric code.

HOTA (Luiten et al. 2021, :func:`hota`) is computed by TrackEval's ``HOTA`` metric (the ``trackeval`` package on
PyPI, a packaging of Luiten's TrackEval). For people as points the localisation similarity of a pair is
``max(0, 1 - d / gate)``: at threshold ``alpha`` a pair may match when ``d <= (1 - alpha) gate``, and HOTA is the
mean of ``sqrt(DetA AssA)`` over ``alpha = 0.05 .. 0.95``. The set-up installs ``trackeval`` without its declared
dependencies (``pip install --no-deps``): they pull the GUI build of OpenCV (``opencv-python``), which would
replace the headless build the HOG detector needs; its HOTA metric uses only numpy and scipy. Without the package
:func:`hota` returns NaN (and says why once, in the log).
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pfpeople.extras import require

__all__ = ["HotaScores", "MotScores", "accumulate", "clear_mot", "distance_matrix", "hota", "scores_from_events"]

log = logging.getLogger(__name__)

FrameData = tuple[ArrayLike, ArrayLike]


@dataclass(frozen=True, kw_only=True)
class MotScores:
    """CLEAR-MOT scores of one sequence (see the module docstring).

    ``motp`` is a mean distance in metres (NaN without matches); ``mota``, ``recall`` and ``precision`` are
    NaN when undefined (no ground truth, no hypotheses). ``num_gt`` counts ground-truth objects over all
    frames, ``num_gt_ids`` distinct people; ``num_matches`` counts every correspondence, switches included
    (motmetrics' ``num_matches`` plus ``num_switches``), so ``num_gt = num_matches + num_misses``.
    """

    mota: float
    motp: float
    id_switches: int
    fragmentations: int
    mostly_tracked: int
    mostly_lost: int
    recall: float
    precision: float
    num_frames: int
    num_gt: int
    num_false_positives: int
    num_misses: int
    num_matches: int
    num_gt_ids: int

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _frame(data: FrameData, what: str, k: int) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    ids_in, pos_in = data
    ids = np.asarray(ids_in).reshape(-1)
    pos = np.asarray(pos_in, dtype=float)
    if pos.size == 0:
        pos = pos.reshape(0, 2)
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"{what}[{k}] positions must have shape (K, 2), got {pos.shape}")
    if ids.shape[0] != pos.shape[0]:
        raise ValueError(f"{what}[{k}]: {ids.shape[0]} ids for {pos.shape[0]} positions")
    if ids.size and not np.issubdtype(ids.dtype, np.integer):
        if not np.all(np.equal(np.mod(ids.astype(float), 1), 0)):
            raise ValueError(f"{what}[{k}] ids must be integers")
    if not np.all(np.isfinite(pos)):
        raise ValueError(f"{what}[{k}] positions contain NaN or infinite values")
    if np.unique(ids).size != ids.size:
        raise ValueError(f"{what}[{k}] ids must be unique within a frame")
    return ids.astype(np.int64), pos


def _region(pos: NDArray[np.float64], sector: tuple[float, float] | None, max_range: float | None) -> NDArray[np.bool_]:
    keep = np.ones(pos.shape[0], dtype=bool)
    if sector is not None:
        b = np.arctan2(pos[:, 1], pos[:, 0])
        keep &= (b >= sector[0]) & (b <= sector[1])
    if max_range is not None:
        keep &= np.hypot(pos[:, 0], pos[:, 1]) <= max_range
    return keep


def distance_matrix(gt: ArrayLike, hyp: ArrayLike, gate: float) -> NDArray[np.float64]:
    """Euclidean distances ``(K_gt, K_hyp)`` (m), NaN where above ``gate`` (the pair may not match)."""
    a = np.asarray(gt, dtype=float).reshape(-1, 2)
    b = np.asarray(hyp, dtype=float).reshape(-1, 2)
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    return np.where(d <= gate, d, np.nan)


def _check_args(gate: float, sector: tuple[float, float] | None, max_range: float | None) -> None:
    if not (isinstance(gate, int | float) and math.isfinite(gate) and gate > 0):
        raise ValueError(f"gate must be finite and > 0 m, got {gate!r}")
    if sector is not None:
        lo, hi = (float(v) for v in sector)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"sector must be (bearing_min, bearing_max) rad with min < max, got {sector!r}")
    if max_range is not None and not (math.isfinite(max_range) and max_range > 0):
        raise ValueError(f"max_range must be finite and > 0 m, got {max_range!r}")


def accumulate(
    gt_frames: Sequence[FrameData],
    hyp_frames: Sequence[FrameData],
    *,
    gate: float = 0.75,
    sector: tuple[float, float] | None = None,
    max_range: float | None = None,
) -> Any:
    """The ``motmetrics.MOTAccumulator`` of a sequence (arguments as :func:`clear_mot`)."""
    mm = require("eval", "the CLEAR-MOT scores")
    acc = mm.MOTAccumulator(auto_id=True)
    for gid, gpos, hid, hpos in _frames_in_region(gt_frames, hyp_frames, gate, sector, max_range):
        acc.update(gid.tolist(), hid.tolist(), distance_matrix(gpos, hpos, gate))
    return acc


def _frames_in_region(
    gt_frames: Sequence[FrameData],
    hyp_frames: Sequence[FrameData],
    gate: float,
    sector: tuple[float, float] | None,
    max_range: float | None,
) -> Iterator[tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]]:
    """Checked frames ``(gt ids, gt positions, hyp ids, hyp positions)`` inside the region (arguments checked)."""
    _check_args(gate, sector, max_range)
    if len(gt_frames) != len(hyp_frames):
        raise ValueError(f"gt_frames has {len(gt_frames)} frames but hyp_frames has {len(hyp_frames)}")
    for k, (g, h) in enumerate(zip(gt_frames, hyp_frames, strict=True)):
        gid, gpos = _frame(g, "gt_frames", k)
        hid, hpos = _frame(h, "hyp_frames", k)
        kg, kh = _region(gpos, sector, max_range), _region(hpos, sector, max_range)
        yield gid[kg], gpos[kg], hid[kh], hpos[kh]


def clear_mot(
    gt_frames: Sequence[FrameData],
    hyp_frames: Sequence[FrameData],
    *,
    gate: float = 0.75,
    sector: tuple[float, float] | None = None,
    max_range: float | None = None,
) -> MotScores:
    """CLEAR-MOT scores of hypotheses against ground truth.

    Parameters
    ----------
    gt_frames, hyp_frames : sequence of (ids, positions)
        Per frame (same length): ids ``(K,)`` integers, unique in the frame, and positions ``(K, 2)`` (m),
        both in the same frame.
    gate : float
        Largest matching distance (m), default 0.75 (leg_tracker's benchmark).
    sector : (float, float), optional
        Bearing interval (rad, ``atan2(y, x)``) outside which ground truth and hypotheses are ignored.
    max_range : float, optional
        Range (m) beyond which ground truth and hypotheses are ignored.

    Returns
    -------
    MotScores
    """
    mm = require("eval", "the CLEAR-MOT scores")
    acc = accumulate(gt_frames, hyp_frames, gate=gate, sector=sector, max_range=max_range)
    names = [
        "mota",
        "motp",
        "num_switches",
        "num_fragmentations",
        "mostly_tracked",
        "mostly_lost",
        "recall",
        "precision",
        "num_frames",
        "num_objects",
        "num_false_positives",
        "num_misses",
        "num_matches",
        "num_unique_objects",
    ]
    mh = mm.metrics.create()
    row = mh.compute(acc, metrics=names, name="seq").loc["seq"]

    def f(name: str) -> float:
        v = float(row[name])
        return v if math.isfinite(v) else math.nan

    def i(name: str) -> int:
        v = float(row[name])
        return int(v) if math.isfinite(v) else 0

    n_frames = len(gt_frames)
    return MotScores(
        mota=f("mota") if i("num_objects") else math.nan,
        motp=f("motp") if i("num_matches") else math.nan,
        id_switches=i("num_switches"),
        fragmentations=i("num_fragmentations"),
        mostly_tracked=i("mostly_tracked"),
        mostly_lost=i("mostly_lost"),
        recall=f("recall") if i("num_objects") else math.nan,
        precision=f("precision") if i("num_matches") + i("num_false_positives") else math.nan,
        num_frames=n_frames,
        num_gt=i("num_objects"),
        num_false_positives=i("num_false_positives"),
        num_misses=i("num_misses"),
        num_matches=i("num_matches") + i("num_switches"),
        num_gt_ids=i("num_unique_objects"),
    )


@dataclass(frozen=True)
class HotaScores:
    """HOTA and its detection / association parts (means over the localisation thresholds; NaN: not computed)."""

    hota: float
    deta: float
    assa: float


_NO_HOTA = HotaScores(math.nan, math.nan, math.nan)


def _hota_metric() -> Any:
    """TrackEval's HOTA metric, or None (logged) when ``trackeval`` is not installed."""
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # it prints about datasets it cannot import
            from trackeval.metrics import HOTA
    except ImportError as exc:
        log.warning("HOTA is not computed: trackeval is not installed (%s); `make setup` installs it", exc)
        return None
    return HOTA()


def hota(
    gt_frames: Sequence[FrameData],
    hyp_frames: Sequence[FrameData],
    *,
    gate: float = 0.75,
    sector: tuple[float, float] | None = None,
    max_range: float | None = None,
) -> HotaScores:
    """HOTA of hypotheses against ground truth (arguments as :func:`clear_mot`; see the module docstring).

    Returns
    -------
    HotaScores
        NaN when ``trackeval`` is missing; with no ground truth and no hypotheses, NaN too.
    """
    frames = list(_frames_in_region(gt_frames, hyp_frames, gate, sector, max_range))
    metric = _hota_metric()
    if metric is None:
        return _NO_HOTA
    gt_index: dict[int, int] = {}
    hyp_index: dict[int, int] = {}
    gt_ids, hyp_ids, sims = [], [], []
    n_gt = n_hyp = 0
    for gid, gpos, hid, hpos in frames:
        gt_ids.append(np.array([gt_index.setdefault(int(i), len(gt_index)) for i in gid], dtype=int))
        hyp_ids.append(np.array([hyp_index.setdefault(int(i), len(hyp_index)) for i in hid], dtype=int))
        d = np.linalg.norm(gpos[:, None, :] - hpos[None, :, :], axis=2).reshape(len(gid), len(hid))
        sims.append(np.clip(1.0 - d / gate, 0.0, 1.0))
        n_gt += len(gid)
        n_hyp += len(hid)
    if n_gt == 0 and n_hyp == 0:
        return _NO_HOTA
    data = {
        "gt_ids": gt_ids,
        "tracker_ids": hyp_ids,
        "similarity_scores": sims,
        "num_gt_ids": len(gt_index),
        "num_tracker_ids": len(hyp_index),
        "num_gt_dets": n_gt,
        "num_tracker_dets": n_hyp,
        "num_timesteps": len(gt_frames),
    }
    res = metric.eval_sequence(data)
    return HotaScores(
        hota=float(np.mean(res["HOTA"])), deta=float(np.mean(res["DetA"])), assa=float(np.mean(res["AssA"]))
    )


def scores_from_events(acc: Any) -> dict[str, float]:
    """MOTA, MOTP and the counts recomputed from an accumulator's event table (a check on motmetrics' metrics).

    Counts: MATCH and SWITCH events are matches (a SWITCH is a match with a new id); MISS and FP as named;
    TRANSFER / ASCEND / MIGRATE rows are extra annotations of SWITCH events and are not counted.
    """
    ev = acc.mot_events
    types = ev["Type"].to_numpy(dtype=str)
    matched = np.isin(types, ["MATCH", "SWITCH"])
    n_match = int(matched.sum())
    n_sw = int((types == "SWITCH").sum())
    n_miss = int((types == "MISS").sum())
    n_fp = int((types == "FP").sum())
    n_gt = n_match + n_miss
    d = ev["D"].to_numpy(dtype=float)[matched]
    return {
        "mota": 1.0 - (n_miss + n_fp + n_sw) / n_gt if n_gt else math.nan,
        "motp": float(d.sum() / n_match) if n_match else math.nan,
        "id_switches": n_sw,
        "num_false_positives": n_fp,
        "num_misses": n_miss,
        "num_matches": n_match,
        "num_gt": n_gt,
    }
