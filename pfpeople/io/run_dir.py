"""The output of a run: a directory written frame by frame, so a run that stops part-way keeps its frames.

Format (``format = "pfpeople-run"``, ``version = 1``)::

    RUN_DIR/
      run.json        configuration, provenance, grid, detector models, status, statistics
      grids.npy       float32 array (N, nx, ny): the belief grid of every frame (grid frame, cell [i, j] as
                      GridSpec); a standard .npy whose header is rewritten after each frame, so
                      numpy.load(path, mmap_mode="r") reads the frames written so far at any time
      frames.csv      frame, driver_index, stamp_ns, bag_time_ns, dt_s, v_mps, omega_radps, vy_mps,
                      odometry, forced, n_people, no_data
      people.csv      frame, driver_index, stamp_ns, bag_time_ns, x_m, y_m, size_cells, mean_probability
      detections.csv  frame, driver_index, stamp_ns, bag_time_ns, detector, x_m, y_m, static
      tracks.csv      frame, stamp_ns, id, x, y, vx, vy, cov_xx, cov_xy, cov_yy, score   (when tracking is on)
      support.csv     frame, driver_index, stamp_ns, bag_time_ns, detector, x_m, y_m, static
                      (when the tracker is given support positions: the laser detectors' single legs)
      scans.npy       the laser returns of every frame in the grid frame (:data:`SCAN_DTYPE` records: frame,
                      laser, static, x, y; 10 bytes a return, about 7 kB a 720-beam scan); lasers named in
                      ``run.json`` ``scans.topics`` (written unless the run is told not to: ``--no-scans``)
      particles.npy   particle runs: at most :data:`MAX_PARTICLES_SAVED` particles a frame, a uniform subsample
                      (:data:`PARTICLE_DTYPE` records: frame, x, y; 8 bytes a particle, at most 16 kB a frame)

Positions are metres in the grid frame (REP-103; the grid frame is named in ``run.json``). ``frame`` counts
the frames of the run (0, 1, ...); ``driver_index`` is the index of the driving message on its topic (the
"scan index" of ground-truth files); ``stamp_ns`` the frame stamp used for synchronisation (header or bag
time, see ``run.json`` ``config.frames.time_source``); ``bag_time_ns`` the driver's record time. In
``frames.csv``, ``v_mps``, ``omega_radps`` and ``vy_mps`` are the ego-motion the filters got (forward speed, yaw
rate and lateral speed of the grid frame, :class:`gridbridge.Odometry`; runs written before ``vy_mps`` read
as 0), ``odometry`` is 1 when the step used odometry (0: the robot was taken as standing),
``forced`` is 1 when the frame was finalised before every topic caught up, and ``no_data`` lists (``;``)
the detectors that had no data in the frame (they covered no cell). In ``detections.csv`` every detection of
every detector is listed (each detector alone); ``static`` is 1 for those the static-clutter map suppressed
(:mod:`pfpeople.perception.clutter_map`): the filter did not see them (runs written before this column read as 0).
``people.csv`` holds the people the run reports (:mod:`pfpeople.track.reported_people`): with ``[tracking] people =
"confirmed"`` (the recommended mode) a coasting track reported through a missed frame has ``size_cells`` 0 and
the belief at its cell as ``mean_probability``. ``tracks.csv`` holds the confirmed tracks of :mod:`pfpeople.track`
(m, m/s, m^2, grid frame). ``support.csv`` lists every support position of every detector (the laser detectors'
unpaired single legs, :class:`pfpeople.detect.adapters.Detections`); the tracker got those with ``static`` 0.
``status`` in ``run.json`` is ``"running"`` while a run writes, then ``"complete"``, ``"failed"`` (with
``error``) or ``"interrupted"`` (SIGINT / SIGTERM, with ``error`` naming the signal); the frames written before
stay valid and ``frames`` is the number of frames on disk. ``scans.npy`` and ``particles.npy`` are standard
``.npy`` files of structured records grown like ``grids.npy`` (the header counts the complete rows), rows in
frame order; in ``scans.npy`` ``static`` is 1 for a return whose cell the laser's static-clutter map calls static
(:meth:`pfpeople.perception.clutter_map.StaticClutterMap.static_points`; 0 when the run has no map). Both are optional:
run directories written before them, or with ``--no-scans``, read with ``scans`` / ``particles`` None.

Safety against a second process and damage:

- A run directory is locked while it is written (``fcntl.flock`` on ``RUN_DIR/.lock``, released by the
  operating system when the process dies; not kept by a forked child; taken over, with a warning, when the pid
  holding it is dead: :mod:`pfpeople.io.locks`): a second writer, also with ``overwrite``, is refused
  (:class:`RunLockedError`). ``run.json`` is replaced atomically (a temporary file, fsync, ``os.replace``), with
  the permissions of the umask like every other file (0644 under umask 022).
- A directory that holds files but no ``run.json`` is never written into (they are the user's files), and gets no
  lock file: it is refused before anything is created. ``overwrite`` replaces exactly a run's own files
  (:data:`REPLACED_ON_OVERWRITE`: the run's tables and arrays, ``tracks.csv``, ``support.csv``, and the pictures
  ``pfpeople view`` made of it, ``view.mp4``, ``view.gif``, ``summary.png``) and keeps every other file.
- Nothing is written through a symbolic link: every file of the run is created anew (``O_EXCL | O_NOFOLLOW``), the
  lock file is opened without following a link (:mod:`pfpeople.io.locks`), and an output directory holding a link
  in place of one of the run's files is refused, naming it, before anything is changed. A dangling symbolic link
  given as the directory is refused naming where it points.
- Writing errors (a full disk, ``ENOSPC``) are re-raised naming the file; the frames before stay readable:
  :func:`load_run` reads the frames that every file holds completely (a half-written last row is dropped).
- :func:`interrupt_signals` turns SIGTERM into :class:`RunInterrupted` (as SIGINT is turned into
  ``KeyboardInterrupt``) so a run's ``finally`` blocks close its files; :meth:`RunWriter.write_frame` defers
  a signal arriving mid-frame until the frame is complete.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import signal
import struct
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import FrameType, TracebackType
from typing import IO, Any, BinaryIO, TextIO

import numpy as np
from numpy.typing import NDArray

from gridbridge.ego_motion import Odometry
from gridbridge.grid import GridSpec
from gridbridge.validation import finite_rows
from pfpeople.io import locks
from pfpeople.io.files import create_new, current_umask, named_os_error
from pfpeople.io.jsonio import dumps

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "MAX_PARTICLES_SAVED",
    "PARTICLE_DTYPE",
    "REPLACED_ON_OVERWRITE",
    "RUN_FILES",
    "SCAN_DTYPE",
    "RunData",
    "RunInterrupted",
    "RunLockedError",
    "RunWriter",
    "check_output_paths",
    "deferred_signals",
    "interrupt_signals",
    "load_run",
    "particle_records",
    "scan_records",
]

FORMAT = "pfpeople-run"
FORMAT_VERSION = 1
_HEADER_BYTES = 128
LOCK_NAME = ".lock"
#: The files a run directory holds (``--overwrite`` replaces exactly these).
RUN_FILES = ("run.json", "grids.npy", "frames.csv", "people.csv", "detections.csv", "scans.npy", "particles.npy")
#: One laser return of ``scans.npy`` (grid frame, m; ``laser`` indexes ``run.json`` ``scans.topics``).
SCAN_DTYPE = np.dtype([("frame", "<u4"), ("laser", "u1"), ("static", "u1"), ("x", "<f2"), ("y", "<f2")])
#: One particle of ``particles.npy`` (grid frame, m).
PARTICLE_DTYPE = np.dtype([("frame", "<u4"), ("x", "<f2"), ("y", "<f2")])
#: Most particles ``particles.npy`` keeps a frame (a uniform subsample of the filter's particles).
MAX_PARTICLES_SAVED = 2000
_RECORD_HEADER_BYTES = 256


class RunLockedError(locks.PathLockedError):
    """The run directory is being written by another process (its lock is held)."""


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by a signal (SIGINT or SIGTERM); ``signum`` is the signal, ``exit_code`` 128 + signum."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(f"interrupted by {signal.Signals(self.signum).name}")

    @property
    def exit_code(self) -> int:
        return 128 + self.signum


class _SignalState:
    depth = 0  # > 0 while a frame is being written: signals are deferred
    pending: int | None = None


_SIGNALS = _SignalState()


def _on_signal(signum: int, frame: FrameType | None) -> None:
    if _SIGNALS.depth > 0:
        _SIGNALS.pending = signum
        return
    raise RunInterrupted(signum)


@contextlib.contextmanager
def interrupt_signals() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`RunInterrupted` (deferred inside frame writes).

    Does nothing outside the main thread (Python delivers signals to the main thread only).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {sig: signal.signal(sig, _on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


@contextlib.contextmanager
def deferred_signals() -> Iterator[None]:
    _SIGNALS.depth += 1
    try:
        yield
    finally:
        _SIGNALS.depth -= 1
        if _SIGNALS.depth == 0 and _SIGNALS.pending is not None:
            signum, _SIGNALS.pending = _SIGNALS.pending, None
            raise RunInterrupted(signum)


#: The names a run directory's writer creates, replaces or locks in it.
RUN_OWNED = (*RUN_FILES, "tracks.csv", "support.csv", LOCK_NAME)
#: The pictures ``pfpeople view`` writes into a run directory by default (they show the run they were made of).
VIEW_FILES = ("view.mp4", "view.gif", "summary.png")
#: The files ``overwrite`` replaces: the previous run's own and its pictures (every other file is kept).
REPLACED_ON_OVERWRITE = (*RUN_FILES, "tracks.csv", "support.csv", *VIEW_FILES)


def _check_out_dir(path: Path) -> None:
    """Refuse an output directory path that is a file or a dangling symbolic link (``[Errno 17]`` from mkdir)."""
    if path.is_symlink() and not path.exists():
        raise FileExistsError(
            f"output directory {str(path)!r} is a symbolic link to {os.readlink(path)!r}, which does not exist; "
            "remove the link or create the directory it names"
        )
    if path.exists() and not path.is_dir():
        raise FileExistsError(f"output path {str(path)!r} exists and is not a directory")


def _overlaps(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` are the same file or folder, or one lies inside the other (symlinks resolved)."""
    ra, rb = a.resolve(), b.resolve()
    if ra == rb or ra in rb.parents or rb in ra.parents:
        return True
    try:
        return os.path.samefile(a, b)  # hard links
    except OSError:
        return False


