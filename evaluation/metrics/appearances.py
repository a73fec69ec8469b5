"""How often short appearances become reported people.

A robot meets many people only briefly: a walker crossing the laser's view, a person stepping out of a group. A
front end that needs several scans of evidence misses them while its recall, dominated by people seen for a long
time, looks fine. This module scores ``pfpeople run`` directories against ground-truth CSVs with ``person_id`` and
``hit_beams`` columns (the scan-level simulator writes them, :mod:`evaluation.scenarios.scan.bagfile`):

* an **appearance** is a maximal stretch of scans in which one person is seen (at least ``seen_beams`` laser beams
  on them) inside the run's grid, gaps of up to ``max_gap_s`` bridged; its duration runs from its first scan to
  one scan period after its last;
* in each of its scans the person is **found** when a reported person (``people.csv``) is matched to them one to
  one within ``gate`` (Hungarian assignment among the true people of that scan inside the grid,
  :func:`evaluation.metrics.standing_walking.motion_split`'s matching);
* per duration bin: the appearances, the fraction **reported** at least once, and the fraction of their scans found.

The run's grid frame must be the ground truth's frame (the scan-level scenes' grid is in the driving laser's frame).

Usage::

    python -m evaluation.metrics.appearances RUN_DIR GT_CSV [RUN_DIR GT_CSV ...]   # pooled over the pairs
"""

from __future__ import annotations

import argparse
import csv
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from evaluation.metrics.standing_walking import matched_people, run_rows_by_frame

__all__ = ["BINS_S", "Appearance", "AppearanceRow", "appearance_rows", "appearances", "format_appearance_rows"]

#: Duration bins (s): shorter than 1 s, 1-3 s (the short appearances a robot must still report), 3 s and longer.
BINS_S: tuple[tuple[float, float], ...] = ((0.0, 1.0), (1.0, 3.0), (3.0, float("inf")))


@dataclass(frozen=True)
class AppearanceRow:
    """One duration bin ``[low_s, high_s)``: its appearances, the fraction reported at least once and the fraction
    of their scans in which the person was found (NaN without appearances)."""

    low_s: float
    high_s: float
    appearances: int
    reported: float
    scans_found: float


@dataclass(frozen=True)
class Appearance:
    """One person's appearance: its duration (s), its scans and in how many of them the person was found."""

    person: int
    duration_s: float
    scans: int
    found: int


