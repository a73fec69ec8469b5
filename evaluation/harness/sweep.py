"""Parameter sweeps on Dask: scenarios x seeds x parameter values, one A/B evaluation per task.

Each point of the Cartesian product ``scenarios x seeds x values(key_1) x ... x values(key_n)`` is one Dask
task (:func:`run_point`) that simulates the scenario with that seed (:class:`evaluation.scenarios.Scenario`)
and runs :func:`evaluation.harness.ab.run_ab` with the point's filters, returning metric rows:

- one row per detector alone (``classifier = "detector"``, ``filter`` = the detector name);
- per filter, one row per classifier (``"blobs"``, the paper's; ``"threshold"``, connected cells above 0.5):
  ``recall``, ``precision``, ``fpcpf`` (false-positive cells per frame), ``ms_per_iter`` (median filter step,
  ms; on the filter's rows only), ``tracked_fraction`` (the paper's tracking application, blob rows only).

Every row also holds ``scenario``, ``seed``, the swept keys' values, ``task`` (the task's name, also its
record folder ``OUT/tasks/<task>/run.json``), ``n_frames``, ``wall_s``, ``status`` and ``error``. A task that
fails yields one row with ``status = "failed"`` and the error (its traceback in ``OUT/tasks/<task>/error.txt``);
the other tasks go on. The seed is the scenario's seed (robot path, people, detectors, odometry noise) and the
particle filters' seed.

The sweepable keys are :data:`SWEEP_KEYS` (anything else is an error naming the key): ``frames``,
``particles`` (0: no particle filter), ``form``, ``motion_model``, ``mode``, ``gate``, ``odometry``. The filters
of a point, in each of its modes (``mode``; default both, ``paper`` and ``recommended``):

- paper mode: the paper's grid filter in the point's ``form`` (``grid (paper)``, ``grid (linear)``) and
  (``particles > 0``) the particle filter with that count and ``motion_model`` (default ``paper``),
  classified by blobs;
- recommended mode: the recommended grid filter (``recommended grid``; it has no ``form``) and
  (``particles > 0``) the recommended particle filter with that count and ``motion_model`` (default
  ``persistent``, the recommended mode's), classified by the recommended peaks (``classifier = "peaks"``).

Each filter (and the detectors' rows) runs once per sweep: a point runs only what depends on a value no earlier
point had (:data:`RUN_KEYS`), so a grid filter is run once whatever the particle counts and the recommended grid
once whatever the forms; its rows leave the swept keys it does not depend on empty. A point with nothing left is
not a task.
"""

from __future__ import annotations

import itertools
import math
import re
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

__all__ = [
    "RUN_KEYS",
    "SWEEP_KEYS",
    "SweepKey",
    "SweepPoint",
    "parse_param",
    "run_point",
    "run_sweep",
    "sweep_points",
]


