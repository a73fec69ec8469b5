"""Pictures of a run directory (:mod:`pfpeople.io.run_dir`): an animation frame per run frame, and a summary page.

Drawn with matplotlib's object-oriented API on an Agg canvas (no pyplot state, any backend). The grid is drawn
as the paper and :mod:`evaluation.harness.figures` draw it: the sensor at the bottom middle, x (forward) up, y (left) to
the left; only the display is flipped (``grid[::-1, ::-1]`` with extent ``(y1, y0, x0, x1)``), never the data.
Points (m, grid frame) are plotted at ``(y, x)`` on those axes, whose limits are the grid's extent at equal
scale (:func:`layout`; :func:`fit_size` gives a frame size of the grid's aspect).

One animation frame shows, bottom to top:

- the belief grid (probability of a person per cell, grey scale from 0 = white to 1 = black);
- the scan of every laser (``scans.npy``: small dots, one colour per laser) with the returns the laser's
  static-clutter map calls static in grey, and each laser's field of view once (thin dashed outline in the
  laser's colour, from ``run.json`` ``detector_models``; detectors sharing a mount and field of view share it);
- the particles of a particle run (``particles.npy``, a subsample: tiny pink dots);
- each detector's detections, in the run's detector order, each with its own hollow marker shape, colour and
  size (the first largest), so detections of several detectors on one spot nest instead of hiding each other;
- the classified people (red circles), ground truth when given (green plus signs), tracks when the run has
  ``tracks.csv`` (columns :data:`TRACK_COLUMNS`: id labels and velocity arrows showing one second of motion);
- in the side panel: the legend, the frame counter (run frame, driver index), the time since the first frame
  (s), the frame's ego-motion source (odometry, scan matching or none: :func:`ego_sources`) with its controls (v
  and the lateral vy in m/s, omega in deg/s), the detections per detector, and the grid frame's path integrated
  from the controls of ``frames.csv`` (exact constant-velocity motions, in the frame of the first run frame,
  drawn with the same x-up convention) with the current pose.

Runs written before ``scans.npy`` / ``particles.npy`` existed draw without them.

:func:`render_summary` draws a one-page summary PNG: people per frame (and true people per frame with ground
truth, tracks per frame when present), detections per detector per frame over time, the histogram of the
belief over all frames and cells, and the run's figures (ego-motion sources among them).
"""

from __future__ import annotations

import csv
import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from gridbridge.ego_motion import velocity_displacement
from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from gridbridge.validation import check_int, check_real
from pfpeople.io.run_dir import RunData

__all__ = [
    "TRACK_COLUMNS",
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
    "render_summary",
    "robot_path",
]

TRACK_COLUMNS = ("frame", "stamp_ns", "id", "x", "y", "vx", "vy", "cov_xx", "cov_xy", "cov_yy", "score")
_MARKERS = ("s", "^", "D", "v", "P", "X", "<", ">", "h", "*")
#: Detector colours (the summary's too); none is a laser colour, the people's red or the tracks' green.
_COLOURS = ("darkorange", "magenta", "deepskyblue", "gold", "black", "chocolate", "orchid", "dimgray")
#: Laser colours (scan points and field-of-view outlines).
_LASER_COLOURS = ("royalblue", "darkviolet", "darkcyan", "olive", "sienna", "slateblue")
_STATIC_COLOUR = "0.62"
_PARTICLE_COLOUR = "deeppink"


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


def read_tracks(path: str | Path) -> dict[str, NDArray[Any]]:
    """Read a ``tracks.csv`` (columns :data:`TRACK_COLUMNS`, positions and velocities in the grid frame).

    Returns
    -------
    dict of str to ndarray
        One array per column (``frame``, ``stamp_ns``, ``id`` int64; the others float), rows in file order.
    """
    path = Path(path)
    with path.open(newline="", encoding="utf-8-sig") as fh:
        rows = list(csv.reader(fh))
    if not rows or tuple(h.strip() for h in rows[0]) != TRACK_COLUMNS:
        raise ValueError(f"tracks file {str(path)!r}: expected columns {list(TRACK_COLUMNS)}, got {rows[:1]}")
    body = [r for r in rows[1:] if r]
    out: dict[str, NDArray[Any]] = {}
    for k, name in enumerate(TRACK_COLUMNS):
        try:
            vals = [r[k] for r in body]
            dtype = np.int64 if name in ("frame", "stamp_ns", "id") else float
            out[name] = np.array(vals, dtype=dtype).reshape(-1)
        except (IndexError, ValueError) as exc:
            raise ValueError(f"tracks file {str(path)!r}: column {name!r}: {exc}") from None
    return out


