"""Soak benchmark: many filter steps on random input, per filter mode; no NaN, bounded mass, flat memory and speed.

Run ``python -m evaluation.bench.soak [--steps N] [--modes NAME ...] [--seed S]`` (default 100000 steps per
mode; it pins one core like the other benchmarks).

Bag mode, ``python -m evaluation.bench.soak --bag-frames N [--workdir DIR]``: writes a synthetic ROS1 bag of
``N`` LaserScans at 10 Hz (:func:`write_soak_bag`: two people walking back and forth in front of a 180 deg laser,
0.5 deg spacing, mounted through ``/tf_static``) and runs ``pfpeople run BAG --driver /scan`` on it in a
subprocess (the default grid filter, front end in a second process where it can). It samples the resident memory
of the run's process tree (the run and its front-end process, ``psutil``) every 0.5 s and the frames written
(rows of ``frames.csv``), and reports the memory when 10 %, 50 % and 100 % of the frames are written, the peak,
the frames per second, and the size of each output file. Exit code 1 when the run failed or did not write every
frame.

Input (seeded ``numpy.random.Generator``): the paper's grid and three detectors; every step each detector has
no data with probability 0.1, else a Poisson(1.5) number of people uniform over a box 2 m larger than the grid
on every side (so some fall outside); the robot has no odometry with probability 0.05, else
``v ~ U(-1, 1.5) m/s``, ``omega ~ U(-1, 1) rad/s``; ``dt ~ U(0.095, 0.105) s`` (a laser clock's jitter:
11 motion kernels at the filters' 1 ms dt quantum). The input of every step is drawn before it is timed.

Reported per mode: steps with a NaN or a belief outside [0, 1]; the smallest and largest belief mass (sum over
cells: bounded by 0 and the number of cells); resident memory (``psutil``) and the peak
(``resource.getrusage``) after the first 10 % of the steps and at the end; the median ms per step in the
first and in the last 10 % of the steps and their ratio (1.0: no slow-down). The exit code is 1 when a mode
produced a NaN or a belief outside [0, 1].

The modes come from :func:`soak_modes` (name -> factory ``rng -> filter``): add a mode there and this
benchmark runs it.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, as for the other benchmarks

import argparse  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import psutil  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from gridbridge import GridFilter, GridSpec, Odometry  # noqa: E402
from gridbridge.params import PAPER_DETECTORS  # noqa: E402
from pfpeople.particle.filter import ParticleFilter  # noqa: E402
from pfpeople.particle.predictor import PersistentSampling  # noqa: E402

__all__ = ["SoakResult", "main", "soak", "soak_modes"]

Factory = Callable[[np.random.Generator], Any]


def soak_modes() -> dict[str, Factory]:
    """The filter modes the soak benchmark runs: name -> ``factory(rng) -> filter`` (``step(dets, odo, dt)``,
    ``belief``). The paper's grid forms, the particle filter with both people motion models, and the recommended
    grid and particle filters (:func:`pfpeople.pipeline.assembly.build_filter`)."""
    from pfpeople.config import FilterConfig
    from pfpeople.pipeline.assembly import build_filter

    spec = GridSpec()
    return {
        "recommended-grid": lambda rng: build_filter(FilterConfig(), spec, PAPER_DETECTORS),
        "recommended-particle": lambda rng: build_filter(
            FilterConfig(kind="particle", seed=int(rng.integers(2**31))), spec, PAPER_DETECTORS
        ),
        "grid-paper": lambda rng: GridFilter(spec, detectors=PAPER_DETECTORS, form="paper"),
        "grid-linear": lambda rng: GridFilter(spec, detectors=PAPER_DETECTORS, form="linear"),
        "particle": lambda rng: ParticleFilter(spec, detectors=PAPER_DETECTORS, n_particles=5000, rng=rng),
        "particle-persistent": lambda rng: ParticleFilter(
            spec, detectors=PAPER_DETECTORS, n_particles=5000, rng=rng, people_motion=PersistentSampling()
        ),
    }


@dataclass
class SoakResult:
    mode: str
    steps: int
    bad_steps: int
    mass_min: float
    mass_max: float
    rss_start_mib: float
    rss_end_mib: float
    peak_start_mib: float
    peak_end_mib: float
    ms_first: float
    ms_last: float

    @property
    def slowdown(self) -> float:
        return self.ms_last / self.ms_first if self.ms_first > 0 else float("nan")


def _peak_mib() -> float:
    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return kib / 1024.0


def random_input(
    rng: np.random.Generator, spec: GridSpec, n_detectors: int
) -> tuple[list[NDArray[np.float64] | None], Odometry | None, float]:
    """One step's random detections (per detector), odometry and dt (see the module docstring)."""
    dets: list[NDArray[np.float64] | None] = []
    for _ in range(n_detectors):
        if rng.random() < 0.1:
            dets.append(None)
            continue
        n = rng.poisson(1.5)
        x = rng.uniform(spec.x0 - 2.0, spec.x1 + 2.0, n)
        y = rng.uniform(spec.y0 - 2.0, spec.y1 + 2.0, n)
        dets.append(np.column_stack((x, y)))
    odo = None if rng.random() < 0.05 else Odometry(v=float(rng.uniform(-1.0, 1.5)), omega=float(rng.uniform(-1, 1)))
    return dets, odo, float(rng.uniform(0.095, 0.105))


