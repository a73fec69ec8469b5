"""``pfpeople view`` on a 3-laser run: a legible side panel, distinct marks, and the painted layers checked against
matplotlib drawing the same thing.

The synthetic run: grid 20 x 24 cells of 0.5 m (x in [-5, 5] m, y in [-6, 6] m) with a belief ramp, three lasers
(``/left_scan``, ``/rear_scan``, ``/right_scan``) with the three built-in detectors each (nine detectors, the
longest name ``laser_single_legs_right_scan``), one detection of every detector at (1, 1) m, ground truth at
(3, -3) m and a track (id 4) at (-2, 2) m walking 0.6 m/s along +x.
"""

from __future__ import annotations

import csv
import itertools
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure

from gridbridge.grid import GridSpec
from pfpeople.io.run_dir import RunWriter, load_run
from pfpeople.viz.frame_layout import TRACK_COLOUR, TRUTH_COLOUR, ViewOptions, display, extent, fit_size
from pfpeople.viz.raster import GridPainter, Overlay, TextPainter, blend
from pfpeople.viz.run_view import LEGEND_MARKER_PT, TRACK_COLUMNS, RunFrameRenderer, read_tracks

SPEC = GridSpec(nx=20, ny=24, resolution=0.5, x0=-5.0, y0=-6.0)
TOPICS = ("/left_scan", "/rear_scan", "/right_scan")
KINDS = ("laser_legs", "laser_boosted", "laser_single_legs")
NAMES = [kind if t == TOPICS[0] else f"{kind}_{t[1:]}" for t in TOPICS for kind in KINDS]


