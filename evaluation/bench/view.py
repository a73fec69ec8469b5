"""Benchmark of ``pfpeople view``: frames per second of drawing a run and of writing its MP4, against a baseline.

The run drawn is ``--run RUN`` or, by default, the 3-laser real bag ``negative_2`` (three 768-beam lasers, nine
detectors, tracks) run once into ``--work`` with the starter configuration of ``pfpeople inspect BAG
--write-config`` (``--max-frames`` frames). Each worker process (``--worker``) loads the run, builds
:class:`pfpeople.viz.run_view.RunFrameRenderer` at the size ``pfpeople view`` picks (:func:`fit_size`) with the
run's tracks, draws the frames once to warm up, then measures, over the same frames:

- ``render fps``: :meth:`RunFrameRenderer.render` alone (the RGB image of each frame);
- ``mp4 fps``: :func:`pfpeople.viz.video.write_animation` to an MP4 (drawing and H.264 encoding, what
  ``pfpeople view`` does), with the CPU seconds of the worker and of its ffmpeg per frame.

With ``--baseline REV`` (default ``main``; ``none`` skips it) the same worker also runs with the packages of
revision ``REV`` (:func:`evaluation.bench.release_baseline.run_worker`), interleaved with this checkout's runs
(``--repeat`` rounds), and the table shows the same-run ratio ``this / baseline`` of the medians::

    python -m evaluation.bench.view [--run RUN] [--max-frames 200] [--frames 120] [--repeat 3] [--baseline main]
    python -m evaluation.bench.view --worker --run RUN --frames 120 --out OUT.mp4

Wall-clock figures depend on the machine (and its load); tests never assert them.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from evaluation.bench.release_baseline import REPO, release_checkout, run_worker

#: The 3-laser bag drawn by default (``--data`` holds ``leg_tracker/``).
BAG = "leg_tracker/negative_2.bag"


def _worker(run_dir: Path, n_frames: int, out: Path) -> dict[str, Any]:
    """Draw ``n_frames`` frames of ``run_dir`` (render alone, then render + MP4); frames per second of each."""
    import resource

    from pfpeople.io.run_dir import load_run
    from pfpeople.viz.run_view import RunFrameRenderer, ViewOptions, fit_size, read_tracks
    from pfpeople.viz.video import write_animation

    run = load_run(run_dir)
    w, h = fit_size(run.spec)
    tracks = read_tracks(run_dir / "tracks.csv") if (run_dir / "tracks.csv").is_file() else None
    renderer = RunFrameRenderer(run, options=ViewOptions(width_px=w, height_px=h, fps=7.5), tracks=tracks)
    frames = range(min(n_frames, run.n_frames))
    for k in frames[:5]:
        renderer.render(k)  # warm-up: fonts, caches
    t0 = time.perf_counter()
    for k in frames:
        renderer.render(k)
    render_s = time.perf_counter() - t0
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    c0, t0 = time.process_time(), time.perf_counter()
    write_animation(renderer, frames, mp4=out, progress=False)
    mp4_s = time.perf_counter() - t0
    cpu_s = time.process_time() - c0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    ffmpeg_s = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    n = len(frames)
    return {
        "frames": n,
        "size": f"{w}x{h}",
        "render_fps": n / render_s,
        "mp4_fps": n / mp4_s,
        "cpu_ms": 1e3 * cpu_s / n,
        "ffmpeg_ms": 1e3 * ffmpeg_s / n,
    }


def _make_run(data: Path, work: Path, max_frames: int) -> Path:
    """Run the default bag once into ``work`` (starter config of ``pfpeople inspect``); reused when present."""
    run_dir = work / f"negative_2_{max_frames}"
    if (run_dir / "run.json").is_file() and (run_dir / "tracks.csv").is_file():
        return run_dir
    bag = data / BAG
    if not bag.is_file():
        raise SystemExit(f"{bag} is missing: give --data (holding {BAG}) or --run RUN")
    work.mkdir(parents=True, exist_ok=True)
    cli = [sys.executable, "-m", "pfpeople.cli"]
    config = work / "negative_2.toml"
    subprocess.run([*cli, "inspect", str(bag), "--write-config", str(config), "--overwrite"], check=True)
    run = [*cli, "run", str(bag), "--config", str(config), "--out", str(run_dir), "--overwrite"]
    subprocess.run([*run, "--max-frames", str(max_frames)], check=True)
    return run_dir


def _median(rows: list[dict[str, Any]], key: str) -> float:
    return statistics.median(r[key] for r in rows)


def _table(results: dict[str, list[dict[str, Any]]]) -> list[str]:
    """The table: per code, the medians of the rounds, and the ratio to the baseline."""
    lines = [f"{'code':<18} {'frames':>6} {'size':>9} {'render fps':>10} {'mp4 fps':>8} {'cpu ms':>7} {'ffmpeg ms':>9}"]
    for name, rows in results.items():
        lines.append(
            f"{name:<18} {rows[0]['frames']:>6} {rows[0]['size']:>9} {_median(rows, 'render_fps'):>10.1f} "
            f"{_median(rows, 'mp4_fps'):>8.1f} {_median(rows, 'cpu_ms'):>7.1f} {_median(rows, 'ffmpeg_ms'):>9.1f}"
        )
    if len(results) == 2:
        this, base = results.values()
        render = _median(this, "render_fps") / _median(base, "render_fps")
        mp4 = _median(this, "mp4_fps") / _median(base, "mp4_fps")
        lines.append(f"{'this / baseline':<18} {'':>6} {'':>9} {render:>9.2f}x {mp4:>7.2f}x")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--run", type=Path, help="run directory to draw (default: negative_2, run into --work)")
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data", help="the shared recordings")
    parser.add_argument("--work", type=Path, default=REPO / ".bench" / "view", help="where the default run goes")
    parser.add_argument("--max-frames", type=int, default=200, help="frames of the default run (default 200)")
    parser.add_argument("--frames", type=int, default=120, help="frames drawn per measurement (default 120)")
    parser.add_argument("--repeat", type=int, default=3, help="rounds, each code once a round (default 3)")
    parser.add_argument("--baseline", default="main", help="git revision to compare with ('none': skip)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(_worker(args.run, args.frames, args.out)))
        return 0
    run_dir = args.run or _make_run(args.data, args.work, args.max_frames)
    codes: dict[str, Path] = {"this checkout": REPO}
    if args.baseline != "none":
        codes[f"baseline {args.baseline}"] = release_checkout(args.baseline)
    results: dict[str, list[dict[str, Any]]] = {name: [] for name in codes}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeat):
            for name, root in codes.items():
                out = Path(tmp) / f"{r}_{len(results[name])}.mp4"
                worker_args = ["--worker", "--run", str(run_dir.resolve()), "--frames", str(args.frames)]
                results[name].append(run_worker(root, "evaluation.bench.view", [*worker_args, "--out", str(out)]))
    print(f"pfpeople view of {run_dir} ({args.repeat} rounds, medians)")
    print("\n".join(_table(results)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
