"""The pipeline's front end (ego-motion, detectors, static clutter) in a second process.

A frame's work splits in two: the *front end* (:mod:`pfpeople.pipeline.front`: ego-motion, the detectors, the
static-clutter map) needs only the frame's messages and its own state; the *back end* (:mod:`pfpeople.pipeline.back`:
filter, classifier, tracker) and the outputs need the front end's result. On a machine with two or more cores the
front end of the next frames runs in a child process while this one runs the back end of the current frame, as a
robot runs its detectors and its fusion as separate ROS nodes. The results are the same as in one process: the same
code runs on the same frames in the same order, only in two processes.

Protocol. The child is forked once the pipeline is prepared: it starts with a copy of every part in the state
of the start of the run. It reads the bag itself, with its own reader of the same files (an open reader cannot
be shared across a fork; both read the same frames, checked by index and stamp), and sends each frame's
``("ok", index, stamp, FrontResult, counters, records)``: the front end's result, the
:class:`~pfpeople.run_state.RunSummary` counters the front end keeps (copied into this process's summary as each
frame is taken, so the summary always describes the frames processed) and the log records the front end emitted
for that frame (re-emitted here, through this process's handlers). An exception in the front end is sent as
``("error", index, stamp, exc, records)`` and raised here when the run reaches that frame: the frames before it
are processed and written as in one process. A reading error ends the child quietly: this process's own reading
meets it at the same frame and raises it there, as in one process. The child ignores SIGINT (the terminal's
Ctrl-C goes to this process, which ends the run) and is terminated when the run ends, however it ends: also when
this process is killed (SIGKILL), as the child then gets SIGTERM (Linux ``PR_SET_PDEATHSIG``), sees its parent pid
change (a watchdog thread, every :data:`WATCHDOG_PERIOD_S`) and meets a broken pipe (it keeps no copy of the
reading end). It keeps none of this process's output locks either (:mod:`pfpeople.io.locks`), so a rerun is never
refused for a dead run.
"""

from __future__ import annotations

import ctypes
import logging
import multiprocessing
import os
import pickle
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from logging.handlers import QueueHandler
from multiprocessing.connection import Connection
from typing import Any

from pfpeople.io.bag.sync import Frame
from pfpeople.pipeline.blas import blas_threads_in_use
from pfpeople.pipeline.front import FrontResult
from pfpeople.run_state import RunSummary

__all__ = ["FRONT_COUNTERS", "FrontProcess", "FrontResult", "front_process_available"]

#: The :class:`~pfpeople.run_state.RunSummary` fields the front end updates (the back end: ``frames``, ``sync``,
#: ``elapsed_s``, ``error``, ``blas_threads``, ``readmitted``, ``fov_narrowed``, and ``mount_changes`` and
#: ``bad_transforms``, from the TF it reads along the frames).
FRONT_COUNTERS = (
    "no_data",
    "empty_scans",
    "bad_messages",
    "bad_scans",
    "frames_without_odometry",
    "filter_restarts",
    "odometry_jumps",
    "odometry_other_child",
    "mounts_followed",
    "frame_id_changes",
    "frame_id_unplaced",
    "max_lateral_m",
    "suppressed",
    "arrived",
    "laser_odometry_frames",
    "ego_motion",
    "front_blas_threads",
    "output_unplaced",
)


def front_process_available() -> tuple[bool, str]:
    """Whether a front-end process can run here, and why not ("" when it can).

    It needs Linux (``fork``), two or more usable cores, the main thread, and a process allowed to have children
    (a daemonic worker, e.g. Dask's, is not).
    """
    if not sys.platform.startswith("linux"):
        return False, f"no fork start method on {sys.platform}"
    cores = len(os.sched_getaffinity(0))
    if cores < 2:
        return False, f"{cores} usable core"
    if threading.current_thread() is not threading.main_thread():
        return False, "not in the main thread"
    if multiprocessing.current_process().daemon:
        return False, "a daemonic process cannot have children"
    return True, ""


class _Records(logging.Handler):
    """Collects the child's log records, made picklable (message formatted, arguments dropped)."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []
        self._prepare = QueueHandler(None).prepare  # type: ignore[arg-type]

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(self._prepare(record))


def _counters(summary: RunSummary) -> dict[str, Any]:
    return {name: getattr(summary, name) for name in FRONT_COUNTERS}


def _picklable(exc: BaseException) -> BaseException:
    """``exc`` with its traceback as a note (a traceback does not cross processes), or its text in a
    RuntimeError when it cannot be pickled."""
    exc.add_note("raised in the front-end process:\n" + "".join(traceback.format_tb(exc.__traceback__)))
    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:
        return RuntimeError(f"{type(exc).__name__}: {exc}")
    return exc


#: How often (s) the child checks that its parent is alive (the portable fallback of ``PR_SET_PDEATHSIG``).
WATCHDOG_PERIOD_S = 0.5
_PR_SET_PDEATHSIG = 1


def _set_parent_death_signal() -> bool:
    """Linux: have the kernel send SIGTERM to this process when its parent dies; whether that was set."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent_pid: int) -> None:
    """End this process (exit code 0) as soon as its parent is gone (it is then re-parented)."""
    while os.getppid() == parent_pid:
        time.sleep(WATCHDOG_PERIOD_S)
    os._exit(0)


