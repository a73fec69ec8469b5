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

A lock file is never opened through a symbolic link (``O_NOFOLLOW``): a link in its place (``ln -s ~/victim
RUN/.lock``) is refused, naming it, and what it points to is neither read nor written. :func:`acquire` tells whether
it created the file (:func:`created`), so a writer that then refuses its output removes only a lock file of its
own. An error writing the pid (a full disk) names the lock file.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import logging
import os
import stat
from pathlib import Path
from typing import IO

from pfpeople.io.files import named_os_error

__all__ = ["PathLockedError", "acquire", "check_free", "created", "release"]

log = logging.getLogger(__name__)

#: The lock files this process holds (closed in a forked child).
_HELD: list[IO[str]] = []
#: The ids of the held lock files that :func:`acquire` created (see :func:`created`).
_CREATED: set[int] = set()


class PathLockedError(FileExistsError):
    """An output is being written by another process (its lock is held by a live process)."""


def _close_in_child() -> None:
    for fh in _HELD:
        with contextlib.suppress(OSError):
            fh.close()  # the child's copy only: the parent's lock stays
    _HELD.clear()
    _CREATED.clear()


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


def _open_lock(lock_path: Path, what: str, error: type[PathLockedError], *, create: bool) -> tuple[IO[str], bool]:
    """Open ``lock_path`` without following a link, to lock it (created if need be, read and write) or, without
    ``create``, to read it; ``(file, created)``.

    Raises
    ------
    PathLockedError (or ``error``)
        The path is a symbolic link or not a regular file.
    FileNotFoundError
        It does not exist and ``create`` is false.
    """
    flags = (os.O_RDWR if create else os.O_RDONLY) | os.O_NOFOLLOW | os.O_CLOEXEC
    made = False
    try:
        if create:
            try:
                fd, made = os.open(lock_path, flags | os.O_CREAT | os.O_EXCL, 0o666), True
            except FileExistsError:
                fd = os.open(lock_path, flags)
        else:
            fd = os.open(lock_path, flags)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise error(
                f"{what}: its lock file {str(lock_path)!r} is a symbolic link: not followed; remove it "
                "(or choose another output)"
            ) from None
        raise
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise error(f"{what}: its lock file {str(lock_path)!r} is not a regular file; remove it")
    return os.fdopen(fd, "r+" if create else "r"), made


def _try_lock(lock_path: Path, what: str, error: type[PathLockedError]) -> tuple[IO[str] | None, str, bool]:
    """Lock ``lock_path`` once: ``(file, "", created)``, or ``(None, holder pid, created)`` when another process
    holds it."""
    fh, made = _open_lock(lock_path, what, error, create=True)
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        holder = _holder(fh)
        fh.close()
        return None, holder, made
    try:
        same = os.path.samestat(os.fstat(fh.fileno()), os.stat(lock_path, follow_symlinks=False))
    except FileNotFoundError:
        same = False
    if not same:  # replaced or removed after we opened it: not the lock any more
        fh.close()
        return None, "", made
    return fh, "", made


def _pwrite(fd: int, data: bytes, offset: int) -> int:
    """``os.pwrite`` (a seam for the tests' full disk)."""
    return os.pwrite(fd, data, offset)


def _write_pid(fh: IO[str], lock_path: Path) -> None:
    """Replace the lock file's content by this pid; an error (a full disk) names the lock file."""
    data = f"{os.getpid()}\n".encode()
    try:
        os.ftruncate(fh.fileno(), 0)
        done = 0
        while done < len(data):
            done += _pwrite(fh.fileno(), data[done:], done)
    except OSError as exc:
        raise named_os_error(exc, lock_path) from None


def acquire(lock_path: Path, what: str, error: type[PathLockedError] = PathLockedError) -> IO[str]:
    """Take the lock ``lock_path`` of the output ``what`` (a description naming it) and write this pid into it.

    Raises
    ------
    PathLockedError (or ``error``)
        A live process holds the lock (its pid named), or the lock file is a symbolic link or not a regular file.
    OSError
        The pid cannot be written (naming the lock file).
    """
    made_any = False
    for _ in range(20):
        fh, holder, made = _try_lock(lock_path, what, error)
        made_any = made_any or made
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
    try:
        _write_pid(fh, lock_path)
    except OSError:
        fh.close()
        if made_any:
            with contextlib.suppress(OSError):
                lock_path.unlink()
        raise
    _HELD.append(fh)
    if made_any:
        _CREATED.add(id(fh))
    return fh


def created(fh: IO[str]) -> bool:
    """Whether :func:`acquire` created the lock file of ``fh`` (it did not exist before)."""
    return id(fh) in _CREATED


def check_free(lock_path: Path, what: str, error: type[PathLockedError] = PathLockedError) -> None:
    """Refuse now, before anything is created, an output whose lock a live process holds, or whose lock file is a
    symbolic link (nothing is written)."""
    try:
        fh, _ = _open_lock(lock_path, what, error, create=False)
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
    _CREATED.discard(id(fh))
    fcntl.flock(fh.fileno(), fcntl.LOCK_UN)
    fh.close()
