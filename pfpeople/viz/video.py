"""Encode rendered run frames: MP4 (H.264 through imageio-ffmpeg's ffmpeg) and GIF (imageio's pillow plugin).

MP4 frames are streamed to ffmpeg one at a time (memory does not grow with the run). A GIF is written for
small runs: its frames are kept in memory at half resolution until the end, so at most :data:`GIF_MAX_FRAMES`
frames are stored; longer selections keep every k-th frame (logged).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Generator, Sequence
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import imageio_ffmpeg
import numpy as np
from numpy.typing import NDArray

from pfpeople.progress import progress_bar
from pfpeople.viz.run_view import RunFrameRenderer

__all__ = ["GIF_MAX_FRAMES", "X264_PRESET", "write_animation"]

log = logging.getLogger(__name__)

#: Largest number of frames stored in a GIF (longer selections are subsampled).
GIF_MAX_FRAMES = 300
#: libx264's speed preset: on the frames of a run, "veryfast" encodes with half the CPU time of the default
#: ("medium") for a file 3 % larger at the same quality setting (``python -m evaluation.bench.view``).
X264_PRESET = "veryfast"


def write_animation(
    renderer: RunFrameRenderer,
    frames: Sequence[int],
    *,
    mp4: str | Path | None = None,
    gif: str | Path | None = None,
    progress: bool = True,
) -> dict[str, int]:
    """Render ``frames`` (run frame indices) and write them to ``mp4`` and/or ``gif``.

    Parameters
    ----------
    renderer : RunFrameRenderer
        Draws each frame; its ``options`` give the size and frame rate.
    frames : sequence of int
        Run frames to draw, in order.
    mp4, gif : path, optional
        Output files (at least one).
    progress : bool
        Show a progress bar (:func:`pfpeople.progress.progress_bar`).

    Returns
    -------
    dict
        ``{"mp4_frames": n, "gif_frames": m}`` (frames written to each file; 0 for a file not written).
    """
    if mp4 is None and gif is None:
        raise ValueError("write_animation needs an mp4 or a gif output path")
    frames = list(frames)
    if not frames:
        raise ValueError("write_animation: no frames selected")
    opts = renderer.options
    writer = _mp4_writer(mp4, opts.width_px, opts.height_px, opts.fps) if mp4 is not None else None
    stride = max(1, math.ceil(len(frames) / GIF_MAX_FRAMES)) if gif is not None else 1
    if gif is not None and stride > 1:
        log.info("GIF %s: %d frames selected, keeping every %d-th", gif, len(frames), stride)
    gif_frames: list[NDArray[np.uint8]] = []
    n_mp4 = 0
    try:
        for pos, k in enumerate(progress_bar(frames, desc="view", unit="frame", disable=not progress)):
            image = renderer.render(k)
            if writer is not None:
                writer.send(image)
                n_mp4 += 1
            if gif is not None and pos % stride == 0:
                gif_frames.append(image[::2, ::2].copy())
    finally:
        if writer is not None:
            writer.close()
    if gif is not None:
        _write_gif(gif, gif_frames, 1000.0 * stride / opts.fps)
    return {"mp4_frames": n_mp4, "gif_frames": len(gif_frames)}


def _mp4_writer(mp4: str | Path, width_px: int, height_px: int, fps: float) -> Generator[None, Any, None]:
    """A started imageio-ffmpeg writer of ``mp4`` (its folder created): H.264 (:data:`X264_PRESET`), yuv420p,
    quality 7.

    Parameters
    ----------
    mp4 : path
        The output file.
    width_px, height_px : int
        The frame size (pixels).
    fps : float
        The frame rate (frames per second).

    Returns
    -------
    generator
        ``send`` each frame (RGB uint8, ``(height_px, width_px, 3)``) to it, then ``close`` it.
    """
    Path(mp4).parent.mkdir(parents=True, exist_ok=True)
    writer = imageio_ffmpeg.write_frames(
        str(mp4),
        (width_px, height_px),
        fps=fps,
        codec="libx264",
        pix_fmt_out="yuv420p",
        macro_block_size=1,
        quality=7,
        output_params=["-preset", X264_PRESET],
    )
    writer.send(None)
    return writer


def _write_gif(gif: str | Path, frames: list[NDArray[np.uint8]], duration_ms: float) -> None:
    """Write ``frames`` (RGB uint8 images of one shape) to ``gif`` (its folder created), each shown
    ``duration_ms`` ms, looping."""
    Path(gif).parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(gif, np.stack(frames), plugin="pillow", duration=duration_ms, loop=0)
