"""Many bags on Dask: one task per bag, each running the whole pipeline into its own run directory.

``run_batch`` submits :func:`run_bag` once per bag to a ``dask.distributed`` cluster (a local one by default:
one single-threaded worker process per core, or an existing scheduler by address), shows progress over the
tasks as they complete, and returns one row per bag (:data:`ROW_COLUMNS`), in the order the bags were given:

- ``bag``: the bag path as given; ``run_dir``: its run directory ``OUT/<bag stem>`` (``<stem>-2``, ... when two
  bags share a stem);
- ``status``: ``"complete"`` or ``"failed"``; ``error``: ``"<ExceptionType>: <message>"`` of a failed bag
  (``""`` otherwise);
- ``frames``: frames processed (those before the error for a failed run, from its ``run.json``);
  ``fps``: frames per second of the pipeline loop; ``wall_s``: the task's wall time (s, opening the bag and
  preparing included); ``cpu_s``: the CPU time of the task's thread (s; ``cpu_s / wall_s`` below 1 shows a
  worker waiting for a core or the disk); ``people_per_frame``: mean number of classified people per frame
  (NaN without frames).

A failing bag (corrupt, truncated, missing topic ...) does not stop the others: the task catches the error,
records it in its row and in ``RUN_DIR/batch_error.txt`` (the traceback; the pipeline's own ``run.json`` with
``status = "failed"`` is there too when the run had started), and returns. A task lost with its worker (killed,
out of memory) is recorded the same way from the future's exception.

With a remote cluster (``scheduler``), the bag paths and the output folder must be reachable by the workers
under the same paths (shared file system), and pfpeople must be installed in the workers' environment.
:func:`dask_client` and :func:`run_tasks` are shared with :mod:`evaluation.harness.sweep`.
"""

from __future__ import annotations

import csv
import importlib
import json
import logging
import math
import os
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from gridbridge.validation import check_int
from pfpeople.config import BagConfig
from pfpeople.extras import require
from pfpeople.pipeline.blas import resolve_blas_threads

__all__ = [
    "ROW_COLUMNS",
    "TABLE_SUFFIXES",
    "check_cluster_args",
    "check_out_dir",
    "check_table_path",
    "dashboard_available",
    "dask_client",
    "quiet_dask_logs",
    "run_bag",
    "run_batch",
    "run_dir_names",
    "run_tasks",
    "write_table",
]

log = logging.getLogger(__name__)

#: Columns of a batch row.
ROW_COLUMNS = ("bag", "run_dir", "status", "frames", "fps", "wall_s", "cpu_s", "people_per_frame", "error")
#: Table formats by suffix.
TABLE_SUFFIXES = (".csv", ".parquet")
#: File with the traceback of a failed bag, in its run directory.
ERROR_FILE = "batch_error.txt"


def check_cluster_args(scheduler: str | None, workers: int | None) -> None:
    """``workers``: None or a positive integer, and not together with a ``scheduler`` address."""
    if workers is not None:
        check_int(workers, "workers", minimum=1)
    if scheduler is not None and workers is not None:
        raise ValueError("workers sets the size of a local cluster; it cannot be combined with a scheduler address")


def dashboard_available() -> bool:
    """Whether the Dask dashboard can be served: it needs ``bokeh``, an optional dependency.

    Without it the scheduler's dashboard address only answers that bokeh is missing, so none is advertised.
    """
    try:
        importlib.import_module("bokeh")
    except ImportError:
        return False
    return True