def _die_with_parent(parent_pid: int) -> None:
    """Make the child end with its parent: ``PR_SET_PDEATHSIG`` (Linux), a parent-pid watchdog thread (anywhere).

    A parent killed with SIGKILL runs no ``finally`` and never terminates its child; without this the child
    would live on, blocked on its full pipe.
    """
    _set_parent_death_signal()
    if os.getppid() != parent_pid:  # the parent died before the death signal was set
        os._exit(0)
    threading.Thread(target=_watch_parent, args=(parent_pid,), name="pfpeople-front-watchdog", daemon=True).start()


def _child(
    frames: Callable[[], Iterator[Frame]],
    front: Callable[[Frame], FrontResult],
    summary: RunSummary,
    pipes: tuple[Connection, Connection],
    parent_pid: int,
) -> None:
    """The child's loop: read the frames, send each one's front-end result, then ``("end", reason)``.

    ``pipes`` is ``(the parent's reading end, the child's writing end)``: the child closes its copy of the reading
    end, so the pipe breaks when the parent dies.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the run's handler (an exception in the parent) is inherited
    inbox, outbox = pipes
    inbox.close()
    _die_with_parent(parent_pid)
    root = logging.getLogger()
    for h in list(root.handlers):
        root.removeHandler(h)
    records = _Records()
    root.addHandler(records)
    summary.front_blas_threads = blas_threads_in_use()  # the limit of the run, inherited through the fork
    it = iter(frames())
    try:
        while True:
            try:
                frame = next(it)
            except StopIteration:
                outbox.send(("end", "the bag ended"))
                return
            except BaseException as exc:  # the parent's own reading meets the same error
                outbox.send(("end", f"reading failed: {type(exc).__name__}: {exc}"))
                return
            records.records = []  # what the reading logged, the parent logs too: only the front end's records go
            try:
                result = front(frame)
            except BaseException as exc:  # every error goes to the parent, which raises it at this frame
                outbox.send(("error", frame.index, frame.stamp_ns, _picklable(exc), records.records))
                return
            outbox.send(("ok", frame.index, frame.stamp_ns, result, _counters(summary), records.records))
    except (BrokenPipeError, ConnectionResetError):  # the parent stopped reading: the run is over
        return


class FrontProcess:
    """A child process that reads the frames itself and runs the front end on them (module docstring).

    Parameters
    ----------
    frames : callable
        ``frames() -> iterator of Frame``, called in the child: the run's frames, read from the child's own
        reader of the same bag (a reader's open file cannot be shared across a fork).
    front : callable
        ``front(frame) -> FrontResult`` (the pipeline's front end, state included: the child works on its copy).
    summary : RunSummary
        The summary the front end updates (the child's copy is read after each frame; this one is updated as the
        results are taken).

    The child runs ahead of :meth:`take` by as many results as the pipe holds (tens of frames), then waits.
    """

    def __init__(
        self, frames: Callable[[], Iterator[Frame]], front: Callable[[Frame], FrontResult], summary: RunSummary
    ) -> None:
        self.summary = summary
        ctx = multiprocessing.get_context("fork")
        self._from_child, child_out = ctx.Pipe(duplex=False)
        self._proc = ctx.Process(
            target=_child,
            args=(frames, front, summary, (self._from_child, child_out), os.getpid()),
            name="pfpeople-front",
            daemon=True,
        )
        self._proc.start()
        child_out.close()

    def take(self, frame: Frame) -> FrontResult:
        """The front-end result of ``frame``, the next frame of the run (blocks until the child has it).

        Raises
        ------
        Exception
            The child's exception for this frame (with the child's traceback as a note).
        RuntimeError
            The child ended before this frame or sent another frame's result (its reading differs from this
            process's).
        """
        try:
            msg = self._from_child.recv()
        except EOFError:
            self._proc.join(timeout=5.0)  # reaped: its exit code is known
            raise RuntimeError(
                f"the front-end process ended before frame {frame.index} (exit code {self._proc.exitcode})"
            ) from None
        if msg[0] == "end":
            raise RuntimeError(f"the front-end process ended before frame {frame.index}: {msg[1]}")
        for record in msg[-1]:
            logging.getLogger(record.name).handle(record)
        if (msg[1], msg[2]) != (frame.index, frame.stamp_ns):
            raise RuntimeError(
                f"the front-end process read frame {msg[1]} (stamp {msg[2]} ns) where this one read frame "
                f"{frame.index} (stamp {frame.stamp_ns} ns)"
            )
        if msg[0] == "error":
            raise msg[3]
        for name, value in msg[4].items():
            setattr(self.summary, name, value)
        result: FrontResult = msg[3]
        return result

    def close(self) -> None:
        """Stop the child (idempotent)."""
        self._from_child.close()
        if self._proc.is_alive():
            self._proc.terminate()
        self._proc.join(timeout=5.0)
