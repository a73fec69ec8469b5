"""The output of a run: a directory written frame by frame, so a run that stops part-way keeps its frames.

Format (``format = "pfpeople-run"``, ``version = 1``)::

    RUN_DIR/
      run.json        configuration, provenance, grid, detector models, status, statistics
      grids.npy       float32 array (N, nx, ny): the belief grid of every frame (grid frame, cell [i, j] as
                      GridSpec); a standard .npy whose header is rewritten after each frame, so
                      numpy.load(path, mmap_mode="r") reads the frames written so far at any time
      frames.csv      frame, driver_index, stamp_ns, bag_time_ns, dt_s, v_mps, omega_radps, odometry,
                      forced, n_people, no_data
      people.csv      frame, driver_index, stamp_ns, bag_time_ns, x_m, y_m, size_cells, mean_probability
      detections.csv  frame, driver_index, stamp_ns, bag_time_ns, detector, x_m, y_m

Positions are metres in the grid frame (REP-103; the grid frame is named in ``run.json``). ``frame`` counts
the frames of the run (0, 1, ...); ``driver_index`` is the index of the driving message on its topic (the
"scan index" of ground-truth files); ``stamp_ns`` the frame stamp used for synchronisation (header or bag
time, see ``run.json`` ``config.frames.time_source``); ``bag_time_ns`` the driver's record time. In
``frames.csv``, ``odometry`` is 1 when the step used odometry (0: the robot was taken as standing),
``forced`` is 1 when the frame was finalised before every topic caught up, and ``no_data`` lists (``;``)
the detectors that had no data in the frame (they covered no cell). ``status`` in ``run.json`` is
``"running"`` while a run writes, then ``"complete"`` or ``"failed"`` (with ``error``); the frames written
before a failure stay valid.
"""

from __future__ import annotations

import csv
import json
import math
import struct
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO, TextIO

import numpy as np
from numpy.typing import NDArray

from gridbridge.grid import GridSpec

__all__ = ["FORMAT", "FORMAT_VERSION", "RunData", "RunWriter", "load_run"]

FORMAT = "pfpeople-run"
FORMAT_VERSION = 1
_HEADER_BYTES = 128

FRAME_COLUMNS = (
    "frame",
    "driver_index",
    "stamp_ns",
    "bag_time_ns",
    "dt_s",
    "v_mps",
    "omega_radps",
    "odometry",
    "forced",
    "n_people",
    "no_data",
)
PEOPLE_COLUMNS = ("frame", "driver_index", "stamp_ns", "bag_time_ns", "x_m", "y_m", "size_cells", "mean_probability")
DETECTION_COLUMNS = ("frame", "driver_index", "stamp_ns", "bag_time_ns", "detector", "x_m", "y_m")


def _npy_header(n: int, nx: int, ny: int) -> bytes:
    body = f"{{'descr': '<f4', 'fortran_order': False, 'shape': ({n}, {nx}, {ny}), }}"
    body = body.ljust(_HEADER_BYTES - 11) + "\n"
    if len(body) != _HEADER_BYTES - 10:
        raise ValueError(f"grid shape ({n}, {nx}, {ny}) too large for the fixed .npy header")
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(body)) + body.encode("latin1")


