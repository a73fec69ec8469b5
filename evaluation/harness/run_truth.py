"""A pipeline run (``pfpeople run``) next to its ground truth, frame by frame, in the run's grid frame.

Used by ``pfpeople-eval score`` and ``pfpeople-eval calibrate --run``: ground-truth rows are assigned to the
run's frames (:meth:`pfpeople.io.ground_truth.GroundTruth.assign`), mapped into the grid frame, and limited to an
optional bearing sector and range; each detector's detections (``detections.csv``) and the filter's classified
people (``people.csv``) are grouped per frame the same way.

The ground-truth frame: a file whose columns name one (``x_laser_m``) is in that frame; a requested frame that
differs is an error naming both (:func:`pfpeople.io.ground_truth.resolve_gt_frame`). GT rows after the run's last frame
(a run stopped early, a ``frames.csv`` cut short) are counted and logged as a warning, never dropped silently:
see :func:`gt_coverage`.

Stamps: a file keyed by ``scan_index`` that also has a ``stamp_ns`` (or ``bag_time_ns``) column is checked
against the run frames its rows are matched to (:func:`check_gt_stamps`): a ``scan_index`` shifted against the
run, or a GT of another recording, is refused when more than 10 % of the matched rows disagree, naming the
first such line and the offset; fewer disagreeing rows are logged as a warning and counted
(``gt_rows_stamp_mismatch``).
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfpeople.io.ground_truth import GroundTruth, gt_to_grid, resolve_gt_frame, stamp_agreement
from pfpeople.io.run_dir import RunData

__all__ = [
    "MAX_STAMP_MISMATCH",
    "check_gt_stamps",
    "group_by_frame",
    "gt_coverage",
    "gt_to_grid",
    "in_region",
    "lost_rows",
    "truth_and_sources",
]

log = logging.getLogger(__name__)

MAX_STAMP_MISMATCH = 0.10
"""Largest fraction of matched GT rows whose stamp may disagree with their run frame's before refusing."""


def check_gt_stamps(run: RunData, gt: GroundTruth, frame_of_row: NDArray[np.int64]) -> int:
    """Check the stamps of a ``scan_index``-keyed GT against its run frames
    (:func:`pfpeople.io.ground_truth.stamp_agreement`).

    Parameters
    ----------
    run : RunData
    gt : GroundTruth
    frame_of_row : ndarray, shape (N,), int64
        Run frame of every GT row, -1 where none (:meth:`pfpeople.io.ground_truth.GroundTruth.assign`).

    Returns
    -------
    int
        Matched rows whose stamp disagrees (0 when the file has no time column); when any do, a warning names
        the count.

    Raises
    ------
    ValueError
        When more than :data:`MAX_STAMP_MISMATCH` of the matched rows disagree: naming the file, the first
        disagreeing line, its stamp, the frame's, and the offset in frames and seconds.
    """
    fr = run.frames
    check = stamp_agreement(gt, frame_of_row, fr["stamp_ns"], fr["bag_time_ns"])
    if check is None or not check.disagree.any():
        return 0
    bad = int(check.disagree.sum())
    row = int(np.flatnonzero(check.disagree)[0])
    line = int(gt.lines[row]) if gt.lines is not None else row + 2
    col, f = check.column, int(frame_of_row[row])
    detail = (
        f"line {line}: scan_index {int(gt.keys[row])} has {col} {int(check.delta_ns[row]) + int(fr[col][f])} but "
        f"run frame {f} (driver_index {int(fr['driver_index'][f])}) has {col} {int(fr[col][f])}: an offset of "
        f"{check.offset_frames(row):+d} frame(s), {check.delta_ns[row] / 1e9:+.3f} s (frame period "
        f"{check.period_ns / 1e9:.3f} s)"
    )
    share = f"{bad} of {check.checked} matched ground-truth rows ({100 * bad / check.checked:.0f} %)"
    if bad > MAX_STAMP_MISMATCH * check.checked:
        raise ValueError(
            f"ground-truth file {str(gt.path)!r} does not match run {str(run.path)!r}: {share} disagree in {col}; "
            f"first at {detail}. Its scan_index column is shifted against the run, or it is the ground truth "
            "of another recording"
        )
    log.warning(
        "ground-truth file %s: %s disagree with run %s in %s; first at %s", gt.path, share, run.path, col, detail
    )
    return bad


