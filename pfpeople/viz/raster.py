"""Pixel layers of an animation frame, painted with numpy (and Pillow for text) into an RGBA frame buffer.

:class:`pfpeople.viz.run_view.RunFrameRenderer` draws what does not change from frame to frame once with
matplotlib (axes, ticks, colour bar, legend, the side panel's frame) and paints what changes into a copy of it.
matplotlib draws a frame's text glyph by glyph and resamples an image every frame; the layers here do the same
with a lookup and a copy:

- :class:`GridPainter`: the belief grid as matplotlib's ``imshow(..., interpolation="nearest")`` shows it, by
  a colour lookup per cell and two index gathers (each screen pixel shows the cell under its centre);
- :class:`Overlay`: a layer drawn once by matplotlib on a transparent figure (the fields of view, the map's
  frame) and alpha-blended over the grid every frame (only its non-transparent pixels);
- :class:`TextPainter`: text rendered with Pillow in matplotlib's DejaVu fonts, each string once (cached), then
  alpha-blended in its colour.

Buffers are ``(H, W, 4)`` uint8 RGBA arrays, row 0 at the top (the layout of matplotlib's Agg buffer).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import to_rgb
from matplotlib.font_manager import FontProperties, findfont
from numpy.typing import NDArray
from PIL import Image, ImageDraw, ImageFont

__all__ = ["GridPainter", "Overlay", "TextPainter", "blend", "rgb8"]

#: Colour levels of a matplotlib colour map (``Colormap.N``): a value v in [0, 1] shows level min(int(256 v), 255).
LEVELS = 256


def rgb8(colour: Any) -> tuple[int, int, int]:
    """A matplotlib colour as 0..255 integers."""
    r, g, b = to_rgb(colour)
    return round(255 * r), round(255 * g), round(255 * b)


def blend(buf: NDArray[np.uint8], alpha: NDArray[np.uint8], top: int, left: int, colour: tuple[int, int, int]) -> None:
    """Blend ``colour`` into ``buf`` (H, W, 4) with opacity ``alpha`` (h, w; 0..255) at row ``top``, column ``left``.

    The part of ``alpha`` outside the buffer is left out.
    """
    h, w = alpha.shape
    r0, c0 = max(top, 0), max(left, 0)
    r1, c1 = min(top + h, buf.shape[0]), min(left + w, buf.shape[1])
    if r0 >= r1 or c0 >= c1:
        return
    a = alpha[r0 - top : r1 - top, c0 - left : c1 - left, None].astype(np.uint16)
    region = buf[r0:r1, c0:c1, :3]
    mixed = region * (255 - a) + np.asarray(colour, dtype=np.uint16) * a + 127
    region[...] = mixed // 255


class GridPainter:
    """Paints an ``(nx, ny)`` grid into a rectangle of the frame, cell by cell, in a matplotlib colour map.

    Parameters
    ----------
    rows_i : ndarray (R,) of int
        For each screen row of the rectangle (top to bottom), the grid index ``i`` (x) under it.
    cols_j : ndarray (C,) of int
        For each screen column (left to right), the grid index ``j`` (y) under it.
    top, left : int
        The rectangle's first row and column in the frame.
    cmap : str
        A matplotlib colour map; values are clipped to [0, 1] (``vmin = 0``, ``vmax = 1``).
    """

    def __init__(self, rows_i: NDArray[np.intp], cols_j: NDArray[np.intp], top: int, left: int, cmap: str) -> None:
        self.rows_i, self.cols_j = np.asarray(rows_i, dtype=np.intp), np.asarray(cols_j, dtype=np.intp)
        self.top, self.left = int(top), int(left)
        rgba = (np.asarray(colormaps[cmap](np.arange(LEVELS) / (LEVELS - 1))) * 255).round().astype(np.uint8)
        rgba[:, 3] = 255
        #: The colour of each level as one 32-bit word (the RGBA bytes of a pixel), so a pixel is copied at once.
        self.lut = np.ascontiguousarray(rgba).view(np.uint32).ravel()

    def levels(self, grid: NDArray[np.floating]) -> NDArray[np.intp]:
        """The colour level of each cell (as matplotlib maps a value in [0, 1]; NaN shows as 0)."""
        v = np.nan_to_num(np.asarray(grid, dtype=float), nan=0.0)
        return np.clip((v * LEVELS).astype(np.intp), 0, LEVELS - 1)

    def paint(self, buf: NDArray[np.uint8], grid: NDArray[np.floating]) -> None:
        """Paint ``grid`` (nx, ny) into ``buf`` (a C-contiguous (H, W, 4) uint8 array)."""
        cells = self.lut[self.levels(grid)]  # (nx, ny) RGBA words
        image = np.take(np.take(cells, self.rows_i, axis=0), self.cols_j, axis=1)
        words = buf.view(np.uint32)[..., 0]  # (H, W): one word a pixel
        words[self.top : self.top + len(self.rows_i), self.left : self.left + len(self.cols_j)] = image


@dataclass(frozen=True)
class Overlay:
    """The non-transparent pixels of an RGBA layer, blended over a frame.

    Attributes
    ----------
    index : ndarray (P,) of int
        Flat pixel indices (row * W + column).
    rgb : ndarray (P, 3) of uint16
        Their colours.
    alpha : ndarray (P, 1) of uint16
        Their opacity (1..255).
    """

    index: NDArray[np.intp]
    rgb: NDArray[np.uint16]
    alpha: NDArray[np.uint16]

    @classmethod
    def from_rgba(cls, layer: NDArray[np.uint8]) -> Overlay:
        """The overlay of an ``(H, W, 4)`` RGBA layer (straight alpha, as matplotlib's Agg buffer)."""
        flat = np.asarray(layer).reshape(-1, 4)
        index = np.flatnonzero(flat[:, 3])
        return cls(index, flat[index, :3].astype(np.uint16), flat[index, 3:4].astype(np.uint16))

    def paint(self, buf: NDArray[np.uint8]) -> None:
        """Blend the layer over ``buf`` (same size)."""
        flat = buf.reshape(-1, 4)
        under = flat[self.index, :3].astype(np.uint16)
        flat[self.index, :3] = (under * (255 - self.alpha) + self.rgb * self.alpha + 127) // 255


class TextPainter:
    """Text in matplotlib's DejaVu Sans (``mono``: DejaVu Sans Mono) at a point size, painted into a frame.

    Each (string, font) is rendered once with Pillow and kept (the last :attr:`CACHE` of them), then blended in
    its colour. Positions are pixels: ``x`` the left (``align="left"``) or right (``"right"``) end of the text,
    ``y`` its top (``valign="top"``: the font's ascent) or its middle (``"middle"``).

    Parameters
    ----------
    dpi : float
        Dots per inch: a point is ``dpi / 72`` pixels, as in matplotlib.
    """

    #: Strings kept rendered.
    CACHE = 4096

    def __init__(self, dpi: float) -> None:
        self.dpi = float(dpi)
        self._fonts: dict[tuple[float, bool], ImageFont.FreeTypeFont] = {}
        self._masks: OrderedDict[tuple[str, float, bool], tuple[NDArray[np.uint8], int]] = OrderedDict()

    def font(self, size_pt: float, mono: bool) -> ImageFont.FreeTypeFont:
        """The Pillow font of matplotlib's DejaVu Sans (Mono) at ``size_pt`` points."""
        key = (float(size_pt), bool(mono))
        if key not in self._fonts:
            path = findfont(FontProperties(family=["DejaVu Sans Mono" if mono else "DejaVu Sans"]))
            self._fonts[key] = ImageFont.truetype(path, size=size_pt * self.dpi / 72.0)
        return self._fonts[key]

    def mask(self, text: str, size_pt: float, mono: bool = False) -> tuple[NDArray[np.uint8], int]:
        """``(alpha, ascent)``: the text's coverage (h, w; 0..255) from its ascent line down, and the ascent (px)."""
        key = (text, float(size_pt), bool(mono))
        hit = self._masks.get(key)
        if hit is not None:
            self._masks.move_to_end(key)
            return hit
        font = self.font(size_pt, mono)
        ascent, descent = font.getmetrics()
        width = max(1, int(np.ceil(font.getlength(text))) + 2)
        image = Image.new("L", (width, ascent + descent))
        ImageDraw.Draw(image).text((0, 0), text, fill=255, font=font, anchor="la")
        out = (np.asarray(image), ascent)
        self._masks[key] = out
        if len(self._masks) > self.CACHE:
            self._masks.popitem(last=False)
        return out

    def width(self, text: str, size_pt: float, mono: bool = False) -> float:
        """The text's advance width (px)."""
        return float(self.font(size_pt, mono).getlength(text))

    def paint(
        self,
        buf: NDArray[np.uint8],
        text: str,
        x: float,
        y: float,
        *,
        size_pt: float,
        colour: tuple[int, int, int] = (0, 0, 0),
        mono: bool = False,
        align: str = "left",
        valign: str = "top",
    ) -> tuple[int, int, int, int]:
        """Paint ``text`` into ``buf``; returns its box ``(top, left, bottom, right)`` in pixels."""
        alpha, _ = self.mask(text, size_pt, mono)
        h, w = alpha.shape
        left = round(x - (w - 2 if align == "right" else 0))
        top = round(y - (h / 2 if valign == "middle" else 0))
        blend(buf, alpha, top, left, colour)
        return top, left, top + h, left + w