def check_output_paths(
    inputs: Sequence[str | Path], *, out_dir: str | Path | None = None, bag_out: str | Path | None = None
) -> None:
    """Refuse outputs that would write over an input or over each other, before anything is opened or created.

    Every output (the run directory ``out_dir``, the result bag ``bag_out``) is compared with every input (bag
    files, bag folders, configuration files): resolved, so symlinks count, and as folders, so a path inside an
    input folder (or an output folder holding an input) counts as the input. ``bag_out`` must not be ``out_dir``,
    hold it, or be one of the run directory's own files (:data:`RUN_OWNED`).

    Raises
    ------
    ValueError
        Naming both paths.
    """
    outputs = [(f"output directory {str(out_dir)!r}", Path(out_dir))] if out_dir is not None else []
    if bag_out is not None:
        outputs.append((f"bag output {str(bag_out)!r}", Path(bag_out)))
    for label, out in outputs:
        for given in inputs:
            if _overlaps(out, Path(given)):
                raise ValueError(
                    f"{label} would write over the input {str(given)!r} (resolved: {str(out.resolve())!r} and "
                    f"{str(Path(given).resolve())!r}); choose an output outside the inputs"
                )
    if out_dir is None or bag_out is None:
        return
    run, bag = Path(out_dir).resolve(), Path(bag_out).resolve()
    if run == bag or bag in run.parents or (bag.parent == run and bag.name in RUN_OWNED):
        raise ValueError(
            f"bag output {str(bag_out)!r} conflicts with the output directory {str(out_dir)!r} "
            f"(resolved: {str(bag)!r} and {str(run)!r}); give the bag another path"
        )


