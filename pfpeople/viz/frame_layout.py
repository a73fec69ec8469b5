"""The size, layout and colours of an animation frame of a run (:class:`pfpeople.viz.run_view.RunFrameRenderer`).

The grid is drawn as the paper and :mod:`evaluation.harness.figures` draw it: the sensor at the bottom middle, x
(forward) up, y (left) to the left; only the display is flipped (:func:`display`, with :func:`extent`), never the
data. The map's axes have the grid's extent at equal scale (:func:`layout`); :func:`fit_size` gives a frame size
of the grid's aspect.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gridbridge.grid import GridSpec
from gridbridge.validation import check_int, check_real

__all__ = [
    "DETECTOR_COLOURS",
    "LASER_COLOURS",
    "MARKERS",
    "PARTICLE_COLOUR",
    "PEOPLE_COLOUR",
    "STATIC_COLOUR",
    "TRACK_COLOUR",
    "TRUTH_COLOUR",
    "ViewOptions",
    "display",
    "extent",
    "fit_size",
    "layout",
]

#: Detector marker shapes (hollow), in the run's detector order.
MARKERS = ("s", "^", "D", "v", "P", "X", "<", ">", "h", "*")
#: Detector colours (the summary's too): none is a laser colour, the people's red, the ground truth's green or the
#: tracks' blue.
DETECTOR_COLOURS = (
    "darkorange",
    "magenta",
    "deepskyblue",
    "gold",
    "black",
    "chocolate",
    "orchid",
    "dimgray",
    "darkkhaki",
)
#: Laser colours (scan points and field-of-view outlines).
LASER_COLOURS = ("royalblue", "darkviolet", "darkcyan", "olive", "sienna", "slateblue")
STATIC_COLOUR = "0.62"
PARTICLE_COLOUR = "deeppink"
PEOPLE_COLOUR = "red"
#: Ground truth (plus signs) and tracks (stars, id labels, velocity arrows): two colours no other mark has.
TRUTH_COLOUR = "limegreen"
TRACK_COLOUR = "blue"


def display(grid: NDArray[np.floating]) -> NDArray[np.float64]:
    """The ``(nx, ny)`` grid as an image: rows = x from far (top) to near, columns = y from left to right."""
    return np.asarray(grid, dtype=float)[::-1, ::-1]


def extent(spec: GridSpec) -> tuple[float, float, float, float]:
    """imshow extent (left, right, bottom, top): the horizontal axis is y decreasing (left is +y), x is up."""
    return (spec.y1, spec.y0, spec.x0, spec.x1)


@dataclass(frozen=True, kw_only=True)
class ViewOptions:
    """Size and rate of the animation.

    Parameters
    ----------
    width_px, height_px : int
        Frame size in pixels (even numbers: the H.264 encoder's 4:2:0 sampling needs them).
    dpi : float
        Dots per inch of the drawing (text and marker sizes scale with it).
    fps : float
        Frames per second of the video.
    """

    width_px: int = 960
    height_px: int = 640
    dpi: float = 100.0
    fps: float = 10.0

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            v = check_int(getattr(self, name), f"ViewOptions.{name}", minimum=160, maximum=7680)
            if v % 2:
                raise ValueError(f"ViewOptions.{name} must be an even number of pixels in [160, 7680], got {v}")
        for name in ("dpi", "fps"):
            check_real(getattr(self, name), f"ViewOptions.{name}", low=0.0, low_open=True)


#: Pixels of the frame layout: margins around the map, colour bar, and the side panel's share of the width.
_LEFT, _BOTTOM, _TOP, _CBAR = 60, 46, 30, 46


def _panel_px(width_px: int) -> int:
    return int(np.clip(0.27 * width_px, 130, 330))


def layout(spec: GridSpec, width_px: int, height_px: int) -> dict[str, tuple[float, float, float, float]]:
    """Axes rectangles (figure fractions: left, bottom, width, height) of a frame: ``map`` (the grid at equal
    scale in x and y, as large as fits beside the side panel), ``cbar`` (its colour bar), ``panel`` (the side
    panel: legend and readout) and ``path`` (the path plot, at the panel's bottom)."""
    panel = _panel_px(width_px)
    aspect = (spec.y1 - spec.y0) / (spec.x1 - spec.x0)  # width / height of the map in data units
    avail_w = max(width_px - _LEFT - _CBAR - panel, 40)
    avail_h = max(height_px - _BOTTOM - _TOP, 40)
    map_w = min(avail_w, avail_h * aspect)
    map_h = map_w / aspect
    x0 = _LEFT + (avail_w - map_w) / 2
    y0 = _BOTTOM + (avail_h - map_h) / 2
    px0 = width_px - panel + 12
    side = min(panel - 40, 0.34 * height_px)
    w, h = float(width_px), float(height_px)
    return {
        "map": (x0 / w, y0 / h, map_w / w, map_h / h),
        "cbar": ((x0 + map_w + 6) / w, y0 / h, 10 / w, map_h / h),
        "panel": (px0 / w, 0.0, (panel - 12) / w, 1.0),
        "path": ((px0 + 24) / w, 34 / h, side / w, side / h),
    }


def fit_size(spec: GridSpec, height_px: int = 640) -> tuple[int, int]:
    """A frame size (even pixels) ``height_px`` high whose map, at equal scale, fills its share of the width:
    a grid wider than deep gets a wider frame (between 480 and 1920 pixels)."""
    aspect = (spec.y1 - spec.y0) / (spec.x1 - spec.x0)
    map_w = (height_px - _BOTTOM - _TOP) * aspect
    width = _LEFT + map_w + _CBAR
    width = width / 0.73 if width / 0.73 * 0.27 <= 330 else width + 330  # the panel's share (_panel_px)
    width = int(np.clip(math.ceil(width), 480, 1920))
    return width + width % 2, height_px + height_px % 2