def _int_at_least(minimum: int) -> Callable[[str, str], int]:
    def parse(key: str, text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise ValueError(f"sweep parameter {key!r}: {text!r} is not an integer") from None
        if value < minimum:
            raise ValueError(f"sweep parameter {key!r}: {value} must be >= {minimum}")
        return value

    return parse


def _positive_float(key: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"sweep parameter {key!r}: {text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"sweep parameter {key!r}: {value} must be a positive number")
    return value


def _choice(*options: str) -> Callable[[str, str], str]:
    def parse(key: str, text: str) -> str:
        if text not in options:
            raise ValueError(f"sweep parameter {key!r}: {text!r} is not one of {list(options)}")
        return text

    return parse


@dataclass(frozen=True, kw_only=True)
class SweepKey:
    """A sweepable parameter: how its values are parsed and checked, its default and what it sets.

    Attributes
    ----------
    parse : callable
        ``parse(key, text)``: the value, or ``ValueError``.
    default : object
        The value of a point that does not sweep the key.
    help : str
        What it sets, for ``--help``; :attr:`text` adds the accepted values.
    choices : tuple of str
        The accepted values of a key with a fixed set of them (empty for numbers).
    default_text : str or None
        What a point that does not sweep the key runs, as :attr:`text` states it (None: ``default``).
    """

    parse: Callable[[str, str], Any]
    default: Any
    help: str
    choices: tuple[str, ...] = ()
    default_text: str | None = None

    @property
    def text(self) -> str:
        """The help with the accepted values, e.g. ``"... (paper|linear; default paper)"``."""
        if not self.choices:
            return self.help
        default = f"default {self.default}" if self.default_text is None else f"unset: {self.default_text}"
        return f"{self.help} ({'|'.join(self.choices)}; {default})"


def _choice_key(
    choices: tuple[str, ...], *, default: str | None, help: str, default_text: str | None = None
) -> SweepKey:
    return SweepKey(parse=_choice(*choices), default=default, help=help, choices=choices, default_text=default_text)


#: The sweepable parameters (``--param KEY=V1,V2``).
SWEEP_KEYS: dict[str, SweepKey] = {
    "frames": SweepKey(parse=_int_at_least(1), default=None, help="scenario frames (default: the scenario's)"),
    "particles": SweepKey(
        parse=_int_at_least(0), default=5_000, help="particle count of the particle filters (0: grid filters only)"
    ),
    "form": _choice_key(
        ("paper", "linear"),
        default="paper",
        help="prediction form of the paper-mode grid filter",
    ),
    "motion_model": _choice_key(
        ("paper", "persistent"),
        default=None,
        help="particle filters' people motion model",
        default_text="paper in paper mode, persistent in recommended mode",
    ),
    "mode": _choice_key(
        ("paper", "recommended"),
        default=None,
        help="filter mode: the paper's filters or the recommended ones",
        default_text="each point runs both",
    ),
    "gate": SweepKey(parse=_positive_float, default=0.5, help="matching distance (m) for recall / precision"),
    "odometry": _choice_key(
        ("noisy", "true"),
        default="noisy",
        help="odometry given to the filters: the simulated robot's noisy one or the true motion",
    ),
}

#: What a point runs (``"detectors"``: the detectors' own rows; ``"<kind> <mode>"``: a filter) and the keys it
#: depends on besides the scenario, seed, ``frames``, ``gate`` and ``odometry``: the same values of these give the
#: same rows, so each runs once per sweep. A mode's filters run only in points of that mode (or of both).
RUN_KEYS: dict[str, tuple[str, ...]] = {
    "detectors": (),
    "grid paper": ("form",),
    "grid recommended": (),
    "particle paper": ("particles", "motion_model"),
    "particle recommended": ("particles", "motion_model"),
}
_COMMON_KEYS = ("frames", "gate", "odometry")


def parse_param(text: str) -> tuple[str, list[Any]]:
    """``"KEY=V1,V2"`` -> ``(KEY, [v1, v2])`` with the values parsed and checked (:data:`SWEEP_KEYS`)."""
    key, sep, values = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ValueError(f"sweep parameter {text!r}: expected KEY=V1,V2,...")
    if key not in SWEEP_KEYS:
        raise ValueError(f"unknown sweep parameter {key!r}; sweepable: {sorted(SWEEP_KEYS)}")
    items = [v.strip() for v in values.split(",")]
    if not values.strip() or any(not v for v in items):
        raise ValueError(f"sweep parameter {key!r}: empty value in {values!r}")
    parsed = [SWEEP_KEYS[key].parse(key, v) for v in items]
    if len(set(parsed)) != len(parsed):
        raise ValueError(f"sweep parameter {key!r}: repeated value in {values!r}")
    return key, parsed


@dataclass(frozen=True, kw_only=True)
class SweepPoint:
    """One task of a sweep: a scenario (built-in name or TOML path), a seed and one value per swept key."""

    scenario: str
    seed: int
    params: tuple[tuple[str, Any], ...] = ()
    #: What the point runs (keys of :data:`RUN_KEYS`); None: everything its parameters give (:meth:`all_runs`).
    runs: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.scenario, str) or not self.scenario:
            raise ValueError(f"SweepPoint.scenario must be a non-empty string, got {self.scenario!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"SweepPoint.seed must be a non-negative integer, got {self.seed!r}")
        for key, _ in self.params:
            if key not in SWEEP_KEYS:
                raise ValueError(f"unknown sweep parameter {key!r}; sweepable: {sorted(SWEEP_KEYS)}")
        for run in self.runs or ():
            if run not in RUN_KEYS:
                raise ValueError(f"SweepPoint.runs: unknown run {run!r}; known: {list(RUN_KEYS)}")

    def all_runs(self) -> tuple[str, ...]:
        """Everything the point's parameters give: the detectors and each filter of its modes (``mode``)."""
        modes = ("paper", "recommended") if self.value("mode") is None else (self.value("mode"),)
        kinds = ("grid", "particle") if self.value("particles") > 0 else ("grid",)
        return ("detectors", *(f"{kind} {mode}" for kind in kinds for mode in modes))

    def planned(self) -> tuple[str, ...]:
        """What the point runs: :attr:`runs`, or :meth:`all_runs` when that is None."""
        return self.all_runs() if self.runs is None else self.runs

    def run_values(self, run: str) -> tuple[tuple[str, Any], ...]:
        """The swept values that ``run`` depends on (:data:`RUN_KEYS`), in the point's order."""
        keys = (*_COMMON_KEYS, *RUN_KEYS[run])
        return tuple((k, v) for k, v in self.params if k in keys)

    def value(self, key: str) -> Any:
        """The point's value of ``key``, else its default."""
        return dict(self.params).get(key, SWEEP_KEYS[key].default)

    @property
    def name(self) -> str:
        """A file-system-safe task name, e.g. ``complementary_seed1_particles=500``."""
        stem = Path(self.scenario).stem if self.scenario.endswith(".toml") else self.scenario
        parts = [stem, f"seed{self.seed}", *(f"{k}={v}" for k, v in self.params)]
        return re.sub(r"[^A-Za-z0-9_.=-]", "_", "_".join(parts))


def sweep_points(
    scenarios: Sequence[str], seeds: Sequence[int], params: Mapping[str, Sequence[Any]]
) -> list[SweepPoint]:
    """The tasks of ``scenarios x seeds x params`` (in that order, the last key varying fastest).

    Each point's :attr:`SweepPoint.runs` leaves out what an earlier point runs with the same values (a grid
    filter is run once whatever the particle counts); a point with nothing left out of the product is dropped.
    """
    if not scenarios:
        raise ValueError("no scenario given")
    if not seeds:
        raise ValueError("no seed given")
    if len(set(scenarios)) != len(scenarios) or len(set(seeds)) != len(seeds):
        raise ValueError("scenarios and seeds must not repeat")
    for key, values in params.items():
        if key not in SWEEP_KEYS:
            raise ValueError(f"unknown sweep parameter {key!r}; sweepable: {sorted(SWEEP_KEYS)}")
        if not values:
            raise ValueError(f"sweep parameter {key!r} has no value")
    keys = list(params)
    done: set[tuple[Any, ...]] = set()
    out = []
    for sc, seed in itertools.product(scenarios, seeds):
        for combo in itertools.product(*(params[k] for k in keys)):
            point = SweepPoint(scenario=sc, seed=int(seed), params=tuple(zip(keys, combo, strict=True)))
            runs = []
            for run in point.all_runs():  # each run once per sweep (RUN_KEYS): the first point that has it
                identity = (sc, int(seed), run, point.run_values(run))
                if identity not in done:
                    done.add(identity)
                    runs.append(run)
            if runs:
                out.append(SweepPoint(scenario=sc, seed=int(seed), params=point.params, runs=tuple(runs)))
    return out


def _filter(point: SweepPoint, run: str) -> Any:
    """The :class:`evaluation.harness.ab.FilterSpec` of one filter run (``"<kind> <mode>"``) of ``point``."""
    from evaluation.harness.ab import FilterSpec, particles_label
    from pfpeople.config import FilterConfig

    kind, mode = run.split()
    if kind == "grid":
        if mode == "recommended":
            return FilterSpec(name="recommended grid", mode="recommended")
        return FilterSpec(name=f"grid ({point.value('form')})", form=point.value("form"))
    n = point.value("particles")
    default = FilterConfig(mode=cast(Any, mode)).motion_model
    model = point.value("motion_model") or default
    label = particles_label(n) + ("" if model == default else f" {model}")
    if mode == "recommended":
        label = f"recommended {label}"
    return FilterSpec(name=label, kind="particle", n_particles=n, motion_model=cast(Any, model), mode=cast(Any, mode))


def _filters(point: SweepPoint) -> list[tuple[str, Any]]:
    """``(run, FilterSpec)`` of each filter the point runs."""
    return [(run, _filter(point, run)) for run in point.planned() if run != "detectors"]


def _base_row(point: SweepPoint, run: str | None = None) -> dict[str, Any]:
    """The row's task, scenario, seed and swept values; with ``run``, the values it does not depend on empty."""
    row: dict[str, Any] = {"task": point.name, "scenario": point.scenario, "seed": point.seed}
    row.update(dict(point.params))
    if run is not None:
        kept = dict(point.run_values(run))
        if "mode" in row and run != "detectors":
            kept["mode"] = row["mode"]
        row.update({k: kept.get(k) for k, _ in point.params})
    return row


def run_point(point: SweepPoint, out_dir: str | Path | None = None) -> list[dict[str, Any]]:
    """Evaluate one sweep point; never raises for a failing evaluation: returns its rows (see module docstring).

    Parameters
    ----------
    point : SweepPoint
        The task: scenario, seed, values and what it runs (:meth:`SweepPoint.planned`).
    out_dir : path, optional
        The A/B run record goes to ``out_dir/tasks/<point.name>/run.json`` (or ``error.txt``).

    Returns
    -------
    list of dict
        The point's rows (one ``failed`` row when the evaluation raised).
    """
    from evaluation.harness.ab import run_ab
    from evaluation.scenarios.scenario import Scenario

    t0 = time.perf_counter()
    task_dir = None if out_dir is None else Path(out_dir) / "tasks" / point.name
    try:
        filters = _filters(point)
        scenario = Scenario.from_name(point.scenario, n_frames=point.value("frames"), seed=point.seed)
        result = run_ab(
            scenario,
            [spec for _, spec in filters],
            gate=point.value("gate"),
            out_dir=task_dir,
            seed=point.seed,
            noisy_odometry=point.value("odometry") == "noisy",
        )
    except Exception as exc:
        if task_dir is not None:
            try:
                task_dir.mkdir(parents=True, exist_ok=True)
                (task_dir / "error.txt").write_text(f"{point}\n{traceback.format_exc()}")
            except OSError:
                pass
        error = f"{type(exc).__name__}: {exc}"
        return [{**_base_row(point), "status": "failed", "error": error, "wall_s": time.perf_counter() - t0}]
    rows = _result_rows(point, [run for run, _ in filters], result)
    for row in rows:
        row.update(n_frames=result.n_frames, wall_s=time.perf_counter() - t0, status="complete", error="")
    return rows


def _result_rows(point: SweepPoint, runs: Sequence[str], result: Any) -> list[dict[str, Any]]:
    """The metric rows of an A/B result whose filters are the point's ``runs``, in that order."""
    rows: list[dict[str, Any]] = []

    def add(run: str, filter_name: str, classifier: str, s: Mapping[str, Any], **extra: Any) -> None:
        metrics = {"recall": s["recall"], "precision": s["precision"], "fpcpf": s["fpcpf"]}
        rows.append({**_base_row(point, run), "filter": filter_name, "classifier": classifier, **metrics, **extra})

    if "detectors" in point.planned():
        for name, s in result.detector_scores.items():
            add("detectors", name, "detector", s)
    for run, r in zip(runs, result.filters, strict=True):
        tracked = r.tracking.get("tracked_fraction", math.nan) if r.tracking else math.nan
        add(run, r.name, r.classifier, r.scores, ms_per_iter=r.ms_per_iteration, tracked_fraction=tracked)
        add(run, r.name, "threshold", r.threshold_scores, ms_per_iter=r.ms_per_iteration)
    return rows


#: Columns of a sweep table, before the swept keys are inserted after ``seed``.
_COLUMNS = (
    "task",
    "scenario",
    "seed",
    "filter",
    "classifier",
    "recall",
    "precision",
    "fpcpf",
    "ms_per_iter",
    "tracked_fraction",
    "n_frames",
    "wall_s",
    "status",
    "error",
)


def columns_for(keys: Sequence[str]) -> list[str]:
    """The table columns of a sweep over ``keys``."""
    cols = list(_COLUMNS)
    at = cols.index("seed") + 1
    return [*cols[:at], *keys, *cols[at:]]


def check_scenarios(scenarios: Sequence[str]) -> None:
    """Load each scenario's configuration (not its frames): an unknown name or bad file fails here."""
    from evaluation.scenarios.scenario import load_scenario_config

    for name in scenarios:
        try:
            load_scenario_config(name)
        except (ValueError, OSError) as exc:
            raise ValueError(f"scenario {name!r}: {exc}") from None


def run_sweep(
    scenarios: Sequence[str],
    seeds: Sequence[int],
    params: Mapping[str, Sequence[Any]],
    out_dir: str | Path | None = None,
    *,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    processes: bool = True,
    progress: bool = True,
) -> list[dict[str, Any]]:
    """Run a sweep (see the module docstring): one Dask task per point, rows in point order.

    Parameters
    ----------
    scenarios : sequence of str
        Built-in scenario names or scenario TOML files.
    seeds : sequence of int
        Scenario (and particle filter) seeds.
    params : mapping of str to sequence
        Swept keys (:data:`SWEEP_KEYS`) and their values (parsed, e.g. by :func:`parse_param`).
    out_dir : path, optional
        Task records go to ``out_dir/tasks/<task>``.
    client, scheduler, workers, processes
        As :func:`pfpeople.pipeline.batch.run_batch`.
    """
    from pfpeople.pipeline.batch import check_cluster_args, dask_client, run_tasks

    if client is None:
        check_cluster_args(scheduler, workers)
    checked: dict[str, list[Any]] = {}
    for key, values in params.items():  # values given programmatically are checked like parsed ones
        if key not in SWEEP_KEYS:
            raise ValueError(f"unknown sweep parameter {key!r}; sweepable: {sorted(SWEEP_KEYS)}")
        checked[key] = [SWEEP_KEYS[key].parse(key, str(v)) for v in values]
    points = sweep_points(scenarios, seeds, checked)
    check_scenarios(scenarios)
    out = None if out_dir is None else Path(out_dir).absolute()
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    stamp = time.time_ns()
    keys = [f"pfpeople-sweep-{k}-{p.name}-{stamp}" for k, p in enumerate(points)]
    args = [(p, None if out is None else str(out)) for p in points]

    def lost(i: int, exc: BaseException) -> list[dict[str, Any]]:
        return [{**_base_row(points[i]), "status": "failed", "error": f"{type(exc).__name__}: {exc}"}]

    def go(c: Any) -> list[dict[str, Any]]:
        per_task = run_tasks(c, run_point, args, keys=keys, on_error=lost, progress=progress, desc="sweep")
        return [row for rows in per_task for row in rows]

    if client is not None:
        return go(client)
    with dask_client(scheduler, workers, processes=processes) as c:
        return go(c)