FRAME_COLUMNS = (
    "frame",
    "driver_index",
    "stamp_ns",
    "bag_time_ns",
    "dt_s",
    "v_mps",
    "omega_radps",
    "vy_mps",
    "odometry",
    "forced",
    "n_people",
    "no_data",
)
#: The columns of run directories written before the ``vy_mps`` column (read with ``vy_mps = 0``).
_FRAME_COLUMNS_V1 = tuple(c for c in FRAME_COLUMNS if c != "vy_mps")
PEOPLE_COLUMNS = ("frame", "driver_index", "stamp_ns", "bag_time_ns", "x_m", "y_m", "size_cells", "mean_probability")
#: With an output frame (``[output] frame``, ``run.json`` ``output_frame``): the columns appended to ``frames.csv``
#: (the grid frame's pose in the output frame), ``people.csv`` and ``tracks.csv`` (positions, velocities and the
#: position covariance in the output frame); NaN where the pose was unknown.
OUT_FRAME_COLUMNS = ("out_x_m", "out_y_m", "out_yaw_rad")
OUT_PEOPLE_COLUMNS = ("out_x_m", "out_y_m")
OUT_TRACK_COLUMNS = ("out_x", "out_y", "out_vx", "out_vy", "out_cov_xx", "out_cov_xy", "out_cov_yy")
DETECTION_COLUMNS = ("frame", "driver_index", "stamp_ns", "bag_time_ns", "detector", "x_m", "y_m", "static")
#: The columns of run directories written before the ``static`` column (read with ``static = 0``).
_DETECTION_COLUMNS_V1 = DETECTION_COLUMNS[:-1]


def _odometry_row(odometry: Odometry | tuple[float, ...] | None) -> tuple[float, float, float]:
    """``(v_mps, omega_radps, vy_mps)`` of a frame's ego-motion for ``frames.csv`` (zeros for None)."""
    if odometry is None:
        return 0.0, 0.0, 0.0
    if isinstance(odometry, Odometry):
        return odometry.v, odometry.omega, odometry.vy
    if len(odometry) not in (2, 3):
        raise ValueError(f"odometry must be Odometry, (v, omega) or (v, omega, vy), got {odometry!r}")
    return float(odometry[0]), float(odometry[1]), float(odometry[2]) if len(odometry) == 3 else 0.0


def _npy_header(n: int, nx: int, ny: int) -> bytes:
    body = f"{{'descr': '<f4', 'fortran_order': False, 'shape': ({n}, {nx}, {ny}), }}"
    body = body.ljust(_HEADER_BYTES - 11) + "\n"
    if len(body) != _HEADER_BYTES - 10:
        raise ValueError(f"grid shape ({n}, {nx}, {ny}) too large for the fixed .npy header")
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(body)) + body.encode("latin1")


def _pwrite_all(fh: BinaryIO, data: bytes) -> None:
    """Write ``data`` at the start of the flushed file ``fh`` without moving its position (``os.pwrite``, again
    for the rest after a short write)."""
    fd, done = fh.fileno(), 0
    while done < len(data):
        done += os.pwrite(fd, data[done:], done)


class _RecordFile:
    """A ``.npy`` file of structured records (shape ``(n,)``) grown row by row; the header counts the rows written.

    Parameters
    ----------
    path : path
        The file (created, replacing one there).
    dtype : numpy.dtype
        The record type.
    """

    def __init__(self, path: Path, dtype: np.dtype[Any]) -> None:
        self.path, self.dtype, self.rows = path, dtype, 0
        self._descr = np.lib.format.dtype_to_descr(dtype)  # once: numpy builds it anew each call
        self.fh: BinaryIO = create_new(path, "wb")
        self.fh.write(self._header())

    def _header(self) -> bytes:
        body = f"{{'descr': {self._descr!r}, 'fortran_order': False, 'shape': ({self.rows},), }}"
        body = body.ljust(_RECORD_HEADER_BYTES - 11) + "\n"
        if len(body) != _RECORD_HEADER_BYTES - 10:
            raise ValueError(f"{self.rows} records too many for the fixed .npy header of {self.path.name}")
        return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(body)) + body.encode("latin1")

    def append(self, records: NDArray[Any]) -> None:
        """Write ``records`` (of :attr:`dtype`) and flush them, then the header that counts them (written in place
        by ``os.pwrite``, which leaves the file's position at its end)."""
        if not len(records):
            return
        self.fh.write(np.ascontiguousarray(records, dtype=self.dtype).data)
        self.fh.flush()
        self.rows += len(records)
        _pwrite_all(self.fh, self._header())


def scan_records(
    frame: int, scans: Mapping[str, tuple[NDArray[np.float64], NDArray[np.bool_] | None]], topics: list[str]
) -> NDArray[Any]:
    """The :data:`SCAN_DTYPE` records of one frame's ``scans`` (topic -> (points (N, 2), static (N,) or None));
    topics not in ``topics`` are appended to it (their ``laser`` index); non-finite points are dropped."""
    parts = []
    for topic, (pts, static) in scans.items():
        if topic not in topics:
            topics.append(topic)
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        ok = finite_rows(pts)
        every = bool(ok.all())  # the pipeline's scans hold finite points only: no copies then
        rec = np.zeros(pts.shape[0] if every else int(np.count_nonzero(ok)), dtype=SCAN_DTYPE)
        rec["frame"], rec["laser"] = frame, topics.index(topic)
        rec["x"], rec["y"] = (pts[:, 0], pts[:, 1]) if every else (pts[ok, 0], pts[ok, 1])
        if static is not None:
            flags = np.asarray(static, dtype=bool)
            rec["static"] = flags if every else flags[ok]
        parts.append(rec)
    if len(parts) == 1:  # one laser: its records as they are
        return parts[0]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=SCAN_DTYPE)


