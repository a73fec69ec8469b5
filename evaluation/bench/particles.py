"""Benchmark: particle filter ms/step against the previous release, Stone Soup, filterpy and the grid filter.

Run ``python -m evaluation.bench.particles [--repeats K] [--sizes N ...] [--baseline REV] [--clock cpu]``
(``--clock cpu`` times with the thread's CPU time instead of the wall clock; it pins one core,
as the targets of issue 26 are stated: 1e5 particles <= 3 ms/step, 1e6 <= 25 ms/step and at least 15 times
Stone Soup's bootstrap particle step, on the paper's 30 x 30 grid).

Scenario (fixed): the paper's grid and detectors; the robot drives at 0.5 m/s turning at 0.2 rad/s with the
default odometry noise; every frame the three detectors fire (laser_legs twice, laser_boosted twice, camera
once) at fixed positions; dt = 0.1 s. Each configuration runs ``--warmup`` steps, then ``--repeats`` timed
steps; the table gives the median ms per step.

Every size is measured twice in the same run, each in its own process (``--worker``, which prints one JSON
line): with this checkout's packages and with the previous release's (``--baseline REV``, default
:data:`evaluation.bench.release_baseline.PREVIOUS_RELEASE`; ``none`` skips it), checked out under ``.bench/``.

Columns: ``now ms`` is :class:`pfpeople.ParticleFilter` as configured by default (ESS-triggered resampling;
``resamp`` the fraction of timed steps that resampled), ``release`` the same in the previous release, ``ratio``
release / now. ``forced`` resamples every step (our systematic resampler), now and in the release.
``filterpy`` is the forced filter with ``filterpy.monte_carlo.systematic_resample`` (a pure-Python loop on the
global NumPy RNG) in place of ours; ``stonesoup`` is Stone Soup's bootstrap particle step (one target, no grid;
skipped when Stone Soup is not installed) and ``x soup`` stonesoup / now. ``RSS MB`` is each worker's peak
resident set size after its particle-filter runs (the process with its imports; the first row's worker also
measured the grid filter). The grid filter's ms/step (paper and linear forms) is measured in the first row's
workers.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, as the speed targets say

import argparse  # noqa: E402
import datetime  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Literal  # noqa: E402

import numpy as np  # noqa: E402
from filterpy.monte_carlo import systematic_resample  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from gridbridge import GridFilter, Odometry  # noqa: E402
from pfpeople import ParticleFilter  # noqa: E402

#: The grid filter's forms (as in :mod:`evaluation.bench.grid`, which a worker of the previous release cannot
#: import).
FORMS: tuple[Literal["paper", "linear"], ...] = ("paper", "linear")

DETECTIONS = [
    np.array([[3.0, 0.5], [5.0, -1.0]]),
    np.array([[3.1, 0.4], [6.0, 2.0]]),
    np.array([[4.0, 0.0]]),
]
ODOMETRY = Odometry(v=0.5, omega=0.2)
DT = 0.1

#: Wall clock or this thread's CPU time (``--clock cpu``: less sensitive to other load on a shared machine).
#: Defined here, not imported: a worker run against a release imports the release's evaluation package.
CLOCKS = {"wall": time.perf_counter, "cpu": time.thread_time}
_CLOCK = {"name": "wall"}


def filterpy_systematic(weights: NDArray[np.float64], n: int, *, rng: np.random.Generator) -> NDArray[np.intp]:
    """filterpy's systematic resampler as a drop-in: ``len(weights)`` draws thinned evenly to ``n``.

    filterpy draws its offset from the global ``np.random``; it is seeded from ``rng`` so runs repeat.
    """
    np.random.seed(int(rng.integers(2**32)))  # noqa: NPY002 (filterpy reads the global RNG)
    w = np.asarray(weights, dtype=float)
    idx = systematic_resample(w / w.sum())
    pick = np.linspace(0, len(idx) - 1, n).astype(np.intp) if n < len(idx) else np.arange(len(idx))
    return np.asarray(idx[pick], dtype=np.intp)


def _time_steps(step: Callable[[], object], warmup: int, repeats: int) -> tuple[float, list[bool]]:
    """Median ms of ``step`` and whether each timed step resampled.

    Only the flag of each output is kept: holding on to the outputs (with 1e6 particles, 40 MB each) would make
    every later step allocate fresh pages and measure the allocator instead of the filter.
    """
    for _ in range(warmup):
        step()
    times, flags = [], []
    clock = CLOCKS[_CLOCK["name"]]
    for _ in range(repeats):
        t0 = clock()
        out = step()
        times.append(clock() - t0)
        flags.append(bool(getattr(out, "resampled", False)))
        del out
    return 1e3 * statistics.median(times), flags


def _has_components() -> bool:
    """Whether the imported ``pfpeople`` has the particle components (a file test, not an import: an editable
    install of this checkout would supply the module to a release's worker)."""
    import pfpeople

    particle = Path(pfpeople.__file__ or "").parent / "particle"
    return (particle / "components.py").is_file() or (particle / "resampler" / "policy.py").is_file()


def _particle_filter(n: int, **resampling: Any) -> ParticleFilter:
    """The benchmark's particle filter with ``n`` particles, resampling as ``resampling`` says (``ess_threshold``,
    ``resampler``: a scheme name or callable): through the components of this checkout
    (:class:`pfpeople.Resampling`) or, in a release without them, the constructor's keywords."""
    if not _has_components():
        return ParticleFilter(n_particles=n, rng=np.random.default_rng(2015), **resampling)  # a release's keywords
    from pfpeople import Resampling

    policy = Resampling(
        scheme=resampling.pop("resampler", "systematic"), ess_threshold=resampling.pop("ess_threshold", 0.5)
    )
    if resampling:
        raise TypeError(f"unknown resampling settings {sorted(resampling)}")
    return ParticleFilter(n_particles=n, rng=np.random.default_rng(2015), resampling=policy)


def _pf_case(n: int, warmup: int, repeats: int, **resampling: Any) -> tuple[float, float]:
    pf = _particle_filter(n, **resampling)
    ms, flags = _time_steps(lambda: pf.step(DETECTIONS, ODOMETRY, DT), warmup, repeats)
    frac = float(np.mean(flags))
    return ms, frac


def stonesoup_ms(n: int, warmup: int, repeats: int) -> float:
    """Median ms of Stone Soup's bootstrap particle step with ``n`` particles (NaN when it is not installed).

    The simpler filter a user could take off the shelf: one target, a constant-velocity transition model in
    x and y, a linear Gaussian position measurement, systematic resampling every step (``ParticlePredictor``,
    ``ParticleUpdater(resampler=SystematicResampler())``); no grid, no births.
    """
    try:
        from stonesoup.models.measurement.linear import LinearGaussian
        from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
        from stonesoup.predictor.particle import ParticlePredictor
        from stonesoup.resampler.particle import SystematicResampler
        from stonesoup.types.array import StateVectors
        from stonesoup.types.detection import Detection
        from stonesoup.types.hypothesis import SingleHypothesis
        from stonesoup.types.state import ParticleState as SSParticleState
        from stonesoup.updater.particle import ParticleUpdater
    except ImportError:
        return math.nan
    start = datetime.datetime(2026, 1, 1)
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05), ConstantVelocity(0.05)])
    measurement = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.diag([0.1, 0.1]))
    predictor = ParticlePredictor(transition)
    updater = ParticleUpdater(measurement, resampler=SystematicResampler())
    rng = np.random.default_rng(2015)
    state = [
        SSParticleState(StateVectors(rng.normal(size=(4, n))), log_weight=np.full(n, -math.log(n)), timestamp=start)
    ]

    def step() -> None:
        t = state[0].timestamp + datetime.timedelta(seconds=DT)
        prior = predictor.predict(state[0], timestamp=t)
        det = Detection(np.array([[3.0], [0.5]]), timestamp=t, measurement_model=measurement)
        state[0] = updater.update(SingleHypothesis(prior, det))

    ms, _ = _time_steps(step, warmup, repeats)
    return ms


