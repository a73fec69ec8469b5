"""``pfpeople view RUN``: an animation (MP4, GIF) and a summary page of a run directory.

Examples::

    pfpeople view runs/pf1                                   # runs/pf1/view.mp4 and runs/pf1/summary.png
    pfpeople view runs/pf1 --frames 100:300 --fps 5 --out pf1.mp4
    pfpeople view runs/pf1 --gt person_following_outdoor_1_gt.csv --gif
    pfpeople view runs/pf1 --out pf1.gif --size 640x480       # a GIF only

What is drawn: see :mod:`pfpeople.viz.run_view`: the belief, every laser's scan (``scans.npy``, static returns
grey), the particles of a particle run, each detector's detections, people, tracks (when the run has a
``tracks.csv``), ground truth (``--gt``, also counted per frame in the summary). The video plays in real time by
default (the run's median frame rate); its frames are 640 pixels high and as wide as the grid needs. A GIF
(half resolution) is written besides the MP4 with ``--gif``, and for short selections (at most
:data:`SMALL_RUN_FRAMES` frames) unless ``--no-gif``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from pfpeople.cli.support import examples
from pfpeople.io.ground_truth import read_gt_csv, resolve_gt_frame, truth_per_frame
from pfpeople.io.run_dir import RunData, load_run

#: Selections of at most this many frames also get a GIF (unless --no-gif).
SMALL_RUN_FRAMES = 100


def parse_frames(text: str, n_frames: int, *, run: str = "the run") -> range:
    """``--frames A:B`` (half-open, either end may be omitted; ``A`` alone is one frame) -> a range of frames.

    Raises
    ------
    ValueError
        For text that is not ``A:B`` with integers, or a range outside ``0..n_frames``; the message names
        the option and the run's frame count.
    """
    parts = text.split(":")
    if len(parts) > 2:
        raise ValueError(f"--frames {text!r}: expected A:B (run frames, B excluded), A: or :B")
    try:
        a = int(parts[0]) if parts[0].strip() else 0
        b = (int(parts[1]) if parts[1].strip() else n_frames) if len(parts) == 2 else a + 1
    except ValueError:
        raise ValueError(f"--frames {text!r}: A and B must be integers (run frames, B excluded)") from None
    if not (0 <= a < b <= n_frames):
        raise ValueError(
            f"--frames {text!r} is outside {run}, which has {n_frames} frames (valid: 0 <= A < B <= {n_frames})"
        )
    return range(a, b)


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WIDTHxHEIGHT in pixels, e.g. 960x640") from None
    return w, h


def _check_run(run: RunData) -> None:
    if run.n_frames == 0:
        raise ValueError(
            f"run {str(run.path)!r} has no frames (grids.npy / frames.csv are empty; run.json status "
            f"{run.meta.get('status')!r})"
        )


def _run(args: argparse.Namespace) -> int:
    # Drawing and encoding libraries are imported here, not when the CLI builds its parser for every command.
    from pfpeople.viz.run_view import RunFrameRenderer, ViewOptions, default_fps, fit_size, read_tracks
    from pfpeople.viz.summary import render_summary
    from pfpeople.viz.video import write_animation

    run_dir = Path(args.run)
    if not run_dir.is_dir():
        raise FileNotFoundError(f"run directory {str(run_dir)!r} does not exist")
    run = load_run(run_dir)
    _check_run(run)
    frames = parse_frames(args.frames, run.n_frames, run=f"run {str(run_dir)!r}") if args.frames else None
    frames = frames or range(run.n_frames)
    if args.fps is not None and not args.fps > 0:
        raise ValueError(f"--fps must be positive, got {args.fps}")
    w, h = args.size or fit_size(run.spec)
    options = ViewOptions(width_px=w + w % 2, height_px=h + h % 2, dpi=args.dpi, fps=args.fps or default_fps(run))
    tracks_path = Path(args.tracks) if args.tracks else run_dir / "tracks.csv"
    if args.tracks and not tracks_path.is_file():
        raise FileNotFoundError(f"--tracks {str(tracks_path)!r} does not exist")
    tracks = read_tracks(tracks_path) if tracks_path.is_file() else None
    truth = None
    if args.gt:
        gt = read_gt_csv(args.gt, frame=args.gt_frame)
        frame = resolve_gt_frame(gt, args.gt_frame)
        truth, unassigned = truth_per_frame(run, gt, frame=frame)
        print(f"ground truth {args.gt}: {len(gt)} rows in frame {frame!r}, {unassigned} on no run frame")
    if not args.no_summary:
        out_png = args.summary or run_dir / "summary.png"
        summary = render_summary(run, out_png, tracks=tracks, truth=truth, dpi=args.dpi)
        print(f"summary -> {summary}")
    if args.no_video:
        return 0
    out = Path(args.out) if args.out else run_dir / "view.mp4"
    if out.suffix.lower() not in (".mp4", ".gif"):
        raise ValueError(f"--out {str(out)!r}: the file must end in .mp4 or .gif")
    mp4 = out if out.suffix.lower() == ".mp4" else None
    gif = out if mp4 is None else None
    if mp4 is not None and not args.no_gif and (args.gif or len(frames) <= SMALL_RUN_FRAMES):
        gif = out.with_suffix(".gif")
    renderer = RunFrameRenderer(run, options=options, tracks=tracks, truth=truth)
    counts = write_animation(renderer, frames, mp4=mp4, gif=gif, progress=not args.no_progress)
    span = f"frames {frames.start}..{frames.stop - 1}"
    for path, n in ((mp4, counts["mp4_frames"]), (gif, counts["gif_frames"])):
        if path is not None:
            print(f"{n} frames ({span}) at {options.fps:g} fps, {options.width_px}x{options.height_px} px -> {path}")
    return 0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "view",
        epilog=examples(
            "pfpeople view runs/my",
            "pfpeople view runs/pf1 --gt person_following_outdoor_1_gt.csv --frames 0:100 --gif",
        ),
        help="animate a run directory (MP4/GIF) and draw a summary page (PNG)",
        description=(
            "Animate a run written by 'pfpeople run': belief grid, every laser's scan (static returns grey), "
            "particles (particle runs), each detector's detections, classified people, tracks (tracks.csv), "
            "ground truth (--gt), the ego-motion source (odometry, scan matching or none), frame counter and "
            "time. Also writes a one-page summary PNG (people, true people with --gt, and detections over time, "
            "belief histogram)."
        ),
    )
    p.add_argument("run", help="run directory (run.json, grids.npy, frames.csv, ...)")
    p.add_argument("--out", help="video file, .mp4 or .gif (default: RUN/view.mp4)")
    p.add_argument("--frames", metavar="A:B", help="run frames A (included) to B (excluded); A: or :B")
    p.add_argument(
        "--fps", type=float, help="frames per second of the video (default: the run's median frame rate, real time)"
    )
    p.add_argument("--dpi", type=float, default=100.0, help="drawing resolution (default: %(default)s)")
    p.add_argument(
        "--size", type=_size, metavar="WxH", help="frame size in pixels (default: 640 high, as wide as the grid needs)"
    )
    p.add_argument("--gt", help="ground-truth CSV to draw (see pfpeople.io.ground_truth)")
    p.add_argument("--gt-frame", help="frame of the --gt positions (default: its columns' x_<frame>_m, else grid)")
    p.add_argument("--tracks", help="tracks CSV (default: RUN/tracks.csv when present)")
    p.add_argument("--gif", action="store_true", help="also write a GIF (RUN/view.gif) whatever the length")
    p.add_argument("--no-gif", action="store_true", help=f"no GIF even for short runs (<= {SMALL_RUN_FRAMES} frames)")
    p.add_argument("--summary", help="summary PNG path (default: RUN/summary.png)")
    p.add_argument("--no-summary", action="store_true", help="no summary PNG")
    p.add_argument("--no-video", action="store_true", help="only the summary PNG")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_run)
