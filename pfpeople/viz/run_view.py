"""Pictures of a run directory (:mod:`pfpeople.output`): an animation frame per run frame, and a summary page.

Drawn with matplotlib's object-oriented API on an Agg canvas (no pyplot state, any backend). The grid is drawn
as the paper and :mod:`evaluation.figures` draw it: the sensor at the bottom middle, x (forward) up, y (left) to
the left; only the display is flipped (``grid[::-1, ::-1]`` with extent ``(y1, y0, x0, x1)``), never the data.
Points (m, grid frame) are plotted at ``(y, x)`` on those axes.

One animation frame shows:

- the belief grid (probability of a person per cell, grey scale from 0 = white to 1 = black) and each
  detector's field of view (dashed, from ``run.json`` ``detector_models``: mount, fov_min/max, max_range);
- each detector's detections (one marker and colour per detector, in the legend), the classified people
  (red circles), ground truth when given (green plus signs), tracks when the run has ``tracks.csv``
  (columns :data:`TRACK_COLUMNS`: id labels and velocity arrows showing one second of motion);
- the frame counter (run frame, driver index), the time since the first frame (s), the odometry controls
  (v and the lateral vy in m/s, omega in deg/s, or "no odometry") and, in a side panel, the grid frame's path
  integrated from the controls of ``frames.csv`` (exact constant-velocity motions, in the frame of the first run
  frame, drawn with the same x-up convention) with the current pose.

:func:`render_summary` draws a one-page summary PNG: people per frame, detections per detector per frame
(and tracks per frame when present) over time, and the histogram of the belief over all frames and cells.
"""

from __future__ import annotations

import csv
import math
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
from gridbridge.validation import check_number
from pfpeople.output import RunData

__all__ = [
    "TRACK_COLUMNS",
    "RunFrameRenderer",
    "ViewOptions",
    "display",
    "extent",
    "frame_times_s",
    "read_tracks",
    "render_summary",
    "robot_path",
]

TRACK_COLUMNS = ("frame", "stamp_ns", "id", "x", "y", "vx", "vy", "cov_xx", "cov_xy", "cov_yy", "score")
_MARKERS = ("^", "s", "D", "v", "P", "X", "<", ">", "h", "*")
_COLOURS = ("tab:blue", "tab:orange", "tab:purple", "tab:brown", "tab:cyan", "tab:olive", "tab:pink", "tab:gray")


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
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int):
                raise TypeError(f"ViewOptions.{name} must be an integer, got {type(v).__name__}")
            if v < 160 or v > 7680 or v % 2:
                raise ValueError(f"ViewOptions.{name} must be an even number of pixels in [160, 7680], got {v}")
        for name in ("dpi", "fps"):
            v = getattr(self, name)
            if check_number(v, f"ViewOptions.{name}") <= 0:
                raise ValueError(f"ViewOptions.{name} must be positive and finite, got {v}")


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