def _rss_mb() -> float:
    """Peak resident set size of this process so far (MB; ``ru_maxrss`` is in kB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def measure(
    sizes: Sequence[int], repeats: int, warmup: int, baseline_max: int, *, grid: bool = True, stonesoup_max: int = 0
) -> dict[str, Any]:
    """Measure the grid filter and, per particle count, the PF (ESS, forced) and the filterpy baseline.

    Returns ``{"grid": {form: ms}, "particles": [{"n", "pf_ms", "resampled", "forced_ms", "filterpy_ms",
    "ratio", "stonesoup_ms", "rss_mb"}, ...], "rss_start_mb"}`` (``filterpy_ms`` and ``ratio`` are NaN above
    ``baseline_max``, ``stonesoup_ms`` above ``stonesoup_max`` or without Stone Soup; ``rss_mb`` is the peak RSS
    after the row's particle-filter runs, before its peers).
    """
    rss_start = _rss_mb()
    _pf_case(max(sizes), 3, 1)  # untimed: lets the process grow its heap once, so the first row is not penalised
    forms = {}
    if grid:
        for form in FORMS:
            gf = GridFilter(form=form)
            forms[form], _ = _time_steps(functools.partial(gf.step, DETECTIONS, ODOMETRY, DT), warmup, repeats)
    rows = []
    for n in sizes:
        ms, frac = _pf_case(n, warmup, repeats)
        forced, _ = _pf_case(n, warmup, repeats, ess_threshold=2.0)
        rss = _rss_mb()
        base = math.nan
        if n <= baseline_max:
            base, _ = _pf_case(
                n, min(warmup, 1), max(3, repeats // 4), ess_threshold=2.0, resampler=filterpy_systematic
            )
        soup = stonesoup_ms(n, min(warmup, 1), max(2, repeats // 8)) if n <= stonesoup_max else math.nan
        rows.append(
            {
                "n": n,
                "pf_ms": ms,
                "resampled": frac,
                "forced_ms": forced,
                "filterpy_ms": base,
                "ratio": base / forced,
                "stonesoup_ms": soup,
                "rss_mb": rss,
            }
        )
    return {"grid": forms, "particles": rows, "rss_start_mb": rss_start}


def _worker_args(n: int, args: argparse.Namespace, *, peers: bool, grid: bool) -> list[str]:
    out = ["--worker", "--sizes", str(n), "--repeats", str(args.repeats), "--warmup", str(args.warmup)]
    out += ["--clock", args.clock]
    out += ["--baseline-max", str(args.baseline_max if peers else 0)]
    out += ["--stonesoup-max", str(args.stonesoup_max if peers else 0)]
    return out + ([] if grid else ["--no-grid"])


def collect(args: argparse.Namespace) -> dict[str, Any]:
    """Run the workers: per size this checkout's (with the peers) and the previous release's, alternating which
    goes first; each in its own process (its own peak RSS). Returns ``{"grid", "grid_release", "rows"}``."""
    from evaluation.bench.release_baseline import REPO, release_checkout, run_worker

    root = None if args.baseline.lower() == "none" else release_checkout(args.baseline)
    rows: list[dict[str, Any]] = []
    grid: dict[str, float] = {}
    grid_rel: dict[str, float] = {}
    for k, n in enumerate(args.sizes):
        first = k == 0
        runs: dict[str, Any] = {}
        order = [("now", REPO), ("release", root)] if k % 2 == 0 else [("release", root), ("now", REPO)]
        for name, where in order:
            if where is not None:
                wargs = _worker_args(n, args, peers=name == "now", grid=first)
                runs[name] = run_worker(where, "evaluation.bench.particles", wargs)
        now = runs["now"]["particles"][0]
        rel = runs["release"]["particles"][0] if "release" in runs else None
        rows.append({"now": now, "release": rel, "rss_start_mb": runs["now"]["rss_start_mb"]})
        if first:
            grid = runs["now"]["grid"]
            grid_rel = runs["release"]["grid"] if "release" in runs else {}
    return {"grid": grid, "grid_release": grid_rel, "rows": rows}


def _f(value: float | None, spec: str, width: int) -> str:
    return f"{'-':>{width}}" if value is None or math.isnan(value) else f"{value:{width}{spec}}"


def table(data: dict[str, Any]) -> list[str]:
    """The table's lines from :func:`collect`'s result."""
    lines = []
    for form, ms in data["grid"].items():
        rel = data["grid_release"].get(form)
        tail = "" if rel is None else f"  (previous release {rel:.2f} ms, ratio {rel / ms:.2f})"
        lines.append(f"grid filter ({form:6s})  {ms:8.2f} ms/step{tail}")
    header = (
        f"{'particles':>9} {'now ms':>8} {'release':>8} {'ratio':>6} {'resamp':>6} {'forced':>8} {'release':>8} "
        f"{'ratio':>6} {'filterpy':>9} {'stonesoup':>10} {'x soup':>7} {'RSS MB':>7} {'release':>7}"
    )
    lines += ["", header, "-" * len(header)]
    for row in data["rows"]:
        now, rel = row["now"], row["release"] or {}
        get = rel.get
        lines.append(
            f"{now['n']:>9d} {now['pf_ms']:8.2f} {_f(get('pf_ms'), '.2f', 8)} "
            f"{_f(get('pf_ms', math.nan) / now['pf_ms'], '.2f', 6)} {now['resampled']:6.2f} "
            f"{now['forced_ms']:8.2f} {_f(get('forced_ms'), '.2f', 8)} "
            f"{_f(get('forced_ms', math.nan) / now['forced_ms'], '.2f', 6)} {_f(now['filterpy_ms'], '.1f', 9)} "
            f"{_f(now['stonesoup_ms'], '.1f', 10)} {_f(now['stonesoup_ms'] / now['pf_ms'], '.1f', 7)} "
            f"{now['rss_mb']:7.0f} {_f(get('rss_mb'), '.0f', 7)}"
        )
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m evaluation.bench.particles", description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000, 1_000_000])
    parser.add_argument("--repeats", type=int, default=20, help="timed steps per configuration (median)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed steps first")
    parser.add_argument(
        "--baseline-max", type=int, default=1_000_000, help="largest N for the (slow) filterpy baseline"
    )
    parser.add_argument("--stonesoup-max", type=int, default=1_000_000, help="largest N for the Stone Soup peer")
    parser.add_argument(
        "--baseline", default=None, help="git revision of the previous release to compare with ('none': skip)"
    )
    parser.add_argument("--worker", action="store_true", help="measure in this process, print one JSON line")
    parser.add_argument("--no-grid", action="store_true", help="(worker) skip the grid filter's rows")
    parser.add_argument("--clock", choices=("cpu", "wall"), default="wall", help="wall clock or thread CPU time")
    args = parser.parse_args(argv)
    if args.repeats < 1 or args.warmup < 0 or any(n < 1 for n in args.sizes):
        parser.error("--repeats must be >= 1, --warmup >= 0 and --sizes positive")
    _CLOCK["name"] = args.clock
    if args.worker:
        data = measure(
            args.sizes,
            args.repeats,
            args.warmup,
            args.baseline_max,
            grid=not args.no_grid,
            stonesoup_max=args.stonesoup_max,
        )
        print(json.dumps(data), flush=True)
        return 0
    if args.baseline is None:
        from evaluation.bench.release_baseline import PREVIOUS_RELEASE

        args.baseline = PREVIOUS_RELEASE
    print(
        f"median ms per step, one core; previous release {args.baseline}, measured in the same run; "
        f"clock: {args.clock}",
        flush=True,
    )
    for line in table(collect(args)):
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
