"""``pfpeople view``: a synthetic run whose belief is 1 in one cell and 0 elsewhere, encoded and decoded back.

The run: grid 10 x 10 cells of 0.5 m (x in [0, 5] m, y in [-2.5, 2.5] m), 12 frames 0.1 s apart, belief 1 in
cell [7, 2] (centre x = 3.75 m, y = -1.25 m: far and to the right in the x-up, y-left display) and 0 elsewhere,
two detectors seeing a person at (1.5, 1.5) m, odometry v = 0.5 m/s, omega = 0.2 rad/s, and a tracks.csv.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import cv2
import imageio.v3 as iio
import numpy as np
import pytest

from gridbridge.grid import GridSpec
from pfpeople.cli import main
from pfpeople.cli.commands.view import parse_frames
from pfpeople.io.ground_truth import read_gt_csv, truth_per_frame
from pfpeople.io.run_dir import RunWriter, load_run
from pfpeople.viz.run_view import TRACK_COLUMNS, RunFrameRenderer, ViewOptions, read_tracks, robot_path

SPEC = GridSpec(nx=10, ny=10, resolution=0.5, x0=0.0, y0=-2.5)
CELL = (7, 2)
SIZE = (480, 320)


def write_run(path: Path, n_frames: int = 12, *, tracks: bool = True) -> Path:
    belief = np.zeros(SPEC.shape)
    belief[CELL] = 1.0
    meta = {"grid_frame": "laser", "frames_in_grid": {"laser": [0.0, 0.0, 0.0]}}
    with RunWriter(path, spec=SPEC, detector_names=["legs", "boosted"], metadata=meta) as w:
        for k in range(n_frames):
            w.write_frame(
                frame=k,
                driver_index=10 + k,
                stamp_ns=5 * 10**9 + k * 10**8,
                bag_time_ns=5 * 10**9 + k * 10**8,
                dt_s=0.1,
                odometry=(0.5, 0.2),
                forced=False,
                belief=belief,
                people=np.array([[1.5, 1.5]]),
                detections=[np.array([[1.5, 1.5]]), None if k == 3 else np.array([[1.6, 1.4]])],
            )
    if tracks:
        with (path / "tracks.csv").open("w", newline="") as fh:
            wr = csv.writer(fh)
            wr.writerow(TRACK_COLUMNS)
            for k in range(n_frames):
                wr.writerow([k, 5 * 10**9 + k * 10**8, 4, 1.5, 1.5, 0.5, -0.5, 0.01, 0.0, 0.01, 0.9])
    return path


def dark_centroid(image: np.ndarray, renderer: RunFrameRenderer) -> tuple[float, float]:
    """Centroid (row, col) of the near-black pixels inside the grid axes (spines excluded)."""
    h = renderer.options.height_px
    (x0, y0), (x1, y1) = renderer.ax.get_window_extent().get_points()
    r0, r1, c0, c1 = int(h - y1) + 3, int(h - y0) - 3, int(x0) + 3, int(x1) - 3
    sub = image[r0:r1, c0:c1].astype(int)
    rows, cols = np.nonzero(sub.max(axis=2) < 60)
    assert rows.size > 0
    return r0 + float(rows.mean()), c0 + float(cols.mean())


def test_video_is_decoded_with_the_frame_count_and_the_known_cell(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path / "run")
    out = tmp_path / "v.mp4"
    args = ["view", str(run_dir), "--out", str(out), "--frames", "2:10", "--size", "480x320", "--no-progress"]
    assert main([*args, "--fps", "5", "--no-summary"]) == 0
    assert not (run_dir / "summary.png").exists()
    # Decoded by OpenCV's own FFmpeg build (an independent decoder), BGR -> RGB.
    cap = cv2.VideoCapture(str(out))
    assert cap.isOpened()
    fps = cap.get(cv2.CAP_PROP_FPS)
    frames = []
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        frames.append(bgr[..., ::-1])
    cap.release()
    assert fps == pytest.approx(5.0) and len(frames) == 8 and frames[0].shape == (SIZE[1], SIZE[0], 3)
    renderer = RunFrameRenderer(load_run(run_dir), options=ViewOptions(width_px=480, height_px=320))
    r, c = renderer.cell_pixel(*CELL)
    far = renderer.cell_pixel(2, 9)  # x = 1.25 m, y = +2.25 m: an empty cell
    for img in (frames[0], frames[-1]):
        assert img[r, c].astype(int).max() < 70  # belief 1: black (H.264 tolerance)
        assert img[far].astype(int).min() > 200  # belief 0: white
    # The short selection also got a GIF (half size, same frame count).
    gif = iio.imread(out.with_suffix(".gif"), index=None)
    assert gif.shape[:3] == (8, SIZE[1] // 2, SIZE[0] // 2)


def test_rendered_frame_draws_x_up_and_y_left(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run", tracks=False))
    renderer = RunFrameRenderer(run, options=ViewOptions(width_px=480, height_px=320))
    image = renderer.render(0)
    assert image.shape == (320, 480, 3) and image.dtype == np.uint8
    row, col = dark_centroid(image, renderer)
    r, c = renderer.cell_pixel(*CELL)
    assert abs(row - r) < 2.0 and abs(col - c) < 2.0
    # Cell [7, 2] is far (x = 3.75 of 5 m: upper part) and right (y = -1.25 m: y grows to the left).
    (x0, y0), (x1, y1) = renderer.ax.get_window_extent().get_points()
    assert row < 320 - (y0 + y1) / 2 and col > (x0 + x1) / 2
    assert np.array_equal(renderer.render(0), image)  # blitting leaves nothing of other frames behind
    with pytest.raises(IndexError, match=r"frame 12 is outside run .* \(frames 0..11\)"):
        renderer.render(12)


def test_tracks_and_ground_truth_are_drawn(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path / "run")
    run = load_run(run_dir)
    gt_path = tmp_path / "gt.csv"
    gt_path.write_text("scan_index,person_id,x_laser_m,y_laser_m\n10,1,2.5,-2.0\n11,1,2.5,-2.0\n")
    truth, unassigned = truth_per_frame(run, read_gt_csv(gt_path))
    assert unassigned == 0 and [len(t) for t in truth[:3]] == [1, 1, 0]
    opts = ViewOptions(width_px=480, height_px=320)
    plain = RunFrameRenderer(run, options=opts).render(0)
    full = RunFrameRenderer(run, options=opts, tracks=read_tracks(run_dir / "tracks.csv"), truth=truth).render(0)
    renderer = RunFrameRenderer(run, options=opts)
    r, c = renderer.point_pixel(2.5, -2.0)  # the GT
    lime = full[r - 2 : r + 3, c - 2 : c + 3].astype(int)
    assert np.any((lime[..., 1] > 150) & (lime[..., 0] < 100) & (lime[..., 2] < 100))  # the green GT marker
    assert np.all(plain[r - 2 : r + 3, c - 2 : c + 3] == 255)  # white without it
    assert not np.array_equal(full, plain)
    bad = tmp_path / "bad_tracks.csv"
    bad.write_text("frame,id,x,y\n0,1,1,1\n")
    with pytest.raises(ValueError, match=r"tracks file .*bad_tracks.csv.*expected columns"):
        read_tracks(bad)


def test_summary_page(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_dir = write_run(tmp_path / "run", n_frames=4)
    png = tmp_path / "s.png"
    assert main(["view", str(run_dir), "--no-video", "--summary", str(png), "--dpi", "40"]) == 0
    assert f"summary -> {png}" in capsys.readouterr().out
    image = iio.imread(png)
    assert image.shape[:2] == (340, 440)  # 11 x 8.5 inches at 40 dpi
    assert not (run_dir / "view.mp4").exists()


def test_robot_path_follows_the_arc() -> None:
    n, v, w, dt = 21, 0.5, 0.2, 0.1
    p = robot_path(np.full(n, v), np.full(n, w), np.full(n, dt))
    th = w * dt * (n - 1)
    np.testing.assert_allclose(p[-1], [v / w * math.sin(th), v / w * (1 - math.cos(th)), th], atol=1e-12)
    np.testing.assert_allclose(robot_path(np.full(3, 1.0), np.zeros(3), np.full(3, 0.5))[-1], [1.0, 0.0, 0.0])


def test_frames_option_and_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert parse_frames("2:5", 10) == range(2, 5)
    assert parse_frames(":3", 10) == range(0, 3) and parse_frames("7:", 10) == range(7, 10)
    assert parse_frames("4", 10) == range(4, 5)
    with pytest.raises(ValueError, match=r"--frames '5:100' is outside run 'r', which has 10 frames"):
        parse_frames("5:100", 10, run="run 'r'")
    with pytest.raises(ValueError, match="must be integers"):
        parse_frames("a:b", 10)
    with pytest.raises(ValueError, match=r"outside"):
        parse_frames("6:6", 10)
    with pytest.raises(ValueError, match=r"ViewOptions.width_px must be an even number"):
        ViewOptions(width_px=481)
    with pytest.raises(TypeError, match=r"ViewOptions.fps must be a number"):
        ViewOptions(fps="10")  # type: ignore[arg-type]
    run_dir = write_run(tmp_path / "run", n_frames=3, tracks=False)
    assert main(["view", str(run_dir), "--frames", "1:9", "--no-progress"]) == 2
    assert "--frames '1:9' is outside run" in capsys.readouterr().err
    assert main(["view", str(run_dir), "--out", str(tmp_path / "v.avi"), "--no-progress"]) == 2
    assert "must end in .mp4 or .gif" in capsys.readouterr().err
    assert main(["view", str(tmp_path), "--no-progress"]) == 2
    assert f"{str(tmp_path)!r} is not a run directory (no run.json)" in capsys.readouterr().err
    assert main(["view", str(tmp_path / "nope"), "--no-progress"]) == 2
    assert "does not exist" in capsys.readouterr().err
    empty = tmp_path / "empty"
    RunWriter(empty, spec=SPEC, detector_names=["legs"]).close(status="failed", error="stopped")
    assert main(["view", str(empty), "--no-progress"]) == 2
    assert "has no frames" in capsys.readouterr().err
    assert main(["view", str(run_dir), "--tracks", str(tmp_path / "t.csv"), "--no-progress"]) == 2
    assert "--tracks" in capsys.readouterr().err
    gt = tmp_path / "gt.csv"
    gt.write_text("scan_index,person_id,x_laser_m,y_laser_m\n10,1,2.5,-2.0\n")
    assert main(["view", str(run_dir), "--gt", str(gt), "--gt-frame", "grid", "--no-progress"]) == 2
    assert "in frame 'laser' (columns x_laser_m, y_laser_m) but frame 'grid' was requested" in capsys.readouterr().err
