"""Progress bars that stay sparse when nobody watches them.

On a terminal, :func:`progress_bar` is a plain ``tqdm`` bar. When its stream is not a terminal (a log file,
a pipe, a CI job) the bar prints one line per tenth of the total (at most 11 lines and the closing one), or
one line per ``every`` steps when the total is unknown, each on a line of its own instead of ``\\r``
overwrites: a log keeps a dozen lines of progress, not hundreds.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable
from typing import IO, Any

from tqdm import tqdm

__all__ = ["LineStream", "is_terminal", "progress_bar"]


def is_terminal(stream: Any) -> bool:
    """Whether ``stream`` is an interactive terminal (False for files, pipes and captured streams)."""
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty()) if callable(isatty) else False
    except ValueError:  # a closed stream
        return False


class LineStream:
    """A text stream for ``tqdm`` that turns its ``\\r`` redraws into whole lines (for log files).

    Parameters
    ----------
    stream : text stream
        Where the lines go.
    """

    def __init__(self, stream: IO[str]) -> None:
        self.stream = stream

    def write(self, text: str) -> int:
        line = text.replace("\r", "").rstrip()
        if line:
            self.stream.write(line + "\n")
        return len(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return False

    def __getattr__(self, name: str) -> Any:  # encoding, fileno ...: the wrapped stream's
        if name == "stream":  # not set yet (copy, pickle): no recursion
            raise AttributeError(name)
        return getattr(self.stream, name)


def progress_bar(
    iterable: Iterable[Any] | None = None,
    *,
    total: float | None = None,
    desc: str | None = None,
    unit: str = "it",
    disable: bool = False,
    leave: bool = True,
    file: IO[str] | None = None,
    every: int = 100,
) -> tqdm:
    """A ``tqdm`` bar; when ``file`` (default ``sys.stderr``) is not a terminal, one line per 10 % of the run.

    Parameters
    ----------
    iterable : iterable, optional
        Wrapped as ``tqdm(iterable)`` does; ``total`` defaults to its length when it has one.
    total : float, optional
        Expected number of steps; unknown (None) prints a line every ``every`` steps off a terminal.
    desc, unit, disable, leave
        As ``tqdm``'s.
    file : text stream, optional
        Where the bar goes (default: ``sys.stderr`` at the time of the call).
    every : int
        Steps between lines off a terminal when the total is unknown.

    Returns
    -------
    tqdm
        The bar (a context manager; iterate it, or call ``update``).
    """
    stream = sys.stderr if file is None else file
    kwargs: dict[str, Any] = {"desc": desc, "unit": unit, "disable": disable, "leave": leave}
    if total is None and iterable is not None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    if is_terminal(stream):
        return tqdm(iterable, total=total, file=stream, **kwargs)
    # Off a terminal: a line every tenth (or every `every` steps), never on a timer (maxinterval would make
    # tqdm's monitor thread print on every step of a slow run).
    miniters = max(1, math.ceil(total / 10)) if total else max(1, every)
    return tqdm(
        iterable,
        total=total,
        file=LineStream(stream),
        mininterval=0,
        maxinterval=math.inf,
        miniters=miniters,
        **kwargs,
    )