def _json_default(obj: object) -> object:
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def _json_safe(value: Any) -> Any:
    """``value`` with every non-finite float written as a string (``"inf"``, ``"-inf"``, ``"nan"``): strict JSON."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return value


class RunWriter:
    """Write a run directory incrementally (see the module docstring).

    Parameters
    ----------
    out_dir : path
        The run directory (created; must not hold a run unless ``overwrite``).
    spec : GridSpec
        The grid.
    detector_names : sequence of str
        Detector names, in filter order.
    metadata : mapping
        Extra keys of ``run.json`` (configuration, provenance, grid frame, detector models ...).
    overwrite : bool
        Replace an existing run in ``out_dir``.
    """

    def __init__(
        self,
        out_dir: str | Path,
        *,
        spec: GridSpec,
        detector_names: Sequence[str],
        metadata: Mapping[str, Any] | None = None,
        overwrite: bool = False,
    ) -> None:
        self.path = Path(out_dir)
        if (self.path / "run.json").exists() and not overwrite:
            raise FileExistsError(f"output directory {str(self.path)!r} already holds a run (use overwrite)")
        self.path.mkdir(parents=True, exist_ok=True)
        self.spec = spec
        self.detector_names = list(detector_names)
        self.n_frames = 0
        self._t0 = time.perf_counter()
        self._meta: dict[str, Any] = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "status": "running",
            "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "grid": {"nx": spec.nx, "ny": spec.ny, "resolution": spec.resolution, "x0": spec.x0, "y0": spec.y0},
            "detectors": self.detector_names,
            **dict(metadata or {}),
            "frames": 0,
        }
        self._write_json()
        self._grids: BinaryIO = (self.path / "grids.npy").open("wb")
        self._grids.write(_npy_header(0, spec.nx, spec.ny))
        self._files: list[TextIO] = []
        self._frames = self._csv("frames.csv", FRAME_COLUMNS)
        self._people = self._csv("people.csv", PEOPLE_COLUMNS)
        self._dets = self._csv("detections.csv", DETECTION_COLUMNS)
        self._closed = False

    def _csv(self, name: str, columns: Sequence[str]) -> Any:
        fh = (self.path / name).open("w", newline="")
        self._files.append(fh)
        w = csv.writer(fh)
        w.writerow(columns)
        return w

    def _write_json(self) -> None:
        tmp = self.path / "run.json.tmp"
        tmp.write_text(json.dumps(_json_safe(self._meta), indent=2, default=_json_default) + "\n")
        tmp.replace(self.path / "run.json")

    def __enter__(self) -> RunWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if exc is None:
            self.close(status="complete")
        else:
            self.close(status="failed", error=f"{type(exc).__name__}: {exc}")

    def write_frame(
        self,
        *,
        frame: int,
        driver_index: int,
        stamp_ns: int,
        bag_time_ns: int,
        dt_s: float,
        odometry: tuple[float, float] | None,
        forced: bool,
        belief: NDArray[np.float64],
        people: NDArray[np.float64],
        people_size: Sequence[int] = (),
        people_probability: Sequence[float] = (),
        detections: Sequence[NDArray[np.float64] | None],
    ) -> None:
        """Append one frame to every file and flush (see the module docstring for the columns)."""
        if self._closed:
            raise RuntimeError("RunWriter is closed")
        belief = self.spec.check_grid(belief, "belief")
        if len(detections) != len(self.detector_names):
            raise ValueError(f"detections must have {len(self.detector_names)} entries, got {len(detections)}")
        people = np.asarray(people, dtype=float).reshape(-1, 2)
        sizes = list(people_size) or [0] * len(people)
        probs = list(people_probability) or [math.nan] * len(people)
        key = (frame, driver_index, stamp_ns, bag_time_ns)
        no_data = [n for n, d in zip(self.detector_names, detections, strict=True) if d is None]
        v, w = odometry if odometry is not None else (0.0, 0.0)
        self._frames.writerow(
            (
                *key,
                f"{dt_s:.9g}",
                f"{v:.9g}",
                f"{w:.9g}",
                int(odometry is not None),
                int(forced),
                len(people),
                ";".join(no_data),
            )
        )
        for (x, y), size, p in zip(people, sizes, probs, strict=True):
            self._people.writerow((*key, f"{x:.6f}", f"{y:.6f}", int(size), f"{p:.6g}"))
        for name, det in zip(self.detector_names, detections, strict=True):
            if det is None:
                continue
            for x, y in np.asarray(det, dtype=float).reshape(-1, 2):
                self._dets.writerow((*key, name, f"{x:.6f}", f"{y:.6f}"))
        self._grids.write(belief.astype("<f4").tobytes())
        self.n_frames += 1
        end = self._grids.tell()
        self._grids.seek(0)
        self._grids.write(_npy_header(self.n_frames, self.spec.nx, self.spec.ny))
        self._grids.seek(end)
        self._grids.flush()
        for fh in self._files:
            fh.flush()

    def update(self, **items: Any) -> None:
        """Add or replace keys of ``run.json`` (written at once)."""
        self._meta.update(items)
        self._write_json()

    def close(self, *, status: str = "complete", error: str | None = None, **items: Any) -> None:
        """Close the files and record the final status (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._grids.close()
        for fh in self._files:
            fh.close()
        elapsed = time.perf_counter() - self._t0
        self._meta.update(items)
        self._meta.update(status=status, frames=self.n_frames, elapsed_s=round(elapsed, 3))
        if error is not None:
            self._meta["error"] = error
        self._write_json()


@dataclass(frozen=True, eq=False)
class RunData:
    """A run read back: ``grids`` (N, nx, ny) memory-mapped, tables as dicts of column arrays."""

    path: Path
    meta: dict[str, Any]
    grids: NDArray[np.float32]
    frames: dict[str, NDArray[Any]]
    people: dict[str, NDArray[Any]]
    detections: dict[str, NDArray[Any]]

    @property
    def spec(self) -> GridSpec:
        return GridSpec(**self.meta["grid"])

    @property
    def n_frames(self) -> int:
        return int(self.grids.shape[0])


_INT_COLS = {"frame", "driver_index", "stamp_ns", "bag_time_ns", "odometry", "forced", "n_people", "size_cells"}
_STR_COLS = {"detector", "no_data"}


def _read_csv(path: Path, columns: Sequence[str]) -> dict[str, NDArray[Any]]:
    if not path.is_file():
        raise FileNotFoundError(f"run file {str(path)!r} is missing")
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or tuple(rows[0]) != tuple(columns):
        raise ValueError(f"run file {str(path)!r}: expected columns {list(columns)}, got {rows[:1]}")
    body = rows[1:]
    out: dict[str, NDArray[Any]] = {}
    for k, name in enumerate(columns):
        vals = [r[k] for r in body]
        if name in _STR_COLS:
            out[name] = np.array(vals, dtype=object)
        elif name in _INT_COLS:
            out[name] = np.array(vals, dtype=np.int64).reshape(-1)
        else:
            out[name] = np.array(vals, dtype=float).reshape(-1)
    return out


def load_run(path: str | Path) -> RunData:
    """Read a run directory (also one whose run failed part-way: the frames written are returned)."""
    path = Path(path)
    meta_path = path / "run.json"
    if not meta_path.is_file():
        raise FileNotFoundError(f"{str(path)!r} is not a run directory (no run.json)")
    meta = json.loads(meta_path.read_text())
    if meta.get("format") != FORMAT:
        raise ValueError(f"{str(meta_path)!r} is not a {FORMAT} file (format={meta.get('format')!r})")
    if meta.get("version") != FORMAT_VERSION:
        raise ValueError(f"{str(meta_path)!r}: unsupported version {meta.get('version')!r}")
    grids = np.load(path / "grids.npy", mmap_mode="r")
    frames = _read_csv(path / "frames.csv", FRAME_COLUMNS)
    n = min(len(grids), len(frames["frame"]))
    frames = {k: v[:n] for k, v in frames.items()}
    people = _read_csv(path / "people.csv", PEOPLE_COLUMNS)
    dets = _read_csv(path / "detections.csv", DETECTION_COLUMNS)
    keep_p = people["frame"] < n
    keep_d = dets["frame"] < n
    return RunData(
        path=path,
        meta=meta,
        grids=grids[:n],
        frames=frames,
        people={k: v[keep_p] for k, v in people.items()},
        detections={k: v[keep_d] for k, v in dets.items()},
    )