def frame_times_s(run: RunData) -> NDArray[np.float64]:
    """Time of every run frame (s) since the first frame's stamp, shape (N,)."""
    stamps = run.frames["stamp_ns"]
    return (stamps - stamps[0]).astype(float) / 1e9 if len(stamps) else np.zeros(0)


def robot_path(
    v_mps: NDArray[np.float64],
    omega_radps: NDArray[np.float64],
    dt_s: NDArray[np.float64],
    vy_mps: NDArray[np.float64] | None = None,
) -> NDArray:
    """Poses ``(N, 3)`` (x, y, yaw) of the grid frame integrated from the per-frame controls.

    Frame ``k`` moved with the constant body-frame velocity ``(v[k], vy[k], omega[k])`` (forward m/s, lateral
    m/s, rad/s; :func:`gridbridge.velocity_displacement`) for ``dt[k]`` s before its stamp; ``vy`` defaults to
    0 (arcs). The first frame is the origin (its own controls are not applied). Metres and radians in the frame
    of the first run frame (REP-103).
    """
    n = len(v_mps)
    lateral = np.zeros(n) if vy_mps is None else np.asarray(vy_mps, dtype=float)
    out = np.zeros((n, 3))
    pose = Pose2D()
    for k in range(1, n):
        v, w, dt = float(v_mps[k]), float(omega_radps[k]), float(dt_s[k])
        th = w * dt
        if abs(th) < 1e-9:
            step = Pose2D(x=v * dt, y=0.0, yaw=th)
        else:
            r = v / w
            step = Pose2D(x=r * math.sin(th), y=r * (1.0 - math.cos(th)), yaw=th)
        if lateral[k] != 0.0:
            dx, dy, _ = velocity_displacement(v, w, dt, vy=float(lateral[k]))
            step = Pose2D(x=float(dx), y=float(dy), yaw=th)
        pose = pose.compose(step)
        out[k] = (pose.x, pose.y, pose.yaw)
    return out


def default_fps(run: RunData, fallback: float = 10.0) -> float:
    """The run's frame rate: 1 / the median step between ``frames.csv`` stamps, rounded to 0.1 frames/s.

    A 7.5 Hz laser's run plays at 7.5 frames/s, in real time; ``fallback`` for runs of fewer than two frames or
    without increasing stamps.
    """
    steps = np.diff(np.asarray(run.frames["stamp_ns"], dtype=np.int64))
    steps = steps[steps > 0]
    if not len(steps):
        return fallback
    fps = round(1e9 / float(np.median(steps)), 1)
    return fps if fps > 0 else fallback


def ego_sources(run: RunData) -> NDArray[np.str_]:
    """Where each frame's ego-motion came from: ``"odometry"``, ``"scan matching"`` or ``"none"``, shape (N,).

    ``frames.csv`` ``odometry`` is 1 for both odometry and scan matching; a run without an odometry topic
    (``run.json`` ``config.odometry.topic`` empty) has its controls from scan matching the driving laser
    (:class:`pfpeople.run_state.RunSummary` ``ego_motion``).
    """
    config = run.meta.get("config")
    odo = config.get("odometry") if isinstance(config, dict) else None
    topic = odo.get("topic", "") if isinstance(odo, dict) else ""
    moved = np.asarray(run.frames["odometry"]) == 1
    return np.where(moved, "odometry" if topic else "scan matching", "none")


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


