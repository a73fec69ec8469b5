"""``pfpeople view`` draws what the lasers saw: scans (``scans.npy``), particles (``particles.npy``), real-time fps.

The synthetic run: grid 10 x 10 cells of 0.5 m (x in [0, 5] m, y in [-2.5, 2.5] m), belief 0 everywhere, 7.5 Hz
stamps, two lasers (``/front``: a row of returns at x = 3 m, y in [1.0, 1.6] m, and a row the static-clutter
map calls static at x = 1 m, y in [-1.6, -1.0] m; ``/rear``: a row at x = 4 m, y in [-1.6, -1.0] m) and, for a
particle run, 5000 particles in a 0.4 m square around (2, 0) m.
"""

from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import imageio_ffmpeg
import numpy as np
import pytest
from bag_fixtures import legs_only, write_scan_bag

from gridbridge.grid import GridSpec
from pfpeople.cli import main
from pfpeople.config import FilterConfig
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.run_dir import MAX_PARTICLES_SAVED, RunWriter, load_run, scan_records
from pfpeople.perception.clutter_map import StaticClutterMap
from pfpeople.pipeline.runner import Pipeline
from pfpeople.pipeline.sinks import standard_sinks
from pfpeople.viz.run_view import (
    RunFrameRenderer,
    ViewOptions,
    default_fps,
    ego_sources,
    fit_size,
    layout,
)
from pfpeople.viz.summary import render_summary
from pfpeople.viz.video import write_animation

SPEC = GridSpec(nx=10, ny=10, resolution=0.5, x0=0.0, y0=-2.5)
OPTS = ViewOptions(width_px=480, height_px=320)
STEP_NS = 133_333_333  # 7.5 Hz
ROW = np.linspace(0.0, 0.6, 13)
FRONT = np.column_stack((np.full(13, 3.0), 1.0 + ROW))
STATIC = np.column_stack((np.full(13, 1.0), -1.6 + ROW))
REAR = np.column_stack((np.full(13, 4.0), -1.6 + ROW))
META: dict[str, Any] = {
    "grid_frame": "base_link",
    "config": {
        "odometry": {"topic": ""},
        "filter": {"kind": "grid"},
        "detectors": [{"name": "legs", "topic": "/front"}, {"name": "rear-legs", "topic": "/rear"}],
    },
    "detector_models": [
        {"name": "legs", "mount_x": 0.0, "fov_min": -1.0, "fov_max": 1.0, "max_range": 4.5},
        {"name": "rear-legs", "mount_x": 0.0, "fov_min": -1.0, "fov_max": 1.0, "max_range": 4.5},
    ],
}


def write_run(path: Path, n_frames: int = 6, *, scans: bool = True, particles: bool = False) -> Path:
    rng = np.random.default_rng(3)
    with RunWriter(path, spec=SPEC, detector_names=["legs", "rear-legs"], metadata=META) as w:
        for k in range(n_frames):
            front = np.vstack((FRONT, STATIC, [[np.nan, np.nan]]))
            flags = np.r_[np.zeros(13, bool), np.ones(13, bool), False]
            w.write_frame(
                frame=k,
                driver_index=k,
                stamp_ns=10**9 + k * STEP_NS,
                bag_time_ns=10**9 + k * STEP_NS,
                dt_s=STEP_NS / 1e9,
                odometry=None if k == 0 else (0.2, 0.0),
                forced=False,
                belief=np.zeros(SPEC.shape),
                people=np.zeros((0, 2)),
                detections=[np.array([[2.0, 1.0]]), np.array([[2.0, 1.0]])],
                scans={"/front": (front, flags), "/rear": (REAR, None)} if scans else None,
                particles=(2.0 + rng.uniform(-0.2, 0.2, 5000), rng.uniform(-0.2, 0.2, 5000)) if particles else None,
            )
    return path


def colour_at(image: np.ndarray, renderer: RunFrameRenderer, xy: np.ndarray) -> np.ndarray:
    """Pixel colours (int, (M, 3)) at the projected positions of points ``xy`` (m, grid frame)."""
    return np.array([image[renderer.point_pixel(float(x), float(y))] for x, y in xy], dtype=int)


def is_blue(c: np.ndarray) -> np.ndarray:  # royalblue (65, 105, 225), the first laser
    return (c[:, 2] > 170) & (c[:, 2] - c[:, 0] > 80)


def is_violet(c: np.ndarray) -> np.ndarray:  # darkviolet (148, 0, 211), the second laser
    return (c[:, 0] > 90) & (c[:, 1] < 90) & (c[:, 2] > 150)


def is_grey(c: np.ndarray) -> np.ndarray:  # 0.62 grey (158, 158, 158): static returns
    return (np.ptp(c, axis=1) < 30) & (c.min(axis=1) > 110) & (c.max(axis=1) < 210)


