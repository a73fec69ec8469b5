"""Ground truth of people positions from a CSV file, and its assignment to the frames of a run.

Columns (header row required, any order, extra columns ignored):

- a frame key, at least one of ``scan_index`` (index of the driving message on its topic, i.e. the run's
  ``driver_index``), ``stamp_ns`` (the frame stamp, matched to the nearest run frame within half the run's frame
  period) or ``bag_time_ns`` (a record time, assigned to the latest run frame recorded at or before it and less than
  one frame period earlier, as for the leg_tracker GT messages written 43-57 ms after their 7.5 Hz scan). The window
  follows the run's median frame period (:func:`match_window_ns`: a fixed window shorter than that delay would lose
  rows), and rows
  that fall on no frame are counted (:meth:`GroundTruth.assign`), never dropped silently. When several key columns
  are present the first of this list is used.
- ``person_id`` (integer); a (key, ``person_id``) pair appears once (a duplicate would count a person twice);
- the position in metres: ``x``, ``y`` or ``x_<frame>_m``, ``y_<frame>_m`` (the frame name is then taken
  from the column names, e.g. ``x_laser_m`` -> ``laser``, ``x_base_link_m`` -> ``base_link``, and kept in
  :attr:`GroundTruth.frame`; :func:`resolve_gt_frame` checks it against the frame a caller asks for). A file
  naming several frames must be read with ``frame=`` choosing one.

Keys are non-negative; a file without data rows is refused (every score would be NaN), and so is a row with more or
fewer fields than the header (a shifted column). The file is read as UTF-8 with an optional byte-order mark
(``utf-8-sig``): spreadsheet programs write one, and it would otherwise become part of the first column's name; another
encoding is refused naming the file and the line.

Example: ``../shared/data/leg_tracker/person_following_outdoor_1_gt.csv`` (scan_index, bag_time_ns,
person_id, x_laser_m, y_laser_m).

A run's frames: :meth:`GroundTruth.assign` gives the run frame of every row, :meth:`GroundTruth.beyond` the
rows after the run's last frame, :func:`gt_to_grid` maps positions into the run's grid frame and
:func:`truth_per_frame` does both (used by ``pfpeople view --gt``; scoring is in :mod:`evaluation.harness.run_truth`).
This module lives in ``pfpeople`` so that the viewer can read ground truth; the evaluation reads it from here too.
"""

from __future__ import annotations

import csv
import io
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pfpeople.io.run_dir import RunData
from pfpeople.sensors import Pose2D

__all__ = [
    "DEFAULT_MATCH_NS",
    "KEY_COLUMNS",
    "GroundTruth",
    "StampCheck",
    "gt_to_grid",
    "match_window_ns",
    "read_gt_csv",
    "resolve_gt_frame",
    "stamp_agreement",
    "truth_per_frame",
]

KEY_COLUMNS = ("scan_index", "stamp_ns", "bag_time_ns")
#: The matching window (ns) of a run with fewer than two frames (no period to derive it from).
DEFAULT_MATCH_NS = 50_000_000