def soak(name: str, factory: Factory, steps: int, *, seed: int = 0) -> SoakResult:
    """Run ``steps`` filter steps of one mode on random input; see the module docstring for the figures."""
    if steps < 10:
        raise ValueError(f"steps must be at least 10, got {steps}")
    rng_in = np.random.default_rng(seed)
    filt = factory(np.random.default_rng(seed + 1))
    spec: GridSpec = filt.spec
    n_det = len(filt.detectors)
    proc = psutil.Process()
    tenth = max(1, steps // 10)
    times = np.empty(steps)
    bad = 0
    mass_min, mass_max = np.inf, -np.inf
    rss_start = peak_start = 0.0
    for k in range(steps):
        dets, odo, dt = random_input(rng_in, spec, n_det)
        t0 = time.perf_counter()
        filt.step(dets, odo, dt)
        times[k] = time.perf_counter() - t0
        belief = filt.belief
        if not np.all(np.isfinite(belief)) or belief.min() < 0.0 or belief.max() > 1.0:
            bad += 1
        mass = float(np.sum(belief))
        mass_min, mass_max = min(mass_min, mass), max(mass_max, mass)
        if k == tenth - 1:
            rss_start, peak_start = proc.memory_info().rss / 2**20, _peak_mib()
    return SoakResult(
        mode=name,
        steps=steps,
        bad_steps=bad,
        mass_min=mass_min,
        mass_max=mass_max,
        rss_start_mib=rss_start,
        rss_end_mib=proc.memory_info().rss / 2**20,
        peak_start_mib=peak_start,
        peak_end_mib=_peak_mib(),
        ms_first=1e3 * statistics.median(times[:tenth]),
        ms_last=1e3 * statistics.median(times[-tenth:]),
    )


def main(argv: Sequence[str] | None = None) -> int:
    modes = soak_modes()
    parser = argparse.ArgumentParser(prog="python -m evaluation.bench.soak", description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=lambda s: int(float(s)), default=100_000, help="steps per mode (1e5)")
    parser.add_argument("--modes", nargs="+", choices=sorted(modes), default=list(modes), help="modes to run")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--bag-frames", type=lambda s: int(float(s)), help="bag mode: pfpeople run over a bag of N scans (1e5)"
    )
    parser.add_argument("--workdir", help="bag mode: where the bag and the run go (default: a temporary folder)")
    args = parser.parse_args(argv)
    if args.bag_frames is not None:
        return _bag_main(args.bag_frames, args.workdir)
    n_cells = GridSpec().n_cells
    print(f"soak: {args.steps} steps per mode, seed {args.seed}, belief mass bounds [0, {n_cells}]")
    header = (
        f"{'mode':>20} {'steps':>7} {'bad':>4} {'mass min':>9} {'mass max':>9} {'RSS MiB start':>13} {'end':>7} "
        f"{'peak start':>10} {'end':>7} {'ms first':>9} {'ms last':>8} {'last/first':>10}"
    )
    print(header)
    failed = False
    for name in args.modes:
        r = soak(name, modes[name], args.steps, seed=args.seed)
        failed |= r.bad_steps > 0 or r.mass_min < 0 or r.mass_max > n_cells
        print(
            f"{r.mode:>20} {r.steps:>7} {r.bad_steps:>4} {r.mass_min:>9.2f} {r.mass_max:>9.2f} "
            f"{r.rss_start_mib:>13.1f} {r.rss_end_mib:>7.1f} {r.peak_start_mib:>10.1f} {r.peak_end_mib:>7.1f} "
            f"{r.ms_first:>9.3f} {r.ms_last:>8.3f} {r.slowdown:>10.2f}",
            flush=True,
        )
    return 1 if failed else 0


def _bag_main(frames: int, workdir: str | None) -> int:
    """Bag mode (see the module docstring): run, print the figures, 1 when the run failed or lost frames."""
    import tempfile
    from pathlib import Path

    from evaluation.bench.soak_bag import soak_bag

    if frames < 10:
        raise SystemExit(f"--bag-frames must be at least 10, got {frames}")
    if workdir is not None:
        Path(workdir).mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        r = soak_bag(frames, Path(tmp))
    print(f"bag soak: {r.command}")
    print(f"  bag {r.bag_bytes / 2**20:.1f} MiB, {r.frames} scans; exit code {r.returncode}")
    print(f"  {r.frames_written} frames written in {r.elapsed_s:.0f} s ({r.frames_written / r.elapsed_s:.0f} frames/s)")
    at = ", ".join(f"{k} %: {v:.1f} MiB" for k, v in sorted(r.rss_at.items()))
    print(f"  RSS of the run's processes: {at}; peak {r.peak_rss_mib:.1f} MiB")
    total = sum(r.outputs.values())
    print(f"  outputs {total / 2**20:.1f} MiB ({total / max(r.frames_written, 1):.0f} B a frame):")
    for name, size in r.outputs.items():
        print(f"    {name:<20} {size / 2**20:10.2f} MiB")
    return 0 if r.returncode == 0 and r.frames_written == r.frames else 1


if __name__ == "__main__":
    sys.exit(main())