def particle_records(frame: int, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[Any]:
    """:data:`PARTICLE_DTYPE` records of at most :data:`MAX_PARTICLES_SAVED` of the particles ``(x, y)`` (a
    uniform subsample without replacement, seeded by ``frame``: the same run writes the same file)."""
    x, y = np.asarray(x, dtype=float).reshape(-1), np.asarray(y, dtype=float).reshape(-1)
    if len(x) <= MAX_PARTICLES_SAVED:
        rec = np.zeros(len(x), dtype=PARTICLE_DTYPE)
        rec["frame"], rec["x"], rec["y"] = frame, x, y
        return rec
    chosen = np.zeros(len(x), dtype=bool)  # distinct indices: their mask's ones are them sorted
    chosen[np.random.default_rng(frame).choice(len(x), MAX_PARTICLES_SAVED, replace=False)] = True
    idx = chosen.nonzero()[0]
    rec = np.zeros(len(idx), dtype=PARTICLE_DTYPE)
    rec["frame"], rec["x"], rec["y"] = frame, x[idx], y[idx]
    return rec


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
    output_frame : str
        The output frame (``[output] frame``): ``frames.csv`` and ``people.csv`` get the :data:`OUT_FRAME_COLUMNS`
        and :data:`OUT_PEOPLE_COLUMNS`, ``tracks.csv`` rows carry the :data:`OUT_TRACK_COLUMNS`, ``run.json``
        names it (``output_frame``); ``""``: none.
    """

    def __init__(
        self,
        out_dir: str | Path,
        *,
        spec: GridSpec,
        detector_names: Sequence[str],
        metadata: Mapping[str, Any] | None = None,
        overwrite: bool = False,
        output_frame: str = "",
    ) -> None:
        self.path = Path(out_dir)
        _check_out_dir(self.path)
        if self.path.is_dir():  # refused before anything (a lock file) is created
            locks.check_free(self.path / LOCK_NAME, f"output directory {str(self.path)!r}", RunLockedError)
            self._previous_files(overwrite)
        self.path.mkdir(parents=True, exist_ok=True)
        self._lock_fh: IO[str] | None = self._lock()
        try:
            for old in self._previous_files(overwrite):  # again under the lock
                old.unlink(missing_ok=True)
        except BaseException:
            self._unlock(remove_created=True)
            raise
        self.spec = spec
        self.detector_names = list(detector_names)
        self.output_frame = output_frame
        self.n_frames = 0
        self._t0 = time.perf_counter()
        self._meta: dict[str, Any] = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "status": "running",
            "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "pid": os.getpid(),
            "grid": {"nx": spec.nx, "ny": spec.ny, "resolution": spec.resolution, "x0": spec.x0, "y0": spec.y0},
            "detectors": self.detector_names,
            **dict(metadata or {}),
            **({"output_frame": output_frame} if output_frame else {}),
            "frames": 0,
        }
        self._files: list[TextIO] = []
        self._flushes: list[tuple[str, Callable[[], object]]] = []
        self._closed = False
        try:
            self._write_json()
            self._grids: BinaryIO = create_new(self.path / "grids.npy", "wb")
            self._grids.write(_npy_header(0, spec.nx, spec.ny))
            out = bool(output_frame)
            self._frames = self._csv("frames.csv", FRAME_COLUMNS + OUT_FRAME_COLUMNS * out)
            self._people = self._csv("people.csv", PEOPLE_COLUMNS + OUT_PEOPLE_COLUMNS * out)
            self._dets = self._csv("detections.csv", DETECTION_COLUMNS)
            self._tracks: Any = None
            self._support: Any = None
            self._scans: _RecordFile | None = None
            self._particles: _RecordFile | None = None
            self._scan_topics: list[str] = []
        except OSError as exc:
            self._unlock()
            raise named_os_error(exc, self.path) from exc

    def _previous_files(self, overwrite: bool) -> list[Path]:
        """The files of a previous run in the directory that ``overwrite`` replaces (see the module docstring).

        Raises
        ------
        FileExistsError
            The directory holds a run and ``overwrite`` is false; one of :data:`REPLACED_ON_OVERWRITE` is a symbolic
            link or not a file (naming it); or it holds other files and no ``run.json`` (naming up to 5 of them).
        """
        if (self.path / "run.json").exists() or (self.path / "run.json").is_symlink():
            if not overwrite:
                raise FileExistsError(
                    f"output directory {str(self.path)!r} already holds a run (replace it with --overwrite, or "
                    "overwrite=True from Python)"
                )
            old = []
            for name in REPLACED_ON_OVERWRITE:
                p = self.path / name
                if p.is_symlink():
                    raise FileExistsError(
                        f"output directory {str(self.path)!r}: {name!r} is a symbolic link (to {os.readlink(p)!r}): "
                        "not writing through it or removing it; remove it yourself or choose another directory"
                    )
                if p.exists() and not p.is_file():
                    raise FileExistsError(f"output directory {str(self.path)!r}: {name!r} is not a file: not replaced")
                if p.exists():
                    old.append(p)
            return old
        others = sorted(
            p.name for p in self.path.iterdir() if p.name != LOCK_NAME and not p.name.startswith(".run.json.")
        )
        if others:
            listing = ", ".join(others[:5]) + (", ..." if len(others) > 5 else "")
            raise FileExistsError(
                f"output directory {str(self.path)!r} is not empty and holds no run.json ({listing}): "
                "not writing into it; choose a new or empty directory"
            )
        return []

    def _lock(self) -> IO[str]:
        """Take the directory's lock (non-blocking, :func:`pfpeople.io.locks.acquire`); refuse when a live process
        holds it, take it over (with a warning) when the pid holding it is dead."""
        return locks.acquire(self.path / LOCK_NAME, f"output directory {str(self.path)!r}", RunLockedError)

    def _unlock(self, *, remove_created: bool = False) -> None:
        """Release the directory's lock and remove its file: a finished run directory holds no ``.lock``;
        ``remove_created`` (a refused run): only when this writer created it (a refused directory keeps nothing
        of the writer, and a lock file it found stays)."""
        if self._lock_fh is not None:
            remove = not remove_created or locks.created(self._lock_fh)
            locks.release(self._lock_fh, remove=self.path / LOCK_NAME if remove else None)
            self._lock_fh = None

    def _csv(self, name: str, columns: Sequence[str]) -> Any:
        fh = create_new(self.path / name, "w")
        self._files.append(fh)
        w = csv.writer(fh)
        w.writerow(columns)
        return w

    def _write_json(self) -> None:
        """Replace ``run.json`` atomically (temporary file in the directory, fsync, ``os.replace``)."""
        text = dumps(self._meta) + "\n"
        fd, tmp = tempfile.mkstemp(prefix=".run.json.", suffix=".tmp", dir=self.path)
        try:
            os.fchmod(fd, 0o666 & ~current_umask())  # mkstemp makes it 0600: give it the mode open() would
            with os.fdopen(fd, "w") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, self.path / "run.json")
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise named_os_error(exc, self.path / "run.json") from exc

    def __enter__(self) -> RunWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if exc is None:
            self.close(status="complete")
        elif isinstance(exc, KeyboardInterrupt):
            self.close(status="interrupted", error=str(exc) or "interrupted by SIGINT")
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
        odometry: Odometry | tuple[float, float] | tuple[float, float, float] | None,
        forced: bool,
        belief: NDArray[np.float64],
        people: NDArray[np.float64],
        people_size: Sequence[int] = (),
        people_probability: Sequence[float] = (),
        detections: Sequence[NDArray[np.float64] | None],
        tracks: Sequence[Sequence[Any]] | None = None,
        static: Sequence[NDArray[np.bool_] | None] | None = None,
        support: Sequence[NDArray[np.float64] | None] | None = None,
        support_static: Sequence[NDArray[np.bool_] | None] | None = None,
        scans: Mapping[str, tuple[NDArray[np.float64], NDArray[np.bool_] | None]] | None = None,
        particles: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
        output_pose: tuple[float, float, float] | None = None,
        people_out: NDArray[np.float64] | None = None,
    ) -> None:
        """Append one frame to every file and flush (see the module docstring for the columns).

        ``odometry``: the frame's ego-motion, an :class:`gridbridge.Odometry` or ``(v, omega[, vy])`` (m/s, rad/s,
        m/s; grid frame); None: the robot was taken as standing. ``static``: per detector, which of its detections
        the static-clutter map suppressed (column ``static``). ``tracks``: rows of ``tracks.csv``
        (:data:`pfpeople.track.TRACK_COLUMNS`; the file made at the first frame with them). ``support``,
        ``support_static``: per detector, its support positions and which of them the map called static
        (``support.csv``, made like ``tracks.csv``). ``scans``: per laser topic, its returns (m, grid frame) and
        which of them the map calls static (``scans.npy``; each topic in ``run.json`` ``scans.topics``).
        ``particles``: the filter's particles ``(x, y)`` (m, grid frame), subsampled into ``particles.npy``
        (:func:`particle_records`). With an ``output_frame``: ``output_pose`` (the grid frame's ``x, y, yaw``
        there) and ``people_out`` ``(P, 2)`` (None: unknown, NaN); ``tracks`` rows end with :data:`OUT_TRACK_COLUMNS`.
        """
        belief, people, sizes, probs = self._check_frame(belief, detections, people, people_size, people_probability)
        key = (frame, driver_index, stamp_ns, bag_time_ns)
        row = self._frames_row(key, dt_s, odometry, forced, len(people), detections)
        row, people_out = self._out_values(row, people, output_pose, people_out) if self.output_frame else (row, None)
        with deferred_signals():  # a signal arriving now is raised once the frame is complete on disk
            self._run_steps(
                [
                    ("frames.csv", lambda: self._frames.writerow(row)),
                    ("people.csv", lambda: self._write_people(key, people, sizes, probs, people_out)),
                    ("detections.csv", lambda: self._positions(self._dets, key, detections, static)),
                    ("support.csv", lambda: self._write_support(key, support, support_static)),
                    ("tracks.csv", lambda: self._write_tracks(tracks)),
                ]
            )
            self._run_steps(  # after the tables: support.csv and tracks.csv may have been created just now
                [
                    *self._flush_steps(),
                    ("scans.npy", lambda: self._write_scans(frame, scans) if scans is not None else None),
                    ("particles.npy", lambda: self._write_particles(frame, particles)),
                    ("grids.npy", lambda: self._append_grid(belief)),
                ]
            )
            self.n_frames += 1

    @staticmethod
    def _out_values(
        row: tuple[Any, ...],
        people: NDArray[np.float64],
        output_pose: tuple[float, float, float] | None,
        people_out: NDArray[np.float64] | None,
    ) -> tuple[tuple[Any, ...], NDArray[np.float64]]:
        """The frame's row with the output pose (NaN: unknown), and the people in the output frame (NaN: unknown)."""
        row = (*row, *(f"{v:.9g}" for v in (output_pose or (math.nan,) * 3)))
        return row, np.full_like(people, math.nan) if people_out is None else np.reshape(people_out, (-1, 2))

    def _flush_steps(self) -> list[tuple[str, Callable[[], object]]]:
        """The ``(file name, flush)`` steps of the tables, made anew only when a table was added."""
        if len(self._flushes) != len(self._files):
            self._flushes = [(os.path.basename(fh.name), fh.flush) for fh in self._files]
        return self._flushes

    def _check_frame(
        self,
        belief: NDArray[np.float64],
        detections: Sequence[NDArray[np.float64] | None],
        people: NDArray[np.float64],
        people_size: Sequence[int],
        people_probability: Sequence[float],
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], list[int], list[float]]:
        """Check :meth:`write_frame`'s inputs: the belief grid ``(nx, ny)``, one ``detections`` entry per detector.

        Returns
        -------
        belief : ndarray, shape (nx, ny)
        people : ndarray, shape (K, 2)
            The people positions (m, grid frame).
        sizes, probs : list
            Per person, its cells (default 0) and its probability (default NaN).

        Raises
        ------
        RuntimeError
            The writer is closed.
        ValueError
            A bad belief grid, or a ``detections`` of the wrong length.
        """
        if self._closed:
            raise RuntimeError("RunWriter is closed")
        belief = self.spec.check_grid(belief, "belief")
        if len(detections) != len(self.detector_names):
            raise ValueError(f"detections must have {len(self.detector_names)} entries, got {len(detections)}")
        people = np.asarray(people, dtype=float).reshape(-1, 2)
        sizes = list(people_size) or [0] * len(people)
        probs = list(people_probability) or [math.nan] * len(people)
        return belief, people, sizes, probs

    def _frames_row(
        self,
        key: tuple[int, int, int, int],
        dt_s: float,
        odometry: Odometry | tuple[float, ...] | None,
        forced: bool,
        n_people: int,
        detections: Sequence[NDArray[np.float64] | None],
    ) -> tuple[Any, ...]:
        """The frame's row of ``frames.csv`` (:data:`FRAME_COLUMNS`): ``key``, ``dt_s`` and the odometry as
        ``%.9g``, whether it had odometry, ``forced``, ``n_people`` and the detectors without data (``;``-joined)."""
        no_data = [n for n, d in zip(self.detector_names, detections, strict=True) if d is None]
        v, w, vy = _odometry_row(odometry)
        flags = (int(odometry is not None), int(forced), n_people, ";".join(no_data))
        return (*key, f"{dt_s:.9g}", f"{v:.9g}", f"{w:.9g}", f"{vy:.9g}", *flags)

    def _run_steps(self, steps: Sequence[tuple[str, Callable[[], object]]]) -> None:
        """Run each ``(file name, step)`` in order; an ``OSError`` is re-raised naming the file (not the path: this
        runs every frame)."""
        for name, step in steps:
            try:
                step()
            except OSError as exc:
                raise named_os_error(exc, self.path / name) from exc

    def _write_people(
        self,
        key: tuple[int, int, int, int],
        people: NDArray[np.float64],
        sizes: list[int],
        probs: list[float],
        people_out: NDArray[np.float64] | None = None,
    ) -> None:
        rows: list[tuple[Any, ...]] = [
            (*key, f"{x:.6f}", f"{y:.6f}", int(size), f"{p:.6g}")
            for (x, y), size, p in zip(people.tolist(), sizes, probs, strict=True)
        ]
        if people_out is not None:
            rows = [(*r, f"{x:.6f}", f"{y:.6f}") for r, (x, y) in zip(rows, people_out.tolist(), strict=True)]
        self._people.writerows(rows)

    def _write_support(
        self,
        key: tuple[int, int, int, int],
        support: Sequence[NDArray[np.float64] | None] | None,
        support_static: Sequence[NDArray[np.bool_] | None] | None,
    ) -> None:
        if support is None:
            return
        if self._support is None:
            self._support = self._csv("support.csv", DETECTION_COLUMNS)
        self._positions(self._support, key, support, support_static)

    def _write_tracks(self, tracks: Sequence[Sequence[Any]] | None) -> None:
        if tracks is None:
            return
        if self._tracks is None:
            from pfpeople.track import TRACK_COLUMNS

            self._tracks = self._csv("tracks.csv", TRACK_COLUMNS + OUT_TRACK_COLUMNS * bool(self.output_frame))
        self._tracks.writerows([[f"{v:.6g}" if isinstance(v, float) else v for v in row] for row in tracks])

    def _write_particles(self, frame: int, particles: tuple[NDArray[np.float64], NDArray[np.float64]] | None) -> None:
        if particles is None:
            return
        if self._particles is None:
            self._particles = _RecordFile(self.path / "particles.npy", PARTICLE_DTYPE)
        self._particles.append(particle_records(frame, *particles))

    def _append_grid(self, belief: NDArray[np.float64]) -> None:
        """Append the belief to ``grids.npy``; its header counts the frame only once the grid (and every table row)
        is on disk."""
        self._grids.write(np.ascontiguousarray(belief, dtype="<f4").data)  # row-major, as tobytes()
        self._grids.flush()
        _pwrite_all(self._grids, _npy_header(self.n_frames + 1, self.spec.nx, self.spec.ny))

    def _write_scans(
        self, frame: int, scans: Mapping[str, tuple[NDArray[np.float64], NDArray[np.bool_] | None]]
    ) -> None:
        """Append a frame's returns to ``scans.npy`` (created now if need be); a new topic updates ``run.json``."""
        if self._scans is None:
            self._scans = _RecordFile(self.path / "scans.npy", SCAN_DTYPE)
        known = len(self._scan_topics)
        records = scan_records(frame, scans, self._scan_topics)
        if len(self._scan_topics) > 255:
            raise ValueError(f"scans.npy holds at most 256 lasers, got {len(self._scan_topics)}")
        if len(self._scan_topics) != known or "scans" not in self._meta:
            self._meta["scans"] = {"topics": list(self._scan_topics), "bytes_per_return": SCAN_DTYPE.itemsize}
            self._write_json()
        self._scans.append(records)

    def _positions(
        self,
        writer: Any,
        key: tuple[int, int, int, int],
        positions: Sequence[NDArray[np.float64] | None],
        static: Sequence[NDArray[np.bool_] | None] | None,
    ) -> None:
        """Rows ``(*key, detector, x_m, y_m, static)`` of per-detector positions (None: no data, no row)."""
        if len(positions) != len(self.detector_names):
            n = len(self.detector_names)
            raise ValueError(f"per-detector positions must have {n} entries, got {len(positions)}")
        for i, (name, det) in enumerate(zip(self.detector_names, positions, strict=True)):
            if det is None:
                continue
            pts = np.asarray(det, dtype=float).reshape(-1, 2)
            given = static[i] if static is not None else None
            flags = np.zeros(len(pts), dtype=bool) if given is None else np.asarray(given, dtype=bool)
            # Python numbers (faster, the same text), the rows in one call
            writer.writerows(
                [
                    (*key, name, f"{x:.6f}", f"{y:.6f}", int(st))
                    for (x, y), st in zip(pts.tolist(), flags.tolist(), strict=True)
                ]
            )

    def update(self, **items: Any) -> None:
        """Add or replace keys of ``run.json`` (written at once)."""
        self._meta.update(items)
        self._write_json()

    def close(self, *, status: str = "complete", error: str | None = None, **items: Any) -> None:
        """Close the files and record the final status and the frames on disk (idempotent).

        Closing goes on when a file cannot be flushed (a full disk): every file is closed, ``run.json`` is
        written if possible, the lock released, and the first error is raised (naming its file).
        """
        if self._closed:
            return
        self._closed = True
        first: OSError | None = None
        with deferred_signals():
            handles: list[IO[Any]] = [self._grids, *self._files]
            handles += [f.fh for f in (self._scans, self._particles) if f is not None]
            for fh in handles:
                try:
                    fh.close()
                except OSError as exc:
                    first = first or named_os_error(exc, Path(str(fh.name)))
            elapsed = time.perf_counter() - self._t0
            self._meta.update(items)
            self._meta.update(status=status, frames=self.n_frames, elapsed_s=round(elapsed, 3))
            if error is not None:
                self._meta["error"] = error
            try:
                self._write_json()
            except OSError as exc:
                first = first or exc
            finally:
                self._unlock()
        if first is not None:
            raise first