def test_scan_points_are_drawn_at_their_returns_in_png_and_mp4(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run"))
    assert run.scan_topics == ["/front", "/rear"] and run.meta["scans"]["bytes_per_return"] == 10
    assert run.scans is not None and len(run.scans) == 6 * 39  # the NaN return is not stored
    renderer = RunFrameRenderer(run, options=OPTS)
    png = tmp_path / "f.png"
    iio.imwrite(png, renderer.render(2))
    image = iio.imread(png)
    inner = slice(2, -2)  # the row's ends touch the white background
    assert is_blue(colour_at(image, renderer, FRONT[inner])).all()
    assert is_grey(colour_at(image, renderer, STATIC[inner])).all()
    assert is_violet(colour_at(image, renderer, REAR[inner])).all()
    assert (colour_at(image, renderer, FRONT[inner] + [0.0, -1.5]) > 240).all()  # white where nothing returned
    mp4 = tmp_path / "v.mp4"
    assert write_animation(renderer, range(1, 4), mp4=mp4, progress=False) == {"mp4_frames": 3, "gif_frames": 0}
    frames = _ffmpeg_frames(mp4, OPTS)
    assert len(frames) == 3
    for img in frames:  # H.264 blurs colours: most of each row keeps its laser's colour
        assert is_blue(colour_at(img, renderer, FRONT[inner])).mean() > 0.7
        assert is_violet(colour_at(img, renderer, REAR[inner])).mean() > 0.7
        assert is_grey(colour_at(img, renderer, STATIC[inner])).mean() > 0.7


def _ffmpeg_frames(path: Path, opts: ViewOptions) -> list[np.ndarray]:
    """Decode with imageio-ffmpeg's ffmpeg into PNG files, read back by imageio (RGB frames).

    ``subprocess.run`` rather than ``imageio_ffmpeg.read_frames``: read to the end, the latter leaves the pipes of
    its finished ffmpeg open (a ResourceWarning, an error here).
    """
    out = path.parent / f"{path.stem}_frames"
    out.mkdir()
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(path), str(out / "%03d.png")]
    subprocess.run(cmd, check=True, capture_output=True)
    frames = [iio.imread(f) for f in sorted(out.glob("*.png"))]
    assert all(f.shape == (opts.height_px, opts.width_px, 3) for f in frames)
    return frames


def _video_meta(path: Path) -> dict[str, Any]:
    """imageio-ffmpeg's metadata of a video (fps, size)."""
    reader = imageio_ffmpeg.read_frames(str(path))
    try:
        return dict(next(reader))
    finally:
        reader.close()