def match_window_ns(key: str, times: NDArray[np.int64]) -> int:
    """How far a ground-truth time keyed by ``key`` may lie from its run frame (ns), from the run frames' ``times``
    (their ``stamp_ns`` or ``bag_time_ns`` column): half the median frame period for ``stamp_ns`` (the nearest frame),
    one period for ``bag_time_ns`` (rows are recorded after their frame); :data:`DEFAULT_MATCH_NS` without a period."""
    steps = np.diff(np.asarray(times, dtype=np.int64))
    steps = steps[steps > 0]
    if not steps.size:
        return DEFAULT_MATCH_NS
    period = int(np.median(steps))
    return period // 2 if key == "stamp_ns" else period


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """People positions per frame key.

    Attributes
    ----------
    key : {"scan_index", "stamp_ns", "bag_time_ns"}
        Which column keys the rows.
    keys : ndarray, shape (N,), int64
        Key of each row.
    person_id : ndarray, shape (N,), int64
    xy : ndarray, shape (N, 2)
        Positions (m) in ``frame``.
    frame : str or None
        Frame named by the column names (``x_<frame>_m``), None for plain ``x``/``y``.
    path : Path
    stamp_column : {"stamp_ns", "bag_time_ns"} or None
        For rows keyed by ``scan_index``: the time column the file also has (``stamp_ns`` preferred), which
        :func:`stamp_agreement` checks against the run's frames; None when the file has neither.
    stamps : ndarray, shape (N,), int64, or None
        That column's values.
    lines : ndarray, shape (N,), int64, or None
        File line of each row (for error messages).
    """

    key: str
    keys: NDArray[np.int64]
    person_id: NDArray[np.int64]
    xy: NDArray[np.float64]
    frame: str | None
    path: Path
    stamp_column: str | None = None
    stamps: NDArray[np.int64] | None = None
    lines: NDArray[np.int64] | None = None

    def __len__(self) -> int:
        return int(self.keys.size)

    def assign(
        self,
        driver_index: NDArray[np.int64],
        stamp_ns: NDArray[np.int64],
        bag_time_ns: NDArray[np.int64],
        *,
        tolerance_ns: int | None = None,
    ) -> tuple[NDArray[np.int64], int]:
        """Run frame (row of the run's frames table) of every GT row, -1 where none.

        Parameters
        ----------
        driver_index, stamp_ns, bag_time_ns : ndarray, shape (F,)
            The run's frames (``frames.csv`` columns), increasing.
        tolerance_ns : int, optional
            Largest stamp distance for ``key="stamp_ns"`` (inclusive); largest delay after a frame's record time for
            ``key="bag_time_ns"`` (exclusive). Default: :func:`match_window_ns` of the run's frames.

        Returns
        -------
        frame_of_row : ndarray, shape (N,), int64
        unassigned : int
            Number of GT rows with no run frame (outside the run, or a skipped frame).
        """
        n = len(driver_index)
        if tolerance_ns is None:
            tolerance_ns = self.window_ns(stamp_ns, bag_time_ns)
        if self.key == "scan_index":
            lookup = {int(d): k for k, d in enumerate(driver_index)}
            out = np.array([lookup.get(int(s), -1) for s in self.keys], dtype=np.int64)
        elif self.key == "stamp_ns":
            idx = np.clip(np.searchsorted(stamp_ns, self.keys), 1, max(n - 1, 1)) if n else np.zeros(0, int)
            out = np.full(len(self.keys), -1, dtype=np.int64)
            if n:
                cand = np.stack([idx - 1, np.minimum(idx, n - 1)])
                dist = np.abs(stamp_ns[cand] - self.keys[None, :])
                best = cand[np.argmin(dist, axis=0), np.arange(len(self.keys))]
                ok = np.abs(stamp_ns[best] - self.keys) <= tolerance_ns
                out[ok] = best[ok]
        else:
            idx = np.searchsorted(bag_time_ns, self.keys, side="right") - 1
            ok = (idx >= 0) & (self.keys - bag_time_ns[np.maximum(idx, 0)] < tolerance_ns) if n else idx >= 0
            out = np.where(ok, idx, -1).astype(np.int64)
        return out, int(np.count_nonzero(out < 0))

    def beyond(
        self,
        driver_index: NDArray[np.int64],
        stamp_ns: NDArray[np.int64],
        bag_time_ns: NDArray[np.int64],
        *,
        tolerance_ns: int | None = None,
    ) -> NDArray[np.bool_]:
        """Rows whose key lies after the run's last frame (e.g. a ``frames.csv`` cut short), shape (N,).

        Same arguments as :meth:`assign`; with no run frame at all every row is beyond.
        """
        if len(driver_index) == 0:
            return np.ones(len(self.keys), dtype=bool)
        if self.key == "scan_index":
            return self.keys > int(np.max(driver_index))
        if tolerance_ns is None:
            tolerance_ns = self.window_ns(stamp_ns, bag_time_ns)
        last = int(stamp_ns[-1] if self.key == "stamp_ns" else bag_time_ns[-1])
        reach = tolerance_ns if self.key == "stamp_ns" else tolerance_ns - 1  # bag_time_ns: less than the window
        return self.keys > last + reach

    def before(
        self, driver_index: NDArray[np.int64], stamp_ns: NDArray[np.int64], bag_time_ns: NDArray[np.int64]
    ) -> NDArray[np.bool_]:
        """Rows whose key lies before the run's first frame, shape (N,) (outside its matching window)."""
        if len(driver_index) == 0:
            return np.zeros(len(self.keys), dtype=bool)
        if self.key == "scan_index":
            return self.keys < int(np.min(driver_index))
        if self.key == "stamp_ns":
            return self.keys < int(stamp_ns[0]) - self.window_ns(stamp_ns, bag_time_ns)
        return self.keys < int(bag_time_ns[0])

    def window_ns(self, stamp_ns: NDArray[np.int64], bag_time_ns: NDArray[np.int64]) -> int:
        """The matching window of this file's key for a run whose frames have ``stamp_ns`` and ``bag_time_ns``
        (:func:`match_window_ns`; 0 for ``scan_index``)."""
        if self.key == "scan_index":
            return 0
        return match_window_ns(self.key, stamp_ns if self.key == "stamp_ns" else bag_time_ns)