@dataclass(frozen=True, eq=False)
class RunData:
    """A run read back: ``grids`` (N, nx, ny) memory-mapped, tables as dicts of column arrays."""

    path: Path
    meta: dict[str, Any]
    grids: NDArray[np.float32]
    frames: dict[str, NDArray[Any]]
    people: dict[str, NDArray[Any]]
    detections: dict[str, NDArray[Any]]
    #: ``support.csv`` (columns as ``detections``); None when the run wrote none.
    support: dict[str, NDArray[Any]] | None = None
    #: ``scans.npy`` (:data:`SCAN_DTYPE` records of the frames on disk); None when the run wrote none.
    scans: NDArray[Any] | None = None
    #: ``particles.npy`` (:data:`PARTICLE_DTYPE` records of the frames on disk); None when the run wrote none.
    particles: NDArray[Any] | None = None
    #: ``tracks.csv`` (columns :data:`pfpeople.track.TRACK_COLUMNS`: ``id`` an int, positions and velocities in the
    #: grid frame; with an output frame also :data:`OUT_TRACK_COLUMNS`); None when the run wrote none (tracking off).
    tracks: dict[str, NDArray[Any]] | None = None

    @property
    def scan_topics(self) -> list[str]:
        """The lasers of :attr:`scans`, by their ``laser`` index (``run.json`` ``scans.topics``)."""
        scans = self.meta.get("scans")
        topics = scans.get("topics") if isinstance(scans, dict) else None
        return [str(t) for t in topics] if isinstance(topics, list) else []

    @property
    def spec(self) -> GridSpec:
        return GridSpec(**self.meta["grid"])

    @property
    def n_frames(self) -> int:
        return int(self.grids.shape[0])