class _NoDashboardLink(logging.Filter):
    """Drops the scheduler's and workers' "dashboard at: URL" lines (dead links without bokeh)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "dashboard at" not in record.getMessage()


def quiet_dask_logs(verbose: bool = False) -> None:
    """The ``distributed`` loggers at WARNING (their start/stop INFO lines only with ``verbose``, at INFO).

    ``distributed`` is imported first: its import sets its loggers' levels (INFO), which would undo a level
    set before it.

    Parameters
    ----------
    verbose : bool
        Keep distributed's INFO messages (the ``-v`` of the commands).
    """
    require("batch", "pfpeople batch")

    level = logging.INFO if verbose else logging.WARNING
    logging.getLogger("distributed").setLevel(level)
    for name, logger in list(logging.root.manager.loggerDict.items()):  # children given a level of their own
        if name.startswith("distributed.") and isinstance(logger, logging.Logger) and logger.level != logging.NOTSET:
            logger.setLevel(max(logger.level, level))


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, *, processes: bool = True) -> Iterator[Any]:
    """A ``distributed.Client``: to ``scheduler`` (an address such as ``tcp://host:8786``) or a local cluster.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler; None starts ``LocalCluster(n_workers=workers, threads_per_worker=1,
        processes=processes)``, closed on exit.
    workers : int, optional
        Local workers (default: ``os.cpu_count()``); not allowed with ``scheduler`` (the cluster has its own).
    processes : bool
        Local workers as processes (default; the pipeline holds the GIL in Python code) or threads.
    """
    require("batch", "pfpeople batch")
    from distributed import Client, LocalCluster

    check_cluster_args(scheduler, workers)
    if scheduler is not None:
        with Client(scheduler) as client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    dashboard = dashboard_available()
    for name in ("distributed.scheduler", "distributed.worker"):  # they log their HTTP servers' links
        logger = logging.getLogger(name)
        if not dashboard and not any(isinstance(f, _NoDashboardLink) for f in logger.filters):
            logger.addFilter(_NoDashboardLink())
    with (
        LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=processes,
            dashboard_address=":0",  # a free port (the HTTP server runs anyway: health checks, metrics)
            scheduler_kwargs={"dashboard": dashboard},
        ) as cluster,
        Client(cluster) as client,
    ):
        if dashboard:
            log.info("Dask dashboard: %s", client.dashboard_link)
        yield client


def run_tasks(
    client: Any,
    fn: Callable[..., Any],
    args: Sequence[tuple[Any, ...]],
    *,
    keys: Sequence[str],
    on_error: Callable[[int, BaseException], Any],
    progress: bool = True,
    desc: str = "tasks",
) -> list[Any]:
    """Run ``fn(*args[i])`` as one Dask task each; results in the order of ``args``.

    Progress (:func:`pfpeople.progress.progress_bar`) counts tasks as they complete. A task whose future fails
    (the function raised, or its worker died) yields ``on_error(i, exception)`` instead of a result; the other
    tasks go on.
    """
    require("batch", "pfpeople batch")
    from distributed import as_completed

    from pfpeople.progress import progress_bar

    if len(keys) != len(args) or len(set(keys)) != len(keys):
        raise ValueError("run_tasks: keys must be unique, one per task")
    futures = [client.submit(fn, *a, key=k, pure=False) for a, k in zip(args, keys, strict=True)]
    index = {f.key: i for i, f in enumerate(futures)}
    results: list[Any] = [None] * len(futures)
    with progress_bar(total=len(futures), desc=desc, unit="task", disable=not progress) as bar:
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                results[i] = fut.result()
            except Exception as exc:  # the task raised or its worker was lost: recorded, the others go on
                results[i] = on_error(i, exc)
            fut.release()
            bar.update(1)
    return results


def run_dir_names(bags: Sequence[str | Path]) -> list[str]:
    """Run-directory names: each bag's stem (``a.bag`` / ``a.bag.zip`` / folder ``a`` -> ``a``), made unique
    by ``-2``, ``-3``, ... in the order given."""
    names: list[str] = []
    seen: dict[str, int] = {}
    for bag in bags:
        stem = Path(bag).name.split(".")[0] or "bag"
        seen[stem] = seen.get(stem, 0) + 1
        names.append(stem if seen[stem] == 1 else f"{stem}-{seen[stem]}")
    while len(set(names)) != len(names):  # a stem like "a-2" given as well: suffix again
        dup = {n for n in names if names.count(n) > 1}
        names = [f"{n}-x{k}" if n in dup else n for k, n in enumerate(names)]
    return names


def _people_per_frame(run_dir: Path) -> float:
    path = run_dir / "frames.csv"
    if not path.is_file():
        return math.nan
    with path.open(newline="") as fh:
        counts = [int(r["n_people"]) for r in csv.DictReader(fh)]
    return sum(counts) / len(counts) if counts else math.nan


def _frames_from_record(run_dir: Path) -> int:
    try:
        meta = json.loads((run_dir / "run.json").read_text())
        return int(meta.get("stats", {}).get("frames", 0))
    except (OSError, ValueError, TypeError):
        return 0


def run_bag(
    bag: str | Path,
    config: BagConfig,
    run_dir: str | Path,
    *,
    max_frames: int | None = None,
    overwrite: bool = False,
    blas_threads: int | None = None,
) -> dict[str, Any]:
    """Run the pipeline over one bag into ``run_dir``; never raises for a bad bag: returns its row.

    See the module docstring for the row; ``blas_threads`` is :class:`pfpeople.pipeline.runner.Pipeline`'s.
    """
    from pfpeople.io.bag.reader import BagSource
    from pfpeople.pipeline.runner import Pipeline

    t0, c0 = time.perf_counter(), time.thread_time()
    out = Path(run_dir)
    row: dict[str, Any] = {
        "bag": str(bag),
        "run_dir": str(out),
        "status": "failed",
        "frames": 0,
        "fps": math.nan,
        "wall_s": math.nan,
        "cpu_s": math.nan,
        "people_per_frame": math.nan,
        "error": "",
    }
    try:
        with BagSource(bag) as src:
            # one process per bag: a batch runs its bags in parallel, one per core
            summary, _ = Pipeline(config, front_process=False, blas_threads=blas_threads).run(
                src, out, max_frames=max_frames, overwrite=overwrite, metadata={"command": "pfpeople batch"}
            )
        row.update(status="complete", frames=summary.frames, fps=summary.fps, people_per_frame=_people_per_frame(out))
    except Exception as exc:
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["frames"] = _frames_from_record(out)
        row["people_per_frame"] = _people_per_frame(out)
        try:
            out.mkdir(parents=True, exist_ok=True)
            (out / ERROR_FILE).write_text(f"bag: {bag}\n{traceback.format_exc()}")
        except OSError:  # the row still has the error
            pass
    row["wall_s"] = time.perf_counter() - t0
    row["cpu_s"] = time.thread_time() - c0
    return row


def check_out_dir(path: str | Path) -> Path:
    """The batch output folder ``path``, checked before anything runs: it must be, or be creatable as, a folder.

    Parameters
    ----------
    path : path
        ``--out``: a new folder, or one holding earlier runs.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        When ``path`` is an existing file (not a folder), or one of its parents is: naming both.
    """
    p = Path(path)
    for q in (p, *p.parents):
        if q.exists() and not q.is_dir():
            what = "is a file, not a folder" if q == p else f"cannot be a folder: its parent {str(q)!r} is a file"
            raise ValueError(
                f"--out {str(p)!r} {what}; give a folder for the run directories (new or holding earlier runs)"
            )
        if q.is_dir():
            break
    return p


def check_table_path(path: str | Path) -> Path:
    """A results table path: ``.csv`` or ``.parquet`` (needs pyarrow), in an existing or creatable folder."""
    p = Path(path)
    if p.suffix not in TABLE_SUFFIXES:
        raise ValueError(f"table {str(p)!r}: the name must end in one of {list(TABLE_SUFFIXES)}")
    if p.suffix == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise ValueError(f"table {str(p)!r}: Parquet needs pyarrow (pip install pyarrow), or use .csv") from None
    if p.is_dir():
        raise ValueError(f"table {str(p)!r} is a folder")
    return p


def write_table(rows: Sequence[Mapping[str, Any]], path: str | Path, columns: Sequence[str] | None = None) -> Path:
    """Write ``rows`` as CSV or Parquet (by suffix); columns: ``columns`` or the union of the rows' keys in order.

    NaN is written as an empty CSV cell and a Parquet null.
    """
    p = check_table_path(path)
    cols = list(columns) if columns is not None else list(dict.fromkeys(k for r in rows for k in r))
    p.parent.mkdir(parents=True, exist_ok=True)

    def clean(v: Any) -> Any:
        return None if isinstance(v, float) and math.isnan(v) else v

    if p.suffix == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pylist([{c: clean(r.get(c)) for c in cols} for r in rows])
        if not rows:
            table = pa.table({c: pa.array([], type=pa.null()) for c in cols})
        pq.write_table(table, p)
    else:
        with p.open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
            w.writeheader()
            for r in rows:
                w.writerow({c: "" if clean(r.get(c)) is None else r.get(c) for c in cols})
    return p


def _run_dirs(out_dir: str | Path, names: Sequence[str], overwrite: bool) -> list[Path]:
    """The bags' run directories under ``out_dir`` (created), checked before anything runs.

    Raises
    ------
    FileExistsError
        Without ``overwrite``, when a run directory already holds a run (its ``run.json`` or error file).
    """
    out = check_out_dir(out_dir).absolute()
    run_dirs = [out / n for n in names]
    if not overwrite:
        held = [str(d) for d in run_dirs if (d / "run.json").exists() or (d / ERROR_FILE).exists()]
        if held:
            raise FileExistsError(
                f"run directories already hold runs (replace them with --overwrite, or overwrite=True from Python): "
                f"{held}"
            )
    out.mkdir(parents=True, exist_ok=True)
    return run_dirs


def _lost_row(bag: str | Path, run_dir: Path, exc: BaseException) -> dict[str, Any]:
    """The table row of a bag whose task failed (the function raised, or its worker died)."""
    return {
        "bag": str(bag),
        "run_dir": str(run_dir),
        "status": "failed",
        "frames": _frames_from_record(run_dir),
        "fps": math.nan,
        "wall_s": math.nan,
        "cpu_s": math.nan,
        "people_per_frame": math.nan,
        "error": f"{type(exc).__name__}: {exc}",
    }


def _check_batch(bags: Sequence[str | Path], config: object, cluster: tuple[Any, Any] | None) -> None:
    """:func:`run_batch`'s arguments: some bags, a :class:`BagConfig`, and (without a client) the cluster's."""
    if not bags:
        raise ValueError("no bags given")
    if not isinstance(config, BagConfig):
        raise TypeError(f"config must be a BagConfig, got {type(config).__name__}")
    if cluster is not None:
        check_cluster_args(*cluster)


def _batch_tasks(
    bags: Sequence[str | Path], config: BagConfig, out_dir: str | Path, overwrite: bool
) -> tuple[list[Path], list[tuple[str, BagConfig, str]], list[str]]:
    """The run directories (checked), the task arguments (absolute bag paths) and unique task keys."""
    names = run_dir_names(bags)
    run_dirs = _run_dirs(out_dir, names, overwrite)
    args = [(str(Path(b).absolute()), config, str(d)) for b, d in zip(bags, run_dirs, strict=True)]
    keys = [f"pfpeople-batch-{k}-{n}-{time.time_ns()}" for k, n in enumerate(names)]
    return run_dirs, args, keys


def run_batch(
    bags: Sequence[str | Path],
    config: BagConfig,
    out_dir: str | Path,
    *,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    processes: bool = True,
    max_frames: int | None = None,
    overwrite: bool = False,
    progress: bool = True,
    blas_threads: int | None = None,
) -> list[dict[str, Any]]:
    """Run the pipeline over every bag, one Dask task per bag (see the module docstring).

    Parameters
    ----------
    bags : sequence of path
        ROS 1 ``.bag`` files, rosbag2 folders or ``.zip`` files of either.
    config : BagConfig
        The run configuration, the same for every bag.
    out_dir : path
        Run directories go to ``out_dir / <bag stem>`` (created).
    client : distributed.Client, optional
        Use this client; otherwise one from :func:`dask_client` (``scheduler``, ``workers``, ``processes``).
    max_frames, overwrite : int or None, bool
        Stop each run after this many frames; replace existing runs (else they are an error before anything runs).
    progress : bool
        A progress bar over completed bags (:func:`pfpeople.progress.progress_bar`).
    blas_threads : int, optional
        BLAS threads per worker process during a run (:mod:`pfpeople.pipeline.blas`; 0: no limit; None: this process's
        ``PFPEOPLE_BLAS_THREADS``, else 1, resolved here so that remote workers use the same).

    Returns
    -------
    list of dict
        One row per bag (:data:`ROW_COLUMNS`), in the order of ``bags``.
    """
    _check_batch(bags, config, None if client is not None else (scheduler, workers))
    threads = resolve_blas_threads(blas_threads)
    run_dirs, args, keys = _batch_tasks(bags, config, out_dir, overwrite)

    def task(bag: str, cfg: BagConfig, run_dir: str) -> dict[str, Any]:
        return run_bag(bag, cfg, run_dir, max_frames=max_frames, overwrite=overwrite, blas_threads=threads)

    def lost(i: int, exc: BaseException) -> dict[str, Any]:
        return _lost_row(bags[i], run_dirs[i], exc)

    def go(c: Any) -> list[dict[str, Any]]:
        rows = run_tasks(c, task, args, keys=keys, on_error=lost, progress=progress, desc="bags")
        for row, bag in zip(rows, bags, strict=True):
            row["bag"] = str(bag)  # as given, not the absolute path sent to the worker
        return rows

    if client is not None:
        return go(client)
    with dask_client(scheduler, workers, processes=processes) as c:
        return go(c)