@dataclass(frozen=True, eq=False)
class StampCheck:
    """How the time column of a ``scan_index``-keyed ground truth agrees with the run frames it is matched to.

    Attributes
    ----------
    column : {"stamp_ns", "bag_time_ns"}
        The GT column, compared with the run frames' column of the same name.
    checked : int
        GT rows matched to a run frame (the rows compared).
    disagree : ndarray, shape (N,), bool
        Matched rows whose time lies outside the window (never true for unmatched rows).
    delta_ns : ndarray, shape (N,), int64
        GT time minus the matched frame's time (0 for unmatched rows).
    period_ns : int
        Median frame period of the run.
    window_ns : tuple of int
        Agreeing ``delta_ns`` lie in ``[lo, hi)`` (``stamp_ns``: +- half a period, both ends included) .
    """

    column: str
    checked: int
    disagree: NDArray[np.bool_]
    delta_ns: NDArray[np.int64]
    period_ns: int
    window_ns: tuple[int, int]

    def offset_frames(self, row: int) -> int:
        """Offset of row ``row`` in frame periods: the nearest for ``stamp_ns``, those whole for ``bag_time_ns``."""
        ratio = float(self.delta_ns[row]) / self.period_ns
        return round(ratio) if self.column == "stamp_ns" else math.floor(ratio)


