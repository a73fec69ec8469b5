"""The one-page summary PNG of a run directory (:mod:`pfpeople.io.run_dir`), drawn with matplotlib on an Agg canvas.

:func:`render_summary` draws people per frame (and true people per frame with ground truth, tracks per frame when
present), detections per detector per frame over time, the histogram of the belief over all frames and cells,
and the run's figures (ego-motion sources among them). The colours are the animation's
(:mod:`pfpeople.viz.run_view`): detectors in theirs, ground truth green, tracks blue, people red.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from pfpeople.io.run_dir import RunData
from pfpeople.viz.frame_layout import DETECTOR_COLOURS, TRACK_COLOUR, TRUTH_COLOUR
from pfpeople.viz.run_data import default_fps, ego_sources, frame_times_s

__all__ = ["render_summary"]


def render_summary(
    run: RunData,
    path: str | Path,
    *,
    tracks: dict[str, NDArray[Any]] | None = None,
    truth: Sequence[NDArray[np.float64]] | None = None,
    dpi: float = 100.0,
) -> Path:
    """Write a one-page summary PNG of ``run`` at ``path`` (see the module docstring); returns the path.

    ``truth``: ground truth per run frame (as :class:`RunFrameRenderer`'s); the true people per frame are drawn
    beside the people found, from the first to the last frame with a ground-truth position.
    """
    if run.n_frames == 0:
        raise ValueError(f"run {str(run.path)!r} has no frames (run.json status {run.meta.get('status')!r})")
    if truth is not None and len(truth) != run.n_frames:
        raise ValueError(f"truth must have one entry per run frame ({run.n_frames}), got {len(truth)}")
    path = Path(path)
    n = run.n_frames
    t = frame_times_s(run)
    fig = Figure(figsize=(11.0, 8.5), dpi=dpi)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2)
    _summary_people(axes[0, 0], run, t, tracks, truth)
    a = axes[0, 1]
    det = run.detections
    window = max(1, min(10, n // 20))  # a running mean keeps long runs readable
    kernel = np.ones(window) / window
    for k, name in enumerate(run.meta.get("detectors", [])):
        frames = det["frame"][det["detector"] == name]
        counts = np.bincount(frames, minlength=n)[:n].astype(float)
        smooth = np.convolve(counts, kernel, mode="same")
        a.plot(t, smooth, color=DETECTOR_COLOURS[k % len(DETECTOR_COLOURS)], label=f"{name} ({len(frames)} in all)")
    a.set_title(f"detections per frame, per detector (mean over {window} frames)")
    a.set_xlabel("time (s)")
    a.set_ylabel("detections")
    a.legend(fontsize=8)
    a = axes[1, 0]
    # Histogram over all frames and cells, accumulated frame by frame (the grids are memory-mapped).
    edges = np.linspace(0.0, 1.0, 51)
    hist = np.zeros(len(edges) - 1)
    for k in range(n):
        hist += np.histogram(np.asarray(run.grids[k], dtype=float), bins=edges)[0]
    a.bar(edges[:-1], hist, width=np.diff(edges), align="edge", color="0.4")
    a.set_yscale("log")
    a.set_title(f"belief histogram ({n} frames x {run.spec.nx * run.spec.ny} cells)")
    a.set_xlabel("belief")
    a.set_ylabel("cells")
    a = axes[1, 1]
    a.axis("off")
    wrapped = [w for line in _summary_lines(run, t, truth) for w in textwrap.wrap(line, 64, subsequent_indent="  ")]
    a.text(0.0, 1.0, "\n".join(wrapped), va="top", fontsize=8, family="monospace", transform=a.transAxes)
    fig.suptitle(f"pfpeople run summary: {run.path.name}")
    fig.subplots_adjust(left=0.08, right=0.97, bottom=0.07, top=0.91, wspace=0.25, hspace=0.35)
    fig.savefig(path)
    return path


def _truth_counts(truth: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    """True people per frame, NaN before the first and after the last frame with a ground-truth position."""
    counts = np.array([len(p) for p in truth], dtype=float)
    seen = np.flatnonzero(counts > 0)
    if len(seen):
        counts[: seen[0]] = np.nan
        counts[seen[-1] + 1 :] = np.nan
    return counts


def _summary_people(
    a: Any,
    run: RunData,
    t: NDArray[np.float64],
    tracks: dict[str, NDArray[Any]] | None,
    truth: Sequence[NDArray[np.float64]] | None,
) -> None:
    """The summary's first plot: people found (and tracks, and true people) per frame over time."""
    n = run.n_frames
    if truth is not None:
        a.plot(t, _truth_counts(truth), drawstyle="steps-post", color=TRUTH_COLOUR, lw=2.5, label="true people (GT)")
    a.plot(t, run.frames["n_people"], drawstyle="steps-post", color="red", label="people (filter)")
    if tracks is not None and len(tracks["frame"]):
        counts = np.bincount(tracks["frame"][(tracks["frame"] >= 0) & (tracks["frame"] < n)], minlength=n)
        a.plot(t, counts[:n], drawstyle="steps-post", color=TRACK_COLOUR, label="tracks")
    a.set_title("people over time" + (" (and ground truth)" if truth is not None else ""))
    a.set_xlabel("time (s)")
    a.set_ylabel("count per frame")
    a.legend(fontsize=8)


def _summary_lines(run: RunData, t: NDArray[np.float64], truth: Sequence[NDArray[np.float64]] | None) -> list[str]:
    """The summary's text: run, grid, filter, detectors, ego-motion sources, people, belief, scans."""
    meta, n = run.meta, run.n_frames
    config = meta.get("config")
    kind = config.get("filter", {}).get("kind", "?") if isinstance(config, dict) else "?"
    ppl = run.frames["n_people"]
    src = ego_sources(run)
    ego = ", ".join(f"{name} {int(np.count_nonzero(src == name))}" for name in ("odometry", "scan matching", "none"))
    lines = [
        f"run: {run.path}",
        f"status: {meta.get('status')}   frames: {n}",
        f"span: {t[-1]:.2f} s   frame rate: {default_fps(run):g} Hz (median)",
        f"grid: {run.spec.nx} x {run.spec.ny} cells of {run.spec.resolution} m, frame {meta.get('grid_frame', '?')}",
        f"filter: {kind}",
        f"detectors: {', '.join(meta.get('detectors', []))}",
        f"ego-motion per frame: {ego}",
        f"people per frame: mean {float(np.mean(ppl)):.2f}, max {int(np.max(ppl))}",
    ]
    if truth is not None:
        counts = _truth_counts(truth)
        on = ~np.isnan(counts)
        mean = float(np.mean(counts[on])) if on.any() else math.nan
        lines.append(f"true people per frame: mean {mean:.2f} ({int(on.sum())} frames with GT)")
    lines.append(f"mean belief: {float(np.mean([np.mean(run.grids[k]) for k in range(n)])):.3f}")
    if run.scans is not None:
        lines.append(f"scans: {', '.join(run.scan_topics)}, {len(run.scans) / n:.0f} returns a frame")
    if run.particles is not None:
        lines.append(f"particles drawn: {len(run.particles) / n:.0f} a frame (a subsample)")
    return lines
