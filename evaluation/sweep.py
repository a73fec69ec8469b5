"""Parameter sweeps on Dask: scenarios x seeds x parameter values, one A/B evaluation per task.

Each point of the Cartesian product ``scenarios x seeds x values(key_1) x ... x values(key_n)`` is one Dask
task (:func:`run_point`) that simulates the scenario with that seed (:class:`evaluation.scenarios.Scenario`)
and runs :func:`evaluation.ab.run_ab` with the point's filters, returning metric rows:

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
``particles`` (0: no particle filter), ``form``, ``motion_model``, ``gate``, ``odometry``. The filters of a
point: the grid filter in the point's ``form``, and (``particles > 0``) the particle filter with that count and
``motion_model``.
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
from typing import Any

__all__ = [
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
    """A sweepable parameter: how its values are parsed and checked, its default and what it sets."""

    parse: Callable[[str, str], Any]
    default: Any
    help: str


#: The sweepable parameters (``--param KEY=V1,V2``).
SWEEP_KEYS: dict[str, SweepKey] = {
    "frames": SweepKey(parse=_int_at_least(1), default=None, help="scenario frames (default: the scenario's)"),
    "particles": SweepKey(
        parse=_int_at_least(0), default=5_000, help="particle count of the particle filter (0: grid filter only)"
    ),
    "form": SweepKey(parse=_choice("paper", "linear"), default="paper", help="grid filter prediction form"),
    "motion_model": SweepKey(
        parse=_choice("paper", "persistent"), default="paper", help="particle filter people motion model"
    ),
    "gate": SweepKey(parse=_positive_float, default=0.5, help="matching distance (m) for recall / precision"),
    "odometry": SweepKey(
        parse=_choice("noisy", "true"), default="noisy", help="odometry given to the filters: reported or true"
    ),
}


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

    def __post_init__(self) -> None:
        if not isinstance(self.scenario, str) or not self.scenario:
            raise ValueError(f"SweepPoint.scenario must be a non-empty string, got {self.scenario!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"SweepPoint.seed must be a non-negative integer, got {self.seed!r}")
        for key, _ in self.params:
            if key not in SWEEP_KEYS:
                raise ValueError(f"unknown sweep parameter {key!r}; sweepable: {sorted(SWEEP_KEYS)}")

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
    """The Cartesian product ``scenarios x seeds x params`` (in that order, the last key varying fastest)."""
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
    return [
        SweepPoint(scenario=sc, seed=int(seed), params=tuple(zip(keys, combo, strict=True)))
        for sc, seed in itertools.product(scenarios, seeds)
        for combo in itertools.product(*(params[k] for k in keys))
    ]


def _filters(point: SweepPoint) -> list[Any]:
    from evaluation.ab import FilterSpec, particles_label

    form = point.value("form")
    out = [FilterSpec(name=f"grid ({form})", form=form)]
    n = point.value("particles")
    if n > 0:
        model = point.value("motion_model")
        label = particles_label(n) + (" persistent" if model == "persistent" else "")
        out.append(FilterSpec(name=label, kind="particle", n_particles=n, motion_model=model))
    return out


def _base_row(point: SweepPoint) -> dict[str, Any]:
    row: dict[str, Any] = {"task": point.name, "scenario": point.scenario, "seed": point.seed}
    row.update(dict(point.params))
    return row


def run_point(point: SweepPoint, out_dir: str | Path | None = None) -> list[dict[str, Any]]:
    """Evaluate one sweep point; never raises for a failing evaluation: returns its rows (see module docstring).

    With ``out_dir``, the A/B run record goes to ``out_dir/tasks/<point.name>/run.json`` (or ``error.txt``).
    """
    from evaluation.ab import run_ab
    from evaluation.scenarios.scenario import Scenario

    t0 = time.perf_counter()
    task_dir = None if out_dir is None else Path(out_dir) / "tasks" / point.name
    base = _base_row(point)
    try:
        scenario = Scenario.from_name(point.scenario, n_frames=point.value("frames"), seed=point.seed)
        result = run_ab(
            scenario,
            _filters(point),
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
        return [
            {
                **base,
                "status": "failed",
                "error": f"{type(exc).__name__}: {exc}",
                "wall_s": time.perf_counter() - t0,
            }
        ]
    wall = time.perf_counter() - t0
    rows: list[dict[str, Any]] = []

    def add(filter_name: str, classifier: str, s: Mapping[str, Any], **extra: Any) -> None:
        rows.append(
            {
                **base,
                "filter": filter_name,
                "classifier": classifier,
                "recall": s["recall"],
                "precision": s["precision"],
                "fpcpf": s["fpcpf"],
                **extra,
            }
        )

    for name, s in result.detector_scores.items():
        add(name, "detector", s)
    for r in result.filters:
        tracked = r.tracking.get("tracked_fraction", math.nan) if r.tracking else math.nan
        add(r.name, "blobs", r.scores, ms_per_iter=r.ms_per_iteration, tracked_fraction=tracked)
        add(r.name, "threshold", r.threshold_scores, ms_per_iter=r.ms_per_iteration)
    for row in rows:
        row.update(n_frames=result.n_frames, wall_s=wall, status="complete", error="")
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
        As :func:`pfpeople.batch.run_batch`.
    """
    from pfpeople.batch import check_cluster_args, dask_client, run_tasks

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
