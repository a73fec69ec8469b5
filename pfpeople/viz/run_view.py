"""An animation frame per run frame of a run directory (:mod:`pfpeople.io.run_dir`).

One frame shows, bottom to top:

- the belief grid (probability of a person per cell, grey scale from 0 = white to 1 = black; the map's layout,
  x up and y to the left, is :mod:`pfpeople.viz.frame_layout`'s);
- each laser's field of view (thin dashed outline in the laser's colour, from ``run.json`` ``detector_models``;
  detectors sharing a mount and field of view share it) and the map's frame;
- the particles of a particle run (``particles.npy``, a subsample: tiny pink dots);
- the scan of every laser (``scans.npy``: small dots, one colour per laser) with the returns the laser's
  static-clutter map calls static in grey;
- each detector's detections, in the run's detector order, each with its own hollow marker shape and colour;
  the detectors of one laser nest (the first largest), so detections of several detectors on one spot do not
  hide each other;
- the classified people (red circles), ground truth when given (green plus signs), tracks when the run has
  ``tracks.csv`` (columns :data:`TRACK_COLUMNS`: blue stars edged white, so they show on black cells, with id
  labels and velocity arrows showing one second of motion);
- in the side panel: the legend, each detector's detections in the frame beside its legend entry ("no data"
  when it had none), the frame's ego-motion source (odometry, scan matching or none: :func:`ego_sources`) with
  its controls (v and the lateral vy in m/s, omega in deg/s), the people and tracks of the frame, and the grid
  frame's path integrated from the controls of ``frames.csv`` (exact constant-velocity motions, in the frame of
  the first run frame, drawn with the same x-up convention) with the current pose; above the map, the run, the
  frame counter (run frame, driver index) and the time since the first frame (s).

How it is drawn: what is the same in every frame (axes, ticks, colour bar, legend, the path's frame and the
whole path) is drawn once with matplotlib's object-oriented API on an Agg canvas (no pyplot state) and kept; a
frame starts from a copy of it. The grid, the fields of view and the text are painted with numpy and Pillow
(:mod:`pfpeople.viz.raster`: a colour lookup per cell, a layer drawn once, text rendered once per string); the
markers, arrows and the path are matplotlib artists drawn over it (blitting). Runs written before ``scans.npy``
/ ``particles.npy`` existed draw without them. The summary page is :mod:`pfpeople.viz.summary`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import cv2
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import NDArray

from gridbridge.grid import GridSpec
from pfpeople.io.run_dir import RunData
from pfpeople.viz.frame_layout import (
    DETECTOR_COLOURS,
    LASER_COLOURS,
    MARKERS,
    PARTICLE_COLOUR,
    PEOPLE_COLOUR,
    STATIC_COLOUR,
    TRACK_COLOUR,
    TRUTH_COLOUR,
    ViewOptions,
    display,
    extent,
    fit_size,
    layout,
)
from pfpeople.viz.raster import GridPainter, Overlay, TextPainter, rgb8
from pfpeople.viz.run_data import (
    TRACK_COLUMNS,
    FrameRows,
    default_fps,
    ego_sources,
    frame_times_s,
    laser_of,
    read_tracks,
    robot_path,
)

__all__ = [
    "DETECTOR_COLOURS",
    "TRACK_COLOUR",
    "TRACK_COLUMNS",
    "TRUTH_COLOUR",
    "RunFrameRenderer",
    "ViewOptions",
    "default_fps",
    "display",
    "ego_sources",
    "extent",
    "fit_size",
    "frame_times_s",
    "layout",
    "read_tracks",
    "robot_path",
]

#: Font sizes (points): the title, and the legend and readout (largest; smaller when the panel is narrow).
TITLE_PT, PANEL_PT, MIN_PANEL_PT = 9.0, 7.0, 6.0
#: Marker size (points) of every detector in the legend (on the map they nest, :meth:`RunFrameRenderer.marker_size`).
LEGEND_MARKER_PT = 7.0
#: Frame pixels kept free at the right edge of the side panel.
_RIGHT_PX = 6


class RunFrameRenderer:
    """Draws one animation frame of a run as an RGB image (see the module docstring).

    Parameters
    ----------
    run : RunData
        The run (:func:`pfpeople.io.run_dir.load_run`).
    options : ViewOptions
        Size of the frames.
    tracks : dict of str to ndarray, optional
        :func:`read_tracks` of the run's ``tracks.csv``.
    truth : list of ndarray, optional
        Ground truth per run frame, ``(P, 2)`` in the grid frame (m).
    """

    def __init__(
        self,
        run: RunData,
        *,
        options: ViewOptions | None = None,
        tracks: dict[str, NDArray[Any]] | None = None,
        truth: Sequence[NDArray[np.float64]] | None = None,
    ) -> None:
        if run.n_frames == 0:
            raise ValueError(f"run {str(run.path)!r} has no frames (run.json status {run.meta.get('status')!r})")
        if truth is not None and len(truth) != run.n_frames:
            raise ValueError(f"truth must have one entry per run frame ({run.n_frames}), got {len(truth)}")
        self.run, self.options, self.tracks, self.truth = run, options or ViewOptions(), tracks, truth
        self.spec: GridSpec = run.spec
        self.detectors: list[str] = list(run.meta.get("detectors", []))
        self.times_s = frame_times_s(run)
        fr = run.frames
        self.sources = ego_sources(run)
        self.has_odometry = bool(np.any(self.sources != "none"))
        self.path = robot_path(fr["v_mps"], fr["omega_radps"], fr["dt_s"], fr["vy_mps"])
        n = run.n_frames
        self._det_rows = FrameRows(run.detections["frame"], n)
        self._ppl_rows = FrameRows(run.people["frame"], n)
        self._trk_rows = FrameRows(None if tracks is None else tracks["frame"], n)
        self._scan_rows = FrameRows(None if run.scans is None else run.scans["frame"], n)
        self._part_rows = FrameRows(None if run.particles is None else run.particles["frame"], n)
        self._topic_of = laser_of(run)
        self.lasers: list[str] = list(run.scan_topics)  # scans.npy's order first, then the other detector topics
        for name in self.detectors:
            topic = self._topic_of.get(name, "")
            if topic and topic not in self.lasers:
                self.lasers.append(topic)
        self.text = TextPainter(self.options.dpi)
        self._build()

    def laser_colour(self, topic: str) -> str:
        """The colour of a laser (topic): its scan points and its field-of-view outline."""
        k = self.lasers.index(topic) if topic in self.lasers else len(self.lasers)
        return LASER_COLOURS[k % len(LASER_COLOURS)]

    def marker_size(self, k: int) -> float:
        """Marker size (points) of detector ``k`` on the map: the detectors of one laser (topic) nest, the first
        largest, 2.5 points apart down to 6."""
        topic = self._topic_of.get(self.detectors[k], "")
        same = [i for i, name in enumerate(self.detectors) if self._topic_of.get(name, "") == topic]
        return 6.0 + 2.5 * (len(same) - 1 - same.index(k))

    # -- the parts drawn once --------------------------------------------------------------------------------

    def _build(self) -> None:
        """The figure, its parts drawn once (the background, the overlay) and the artists redrawn every frame."""
        o, spec = self.options, self.spec
        self.fig = Figure(figsize=(o.width_px / o.dpi, o.height_px / o.dpi), dpi=o.dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        rects = layout(spec, o.width_px, o.height_px)
        self.ax = ax = self.fig.add_axes(rects["map"])
        ax.set_xlim(spec.y1, spec.y0)
        ax.set_ylim(spec.x0, spec.x1)
        ax.set_aspect("equal")
        ax.set_xlabel("y (m, left is +y)")
        ax.set_ylabel("x (m, forward)", labelpad=2)
        mappable = ScalarMappable(norm=Normalize(0.0, 1.0), cmap="Greys")
        cbar = self.fig.colorbar(mappable, cax=self.fig.add_axes(rects["cbar"]))
        cbar.ax.tick_params(labelsize=7)
        cbar.set_label("belief", fontsize=8, labelpad=2)
        self.side = self.fig.add_axes(rects["path"])
        self._anim: list[Any] = []
        self._build_artists()
        self._build_panel(rects["panel"])
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.fig.bbox)
        self._buf = np.asarray(self.canvas.buffer_rgba())
        self._grid = self._grid_painter()
        self._overlay = self._draw_overlay(rects["map"])

    def _animated(self, art: Any) -> Any:
        """Register ``art`` as redrawn every frame, above the artists registered before it."""
        art.set_animated(True)
        self._anim.append(art)
        return art

    def _dots(self, colour: str, ms: float, *, alpha: float = 1.0) -> Any:
        """An animated artist of round dots without edges (dense rows of returns stay their colour)."""
        (art,) = self.ax.plot([], [], linestyle="none", marker="o", ms=ms, mew=0.0, color=colour, alpha=alpha)
        return self._animated(art)

    def _build_artists(self) -> None:
        """The map's artists redrawn every frame, bottom to top: particles, scans, detections, people, ground
        truth, tracks and their arrows."""
        run, ax = self.run, self.ax
        self.particle_art = None if run.particles is None else self._dots(PARTICLE_COLOUR, 1.3, alpha=0.55)
        self.static_art = self._dots(STATIC_COLOUR, 3.0)
        self.scan_arts = [self._dots(self.laser_colour(t), 3.0) for t in run.scan_topics]
        self.det_artists = []
        for k in range(len(self.detectors)):
            (art,) = ax.plot([], [], linestyle="none", ms=self.marker_size(k), mew=1.3, **self._det_style(k))
            self.det_artists.append(self._animated(art))
        (people,) = ax.plot([], [], linestyle="none", marker="o", mfc="none", mec=PEOPLE_COLOUR, ms=18, mew=2.0)
        self.people_art = self._animated(people)
        self.truth_art = None
        if self.truth is not None:
            (truth,) = ax.plot([], [], linestyle="none", marker="+", color=TRUTH_COLOUR, ms=16, mew=2.5)
            self.truth_art = self._animated(truth)
        self.track_art = self.arrow_art = None
        if self.tracks is not None:
            (track,) = ax.plot([], [], linestyle="none", marker="*", color=TRACK_COLOUR, ms=11, mec="white", mew=0.6)
            self.track_art = self._animated(track)
            self.arrow_art = self._animated(LineCollection([], colors=TRACK_COLOUR, linewidths=1.5))
            ax.add_collection(self.arrow_art)

    def _det_style(self, k: int) -> dict[str, Any]:
        """Marker shape and colour of detector ``k`` (hollow)."""
        return {"marker": MARKERS[k % len(MARKERS)], "mfc": "none", "mec": DETECTOR_COLOURS[k % len(DETECTOR_COLOURS)]}

    def _legend_entries(self) -> list[tuple[Line2D, str]]:
        """(handle, label) of every legend entry; detectors all at one marker size so the rows do not overlap."""
        run = self.run
        dot: dict[str, Any] = {"linestyle": "none", "marker": "o", "ms": 5.0, "mew": 0.0}
        out: list[tuple[Line2D, str]] = []
        if run.particles is not None:
            out.append((Line2D([], [], color=PARTICLE_COLOUR, **dot), "particles (subsample)"))
        if run.scans is not None and len(run.scans) > 0:
            out.append((Line2D([], [], color=STATIC_COLOUR, **dot), "static returns"))
            out += [(Line2D([], [], color=self.laser_colour(t), **dot), f"scan {t}") for t in run.scan_topics]
        for k, name in enumerate(self.detectors):
            out.append((Line2D([], [], linestyle="none", ms=LEGEND_MARKER_PT, mew=1.3, **self._det_style(k)), name))
        style: dict[str, Any] = {"linestyle": "none", "ms": 10.0}
        out.append((Line2D([], [], marker="o", mfc="none", mec=PEOPLE_COLOUR, mew=2.0, **style), "people (filter)"))
        if self.truth is not None:
            out.append((Line2D([], [], marker="+", color=TRUTH_COLOUR, mew=2.5, **style), "ground truth"))
        if self.tracks is not None:
            out.append((Line2D([], [], marker="*", color=TRACK_COLOUR, **style), "tracks (id, 1 s of motion)"))
        return out

    def _build_panel(self, rect: tuple[float, float, float, float]) -> None:
        """The side panel: the legend (top; its font shrinks until it and the counts fit the panel), the readout
        (below it) and the ego-motion path (below that, as large as fits)."""
        o, x0 = self.options, rect[0]
        entries = self._legend_entries()
        count_w = self.text.width("no data", PANEL_PT, mono=True)
        size = PANEL_PT
        while True:
            self.legend = self.fig.legend(
                [h for h, _ in entries],
                [label for _, label in entries],
                loc="upper left",
                bbox_to_anchor=(x0 - 0.01, 0.955),
                fontsize=size,
                frameon=False,
                labelspacing=0.45,
                handlelength=1.6,
                borderaxespad=0.0,
            )
            self.canvas.draw()  # places the legend's texts
            right = self.legend.get_window_extent().x1
            if right + 6 + count_w * size / PANEL_PT <= o.width_px - _RIGHT_PX or size <= MIN_PANEL_PT:
                break
            self.legend.remove()
            size -= 0.5
        self.panel_pt = size
        rows = {t.get_text(): t.get_window_extent() for t in self.legend.get_texts()}
        # pixel row of each detector's legend entry: its count goes there, in a column right of the labels
        self._count_rows = {n: o.height_px - 0.5 * (rows[n].y0 + rows[n].y1) for n in self.detectors if n in rows}
        self._count_right = min(right + 6 + count_w * size / PANEL_PT, o.width_px - _RIGHT_PX)
        self._readout_top = o.height_px - self.legend.get_window_extent().y0 + 8
        self._line_px = 1.3 * size * o.dpi / 72.0
        self._build_path(x0, self._readout_top + 6.5 * self._line_px)

    def _build_path(self, x0: float, top_px: float) -> None:
        """The path plot: below ``top_px`` (its title above it), square, as large as the panel leaves."""
        o, s = self.options, self.side
        bottom_px, left_px = 34.0, x0 * o.width_px + 24
        side = min(o.width_px - _RIGHT_PX - 8 - left_px, 0.34 * o.height_px, o.height_px - top_px - 16 - bottom_px)
        self._path_shown = side >= 48
        if not self._path_shown:  # no room under a long legend: the readout still gives the ego-motion
            s.set_visible(False)
            return
        s.set_position((left_px / o.width_px, bottom_px / o.height_px, side / o.width_px, side / o.height_px))
        used = sorted({str(v) for v in self.sources if v != "none"})
        s.set_title(f"path ({' + '.join(used) or 'no ego-motion'})", fontsize=7)
        s.tick_params(labelsize=6)
        if not self.has_odometry:
            s.text(0.5, 0.5, "no ego-motion\n(robot taken\nas standing)", ha="center", va="center", fontsize=7,
                   transform=s.transAxes)  # fmt: skip
            s.set_xticks([])
            s.set_yticks([])
            return
        p = self.path
        s.plot(p[:, 1], p[:, 0], color="0.8", lw=1.0)
        self.past_art = self._animated(s.plot([], [], color="tab:blue", lw=1.5)[0])
        self.pose_art = self._animated(s.plot([], [], marker="o", color="tab:red", ms=4)[0])
        self.heading_art = self._animated(s.plot([], [], color="tab:red", lw=1.5)[0])
        span = max(float(np.ptp(p[:, 0])), float(np.ptp(p[:, 1])), 1.0)
        cx, cy = float(np.mean(p[:, 0])), float(np.mean(p[:, 1]))
        s.set_xlim(cy + 0.6 * span, cy - 0.6 * span)
        s.set_ylim(cx - 0.6 * span, cx + 0.6 * span)
        s.set_aspect("equal", adjustable="box")
        self._heading_len = 0.08 * span

    def _grid_painter(self) -> GridPainter:
        """The belief's painter: each screen pixel of the map shows the cell under its centre (as ``imshow``
        with ``interpolation="nearest"``)."""
        h, spec = self.options.height_px, self.spec
        (x0, y0), (x1, y1) = self.ax.get_window_extent().get_points()
        cols = np.arange(math.ceil(x0 - 0.5), math.floor(x1 - 0.5) + 1)
        rows = np.arange(math.ceil(h - y1 - 0.5), math.floor(h - y0 - 0.5) + 1)
        inverse = self.ax.transData.inverted()
        y_m = inverse.transform(np.column_stack((cols + 0.5, np.full(len(cols), 0.5 * (y0 + y1)))))[:, 0]
        x_m = inverse.transform(np.column_stack((np.full(len(rows), 0.5 * (x0 + x1)), h - rows - 0.5)))[:, 1]
        i = np.clip(np.floor((x_m - spec.x0) / spec.resolution), 0, spec.nx - 1).astype(np.intp)
        j = np.clip(np.floor((y_m - spec.y0) / spec.resolution), 0, spec.ny - 1).astype(np.intp)
        return GridPainter(i, j, int(rows[0]), int(cols[0]), "Greys")

    def _draw_overlay(self, rect: tuple[float, float, float, float]) -> Overlay:
        """The layer over the grid, drawn once on a transparent figure: each laser's field of view
        (:meth:`_fov_outlines`) as a thin dashed outline in the laser's colour, and the map's frame."""
        o, spec = self.options, self.spec
        fig = Figure(figsize=(o.width_px / o.dpi, o.height_px / o.dpi), dpi=o.dpi, facecolor="none")
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_axes(rect)
        ax.set_xlim(spec.y1, spec.y0)
        ax.set_ylim(spec.x0, spec.x1)
        ax.set_aspect("equal")
        ax.patch.set_visible(False)
        ax.set_xticks([])
        ax.set_yticks([])
        for (mx, my, myaw, lo, hi, rng), colour in self._fov_outlines().items():
            a = myaw + np.linspace(lo, hi, 60)
            xs = np.concatenate(([mx], mx + rng * np.cos(a), [mx]))
            ys = np.concatenate(([my], my + rng * np.sin(a), [my]))
            ax.plot(ys, xs, linestyle=(0, (4, 3)), lw=0.7, color=colour, alpha=0.6)
        canvas.draw()
        return Overlay.from_rgba(np.asarray(canvas.buffer_rgba()))

    def _fov_outlines(self) -> dict[tuple[float, ...], str]:
        """One field of view per laser: detectors with the same mount, field of view and range share one outline
        (key: mount x, y, yaw, fov min, max, range; value: the colour of its laser)."""
        spec = self.spec
        reach = math.hypot(spec.x1 - spec.x0, spec.y1 - spec.y0) + abs(spec.x0) + abs(spec.y0)
        models = {m.get("name"): m for m in self.run.meta.get("detector_models", []) if isinstance(m, dict)}
        out: dict[tuple[float, ...], str] = {}
        for name in self.detectors:
            m = models.get(name)
            if m is None:
                continue
            try:
                lo, hi = float(m.get("fov_min", -math.pi / 2)), float(m.get("fov_max", math.pi / 2))
                rng = min(float(m.get("max_range", math.inf)), reach)  # "inf" in run.json reads as inf
                mx, my, myaw = (float(m.get(f, 0.0)) for f in ("mount_x", "mount_y", "mount_yaw"))
            except (TypeError, ValueError):
                continue
            key = tuple(round(v, 3) for v in (mx, my, myaw, lo, hi, rng))
            out.setdefault(key, self.laser_colour(self._topic_of.get(name, name)))
        return out

    # -- a frame -----------------------------------------------------------------------------------------------

    def cell_pixel(self, i: int, j: int) -> tuple[int, int]:
        """(row, column) of the pixel at the centre of grid cell ``[i, j]`` in a rendered frame."""
        x, y = self.spec.cell_centre(i, j)
        return self.point_pixel(float(x), float(y))

    def point_pixel(self, x: float, y: float) -> tuple[int, int]:
        """(row, column) of the pixel showing the point (x, y) (m, grid frame) in a rendered frame."""
        px, py = self.ax.transData.transform((y, x))
        return int(self.options.height_px - py), int(px)

    def render(self, k: int) -> NDArray[np.uint8]:
        """The RGB image ``(height_px, width_px, 3)`` uint8 of run frame ``k`` (a new array)."""
        return np.asarray(cv2.cvtColor(self.render_rgba(k), cv2.COLOR_RGBA2RGB), dtype=np.uint8)

    def render_rgba(self, k: int) -> NDArray[np.uint8]:
        """The RGBA image ``(height_px, width_px, 4)`` uint8 of run frame ``k``: the renderer's own buffer, valid
        until the next frame is drawn (copy it to keep it)."""
        run = self.run
        if not 0 <= k < run.n_frames:
            raise IndexError(f"frame {k} is outside run {str(run.path)!r} (frames 0..{run.n_frames - 1})")
        self.canvas.restore_region(self._background)
        self._grid.paint(self._buf, run.grids[k])
        self._overlay.paint(self._buf)
        self._set_scan(k)
        if self.particle_art is not None and run.particles is not None:
            part = run.particles[self._part_rows(k)]
            self.particle_art.set_data(part["y"].astype(float), part["x"].astype(float))
        counts = self._set_detections(k)
        rows = self._ppl_rows(k)
        self.people_art.set_data(run.people["y_m"][rows], run.people["x_m"][rows])
        if self.truth_art is not None and self.truth is not None:
            self.truth_art.set_data(self.truth[k][:, 1], self.truth[k][:, 0])
        labels = self._set_tracks(k)
        self._set_path(k)
        for art in self._anim:
            self.fig.draw_artist(art)
        for tid, x, y in labels:
            self._paint_track_label(tid, x, y)
        self._paint_text(k, counts)
        if self._buf.shape[:2] != (self.options.height_px, self.options.width_px):
            raise RuntimeError(f"rendered {self._buf.shape[1]}x{self._buf.shape[0]} px, expected the options' size")
        return self._buf

    def _set_scan(self, k: int) -> None:
        """The returns of frame ``k``: each laser's in its colour, the static ones (of every laser) grey."""
        scans = self.run.scans
        if scans is None:
            return
        rec = scans[self._scan_rows(k)]
        static = rec["static"] == 1
        x, y = rec["x"].astype(float), rec["y"].astype(float)
        self.static_art.set_data(y[static], x[static])
        for i, art in enumerate(self.scan_arts):
            sel = ~static & (rec["laser"] == i)
            art.set_data(y[sel], x[sel])

    def _set_detections(self, k: int) -> dict[str, int]:
        """Each detector's detections of frame ``k``; returns their number per detector."""
        det = self.run.detections
        rows = self._det_rows(k)
        names, xs, ys = det["detector"][rows], det["x_m"][rows], det["y_m"][rows]
        counts = {}
        for name, art in zip(self.detectors, self.det_artists, strict=True):
            sel = names == name
            art.set_data(ys[sel], xs[sel])
            counts[name] = int(np.count_nonzero(sel))
        return counts

    def _set_tracks(self, k: int) -> list[tuple[int, float, float]]:
        """Tracks of frame ``k``: stars and velocity arrows (one second of motion, with a head); returns the
        ``(id, x, y)`` of those inside the grid, to be labelled."""
        if self.track_art is None or self.arrow_art is None or self.tracks is None:
            return []
        tr, rows = self.tracks, self._trk_rows(k)
        x, y, vx, vy = tr["x"][rows], tr["y"][rows], tr["vx"][rows], tr["vy"][rows]
        self.track_art.set_data(y, x)
        segments = []
        for xi, yi, vxi, vyi in zip(x, y, vx, vy, strict=True):
            tip = np.array([yi + vyi, xi + vxi])  # (y, x): the axes' horizontal, vertical
            segments.append([(yi, xi), tuple(tip)])
            speed = math.hypot(vxi, vyi)
            if speed > 0.05:
                back = -np.array([vyi, vxi]) / speed * min(0.25, 0.4 * speed)
                for a in (0.45, -0.45):
                    c, s = math.cos(a), math.sin(a)
                    wing = (c * back[0] - s * back[1], s * back[0] + c * back[1])
                    segments.append([tuple(tip), tuple(tip + wing)])
        self.arrow_art.set_segments(segments)
        g = self.spec
        inside = (x >= g.x0) & (x <= g.x1) & (y >= g.y0) & (y <= g.y1)
        ids = tr["id"][rows][inside]
        return [(int(t), float(a), float(b)) for t, a, b in zip(ids, x[inside], y[inside], strict=True)]

    def _set_path(self, k: int) -> None:
        """The grid frame's path up to frame ``k``, its pose and heading."""
        if not (self.has_odometry and self._path_shown):
            return
        p = self.path
        self.past_art.set_data(p[: k + 1, 1], p[: k + 1, 0])
        self.pose_art.set_data([p[k, 1]], [p[k, 0]])
        hx = p[k, 0] + self._heading_len * math.cos(p[k, 2])
        hy = p[k, 1] + self._heading_len * math.sin(p[k, 2])
        self.heading_art.set_data([p[k, 1], hy], [p[k, 0], hx])

    def _paint_track_label(self, tid: int, x: float, y: float) -> None:
        """The id of a track in a white box with an edge of the tracks' colour: the text 7 points right of the
        track, its baseline 15 points below it."""
        pt = self.options.dpi / 72.0
        row, col = self.point_pixel(x, y)
        colour = rgb8(TRACK_COLOUR)
        mask, ascent = self.text.mask(str(tid), 9.0)
        pad = round(1.5 * pt)
        top, left = round(row + 15 * pt) - ascent, round(col + 7 * pt)
        buf = self._buf
        r0, c0 = max(top - pad, 0), max(left - pad, 0)
        r1, c1 = min(top + mask.shape[0] + pad, buf.shape[0]), min(left + mask.shape[1] + pad, buf.shape[1])
        if r0 >= r1 or c0 >= c1:
            return
        buf[r0:r1, c0:c1, :3] = colour
        buf[r0 + 1 : r1 - 1, c0 + 1 : c1 - 1, :3] = 255
        self.text.paint(buf, str(tid), left, top, size_pt=9.0, colour=colour)

    def _paint_text(self, k: int, counts: dict[str, int]) -> None:
        """The title, the detections of each detector beside its legend entry, and the readout (ego-motion source
        and controls, people and tracks)."""
        run, fr, o, buf = self.run, self.run.frames, self.options, self._buf
        left = self.ax.get_window_extent().x0
        title = (
            f"{run.path.name}  frame {k + 1}/{run.n_frames} (driver #{int(fr['driver_index'][k])})  "
            f"t = {self.times_s[k]:.2f} s"
        )
        self.text.paint(buf, title, left, 6, size_pt=TITLE_PT)
        no_data = str(fr["no_data"][k]).split(";")
        for name, row in self._count_rows.items():
            count = "no data" if name in no_data else str(counts.get(name, 0))
            right = self._count_right
            self.text.paint(buf, count, right, row, size_pt=self.panel_pt, mono=True, align="right", valign="middle")
        x0 = layout(self.spec, o.width_px, o.height_px)["panel"][0] * o.width_px
        for i, line in enumerate(self.readout_lines(k)):
            self.text.paint(buf, line, x0, self._readout_top + i * self._line_px, size_pt=self.panel_pt, mono=True)

    def readout_lines(self, k: int) -> list[str]:
        """The side panel's readout of frame ``k``: ego-motion source and controls, people and tracks."""
        fr = self.run.frames
        source = str(self.sources[k])
        lines = [f"ego    {source if source != 'none' else 'none (standing)'}"]
        if source != "none":
            lines += [f"v      {fr['v_mps'][k]:+6.2f} m/s", f"vy     {fr['vy_mps'][k]:+6.2f} m/s"]
            lines.append(f"omega  {math.degrees(fr['omega_radps'][k]):+6.1f} deg/s")
        lines.append(f"dt     {fr['dt_s'][k]:6.3f} s")
        people = f"people {int(fr['n_people'][k])}"
        if self.tracks is not None:
            rows = self._trk_rows(k)
            people += f"   tracks {len(self.tracks['id'][rows])}"
        return [*lines, people]
