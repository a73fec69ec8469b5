"""The rasterised particle filter against the grid filter: the figures behind
``tests/pfpeople/particle/test_pf_equivalence.py``.

Run ``python -m evaluation.harness.pf_equivalence``. With the integrated kernel, the linear grid prediction
(``GridFilter(form="linear")``) and ``PaperSampling(redraw_in_cell=True)``, the particle filter is an unbiased
Monte Carlo estimate of the grid filter, so the mean absolute difference of the posteriors shrinks like N^-1/2. The
scenario: ``FRAMES`` frames with fixed detections (``DETECTIONS``), noise-free odometry, the robot standing or
moving at 0.75 m/s and 0.3 rad/s; errors are means over seeds. With the robot moving, the grid's bilinear warp of a
belief assumed uniform within cells is an approximation the particles do not make, which leaves a floor, measured on
the average of several independent runs. Against the paper's form the difference is that of the two prediction forms.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from gridbridge import GridFilter, Odometry, SensorMotionNoise
from pfpeople.particle.filter import ParticleFilter
from pfpeople.particle.predictor import PaperSampling, VelocityEgoSampling

DETECTIONS = [np.array([[3.0, 0.5], [5.0, -1.0]]), np.array([[3.1, 0.4], [6.0, 2.0]]), np.array([[4.0, 0.0]])]
FRAMES = 5
SIZES = (4000, 16_000, 64_000)
MOVING = Odometry(v=0.75, omega=0.3)
NOISELESS = SensorMotionNoise.noiseless()


def grid_belief(odo: Odometry | None, form: Literal["paper", "linear"]) -> NDArray[np.float64]:
    """The grid filter's belief after ``FRAMES`` steps."""
    gf = GridFilter(form=form, noise=NOISELESS)
    for _ in range(FRAMES):
        gf.step(DETECTIONS, odo, 0.1)
    return gf.belief


def particle_belief(odo: Odometry | None, n: int, seed: int) -> NDArray[np.float64]:
    """The rasterised particle filter's belief after ``FRAMES`` steps, in the equivalence mode."""
    pf = ParticleFilter(
        n_particles=n,
        rng=np.random.default_rng(seed),
        people_motion=PaperSampling(redraw_in_cell=True),
        ego_motion=VelocityEgoSampling(noise=NOISELESS),
    )
    for _ in range(FRAMES):
        pf.step(DETECTIONS, odo, 0.1)
    return pf.belief


def error_slope(odo: Odometry | None, sizes: Sequence[int] = SIZES, seeds: int = 3) -> tuple[float, list[float]]:
    """Mean absolute difference to the linear grid filter per particle count, and the fitted log-log slope."""
    ref = grid_belief(odo, "linear")
    errs = [float(np.mean([np.abs(particle_belief(odo, n, s) - ref).mean() for s in range(seeds)])) for n in sizes]
    return float(np.polyfit(np.log(sizes), np.log(errs), 1)[0]), errs


def floor(odo: Odometry | None, n: int = SIZES[-1], runs: int = 8) -> float:
    """Mean absolute difference between the average of ``runs`` independent particle filters and the grid."""
    ref = grid_belief(odo, "linear")
    mean_belief = np.mean([particle_belief(odo, n, 10 + s) for s in range(runs)], axis=0)
    return float(np.abs(mean_belief - ref).mean())


def paper_form_difference(odo: Odometry | None, n: int = 256_000) -> tuple[float, float, float]:
    """(|PF - paper grid|, |linear grid - paper grid|, |PF - linear grid|), mean absolute."""
    paper, linear = grid_belief(odo, "paper"), grid_belief(odo, "linear")
    pf = particle_belief(odo, n, 0)
    return (
        float(np.abs(pf - paper).mean()),
        float(np.abs(linear - paper).mean()),
        float(np.abs(pf - linear).mean()),
    )


def main(argv: Sequence[str] | None = None) -> int:
    argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0]).parse_args(argv)
    for label, odo in (("standing", None), ("moving", MOVING)):
        slope, errs = error_slope(odo)
        cells = "  ".join(f"N={n}: {e:.4f}" for n, e in zip(SIZES, errs, strict=True))
        print(f"{label:>8} robot, mean |PF - linear grid|: {cells}  slope {slope:+.2f}")
    print(f"floor with the robot moving (mean of 8 runs of {SIZES[-1]}): {floor(MOVING):.4f}")
    for label, odo in (("standing", None), ("moving", MOVING)):
        d_pf, d_forms, d_lin = paper_form_difference(odo)
        print(
            f"{label:>8} robot, vs paper-form grid: |PF - paper| {d_pf:.4f}, |linear - paper| {d_forms:.4f}, "
            f"|PF - linear| {d_lin:.4f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