def _laser_of(run: RunData) -> dict[str, str]:
    """Detector name -> its topic (``run.json`` ``config.detectors``); empty for runs that do not say."""
    config = run.meta.get("config")
    dets = config.get("detectors") if isinstance(config, dict) else None
    out: dict[str, str] = {}
    for d in dets if isinstance(dets, list) else []:
        if isinstance(d, dict) and isinstance(d.get("name"), str):
            out[d["name"]] = str(d.get("topic", ""))
    return out


def _frame_rows(frames: NDArray[Any] | None, k: int) -> slice:
    """The rows of frame ``k`` in records sorted by frame (``scans.npy``, ``particles.npy``)."""
    if frames is None or not len(frames):
        return slice(0, 0)
    return slice(int(np.searchsorted(frames, k, "left")), int(np.searchsorted(frames, k, "right")))


def _by_frame(frames: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(order, starts): rows of frame k are ``order[starts[k]:starts[k+1]]`` (stable)."""
    order = np.argsort(frames, kind="stable")
    return order, frames[order]


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
        self.run = run
        self.options = options or ViewOptions()
        self.tracks = tracks
        self.truth = truth
        self.spec = run.spec
        self.detectors: list[str] = list(run.meta.get("detectors", []))
        self.times_s = frame_times_s(run)
        fr = run.frames
        self.sources = ego_sources(run)
        self.has_odometry = bool(np.any(self.sources != "none"))
        self.path = robot_path(fr["v_mps"], fr["omega_radps"], fr["dt_s"], fr["vy_mps"])
        self._det_order, self._det_frames = _by_frame(run.detections["frame"])
        self._ppl_order, self._ppl_frames = _by_frame(run.people["frame"])
        if tracks is not None:
            self._trk_order, self._trk_frames = _by_frame(tracks["frame"])
        self._topic_of = _laser_of(run)
        self.lasers: list[str] = list(run.scan_topics)  # scans.npy's order first, then the other detector topics
        for name in self.detectors:
            topic = self._topic_of.get(name, "")
            if topic and topic not in self.lasers:
                self.lasers.append(topic)
        self._build()

    def laser_colour(self, topic: str) -> str:
        """The colour of a laser (topic): its scan points and its field-of-view outline."""
        k = self.lasers.index(topic) if topic in self.lasers else len(self.lasers)
        return _LASER_COLOURS[k % len(_LASER_COLOURS)]

    # -- figure ------------------------------------------------------------------------------------------

    def _animated(self, art: Any) -> Any:
        """Register ``art`` as redrawn every frame, above the artists registered before it (blitting order)."""
        art.set_animated(True)
        self._anim.append(art)
        return art

    def _dots(self, colour: str, ms: float, label: str | None, *, alpha: float = 1.0) -> Any:
        """An animated artist of round dots without edges (dense rows of returns stay their colour)."""
        (art,) = self.ax.plot(
            [], [], linestyle="none", marker="o", ms=ms, mew=0.0, color=colour, alpha=alpha, label=label
        )
        return self._animated(art)

    def _build(self) -> None:
        """The static parts are drawn once (the background); each frame redraws only its artists (blitting)."""
        o, spec, run = self.options, self.spec, self.run
        self.fig = Figure(figsize=(o.width_px / o.dpi, o.height_px / o.dpi), dpi=o.dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        rects = layout(spec, o.width_px, o.height_px)
        self.ax = ax = self.fig.add_axes(rects["map"])
        self.side = self.fig.add_axes(rects["path"])
        self._anim: list[Any] = []
        self._dynamic: list[Any] = []
        self.image = self._animated(
            ax.imshow(
                display(np.zeros(spec.shape)),
                cmap="Greys",
                vmin=0.0,
                vmax=1.0,
                extent=extent(spec),
                interpolation="nearest",
                origin="upper",
                aspect="equal",
            )
        )
        ax.set_xlim(spec.y1, spec.y0)
        ax.set_ylim(spec.x0, spec.x1)
        ax.set_xlabel("y (m, left is +y)")
        ax.set_ylabel("x (m, forward)", labelpad=2)
        cbar = self.fig.colorbar(self.image, cax=self.fig.add_axes(rects["cbar"]))
        cbar.ax.tick_params(labelsize=7)
        cbar.set_label("belief", fontsize=8, labelpad=2)
        self.particle_art = None
        if run.particles is not None:
            self.particle_art = self._dots(_PARTICLE_COLOUR, 1.3, "particles (subsample)", alpha=0.55)
        self._draw_fields_of_view()
        has_scans = run.scans is not None and len(run.scans) > 0
        # scan dots above the particles (what the lasers saw is never hidden by the filter's state)
        self.static_art = self._dots(_STATIC_COLOUR, 3.0, "static returns" if has_scans else None)
        self.scan_arts = [
            self._dots(self.laser_colour(t), 3.0, f"scan {t}" if has_scans else None) for t in run.scan_topics
        ]
        self._build_markers()
        self._build_panel(rects["panel"])
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.fig.bbox)

    def _build_markers(self) -> None:
        """Detections (one hollow marker per detector, nested sizes, in the run's order), people, GT, tracks."""
        ax, n = self.ax, len(self.detectors)
        self.det_artists = []
        for k, name in enumerate(self.detectors):
            (art,) = ax.plot(
                [],
                [],
                linestyle="none",
                marker=_MARKERS[k % len(_MARKERS)],
                mfc="none",
                mec=_COLOURS[k % len(_COLOURS)],
                ms=max(5.0, 6.0 + 2.5 * (n - 1 - k)),  # the first detector's marker is the largest: they nest
                mew=1.3,
                label=name,
            )
            self.det_artists.append(self._animated(art))
        (people,) = ax.plot(
            [], [], linestyle="none", marker="o", mfc="none", mec="red", ms=18, mew=2.0, label="people (filter)"
        )
        self.people_art = self._animated(people)
        self.truth_art = None
        if self.truth is not None:
            (truth,) = ax.plot(
                [], [], linestyle="none", marker="+", color="limegreen", ms=16, mew=2.5, label="ground truth"
            )
            self.truth_art = self._animated(truth)
        self.track_art = None
        if self.tracks is not None:
            (track,) = ax.plot(
                [], [], linestyle="none", marker="*", color="tab:green", ms=9, label="tracks (id, 1 s of motion)"
            )
            self.track_art = self._animated(track)

    def _build_panel(self, rect: tuple[float, float, float, float]) -> None:
        """The side panel: legend (top), readout (below it) and the ego-motion path (bottom)."""
        fig, x0 = self.fig, rect[0]
        self.title = self._animated(fig.text(self.ax.get_position().x0, 0.985, "", fontsize=9, va="top"))
        legend = fig.legend(loc="upper left", bbox_to_anchor=(x0 - 0.01, 0.94), fontsize=7, frameon=False)
        for handle, text in zip(legend.legend_handles, legend.get_texts(), strict=True):
            if handle is not None and text.get_text().startswith(("scan ", "static ", "particles")):
                handle.set(markersize=5.0, alpha=1.0)  # the dots at a readable size in the legend
        self.canvas.draw()
        top = legend.get_window_extent().y0 / self.options.height_px - 0.01
        self.readout = self._animated(fig.text(x0, top, "", fontsize=7, va="top", family="monospace"))
        s = self.side
        used = sorted({str(v) for v in self.sources if v != "none"})
        s.set_title(f"grid frame path ({' + '.join(used) or 'no ego-motion'})", fontsize=7)
        s.tick_params(labelsize=6)
        if not self.has_odometry:
            s.text(
                0.5,
                0.5,
                "no ego-motion\n(robot taken\nas standing)",
                ha="center",
                va="center",
                fontsize=7,
                transform=s.transAxes,
            )
            s.set_xticks([])
            s.set_yticks([])
            return
        p = self.path
        s.plot(p[:, 1], p[:, 0], color="0.8", lw=1.0)
        (past,) = s.plot([], [], color="tab:blue", lw=1.5)
        (pose,) = s.plot([], [], marker="o", color="tab:red", ms=4)
        (heading,) = s.plot([], [], color="tab:red", lw=1.5)
        self.past_art, self.pose_art, self.heading_art = (
            self._animated(past),
            self._animated(pose),
            self._animated(heading),
        )
        span = max(float(np.ptp(p[:, 0])), float(np.ptp(p[:, 1])), 1.0)
        cx, cy = float(np.mean(p[:, 0])), float(np.mean(p[:, 1]))
        s.set_xlim(cy + 0.6 * span, cy - 0.6 * span)
        s.set_ylim(cx - 0.6 * span, cx + 0.6 * span)
        s.set_aspect("equal", adjustable="box")
        self._heading_len = 0.08 * span

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

    def _draw_fields_of_view(self) -> None:
        """Each laser's field of view (:meth:`_fov_outlines`) as a thin dashed outline in the laser's colour."""
        for (mx, my, myaw, lo, hi, rng), colour in self._fov_outlines().items():
            a = myaw + np.linspace(lo, hi, 60)
            xs = np.concatenate(([mx], mx + rng * np.cos(a), [mx]))
            ys = np.concatenate(([my], my + rng * np.sin(a), [my]))
            (line,) = self.ax.plot(ys, xs, linestyle=(0, (4, 3)), lw=0.7, color=colour, alpha=0.6)
            self._animated(line)  # drawn over the belief image every frame

    def _rows(self, order: NDArray[np.int64], frames: NDArray[np.int64], k: int) -> NDArray[np.int64]:
        return order[np.searchsorted(frames, k, "left") : np.searchsorted(frames, k, "right")]

    def cell_pixel(self, i: int, j: int) -> tuple[int, int]:
        """(row, column) of the pixel at the centre of grid cell ``[i, j]`` in a rendered frame."""
        x, y = self.spec.cell_centre(i, j)
        return self.point_pixel(float(x), float(y))

    def point_pixel(self, x: float, y: float) -> tuple[int, int]:
        """(row, column) of the pixel showing the point (x, y) (m, grid frame) in a rendered frame."""
        px, py = self.ax.transData.transform((y, x))
        return int(self.options.height_px - py), int(px)

    def render(self, k: int) -> NDArray[np.uint8]:
        """The RGB image ``(height_px, width_px, 3)`` uint8 of run frame ``k``."""
        run = self.run
        if not 0 <= k < run.n_frames:
            raise IndexError(f"frame {k} is outside run {str(run.path)!r} (frames 0..{run.n_frames - 1})")
        for art in self._dynamic:
            art.remove()
        self._dynamic = []
        self.canvas.restore_region(self._background)
        self.image.set_data(display(np.asarray(run.grids[k], dtype=float)))
        self._set_scan(k)
        if self.particle_art is not None and run.particles is not None:
            part = run.particles[_frame_rows(run.particles["frame"], k)]
            self.particle_art.set_data(part["y"].astype(float), part["x"].astype(float))
        det = run.detections
        rows = self._rows(self._det_order, self._det_frames, k)
        names = det["detector"][rows]
        for name, art in zip(self.detectors, self.det_artists, strict=True):
            sel = rows[names == name]
            art.set_data(det["y_m"][sel], det["x_m"][sel])
        rows = self._rows(self._ppl_order, self._ppl_frames, k)
        self.people_art.set_data(run.people["y_m"][rows], run.people["x_m"][rows])
        if self.truth_art is not None and self.truth is not None:
            t = self.truth[k]
            self.truth_art.set_data(t[:, 1], t[:, 0])
        self._set_tracks(k)
        self._set_text(k, {n: int(np.count_nonzero(names == n)) for n in self.detectors})
        for art in self._anim + self._dynamic:
            self.fig.draw_artist(art)
        for spine in self.ax.spines.values():
            self.fig.draw_artist(spine)
        rgba = np.asarray(self.canvas.buffer_rgba())
        if rgba.shape[:2] != (self.options.height_px, self.options.width_px):
            raise RuntimeError(f"rendered {rgba.shape[1]}x{rgba.shape[0]} px, expected the ViewOptions size")
        return np.ascontiguousarray(rgba[..., :3])

    def _set_scan(self, k: int) -> None:
        """The returns of frame ``k``: each laser's in its colour, the static ones (of every laser) grey."""
        scans = self.run.scans
        if scans is None:
            return
        rec = scans[_frame_rows(scans["frame"], k)]
        static = rec["static"] == 1
        x, y = rec["x"].astype(float), rec["y"].astype(float)
        self.static_art.set_data(y[static], x[static])
        for i, art in enumerate(self.scan_arts):
            sel = ~static & (rec["laser"] == i)
            art.set_data(y[sel], x[sel])

    def _set_tracks(self, k: int) -> None:
        """Tracks of frame ``k``: stars, velocity arrows (one second of motion) and id labels."""
        if self.track_art is None or self.tracks is None:
            return
        tr = self.tracks
        rows = self._rows(self._trk_order, self._trk_frames, k)
        x, y, vx, vy = tr["x"][rows], tr["y"][rows], tr["vx"][rows], tr["vy"][rows]
        self.track_art.set_data(y, x)
        if len(rows):
            q = self.ax.quiver(
                y, x, vy, vx, angles="xy", scale_units="xy", scale=1.0, color="tab:green", width=0.004, animated=True
            )
            self._dynamic.append(q)
        for tid, xi, yi in zip(tr["id"][rows], x, y, strict=True):
            if self.spec.x0 <= xi <= self.spec.x1 and self.spec.y0 <= yi <= self.spec.y1:
                self._dynamic.append(
                    self.ax.annotate(
                        str(int(tid)),
                        (yi, xi),
                        xytext=(7, -15),
                        textcoords="offset points",
                        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "tab:green", "lw": 0.6},
                        color="tab:green",
                        fontsize=9,
                        weight="bold",
                        animated=True,
                    )
                )

    def _set_text(self, k: int, n_det: dict[str, int]) -> None:
        """Title, readout (ego-motion source and controls, detections per detector) and the path's pose."""
        run, fr = self.run, self.run.frames
        self.title.set_text(
            f"{run.path.name}  frame {k + 1}/{run.n_frames} (driver #{int(fr['driver_index'][k])})  "
            f"t = {self.times_s[k]:.2f} s"
        )
        source = str(self.sources[k])
        lines = [f"ego   {source if source != 'none' else 'none (standing)'}"]
        if source != "none":
            lines += [f"v     {fr['v_mps'][k]:+6.2f} m/s", f"vy    {fr['vy_mps'][k]:+6.2f} m/s"]
            lines.append(f"omega {math.degrees(fr['omega_radps'][k]):+6.1f} deg/s")
        lines += [f"dt    {fr['dt_s'][k]:6.3f} s", f"people {int(fr['n_people'][k])}"]
        no_data = str(fr["no_data"][k]).split(";")
        lines += [f"{n[:16]:<16} {'no data' if n in no_data else c}" for n, c in n_det.items()]
        self.readout.set_text("\n".join(lines))
        if self.has_odometry:
            p = self.path
            self.past_art.set_data(p[: k + 1, 1], p[: k + 1, 0])
            self.pose_art.set_data([p[k, 1]], [p[k, 0]])
            hx = p[k, 0] + self._heading_len * math.cos(p[k, 2])
            hy = p[k, 1] + self._heading_len * math.sin(p[k, 2])
            self.heading_art.set_data([p[k, 1], hy], [p[k, 0], hx])


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
        a.plot(t, smooth, color=_COLOURS[k % len(_COLOURS)], label=f"{name} ({len(frames)} in all)")
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
        a.plot(t, _truth_counts(truth), drawstyle="steps-post", color="limegreen", lw=2.5, label="true people (GT)")
    a.plot(t, run.frames["n_people"], drawstyle="steps-post", color="red", label="people (filter)")
    if tracks is not None and len(tracks["frame"]):
        counts = np.bincount(tracks["frame"][(tracks["frame"] >= 0) & (tracks["frame"] < n)], minlength=n)
        a.plot(t, counts[:n], drawstyle="steps-post", color="tab:green", label="tracks")
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
