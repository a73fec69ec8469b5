"""Replay of real pedestrian trajectories from the ETH/BIWI and UCY datasets (``obsmat.txt``).

Sources (see ``../shared/data/MANIFEST.md``): ETH/BIWI, Pellegrini et al., ICCV 2009; UCY, Lerner et al.,
"Crowds by Example", 2007; files as distributed by crowdbotp/OpenTraj. Research use; not vendored.

``obsmat.txt`` holds one row per observation: ``frame ped_id pos_x pos_z pos_y v_x v_z v_y`` (metres, m/s,
top view; the z columns are 0). Frames are video frame numbers annotated every 0.4 s (ETH every 6 frames,
UCY every 10), so time is ``t = (frame - first_frame) * 0.4 / frame_step`` where ``frame_step`` is the
most common gap between consecutive annotations of one person. World positions are ``(pos_x, pos_y)``.
A person exists from their first to their last observation; in between the position is interpolated
linearly to the simulator's frame times (a person seen once exists only at that instant).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from evaluation.scenarios.tracks import Track

__all__ = [
    "ANNOTATION_PERIOD_S",
    "DataNotFoundError",
    "default_data_root",
    "load_obsmat",
    "load_tracks",
]

#: Time between two annotations in ETH/UCY (s).
ANNOTATION_PERIOD_S = 0.4


class DataNotFoundError(FileNotFoundError):
    """The real-data folder (``../shared/data`` by default) is not there."""


def default_data_root() -> Path:
    """Folder holding ``eth_ucy/``: ``$PFPEOPLE_DATA`` if set, else ``../shared/data`` next to the repo."""
    env = os.environ.get("PFPEOPLE_DATA")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2].parent / "shared" / "data"


def _obsmat_path(sequence: str, data_root: str | os.PathLike[str] | None) -> Path:
    root = Path(data_root) if data_root is not None else default_data_root()
    path = root / "eth_ucy" / sequence / "obsmat.txt"
    if not path.is_file():
        raise DataNotFoundError(
            f"ETH/UCY sequence {sequence!r} not found: {path} does not exist (the real data lives in "
            "../shared/data/eth_ucy; pass data_root or set PFPEOPLE_DATA)"
        )
    return path


def load_obsmat(path: str | os.PathLike[str]) -> NDArray[np.float64]:
    """Read an ``obsmat.txt`` table, shape (N, 8); raise naming the file when it is malformed."""
    path = Path(path)
    if not path.is_file():
        raise DataNotFoundError(f"obsmat file not found: {path}")
    try:
        table = np.loadtxt(path, dtype=float, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{path}: not a numeric obsmat table ({exc})") from exc
    if table.shape[1] != 8:
        raise ValueError(f"{path}: expected 8 columns (frame ped_id x z y vx vz vy), got {table.shape[1]}")
    if not np.all(np.isfinite(table)):
        raise ValueError(f"{path}: contains NaN or infinite values")
    return table


def load_tracks(
    sequence: str = "seq_eth",
    *,
    data_root: str | os.PathLike[str] | None = None,
    annotation_period: float = ANNOTATION_PERIOD_S,
) -> list[Track]:
    """Load one ETH/UCY sequence as world tracks.

    Parameters
    ----------
    sequence : str
        Folder name under ``<data_root>/eth_ucy`` (``seq_eth``, ``seq_hotel``, ``zara01``).
    data_root : path, optional
        Folder holding ``eth_ucy/``; default :func:`default_data_root`.
    annotation_period : float
        Seconds between two annotations (0.4 s for ETH/UCY).

    Returns
    -------
    list of Track
        One per pedestrian id (``person_id`` = the dataset's ``ped_id``), time 0 at the sequence's first
        annotated frame, positions in metres in the dataset's world frame.

    Raises
    ------
    DataNotFoundError
        When the file is missing.
    """
    path = _obsmat_path(sequence, data_root)
    table = load_obsmat(path)
    frames = table[:, 0]
    ids = table[:, 1].astype(np.int64)
    order = np.lexsort((frames, ids))
    table, frames, ids = table[order], frames[order], ids[order]
    gaps = np.diff(frames)[(np.diff(ids) == 0)]
    gaps = gaps[gaps > 0]
    if gaps.size == 0:
        raise ValueError(f"{path}: no pedestrian is annotated twice; cannot infer the frame step")
    values, counts = np.unique(gaps, return_counts=True)
    frame_step = float(values[np.argmax(counts)])
    seconds_per_frame = annotation_period / frame_step
    t = (frames - frames.min()) * seconds_per_frame
    tracks = []
    for pid in np.unique(ids):
        rows = ids == pid
        tt = t[rows]
        if np.any(np.diff(tt) == 0):
            raise ValueError(f"{path}: pedestrian {pid} is annotated twice in the same frame")
        tracks.append(Track(int(pid), tt, table[rows][:, [2, 4]]))
    return tracks