def _truth(gt_csv: Path, grid: dict[str, float]) -> tuple[dict[int, NDArray[np.float64]], dict[int, int]]:
    """Per scan, the true people inside the grid ``(P, 4)``: x, y, person id, hit beams; and each scan's stamp (ns)."""
    x0, y0, r = grid["x0"], grid["y0"], grid["resolution"]
    x1, y1 = x0 + grid["nx"] * r, y0 + grid["ny"] * r
    rows: dict[int, list[list[float]]] = {}
    stamps: dict[int, int] = {}
    with gt_csv.open(newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        names = reader.fieldnames or []
        missing = [c for c in ("scan_index", "stamp_ns", "person_id", "hit_beams") if c not in names]
        if missing:
            raise ValueError(f"{gt_csv}: appearances need the columns {missing}; it has {names}")
        xc = next((c for c in names if c.startswith("x_") and c.endswith("_m")), None)
        if xc is None:
            raise ValueError(f"{gt_csv}: no x_<frame>_m column; it has {names}")
        yc = "y_" + xc[2:]
        for row in reader:
            k = int(row["scan_index"])
            stamps[k] = int(row["stamp_ns"])
            x, y = float(row[xc]), float(row[yc])
            if x0 <= x < x1 and y0 <= y < y1:
                rows.setdefault(k, []).append([x, y, float(row["person_id"]), float(row["hit_beams"])])
    return {k: np.asarray(v, dtype=float) for k, v in rows.items()}, stamps


def appearances(
    run_dir: str | Path,
    gt_csv: str | Path,
    *,
    gate: float = 0.5,
    seen_beams: int = 3,
    max_gap_s: float = 0.5,
) -> list[Appearance]:
    """Every appearance of every person in a run (module docstring).

    Parameters
    ----------
    run_dir : path
        A ``pfpeople run`` output directory (``run.json``, ``people.csv``).
    gt_csv : path
        Ground truth with ``scan_index``, ``stamp_ns``, ``person_id``, ``x_<frame>_m``, ``y_<frame>_m`` and
        ``hit_beams`` columns, in the run's grid frame.
    gate : float
        Largest distance (m) of a match.
    seen_beams : int
        The beams on a person from which they count as seen.
    max_gap_s : float
        Longest stretch (s) without being seen that an appearance bridges.

    Returns
    -------
    list of Appearance

    Raises
    ------
    ValueError
        If the ground truth lacks a column (named).
    """
    run_dir, gt_csv = Path(run_dir), Path(gt_csv)
    grid = json.loads((run_dir / "run.json").read_text(encoding="utf-8"))["grid"]
    truth, stamps = _truth(gt_csv, grid)
    people = run_rows_by_frame(run_dir / "people.csv", ("x_m", "y_m"))
    period_s = float(np.median(np.diff(sorted(stamps.values())))) / 1e9 if len(stamps) > 1 else 0.0
    seen_in: dict[int, list[tuple[int, bool]]] = {}  # person -> [(scan, found)]
    for k in sorted(truth):
        t = truth[k]
        hit = matched_people(people.get(k, np.zeros((0, 2))), t, gate)
        for j in np.flatnonzero(t[:, 3] >= seen_beams):
            seen_in.setdefault(int(t[j, 2]), []).append((k, bool(hit[j])))
    out = []
    for person, scans in seen_in.items():
        start = 0
        for i in range(1, len(scans) + 1):
            if i == len(scans) or (stamps[scans[i][0]] - stamps[scans[i - 1][0]]) / 1e9 > max_gap_s + period_s / 2:
                part = scans[start:i]
                duration = (stamps[part[-1][0]] - stamps[part[0][0]]) / 1e9 + period_s
                out.append(Appearance(person, duration, len(part), sum(f for _, f in part)))
                start = i
    return out


def appearance_rows(found: Sequence[Appearance], bins: Sequence[tuple[float, float]] = BINS_S) -> list[AppearanceRow]:
    """Appearances pooled into duration ``bins`` (module docstring)."""
    rows = []
    for low, high in bins:
        sel = [a for a in found if low <= a.duration_s < high]
        scans = sum(a.scans for a in sel)
        rows.append(
            AppearanceRow(
                low_s=low,
                high_s=high,
                appearances=len(sel),
                reported=sum(a.found > 0 for a in sel) / len(sel) if sel else float("nan"),
                scans_found=sum(a.found for a in sel) / scans if scans else float("nan"),
            )
        )
    return rows


def format_appearance_rows(rows: Sequence[AppearanceRow]) -> str:
    """The table: duration bin, appearances, reported at least once, scans found."""
    lines = [f"{'seen for':<12}{'appearances':>12}{'reported':>10}{'scans found':>13}"]
    for r in rows:
        span = f"{r.low_s:g}-{r.high_s:g} s" if np.isfinite(r.high_s) else f">= {r.low_s:g} s"
        lines.append(f"{span:<12}{r.appearances:>12}{r.reported:>10.3f}{r.scans_found:>13.3f}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m evaluation.metrics.appearances", description=__doc__.split("\n\n")[0])
    p.add_argument("pairs", nargs="+", metavar="RUN_DIR GT_CSV", help="run directories and their ground truth")
    args = p.parse_args(argv)
    if len(args.pairs) % 2:
        p.error(f"give RUN_DIR GT_CSV pairs; got {len(args.pairs)} paths")
    found = [a for run, gt in zip(args.pairs[::2], args.pairs[1::2], strict=True) for a in appearances(run, gt)]
    print(format_appearance_rows(appearance_rows(found)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