_INT_COLS = {
    "frame",
    "driver_index",
    "stamp_ns",
    "bag_time_ns",
    "odometry",
    "forced",
    "n_people",
    "size_cells",
    "static",
    "id",
}
_STR_COLS = {"detector", "no_data"}


def _read_csv(path: Path, columns: Sequence[str]) -> dict[str, NDArray[Any]]:
    if not path.is_file():
        raise FileNotFoundError(f"run file {str(path)!r} is missing")
    try:
        with path.open(newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"run file {str(path)!r} cannot be read: {exc}") from None
    if not rows or tuple(rows[0]) != tuple(columns):
        raise ValueError(f"run file {str(path)!r}: expected columns {list(columns)}, got {rows[:1]}")
    body = rows[1:]
    if body and len(body[-1]) != len(columns):  # a row cut short by a crash or a full disk: not a frame
        body = body[:-1]
    out: dict[str, NDArray[Any]] = {}
    for k, name in enumerate(columns):
        try:
            vals = [r[k] for r in body]
            if name in _STR_COLS:
                out[name] = np.array(vals, dtype=object)
            elif name in _INT_COLS:
                out[name] = np.array(vals, dtype=np.int64).reshape(-1)
            else:
                out[name] = np.array(vals, dtype=float).reshape(-1)
        except (IndexError, ValueError) as exc:
            raise ValueError(f"run file {str(path)!r}: bad value in column {name!r}: {exc}") from None
    return out