def _by_frame(frames: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(order, starts): rows of frame k are ``order[starts[k]:starts[k+1]]`` (stable)."""
    order = np.argsort(frames, kind="stable")
    return order, frames[order]


class RunFrameRenderer:
    """Draws one animation frame of a run as an RGB image (see the module docstring).

    Parameters
    ----------
    run : RunData
        The run (:func:`pfpeople.output.load_run`).
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
        self.has_odometry = bool(np.any(fr["odometry"] == 1))
        self.path = robot_path(fr["v_mps"], fr["omega_radps"], fr["dt_s"], fr["vy_mps"])
        self._det_order, self._det_frames = _by_frame(run.detections["frame"])
        self._ppl_order, self._ppl_frames = _by_frame(run.people["frame"])
        if tracks is not None:
            self._trk_order, self._trk_frames = _by_frame(tracks["frame"])
        self._build()

    # -- figure ------------------------------------------------------------------------------------------

    def _build(self) -> None:
        """The static parts are drawn once (the background); each frame redraws only its artists (blitting)."""
        o, spec = self.options, self.spec
        self.fig = Figure(figsize=(o.width_px / o.dpi, o.height_px / o.dpi), dpi=o.dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.07, 0.08, 0.52, 0.84))
        self.side = self.fig.add_axes((0.73, 0.30, 0.24, 0.34))
        ax = self.ax
        self._animated: list[Any] = []

        def animated(art: Any) -> Any:
            art.set_animated(True)
            self._animated.append(art)
            return art

        self.image = animated(
            ax.imshow(
                display(np.zeros(spec.shape)),
                cmap="Greys",
                vmin=0.0,
                vmax=1.0,
                extent=extent(spec),
                interpolation="nearest",
                origin="upper",
            )
        )
        ax.set_xlim(spec.y1, spec.y0)
        ax.set_ylim(spec.x0, spec.x1)
        ax.set_xlabel("y (m, left is +y)")
        ax.set_ylabel("x (m, forward)")
        self.fig.colorbar(self.image, ax=ax, fraction=0.04, pad=0.02, label="belief")
        self._draw_fields_of_view()
        self.det_artists = []
        for k, name in enumerate(self.detectors):
            (art,) = ax.plot(
                [],
                [],
                linestyle="none",
                marker=_MARKERS[k % len(_MARKERS)],
                mfc="none",
                mec=_COLOURS[k % len(_COLOURS)],
                ms=7,
                mew=1.4,
                label=name,
            )
            self.det_artists.append(animated(art))
        (people,) = ax.plot(
            [], [], linestyle="none", marker="o", mfc="none", mec="red", ms=14, mew=2.0, label="people (filter)"
        )
        self.people_art = animated(people)
        self.truth_art = None
        if self.truth is not None:
            (truth,) = ax.plot(
                [], [], linestyle="none", marker="+", color="limegreen", ms=14, mew=2.5, label="ground truth"
            )
            self.truth_art = animated(truth)
        self.track_art = None
        if self.tracks is not None:
            (track,) = ax.plot(
                [], [], linestyle="none", marker="*", color="tab:green", ms=9, label="tracks (id, 1 s of motion)"
            )
            self.track_art = animated(track)
        self.fig.legend(loc="upper left", bbox_to_anchor=(0.70, 0.99), fontsize=8, frameon=False)
        self.title = animated(self.fig.text(0.07, 0.95, "", fontsize=10))
        self.readout = animated(self.fig.text(0.71, 0.24, "", fontsize=8, va="top", family="monospace"))
        self._dynamic: list[Any] = []
        # Side panel: the odometry path in the first frame's frame, x up and y to the left like the grid.
        s = self.side
        s.set_title("grid frame path (odometry)", fontsize=8)
        s.tick_params(labelsize=6)
        if self.has_odometry:
            p = self.path
            s.plot(p[:, 1], p[:, 0], color="0.8", lw=1.0)
            (past,) = s.plot([], [], color="tab:blue", lw=1.5)
            (pose,) = s.plot([], [], marker="o", color="tab:red", ms=4)
            (heading,) = s.plot([], [], color="tab:red", lw=1.5)
            self.past_art, self.pose_art, self.heading_art = animated(past), animated(pose), animated(heading)
            span = max(float(np.ptp(p[:, 0])), float(np.ptp(p[:, 1])), 1.0)
            cx, cy = float(np.mean(p[:, 0])), float(np.mean(p[:, 1]))
            s.set_xlim(cy + 0.6 * span, cy - 0.6 * span)
            s.set_ylim(cx - 0.6 * span, cx + 0.6 * span)
            s.set_aspect("equal", adjustable="box")
            self._heading_len = 0.08 * span
        else:
            s.text(0.5, 0.5, "no odometry\n(robot standing)", ha="center", va="center", transform=s.transAxes)
            s.set_xticks([])
            s.set_yticks([])
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.fig.bbox)

    def _draw_fields_of_view(self) -> None:
        """Each detector's field of view (``run.json`` ``detector_models``) as a dashed outline."""
        spec = self.spec
        reach = math.hypot(spec.x1 - spec.x0, spec.y1 - spec.y0) + abs(spec.x0) + abs(spec.y0)
        models = {m.get("name"): m for m in self.run.meta.get("detector_models", []) if isinstance(m, dict)}
        for k, name in enumerate(self.detectors):
            m = models.get(name)
            if m is None:
                continue
            try:
                lo, hi = float(m.get("fov_min", -math.pi / 2)), float(m.get("fov_max", math.pi / 2))
                rng = min(float(m.get("max_range", math.inf)), reach)  # "inf" in run.json reads as inf
                mx, my, myaw = (float(m.get(f, 0.0)) for f in ("mount_x", "mount_y", "mount_yaw"))
            except (TypeError, ValueError):
                continue
            a = myaw + np.linspace(lo, hi, 60)
            xs = np.concatenate(([mx], mx + rng * np.cos(a), [mx]))
            ys = np.concatenate(([my], my + rng * np.sin(a), [my]))
            (line,) = self.ax.plot(ys, xs, linestyle="--", lw=0.8, color=_COLOURS[k % len(_COLOURS)], alpha=0.7)
            line.set_animated(True)  # drawn over the belief image every frame
            self._animated.append(line)

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
        if self.track_art is not None and self.tracks is not None:
            tr = self.tracks
            rows = self._rows(self._trk_order, self._trk_frames, k)
            x, y, vx, vy = tr["x"][rows], tr["y"][rows], tr["vx"][rows], tr["vy"][rows]
            self.track_art.set_data(y, x)
            if len(rows):
                q = self.ax.quiver(
                    y,
                    x,
                    vy,
                    vx,
                    angles="xy",
                    scale_units="xy",
                    scale=1.0,
                    color="tab:green",
                    width=0.004,
                    animated=True,
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
        fr = run.frames
        self.title.set_text(
            f"{run.path.name}  frame {k + 1}/{run.n_frames} (driver #{int(fr['driver_index'][k])})  "
            f"t = {self.times_s[k]:.2f} s"
        )
        odo = (
            f"v     {fr['v_mps'][k]:+6.2f} m/s\nvy    {fr['vy_mps'][k]:+6.2f} m/s\n"
            f"omega {math.degrees(fr['omega_radps'][k]):+6.1f} deg/s"
            if fr["odometry"][k]
            else "no odometry"
        )
        n_det = {n: int(np.count_nonzero(names == n)) for n in self.detectors}
        no_data = str(fr["no_data"][k])
        lines = [odo, f"dt    {fr['dt_s'][k]:6.3f} s", f"people {int(fr['n_people'][k])}"]
        lines += [f"{n[:14]:<14} {'no data' if n in no_data.split(';') else c}" for n, c in n_det.items()]
        self.readout.set_text("\n".join(lines))
        if self.has_odometry:
            p = self.path
            self.past_art.set_data(p[: k + 1, 1], p[: k + 1, 0])
            self.pose_art.set_data([p[k, 1]], [p[k, 0]])
            hx = p[k, 0] + self._heading_len * math.cos(p[k, 2])
            hy = p[k, 1] + self._heading_len * math.sin(p[k, 2])
            self.heading_art.set_data([p[k, 1], hy], [p[k, 0], hx])
        for art in self._animated + self._dynamic:
            self.fig.draw_artist(art)
        for spine in self.ax.spines.values():
            self.fig.draw_artist(spine)
        rgba = np.asarray(self.canvas.buffer_rgba())
        if rgba.shape[:2] != (self.options.height_px, self.options.width_px):
            raise RuntimeError(f"rendered {rgba.shape[1]}x{rgba.shape[0]} px, expected the ViewOptions size")
        return np.ascontiguousarray(rgba[..., :3])


def render_summary(
    run: RunData, path: str | Path, *, tracks: dict[str, NDArray[Any]] | None = None, dpi: float = 100.0
) -> Path:
    """Write a one-page summary PNG of ``run`` at ``path`` (see the module docstring); returns the path."""
    if run.n_frames == 0:
        raise ValueError(f"run {str(run.path)!r} has no frames (run.json status {run.meta.get('status')!r})")
    path = Path(path)
    n = run.n_frames
    t = frame_times_s(run)
    fig = Figure(figsize=(11.0, 8.5), dpi=dpi)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2)
    a = axes[0, 0]
    a.plot(t, run.frames["n_people"], drawstyle="steps-post", color="red", label="people (filter)")
    if tracks is not None and len(tracks["frame"]):
        counts = np.bincount(tracks["frame"][(tracks["frame"] >= 0) & (tracks["frame"] < n)], minlength=n)
        a.plot(t, counts[:n], drawstyle="steps-post", color="tab:green", label="tracks")
    a.set_title("people over time")
    a.set_xlabel("time (s)")
    a.set_ylabel("count per frame")
    a.legend(fontsize=8)
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
    meta = run.meta
    config = meta.get("config")
    kind = config.get("filter", {}).get("kind", "?") if isinstance(config, dict) else "?"
    ppl = run.frames["n_people"]
    lines = [
        f"run: {run.path}",
        f"status: {meta.get('status')}   frames: {n}   span: {t[-1]:.2f} s",
        f"grid: {run.spec.nx} x {run.spec.ny} cells of {run.spec.resolution} m, frame {meta.get('grid_frame', '?')}",
        f"filter: {kind}",
        f"detectors: {', '.join(meta.get('detectors', []))}",
        f"frames with odometry: {int(np.count_nonzero(run.frames['odometry']))} / {n}",
        f"people per frame: mean {float(np.mean(ppl)):.2f}, max {int(np.max(ppl))}",
        f"mean belief: {float(np.mean([np.mean(run.grids[k]) for k in range(n)])):.3f}",
    ]
    a.text(0.0, 1.0, "\n".join(lines), va="top", fontsize=9, family="monospace", transform=a.transAxes)
    fig.suptitle(f"pfpeople run summary: {run.path.name}")
    fig.subplots_adjust(left=0.08, right=0.97, bottom=0.07, top=0.91, wspace=0.25, hspace=0.35)
    fig.savefig(path)
    return path
