"""Files the outputs write: created anew, never through a symbolic link, and every error naming the file.

- :func:`create_new` opens a new file for writing with ``O_CREAT | O_EXCL | O_NOFOLLOW``: an existing file or a
  symbolic link in its place (even one put there after the caller's checks) is an error naming the path, never
  written through or truncated.
- :func:`replace_text` writes a whole file by a new temporary file beside it (``mkstemp``: a fresh name, no link
  followed) renamed over the path: a symbolic link at the path is replaced, not followed.
- :func:`named_os_error` gives an ``OSError`` raised without a file name (a full disk, ``ENOSPC``, while writing
  through an open file) the path it was about: ``[Errno 28] No space left on device: 'RUN/grids.npy'``.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["create_new", "current_umask", "named_os_error", "replace_text"]


def named_os_error(exc: OSError, path: str | Path) -> OSError:
    """``exc`` when it names a file, else the same error naming ``path``."""
    if exc.filename:
        return exc
    code = exc.errno if exc.errno is not None else errno.EIO
    return OSError(code, exc.strerror or os.strerror(code), str(path))


def _exclusive(path: str, flags: int) -> int:
    """``open``'s opener of :func:`create_new`: its flags with ``O_CREAT | O_EXCL | O_NOFOLLOW``."""
    return os.open(path, flags | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o666)


def create_new(path: str | Path, mode: str) -> Any:
    """A new file ``path`` open for writing (``"w"``: text without newline translation, or ``"wb"``; the umask's
    permissions), never over an existing file or through a link.

    Raises
    ------
    FileExistsError
        Something (a file, a link) is at ``path``; the error names it.
    """
    return open(path, mode, newline=None if "b" in mode else "", opener=_exclusive)


def replace_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a new temporary file beside it renamed over it (errors name
    ``path``)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf8") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise named_os_error(exc, path) from exc


def current_umask() -> int:
    """The process's umask: from ``/proc/self/status`` (Linux), else set and restored at once."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