def write_run(path: Path, n_frames: int = 3) -> Path:
    belief = np.add.outer(np.linspace(0.0, 0.5, SPEC.nx), np.linspace(0.0, 0.5, SPEC.ny))
    meta = {
        "grid_frame": "left_laser",
        "config": {
            "odometry": {"topic": ""},
            "detectors": [{"name": n, "topic": TOPICS[k // 3]} for k, n in enumerate(NAMES)],
        },
        "detector_models": [{"name": n, "fov_min": -2.3, "fov_max": 2.3, "max_range": 4.0} for n in NAMES],
    }
    with RunWriter(path, spec=SPEC, detector_names=NAMES, metadata=meta) as w:
        for k in range(n_frames):
            w.write_frame(
                frame=k,
                driver_index=k,
                stamp_ns=10**9 + k * 133_333_333,
                bag_time_ns=10**9 + k * 133_333_333,
                dt_s=0.133,
                odometry=None if k == 0 else (0.3, 0.1),
                forced=False,
                belief=belief,
                people=np.zeros((0, 2)),
                detections=[np.array([[1.0, 1.0]])] * len(NAMES),
                scans={t: (np.array([[4.0, -4.0 + j]]), None) for j, t in enumerate(TOPICS)},
            )
    with (path / "tracks.csv").open("w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(TRACK_COLUMNS)
        for k in range(n_frames):
            wr.writerow([k, 10**9 + k * 133_333_333, 4, -2.0, 2.0, 0.6, 0.0, 0.01, 0.0, 0.01, 0.9])
    return path


@pytest.fixture
def renderer(tmp_path: Path) -> RunFrameRenderer:
    run_dir = write_run(tmp_path / "run")
    run = load_run(run_dir)
    w, h = fit_size(run.spec)
    truth = [np.array([[3.0, -3.0]])] * run.n_frames
    return RunFrameRenderer(
        run, options=ViewOptions(width_px=w, height_px=h), tracks=read_tracks(run_dir / "tracks.csv"), truth=truth
    )


def test_side_panel_shows_every_name_whole_and_legend_rows_apart(renderer: RunFrameRenderer) -> None:
    renderer.render(1)
    legend = renderer.legend
    texts = {t.get_text(): t.get_window_extent() for t in legend.get_texts()}
    assert set(NAMES) <= set(texts)  # whole names, not cut to 16 characters
    width = renderer.options.width_px
    assert all(0 <= b.x0 and b.x1 <= width for b in texts.values())  # inside the frame
    assert renderer._count_right <= width - 1  # the counts column too
    # rows one above the other, none overlapping; every detector's legend marker the same size
    boxes = sorted((b.y0, b.y1) for b in texts.values())
    assert all(lo1 >= hi0 - 0.5 for (_, hi0), (lo1, _) in itertools.pairwise(boxes))
    handles = [h for h, t in zip(legend.legend_handles, legend.get_texts(), strict=True) if t.get_text() in NAMES]
    assert {h.get_markersize() for h in handles} == {LEGEND_MARKER_PT}
    row_px = np.diff(sorted(renderer._count_rows.values()))
    assert row_px.min() >= LEGEND_MARKER_PT * renderer.options.dpi / 72  # a marker fits in its row
    # the path plot lies below the readout
    top_of_path = renderer.options.height_px - renderer.side.get_window_extent().y1
    assert renderer._path_shown and top_of_path > renderer._readout_top + 6 * renderer._line_px


def test_ground_truth_and_tracks_have_their_own_colours(renderer: RunFrameRenderer) -> None:
    assert np.ptp(np.subtract(to_rgb(TRUTH_COLOUR), to_rgb(TRACK_COLOUR))) > 0.5
    image = renderer.render(0).astype(int)

    def near(x: float, y: float, colour: str) -> bool:
        r, c = renderer.point_pixel(x, y)
        patch = image[r - 3 : r + 4, c - 3 : c + 4].reshape(-1, 3)
        return bool(np.any(np.abs(patch - np.array(to_rgb(colour)) * 255).max(axis=1) < 40))

    assert near(3.0, -3.0, TRUTH_COLOUR) and not near(3.0, -3.0, TRACK_COLOUR)
    assert near(-2.0, 2.0, TRACK_COLOUR) and not near(-2.0, 2.0, TRUTH_COLOUR)


def test_grid_is_painted_as_matplotlib_imshow_draws_it(renderer: RunFrameRenderer) -> None:
    """The grid painter against ``imshow(interpolation="nearest")`` on the same axes: every pixel equal except
    on the cell borders (each screen pixel shows the cell under its centre; matplotlib's resampling may take the
    neighbour there)."""
    o, spec = renderer.options, renderer.spec
    belief = np.asarray(renderer.run.grids[0], dtype=float)
    fig = Figure(figsize=(o.width_px / o.dpi, o.height_px / o.dpi), dpi=o.dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes(renderer.ax.get_position().bounds)
    ax.imshow(display(belief), cmap="Greys", vmin=0, vmax=1, extent=extent(spec), interpolation="nearest")
    ax.set_xlim(spec.y1, spec.y0)
    ax.set_ylim(spec.x0, spec.x1)
    ax.set_axis_off()
    canvas.draw()
    want = np.asarray(canvas.buffer_rgba())[..., :3].astype(int)
    got = np.zeros((o.height_px, o.width_px, 4), np.uint8)
    painter = renderer._grid
    painter.paint(got, belief)
    rows = slice(painter.top + 1, painter.top + len(painter.rows_i) - 1)
    cols = slice(painter.left + 1, painter.left + len(painter.cols_j) - 1)
    diff = np.abs(got[rows, cols, :3].astype(int) - want[rows, cols]).max(axis=2)
    assert (diff <= 1).mean() > 0.97
    # the pixels that differ are on cell borders: a neighbouring pixel shows the painter's cell change
    i, j = painter.rows_i[1:-1], painter.cols_j[1:-1]
    border_r = np.zeros(len(i), bool)
    border_r[1:] |= np.diff(i) != 0
    border_r[:-1] |= np.diff(i) != 0
    border_c = np.zeros(len(j), bool)
    border_c[1:] |= np.diff(j) != 0
    border_c[:-1] |= np.diff(j) != 0
    bad_r, bad_c = np.nonzero(diff > 1)
    assert np.all(border_r[bad_r] | border_c[bad_c])


def test_grid_painter_levels_follow_matplotlib() -> None:
    painter = GridPainter(np.array([0, 1]), np.array([0]), 0, 0, "Greys")
    values = np.array([[0.0], [1.0]])
    buf = np.zeros((2, 1, 4), np.uint8)
    painter.paint(buf, values)
    from matplotlib import colormaps

    want = (np.asarray(colormaps["Greys"](values[:, 0]))[:, :3] * 255).round()
    np.testing.assert_array_equal(buf[:, 0, :3], want)
    assert (buf[..., 3] == 255).all()
    assert painter.levels(np.array([np.nan, -0.2, 0.5, 1.7])).tolist() == [0, 0, 128, 255]


def test_overlay_and_text_blend_as_straight_alpha() -> None:
    rng = np.random.default_rng(5)
    under = rng.integers(0, 256, (6, 7, 4), dtype=np.uint8)
    layer = rng.integers(0, 256, (6, 7, 4), dtype=np.uint8)
    layer[2, 3, 3] = 0  # a transparent pixel stays as it was
    got = under.copy()
    Overlay.from_rgba(layer).paint(got)
    a = layer[..., 3:].astype(float) / 255
    want = under[..., :3] * (1 - a) + layer[..., :3] * a
    assert np.abs(got[..., :3] - want).max() <= 1
    assert (got[2, 3] == under[2, 3]).all()
    buf = under.copy()
    blend(buf, np.full((3, 3), 255, np.uint8), -1, 5, (1, 2, 3))  # clipped at the top and right edges
    assert (buf[:2, 5:, :3] == (1, 2, 3)).all() and (buf[2:, :, :3] == under[2:, :, :3]).all()
    text = TextPainter(100.0)
    canvas = np.full((30, 120, 4), 255, np.uint8)
    top, left, bottom, right = text.paint(canvas, "people 3", 110, 15, size_pt=7, mono=True, align="right")
    assert right <= 112 and left < 110 and (canvas[top:bottom, left:right, 0] < 128).any()
    assert text.mask("people 3", 7, True)[0] is text.mask("people 3", 7, True)[0]  # rendered once