#: The values of ``run.json`` ``status``.
STATUSES = ("running", "complete", "failed", "interrupted")


def _no_constant(name: str) -> Any:
    """``json.loads``' ``parse_constant``: ``NaN`` and ``Infinity`` are not JSON (the project writes null and
    ``"inf"``, :mod:`pfpeople.io.jsonio`)."""
    raise ValueError(f'{name} is not a JSON value (a non-finite number; the project writes null or "inf")')


def _read_meta(meta_path: Path) -> dict[str, Any]:
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"), parse_constant=_no_constant)
    except (UnicodeDecodeError, ValueError) as exc:  # json.JSONDecodeError is a ValueError
        raise ValueError(f"{str(meta_path)!r} is not valid JSON: {exc}") from None
    if not isinstance(meta, dict):
        raise ValueError(f"{str(meta_path)!r} must hold a JSON object, got {type(meta).__name__}")
    if "status" in meta and meta["status"] not in STATUSES:
        raise ValueError(f"{str(meta_path)!r}: key 'status' must be one of {list(STATUSES)}, got {meta['status']!r}")
    if meta.get("format") != FORMAT:
        raise ValueError(f"{str(meta_path)!r} is not a {FORMAT} file (format={meta.get('format')!r})")
    if meta.get("version") != FORMAT_VERSION:
        raise ValueError(f"{str(meta_path)!r}: unsupported version {meta.get('version')!r}")
    grid = meta.get("grid")
    need = {"nx", "ny", "resolution", "x0", "y0"}
    if not isinstance(grid, dict) or not need <= set(grid):
        raise ValueError(f"{str(meta_path)!r}: key 'grid' must be an object with {sorted(need)}, got {grid!r}")
    try:
        GridSpec(**{k: grid[k] for k in need})
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{str(meta_path)!r}: bad 'grid': {exc}") from None
    return meta


