"""One BLAS thread per process during a run (threadpoolctl), and how to opt out.

numpy's and scipy's OpenBLAS start one thread per core and hand a large enough dot product to all of them
(``np.dot`` of the particle weights in :func:`pfpeople.particle.resampler.schemes.effective_sample_size`, 19 720
weights in the 768-beam scenes). On a 2-core machine whose other core is busy (another process, or the
pipeline's own front-end process) the second BLAS thread waits for that core and the particle pipeline ran 2.5x
slower than with one BLAS thread, for the same outputs. :class:`pfpeople.pipeline.runner.Pipeline` therefore limits
every loaded BLAS library to :func:`resolve_blas_threads` threads while its frames run (the front-end process, forked
inside the limit, inherits it) and restores the libraries' own counts after. ``run.json`` records what the run
saw (``stats.blas_threads``, ``stats.front_blas_threads``: :func:`blas_threads_in_use` in the back end's and the
front end's process).

The number of threads: ``Pipeline(blas_threads=N)`` or ``pfpeople run/batch --blas-threads N``; by default the
environment variable :data:`BLAS_THREADS_ENV` (``PFPEOPLE_BLAS_THREADS``), else 1. ``0`` sets no limit (the
libraries' own thread counts, or ``OPENBLAS_NUM_THREADS``)::

    PFPEOPLE_BLAS_THREADS=0 pfpeople run my.bag --config my.toml     # OpenBLAS as it is: a thread per core
    pfpeople run my.bag --config my.toml --blas-threads 2

Only the BLAS libraries are limited (``user_api="blas"``); OpenMP pools are left alone (the pipeline uses none).

More threads than the CPUs the process may use (:func:`usable_cpus`) are never asked for: a larger count is capped
to it with a warning (``--blas-threads 64`` under an address-space limit crashed OpenBLAS, which reserves memory
for every thread, with a SIGSEGV).
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Any

from threadpoolctl import threadpool_info, threadpool_limits

__all__ = [
    "BLAS_THREADS_ENV",
    "DEFAULT_BLAS_THREADS",
    "blas_threads_in_use",
    "limit_blas",
    "resolve_blas_threads",
    "usable_cpus",
]

log = logging.getLogger(__name__)

#: The environment variable giving the default number of BLAS threads of a run (``0``: no limit).
BLAS_THREADS_ENV = "PFPEOPLE_BLAS_THREADS"
#: BLAS threads per process when neither the caller nor :data:`BLAS_THREADS_ENV` says otherwise.
DEFAULT_BLAS_THREADS = 1


def resolve_blas_threads(threads: int | None = None) -> int:
    """The number of BLAS threads a run uses: ``threads``, else :data:`BLAS_THREADS_ENV`, else 1.

    Parameters
    ----------
    threads : int, optional
        Threads per process (>= 0; 0: no limit). None: from the environment.

    Returns
    -------
    int
        Threads per BLAS library and process, 0 for no limit; at most :func:`usable_cpus` (a larger count is capped,
        with a warning naming the setting).

    Raises
    ------
    ValueError
        If ``threads`` or the environment variable is not an integer >= 0.
    """
    source = "blas_threads"
    if threads is None:
        text = os.environ.get(BLAS_THREADS_ENV, "").strip()
        if not text:
            return DEFAULT_BLAS_THREADS
        source = BLAS_THREADS_ENV
        try:
            threads = int(text)
        except ValueError:
            raise ValueError(f"{source} must be an integer >= 0 (0: no limit), got {text!r}") from None
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 0:
        raise ValueError(f"{source} must be an integer >= 0 (0: no limit), got {threads!r}")
    cpus = usable_cpus()
    if threads > cpus:
        log.warning("%s = %d is more than the %d CPU(s) this process may use: %d used", source, threads, cpus, cpus)
        return cpus
    return threads


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity mask; ``os.cpu_count()`` where there is none), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


_lock = threading.Lock()
_depth = 0
_limiter: Any = None
_control: tuple[int, ThreadPoolExecutor] | None = None


def _on_control_thread(fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` on the one thread of this process that sets and restores the BLAS limits.

    threadpoolctl lets one thread at a time set the thread count of a process-wide OpenBLAS pool (the others' calls
    do nothing until that thread's limits end), so the limits of runs in different threads are set and restored
    from this one thread. A forked child makes its own.
    """
    global _control
    if _control is None or _control[0] != os.getpid():
        _control = (os.getpid(), ThreadPoolExecutor(max_workers=1, thread_name_prefix="pfpeople-blas"))
    return _control[1].submit(fn, *args).result()


def _set_limits(threads: int) -> Any:
    limiter = threadpool_limits(limits=threads, user_api="blas")
    limiter.__enter__()
    return limiter


@contextmanager
def limit_blas(threads: int) -> Iterator[None]:
    """Within the block every BLAS library loaded in this process uses at most ``threads`` threads.

    Parameters
    ----------
    threads : int
        Threads per library (>= 1); 0 leaves the libraries as they are.

    Notes
    -----
    The limit is the process's (OpenBLAS has one thread count per library): other threads of the process see it
    too while the block runs. Blocks that overlap (runs in several threads of one process, e.g. a Dask cluster of
    threads) share the first one's limit, and the libraries' own counts come back when the last of them ends,
    whatever the order. A limit that the caller set with threadpoolctl in another thread, still in force, wins.
    A process forked inside the block inherits the limit. A BLAS library first loaded inside the block is not
    limited (the pipeline's modules load theirs when imported).
    """
    global _depth, _limiter
    if threads <= 0:
        yield
        return
    with _lock:
        if _depth == 0:
            _limiter = _on_control_thread(_set_limits, threads)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _on_control_thread(_limiter.__exit__, None, None, None)
                _limiter = None


def blas_threads_in_use() -> int:
    """The most threads any BLAS library loaded in this process would use now (0: no BLAS library found).

    Returns
    -------
    int
        The largest ``num_threads`` of threadpoolctl's BLAS entries.
    """
    return max((int(info["num_threads"]) for info in threadpool_info() if info.get("user_api") == "blas"), default=0)