def stamp_agreement(
    gt: GroundTruth, frame_of_row: NDArray[np.int64], stamp_ns: NDArray[np.int64], bag_time_ns: NDArray[np.int64]
) -> StampCheck | None:
    """Check the time column of a ``scan_index``-keyed ground truth against the run frames its rows are on.

    ``stamp_ns`` agrees with the frame's ``stamp_ns`` within half the run's median frame period. ``bag_time_ns``
    is a record time at or after its scan's (the leg_tracker GT messages are recorded about half a period after
    their scan): it agrees from a quarter period before the frame's ``bag_time_ns`` to one period after.

    Parameters
    ----------
    gt : GroundTruth
    frame_of_row : ndarray, shape (N,), int64
        Run frame of every GT row, -1 where none (:meth:`GroundTruth.assign`).
    stamp_ns, bag_time_ns : ndarray, shape (F,)
        The run's frames (``frames.csv`` columns).

    Returns
    -------
    StampCheck or None
        None when there is nothing to check: rows not keyed by ``scan_index``, no time column, fewer than two
        run frames (no period).
    """
    if gt.stamp_column is None or gt.stamps is None or len(stamp_ns) < 2:
        return None
    ref = np.asarray(stamp_ns if gt.stamp_column == "stamp_ns" else bag_time_ns, dtype=np.int64)
    period = int(np.median(np.diff(ref)))
    if period <= 0:
        return None
    matched = frame_of_row >= 0
    delta = np.where(matched, gt.stamps - ref[np.maximum(frame_of_row, 0)], 0).astype(np.int64)
    if gt.stamp_column == "stamp_ns":
        lo, hi = -(period // 2), period // 2 + 1
    else:
        lo, hi = -(period // 4), period
    disagree = matched & ((delta < lo) | (delta >= hi))
    return StampCheck(gt.stamp_column, int(matched.sum()), disagree, delta, period, (lo, hi))


def _int(value: str, path: Path, line: int, col: str) -> int:
    try:
        return int(value)
    except ValueError:
        raise ValueError(f"{path}: line {line}: column {col!r} must be an integer, got {value!r}") from None


def resolve_gt_frame(gt: GroundTruth, requested: str | None) -> str:
    """The frame of ``gt``'s positions, checked against the frame a caller asks for.

    Parameters
    ----------
    gt : GroundTruth
        Ground truth; ``gt.frame`` is the frame its column names give (None for plain ``x``/``y``).
    requested : str or None
        The frame the caller (``--frame``) says the positions are in; None: take the file's, else ``"grid"``.

    Returns
    -------
    str
        ``gt.frame`` when the file names one, else ``requested`` (or ``"grid"``).

    Raises
    ------
    ValueError
        When the file names a frame and ``requested`` is another one; the message names both.
    """
    if gt.frame is None:
        return requested or "grid"
    if requested is None or requested == gt.frame:
        return gt.frame
    raise ValueError(_mismatch(gt.path, gt.frame, requested))


def _mismatch(path: Path, have: str, requested: str) -> str:
    return (
        f"ground-truth file {str(path)!r} has positions in frame {have!r} (columns x_{have}_m, y_{have}_m) "
        f"but frame {requested!r} was requested; give --frame {have} or leave --frame out"
    )


def _position_columns(path: Path, cols: list[str], frame: str | None) -> tuple[str, str, str | None]:
    """The position columns ``(x, y)`` of a header and the frame they name (None for plain ``x``/``y``)."""
    if "x" in cols and "y" in cols:
        return "x", "y", None
    named = [m.group(1) for c in cols if (m := re.fullmatch(r"x_(.+)_m", c))]
    named = [f for f in named if f"y_{f}_m" in cols]
    if not named:
        raise ValueError(f"{path}: needs position columns x, y or x_<frame>_m, y_<frame>_m; has {cols}")
    if frame is not None and frame not in named:
        if len(named) == 1:
            raise ValueError(_mismatch(path, named[0], frame))
        raise ValueError(f"{path}: has no columns x_{frame}_m, y_{frame}_m; its frames are {named}")
    if frame is None and len(named) > 1:
        raise ValueError(f"{path}: positions in several frames {named}; choose one (frame=, --frame)")
    frame = frame or named[0]
    return f"x_{frame}_m", f"y_{frame}_m", frame


def _read_rows(
    reader: Iterator[list[str]], path: Path, cols: list[str], key: str, xc: str, yc: str, stamp: str | None
) -> tuple[list[int], list[int], list[tuple[float, float]], list[int], list[int]]:
    """Keys, person ids, positions, ``stamp`` column values (empty when None) and file lines of the data rows.

    Errors name the file and line. A negative key, and a row repeating the key and person id of an earlier
    row (which would count that person twice), are refused naming both lines.
    """
    ik, ip, ix, iy = (cols.index(c) for c in (key, "person_id", xc, yc))
    keys: list[int] = []
    ids: list[int] = []
    xy: list[tuple[float, float]] = []
    stamps: list[int] = []
    lines: list[int] = []
    first_line: dict[tuple[int, int], int] = {}
    for line, row in enumerate(reader, start=2):
        if not row:
            continue
        if len(row) != len(cols):
            raise ValueError(
                f"{path}: line {line} has {len(row)} fields, expected {len(cols)} (the header's: {', '.join(cols)})"
            )
        k, pid = _int(row[ik], path, line, key), _int(row[ip], path, line, "person_id")
        if k < 0:
            raise ValueError(f"{path}: line {line}: {key} must be non-negative, got {k}")
        if (k, pid) in first_line:
            raise ValueError(
                f"{path}: line {line} repeats {key} {k}, person_id {pid} of line {first_line[k, pid]} "
                "(a person would be counted twice); remove the duplicate row"
            )
        first_line[k, pid] = line
        try:
            x, y = float(row[ix]), float(row[iy])
        except ValueError:
            raise ValueError(f"{path}: line {line}: {xc}/{yc} must be numbers, got {row[ix]!r}, {row[iy]!r}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"{path}: line {line}: position is not finite ({x}, {y})")
        if stamp is not None:
            stamps.append(_int(row[cols.index(stamp)], path, line, stamp))
        keys.append(k)
        ids.append(pid)
        xy.append((x, y))
        lines.append(line)
    return keys, ids, xy, stamps, lines


def _utf8_text(path: Path) -> str:
    """The text of ``path`` as UTF-8, without a byte-order mark; ValueError naming the file and line otherwise."""
    data = path.read_bytes()
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ValueError(
            f"ground-truth file {str(path)!r} is not UTF-8 text (byte {data[exc.start]:#04x} at line {line}); save it "
            "as UTF-8"
        ) from None


def read_gt_csv(path: str | Path, *, frame: str | None = None) -> GroundTruth:
    """Read a ground-truth CSV (see the module docstring); errors name the file, line and column.

    Parameters
    ----------
    path : path
        The CSV file (UTF-8, with or without a byte-order mark).
    frame : str, optional
        Which ``x_<frame>_m, y_<frame>_m`` pair to read when the file has several; a file naming another
        frame is an error naming both. Ignored for plain ``x``/``y`` columns (the caller says their frame).

    Raises
    ------
    ValueError
        Naming the file (and the line): not UTF-8, no header (a zero-byte file), no data rows (a header only: every
        score would be NaN), a missing column, a row with more or fewer fields than the header, a bad or negative
        key, a duplicated (key, person_id) row.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"ground-truth file {str(path)!r} does not exist")
    with io.StringIO(_utf8_text(path), newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            raise ValueError(f"{path}: empty file (a header row is required)")
        cols = [h.strip() for h in header]
        key = next((k for k in KEY_COLUMNS if k in cols), None)
        if key is None:
            raise ValueError(f"{path}: needs one of the columns {list(KEY_COLUMNS)}; has {cols}")
        if "person_id" not in cols:
            raise ValueError(f"{path}: needs a person_id column; has {cols}")
        xc, yc, frame = _position_columns(path, cols, frame)
        stamp = next((c for c in KEY_COLUMNS[1:] if c in cols), None) if key == "scan_index" else None
        keys, ids, xy, stamps, lines = _read_rows(reader, path, cols, key, xc, yc, stamp)
    if not keys:
        raise ValueError(f"{path}: no ground-truth rows (only a header): nothing to score against")
    return GroundTruth(
        key=key,
        keys=np.array(keys, dtype=np.int64),
        person_id=np.array(ids, dtype=np.int64),
        xy=np.array(xy, dtype=float).reshape(-1, 2),
        frame=frame,
        path=path,
        stamp_column=stamp,
        stamps=np.array(stamps, dtype=np.int64) if stamp is not None else None,
        lines=np.array(lines, dtype=np.int64),
    )


def gt_to_grid(run: RunData, gt: GroundTruth, frame: str) -> NDArray[np.float64]:
    """GT positions ``(N, 2)`` mapped into the run's grid frame.

    ``frame`` is ``"grid"``, the run's grid frame, a frame the run recorded in ``frames_in_grid`` (mapped by
    its mount), or else ``"laser"`` as an alias of the driving sensor's frame, which the grid is attached to.
    """
    known: dict[str, list[float]] = run.meta.get("frames_in_grid", {})
    if frame in ("grid", run.meta.get("grid_frame", "")):
        return gt.xy
    if frame in known:  # before the "laser" alias: a recorded frame named "laser" has its own mount
        x, y, yaw = known[frame]
        return Pose2D(x=x, y=y, yaw=yaw).apply(gt.xy)
    if frame == "laser":
        return gt.xy
    raise ValueError(
        f"ground-truth frame {frame!r} is not known to run {str(run.path)!r}; use 'grid', 'laser' "
        f"(the driving sensor) or one of {sorted(known)}"
    )


def truth_per_frame(
    run: RunData, gt: GroundTruth, *, frame: str | None = None, tolerance_ns: int | None = None
) -> tuple[list[NDArray[np.float64]], int]:
    """Ground-truth positions of every run frame, ``(P, 2)`` each, in the run's grid frame (m).

    ``frame`` as :func:`resolve_gt_frame` (None: the file's, else ``"grid"``), mapped by :func:`gt_to_grid`.
    Returns the per-frame positions and the number of GT rows that fall on no run frame.
    """
    xy = gt_to_grid(run, gt, resolve_gt_frame(gt, frame))
    fr = run.frames
    rows, unassigned = gt.assign(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    out: list[list[tuple[float, float]]] = [[] for _ in range(run.n_frames)]
    for f, p in zip(rows, xy, strict=True):
        if 0 <= f < run.n_frames:
            out[int(f)].append((float(p[0]), float(p[1])))
    return [np.asarray(o, dtype=float).reshape(-1, 2) for o in out], unassigned
