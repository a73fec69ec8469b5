"""Figures in the style of the paper's Fig. 6: truth, people prior, sensor prior, each detector, fusion, posterior.

Drawn with matplotlib's object-oriented API on an Agg canvas (no pyplot state, any backend). Grids are drawn
as the paper draws them: the sensor at the bottom middle, x (forward) up, y (left) to the left.
Only the display is flipped (``grid[::-1, ::-1]``), never the data.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from evaluation.scenarios.scenario import Frame
from gridbridge import GridSpec
from gridbridge.blobs import BlobParams, classify_blobs
from gridbridge.filter import FilterStep
from gridbridge.params import DetectorModel

__all__ = ["display", "fig6_panels"]


def display(grid: NDArray[np.floating] | NDArray[np.bool_]) -> NDArray[np.float64]:
    """The ``(nx, ny)`` grid as an image: rows = x from far (top) to near, columns = y from left to right."""
    return np.asarray(grid, dtype=float)[::-1, ::-1]


def _extent(spec: GridSpec) -> tuple[float, float, float, float]:
    # imshow extent (left, right, bottom, top) in axis units: horizontal axis is -y (left is +y).
    return (spec.y1, spec.y0, spec.x0, spec.x1)


def fig6_panels(
    frame: Frame,
    step: FilterStep,
    spec: GridSpec,
    models: Sequence[DetectorModel],
    path: Path,
    *,
    title: str = "",
    blob_params: BlobParams | None = None,
) -> Path:
    """Draw one frame's stages as a row of panels and save a PNG at ``path``.

    The "classified people" panel classifies the posterior with ``blob_params`` (default the paper's).
    """
    cls = classify_blobs(step.posterior, spec=spec, params=blob_params)
    panels: list[tuple[str, NDArray[np.float64], str]] = [
        ("ground truth", frame.truth_grid.astype(float), "Reds"),
        ("people prior", step.people_prior, "Greys"),
        ("sensor prior", step.sensor_prior, "Greys"),
    ]
    for i, m in enumerate(models):
        panels.append((f"{m.name}: P(D|p)", step.detector_likelihoods[i], "Greys"))
    panels.append(("fusion (eqs. 13-14)", step.likelihood, "Greys"))
    panels.append(("posterior", step.posterior, "Greys"))
    panels.append(("classified people", cls.mask.astype(float), "Reds"))
    n = len(panels)
    cols = min(n, 5)
    rows = -(-n // cols)
    fig = Figure(figsize=(3.0 * cols, 3.2 * rows))
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax, (name, grid, cmap) in zip(axes.ravel(), panels, strict=False):
        ax.imshow(display(grid), cmap=cmap, vmin=0.0, vmax=1.0, extent=_extent(spec), interpolation="nearest")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("y (m)", fontsize=7)
        ax.set_ylabel("x (m)", fontsize=7)
        ax.tick_params(labelsize=6)
        if len(frame.people):
            ax.plot(frame.people[:, 1], frame.people[:, 0], "o", mfc="none", mec="tab:blue", ms=5, mew=0.8)
        ax.set_xlim(spec.y1, spec.y0)
        ax.set_ylim(spec.x0, spec.x1)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    fig.suptitle(title or f"frame {frame.index}", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    return path