def gt_coverage(run: RunData, gt: GroundTruth, *, tolerance_ns: int | None = None) -> dict[str, Any]:
    """How much of the ground truth the run's frames cover.

    Returns
    -------
    dict
        ``gt_frames``: distinct GT frame keys; ``gt_frames_without_run_frame``: keys no run frame was assigned
        to (skipped frames, rows before the run, rows after it); ``gt_frames_beyond_run`` and
        ``gt_rows_beyond_run``: keys and rows after the run's last frame (a run stopped early or a
        ``frames.csv`` cut short); ``gt_rows_before_run`` and ``gt_rows_between_frames``: the other rows on no
        run frame (before its first frame; in a gap between frames wider than the matching window);
        ``gt_match_window_s``: that window (:func:`pfpeople.io.ground_truth.match_window_ns`, or ``tolerance_ns``;
        0 for ``scan_index`` keys); ``gt_rows_stamp_mismatch``: matched rows whose ``stamp_ns`` / ``bag_time_ns``
        disagrees with their run frame's (:func:`check_gt_stamps`; 0 without such a column).
    """
    fr = run.frames
    rows_frame, _ = gt.assign(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    lost = lost_rows(run, gt, rows_frame, tolerance_ns)
    beyond = gt.beyond(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    check = stamp_agreement(gt, rows_frame, fr["stamp_ns"], fr["bag_time_ns"])
    window = gt.window_ns(fr["stamp_ns"], fr["bag_time_ns"]) if tolerance_ns is None else tolerance_ns
    return {
        "gt_frames": int(np.unique(gt.keys).size),
        "gt_frames_without_run_frame": int(np.unique(gt.keys[rows_frame < 0]).size),
        "gt_frames_beyond_run": int(np.unique(gt.keys[beyond]).size),
        "gt_rows_beyond_run": lost["beyond"],
        "gt_rows_before_run": lost["before"],
        "gt_rows_between_frames": lost["between"],
        "gt_match_window_s": window * 1e-9 if gt.key != "scan_index" else 0.0,
        "gt_rows_stamp_mismatch": int(check.disagree.sum()) if check is not None else 0,
    }


def lost_rows(
    run: RunData, gt: GroundTruth, frame_of_row: NDArray[np.int64], tolerance_ns: int | None = None
) -> dict[str, int]:
    """The GT rows on no run frame, by where they lie: ``before`` the run's first frame, ``beyond`` its last, and
    ``between`` frames (in a gap wider than the matching window: frames the run skipped or did not make)."""
    fr = run.frames
    none = frame_of_row < 0
    before = none & gt.before(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"])
    beyond = none & gt.beyond(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    between = none & ~before & ~beyond
    return {k: int(np.count_nonzero(v)) for k, v in (("before", before), ("beyond", beyond), ("between", between))}


def _warn_lost(run: RunData, gt: GroundTruth, lost: dict[str, int], window_ns: int) -> None:
    """Log the GT rows on no run frame (other than those after the run's last frame, logged on their own)."""
    if not lost["before"] and not lost["between"]:
        return
    window = f"{window_ns / 1e6:.0f} ms {'after' if gt.key == 'bag_time_ns' else 'around'} a frame"
    log.warning(
        "%d ground-truth row(s) of %s (keyed by %s) fall on no frame of run %s and are not scored: %d before its first "
        "frame, %d between frames (further than %s: frames the run skipped or did not make)",
        lost["before"] + lost["between"],
        gt.path,
        gt.key,
        run.path,
        lost["before"],
        lost["between"],
        window if gt.key != "scan_index" else "no frame of their scan_index",
    )


def in_region(
    xy: NDArray[np.float64], sector: tuple[float, float] | None, max_range: float | None
) -> NDArray[np.bool_]:
    keep = np.ones(len(xy), dtype=bool)
    if len(xy) == 0:
        return keep
    if sector is not None:
        lo, hi = (math.radians(a) for a in sector)
        bearing = np.arctan2(xy[:, 1], xy[:, 0])
        keep &= (bearing >= lo) & (bearing <= hi)
    if max_range is not None:
        keep &= np.hypot(xy[:, 0], xy[:, 1]) <= max_range
    return keep


def group_by_frame(frames: NDArray[np.int64], xy: NDArray[np.float64], n: int) -> list[NDArray[np.float64]]:
    out: list[list[tuple[float, float]]] = [[] for _ in range(n)]
    for f, p in zip(frames, xy, strict=True):
        if 0 <= f < n:
            out[int(f)].append((float(p[0]), float(p[1])))
    return [np.asarray(o, dtype=float).reshape(-1, 2) for o in out]


def truth_and_sources(
    run: RunData,
    gt: GroundTruth,
    *,
    frame: str | None = None,
    sector: tuple[float, float] | None = None,
    max_range: float | None = None,
    tolerance_ns: int | None = None,
) -> tuple[list[NDArray[np.float64]], dict[str, list[NDArray[np.float64]]], int]:
    """Per frame: true positions and, per source (each detector and ``"filter"``), positions (m, grid frame).

    ``frame`` is the frame of the GT positions (see :func:`gt_to_grid`); None takes the one the file's
    columns name, else ``"grid"``; a frame other than the file's raises ValueError naming both.

    Returns ``(truth, sources, unassigned)``: ``truth[k]`` is ``(P, 2)``, ``sources[name][k]`` is ``(M, 2)``,
    both limited to the sector and range; ``unassigned`` counts GT rows on no run frame. Those rows are logged as a
    warning with their count (after the run's last frame; before its first or between its frames,
    :func:`lost_rows`); GT stamps are checked against the run's by :func:`check_gt_stamps` (a ValueError when most
    disagree). Rows keyed by a time are matched within :func:`pfpeople.io.ground_truth.match_window_ns` of the run's
    frame period unless ``tolerance_ns`` is given.
    """
    frame = resolve_gt_frame(gt, frame)
    if sector is not None and not sector[0] < sector[1]:
        raise ValueError(f"--sector needs DEG_MIN < DEG_MAX, got {sector}")
    if max_range is not None and not max_range > 0:
        raise ValueError(f"--max-range must be positive, got {max_range}")
    n = run.n_frames
    fr = run.frames
    rows_frame, unassigned = gt.assign(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    check_gt_stamps(run, gt, rows_frame)
    window = gt.window_ns(fr["stamp_ns"], fr["bag_time_ns"]) if tolerance_ns is None else tolerance_ns
    _warn_lost(run, gt, lost_rows(run, gt, rows_frame, tolerance_ns), window)
    beyond = gt.beyond(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    if beyond.any():
        log.warning(
            "%d ground-truth row(s) of %s (%d frame key(s)) lie after the last frame of run %s (%d frames, "
            "status %s): they are not scored (the run stopped early, e.g. --max-frames, or its frames.csv "
            "was cut short)",
            int(beyond.sum()),
            gt.path,
            int(np.unique(gt.keys[beyond]).size),
            run.path,
            n,
            run.meta.get("status"),
        )
    truth = group_by_frame(rows_frame, gt_to_grid(run, gt, frame), n)
    truth = [t[in_region(t, sector, max_range)] for t in truth]
    det = run.detections
    sources: dict[str, list[NDArray[np.float64]]] = {}
    for name in run.meta["detectors"]:
        sel = det["detector"] == name
        sources[name] = group_by_frame(det["frame"][sel], np.column_stack((det["x_m"][sel], det["y_m"][sel])), n)
    ppl = run.people
    sources["filter"] = group_by_frame(ppl["frame"], np.column_stack((ppl["x_m"], ppl["y_m"])), n)
    for name, per_frame in sources.items():
        sources[name] = [d[in_region(d, sector, max_range)] for d in per_frame]
    return truth, sources, unassigned