def test_particles_are_stored_subsampled_and_drawn(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run", n_frames=2, particles=True))
    assert run.particles is not None and len(run.particles) == 2 * MAX_PARTICLES_SAVED
    assert np.all(np.abs(run.particles["x"].astype(float) - 2.0) <= 0.21)
    opts = ViewOptions(width_px=480, height_px=320)
    image = RunFrameRenderer(run, options=opts).render(1)
    plain = RunFrameRenderer(load_run(write_run(tmp_path / "plain", n_frames=2)), options=opts).render(1)
    renderer = RunFrameRenderer(run, options=opts)
    r, c = renderer.point_pixel(2.0, 0.0)
    patch = image[r - 4 : r + 5, c - 4 : c + 5].astype(int)
    pink = (patch[..., 0] > 200) & (patch[..., 1] < 170) & (patch[..., 0] - patch[..., 1] > 60)
    assert pink.sum() > 20  # deep pink dots over the square
    assert np.all(plain[r - 4 : r + 5, c - 4 : c + 5] == 255)


def test_runs_without_scans_still_render(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_dir = write_run(tmp_path / "run", scans=False)
    run = load_run(run_dir)
    assert run.scans is None and run.particles is None and run.scan_topics == []
    image = RunFrameRenderer(run, options=OPTS).render(0)
    assert image.shape == (320, 480, 3)
    # a run directory of before scans.npy: no file, no "scans" key in run.json
    old = write_run(tmp_path / "old")
    (old / "scans.npy").unlink()
    assert load_run(old).scans is None
    assert main(["view", str(old), "--size", "480x320", "--no-progress", "--no-gif"]) == 0
    assert (old / "view.mp4").is_file() and (old / "summary.png").is_file()
    assert "at 7.5 fps" in capsys.readouterr().out


def test_default_fps_is_the_runs_frame_rate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run_dir = write_run(tmp_path / "run")
    assert default_fps(load_run(run_dir)) == 7.5
    assert default_fps(load_run(write_run(tmp_path / "one", n_frames=1))) == 10.0
    out = tmp_path / "v.mp4"
    assert main(["view", str(run_dir), "--out", str(out), "--no-summary", "--no-gif", "--no-progress"]) == 0
    assert "at 7.5 fps" in capsys.readouterr().out
    meta = _video_meta(out)
    assert meta["fps"] == pytest.approx(7.5)
    w, h = fit_size(SPEC)  # the default size: 640 high, the square grid filling its share of the width
    assert meta["size"] == (w, h) and h == 640
    rects = layout(SPEC, w, h)
    assert rects["map"][2] * w == pytest.approx(rects["map"][3] * h)  # equal scale in x and y


def test_ego_motion_source_and_ground_truth_in_the_summary(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run"))
    assert list(ego_sources(run)) == ["none"] + ["scan matching"] * 5  # no odometry topic: scan matching
    renderer = RunFrameRenderer(run, options=OPTS)
    assert renderer.readout_lines(1)[0] == "ego    scan matching"
    assert renderer.readout_lines(0)[0] == "ego    none (standing)"
    assert not np.array_equal(renderer.render(1)[:, -170:], renderer.render(0)[:, -170:])  # the panel shows it
    truth = [np.array([[2.0, 1.0]])] * 6
    with_gt = iio.imread(render_summary(run, tmp_path / "gt.png", truth=truth, dpi=40))
    plain = iio.imread(render_summary(run, tmp_path / "plain.png", dpi=40))
    lime = (with_gt[..., 1] > 180) & (with_gt[..., 0] < 80) & (with_gt[..., 2] < 80)
    assert lime.sum() > 50 and not ((plain[..., 1] > 180) & (plain[..., 0] < 80) & (plain[..., 2] < 80)).any()
    with pytest.raises(ValueError, match="one entry per run frame"):
        render_summary(run, tmp_path / "bad.png", truth=truth[:2])


def test_scan_records_and_static_points() -> None:
    topics: list[str] = ["/a"]
    rec = scan_records(4, {"/b": (np.array([[1.0, 2.0], [np.nan, 0.0]]), np.array([True, False]))}, topics)
    assert topics == ["/a", "/b"] and len(rec) == 1 and rec.itemsize == 10
    assert (rec["frame"][0], rec["laser"][0], rec["static"][0]) == (4, 1, 1)
    m = StaticClutterMap()
    wall = np.column_stack((np.full(40, 3.0), np.linspace(-1.0, 1.0, 40)))
    for _ in range(40):  # 4 s of the same wall at 10 Hz: static (static_time 2 s)
        m.update(wall, dt=0.1)
    st = m.static_points(np.vstack((wall, [[1.5, 0.0], [np.nan, np.nan]])))
    assert st[:40].mean() > 0.9 and not st[40] and not st[41]


def test_a_run_writes_its_scans_unless_told_not_to(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Scan matching fails on this scene (leg circles only), so the map restarts every frame and calls nothing
    # static; the map's answer is replaced to see it reach scans.npy through the front end.
    monkeypatch.setattr(StaticClutterMap, "static_points", lambda self, pts: np.arange(len(pts)) % 2 == 0)
    bag = tmp_path / "s.bag"
    write_scan_bag(bag, 30)
    with BagSource(bag) as src:
        Pipeline(legs_only(), front_process=False).run(src, tmp_path / "run", max_frames=30)
    run = load_run(tmp_path / "run")
    assert run.scan_topics == ["/scan"] and run.scans is not None and run.particles is None
    per_frame = np.bincount(run.scans["frame"], minlength=30)
    assert per_frame.min() == per_frame.max() > 0  # identical scans: the same valid returns every frame
    pts = np.column_stack((run.scans["x"], run.scans["y"])).astype(float)
    assert np.all(np.hypot(*pts.T) < 10.0)  # the scan's valid returns (range_max 10 m), grid frame = laser frame
    assert 0 < run.scans["static"].mean() < 1  # the map's flags, with the invalid beams dropped
    sinks = {"sink_factory": lambda *a, **k: standard_sinks(*a, **k, scans=False)}
    cfg = legs_only(filter=FilterConfig(kind="particle", n_particles=3000))
    with BagSource(bag) as src:
        Pipeline(cfg, front_process=False, **sinks).run(src, tmp_path / "off", max_frames=3)
    assert not (tmp_path / "off" / "scans.npy").exists() and not (tmp_path / "off" / "particles.npy").exists()
    with BagSource(bag) as src:
        Pipeline(cfg, front_process=False).run(src, tmp_path / "pf", max_frames=3)
    parts = load_run(tmp_path / "pf").particles
    assert parts is not None and np.bincount(parts["frame"]).max() <= MAX_PARTICLES_SAVED and len(parts) > 0
    args = ["run", str(bag), "--driver", "/scan", "--max-frames", "2", "--no-progress", "--one-process"]
    assert main([*args, "--out", str(tmp_path / "cli"), "--no-scans"]) == 0
    assert not (tmp_path / "cli" / "scans.npy").exists() and load_run(tmp_path / "cli").n_frames == 2