def _read_table(path: Path, columns: Sequence[str], out: Sequence[str]) -> dict[str, NDArray[Any]]:
    """A table of ``columns``, or of ``columns`` and the output-frame columns ``out`` (a run with an output
    frame)."""
    try:
        return _read_csv(path, columns)
    except ValueError as exc:
        try:
            return _read_csv(path, (*columns, *out))
        except ValueError:
            raise exc from None


def _read_frames(path: Path) -> dict[str, NDArray[Any]]:
    """``frames.csv``; one written before the ``vy_mps`` column reads with ``vy_mps = 0``."""
    try:
        return _read_table(path, FRAME_COLUMNS, OUT_FRAME_COLUMNS)
    except ValueError as exc:  # a run written before vy_mps, or a bad table: then its own error
        try:
            frames = _read_csv(path, _FRAME_COLUMNS_V1)
        except ValueError:
            raise exc from None
        frames["vy_mps"] = np.zeros(len(frames["frame"]))
        return frames


def load_run(path: str | Path) -> RunData:
    """Read a run directory (also one whose run failed part-way: the frames written are returned).

    Every error names the file at fault (``run.json``, ``grids.npy`` or a table).
    """
    path = Path(path)
    meta_path = path / "run.json"
    if not meta_path.is_file():
        raise FileNotFoundError(f"{str(path)!r} is not a run directory (no run.json)")
    meta = _read_meta(meta_path)
    grids_path = path / "grids.npy"
    if not grids_path.is_file():
        raise FileNotFoundError(f"run file {str(grids_path)!r} is missing")
    try:
        grids = np.load(grids_path, mmap_mode="r")
    except (OSError, ValueError, EOFError) as exc:
        raise ValueError(f"run file {str(grids_path)!r} cannot be read: {exc}") from None
    shape = (meta["grid"]["nx"], meta["grid"]["ny"])
    if grids.ndim != 3 or tuple(grids.shape[1:]) != shape:
        raise ValueError(f"run file {str(grids_path)!r}: shape {grids.shape}, expected (N, {shape[0]}, {shape[1]})")
    frames = _read_frames(path / "frames.csv")
    n = min(len(grids), len(frames["frame"]))
    frames = {k: v[:n] for k, v in frames.items()}
    people = _read_table(path / "people.csv", PEOPLE_COLUMNS, OUT_PEOPLE_COLUMNS)
    try:
        dets = _read_csv(path / "detections.csv", DETECTION_COLUMNS)
    except ValueError as exc:  # a run written before the static column, or a bad table: then its own error
        try:
            dets = _read_csv(path / "detections.csv", _DETECTION_COLUMNS_V1)
        except ValueError:
            raise exc from None
        dets["static"] = np.zeros(len(dets["frame"]), dtype=np.int64)
    keep_p = people["frame"] < n
    keep_d = dets["frame"] < n
    support = None
    if (path / "support.csv").is_file():
        sup = _read_csv(path / "support.csv", DETECTION_COLUMNS)
        support = {k: v[sup["frame"] < n] for k, v in sup.items()}
    tracks = None
    if (path / "tracks.csv").is_file():
        from pfpeople.track import TRACK_COLUMNS

        trk = _read_table(path / "tracks.csv", TRACK_COLUMNS, OUT_TRACK_COLUMNS)
        tracks = {k: v[trk["frame"] < n] for k, v in trk.items()}
    return RunData(
        path=path,
        meta=meta,
        grids=grids[:n],
        frames=frames,
        people={k: v[keep_p] for k, v in people.items()},
        detections={k: v[keep_d] for k, v in dets.items()},
        support=support,
        scans=_read_records(path / "scans.npy", SCAN_DTYPE, n),
        particles=_read_records(path / "particles.npy", PARTICLE_DTYPE, n),
        tracks=tracks,
    )


def _read_records(path: Path, dtype: np.dtype[Any], n_frames: int) -> NDArray[Any] | None:
    """The records of ``path`` (memory-mapped) of the frames below ``n_frames``; None when there is no file."""
    if not path.is_file():
        return None
    try:
        rec = np.load(path, mmap_mode="r")
    except (OSError, ValueError, EOFError) as exc:
        raise ValueError(f"run file {str(path)!r} cannot be read: {exc}") from None
    if rec.ndim != 1 or rec.dtype != dtype:
        raise ValueError(f"run file {str(path)!r}: records {rec.dtype} of shape {rec.shape}, expected {dtype}")
    if not len(rec):
        return rec
    return rec[: int(np.searchsorted(rec["frame"], n_frames, "left"))]
