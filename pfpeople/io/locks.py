"""Lock files of the outputs: one writer per run directory (``RUN/.lock``) and per result bag (``OUT.bag.lock``).

A lock is ``fcntl.flock`` (exclusive, non-blocking) on a small file holding the writer's pid; the operating
system releases it when the writer dies. Two more rules make a dead writer never block a rerun:

- A forked child (the front-end process, :mod:`pfpeople.pipeline.front_end`) does not keep its parent's locks:
  every lock taken here is closed in the child right after ``fork`` (:func:`os.register_at_fork`). Closing the
  child's copy leaves the parent's lock in place (the lock belongs to the open file, which the parent still has open).
- A lock still held while the pid it names is dead (a process that inherited it outlived the writer) is taken
  over with a warning naming the dead pid: the lock file is replaced by a new one, which is locked.

Whoever takes a lock checks afterwards that the path still names the file it locked (a lock file replaced or
removed meanwhile is tried again), so a lock file can be removed when its writer is done (:func:`release`).
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
from pathlib import Path
from typing import IO

__all__ = ["PathLockedError", "acquire", "check_free", "release"]

log = logging.getLogger(__name__)

#: The lock files this process holds (closed in a forked child).
_HELD: list[IO[str]] = []


class PathLockedError(FileExistsError):
    """An output is being written by another process (its lock is held by a live process)."""


def _close_in_child() -> None:
    for fh in _HELD:
        with contextlib.suppress(OSError):
            fh.close()  # the child's copy only: the parent's lock stays
    _HELD.clear()


os.register_at_fork(after_in_child=_close_in_child)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def _holder(fh: IO[str]) -> str:
    fh.seek(0)
    return fh.read().strip() or "unknown"


def _try_lock(lock_path: Path) -> tuple[IO[str] | None, str]:
    """Lock ``lock_path`` once: ``(file, "")``, or ``(None, holder pid)`` when another process holds it."""
    fh = lock_path.open("a+")
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        holder = _holder(fh)
        fh.close()
        return None, holder
    try:
        same = os.path.samestat(os.fstat(fh.fileno()), os.stat(lock_path))
    except FileNotFoundError:
        same = False
    if not same:  # replaced or removed after we opened it: not the lock any more
        fh.close()
        return None, ""
    return fh, ""


def acquire(lock_path: Path, what: str, error: type[PathLockedError] = PathLockedError) -> IO[str]:
    """Take the lock ``lock_path`` of the output ``what`` (a description naming it) and write this pid into it.

    Raises
    ------
    PathLockedError (or ``error``)
        A live process holds the lock (its pid named).
    """
    for _ in range(20):
        fh, holder = _try_lock(lock_path)
        if fh is not None:
            break
        if holder.isdigit() and not _pid_alive(int(holder)):
            log.warning("%s: its lock is held for a dead process (pid %s): taking it over", what, holder)
            with contextlib.suppress(FileNotFoundError):
                lock_path.unlink()
            continue
        if holder:
            raise error(
                f"{what} is being written by another process (pid {holder}); "
                "wait for it to finish or choose another output"
            )
    else:  # pragma: no cover - the lock file replaced 20 times in a row
        raise error(f"{what}: its lock file {str(lock_path)!r} keeps changing; another process is taking it")
    fh.seek(0)
    fh.truncate()
    fh.write(f"{os.getpid()}\n")
    fh.flush()
    _HELD.append(fh)
    return fh


def check_free(lock_path: Path, what: str, error: type[PathLockedError] = PathLockedError) -> None:
    """Refuse now, before anything is created, an output whose lock a live process holds (nothing is written)."""
    try:
        fh = lock_path.open("r")
    except FileNotFoundError:
        return
    with fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            holder = _holder(fh)
            if not (holder.isdigit() and not _pid_alive(int(holder))):
                raise error(
                    f"{what} is being written by another process (pid {holder}); "
                    "wait for it to finish or choose another output"
                ) from None
        else:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def release(fh: IO[str], *, remove: Path | None = None) -> None:
    """Release a lock from :func:`acquire`; ``remove``: the lock file, deleted first (while still locked)."""
    if remove is not None:
        with contextlib.suppress(FileNotFoundError):
            remove.unlink()
    with contextlib.suppress(ValueError):
        _HELD.remove(fh)
    fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
    fh.close()
