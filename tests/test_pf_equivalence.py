"""The rasterised particle filter against the grid filter.

With the integrated kernel, the linear grid prediction (``GridFilter(form="linear")``) and
``redraw_in_cell=True`` the particle filter is an unbiased Monte Carlo estimate of the grid filter, so the mean
absolute difference of the posteriors shrinks like N^-1/2. Measured here (5 frames, fixed detections,
noise-free odometry, mean over 3 seeds; numbers from this test's scenario on the development machine):

=========  ================  ==================================
N          standing robot    moving (v = 0.75 m/s, w = 0.3 rad/s)
=========  ================  ==================================
4 000      0.021             0.035
16 000     0.011             0.017
64 000     0.0051            0.0082
=========  ================  ==================================

Fitted log-log slopes -0.50 (standing) and -0.52 (moving). With the robot moving, the grid's bilinear warp
of a belief assumed uniform within cells is an approximation the particles do not make, which leaves a floor:
averaging 8 runs of 64 000 particles (an effective 512 000) gives 0.0031 where pure Monte Carlo noise would give
about 0.0029, and averaging 16 runs of 256 000 particles gives 0.0013 against about 0.0011, so the floor is
about 1e-3 (mean absolute) for this scenario; the test asserts it is below 4e-3.

Against the paper's form (``GridFilter(form="paper")``: speed-density kernel, eq. 8's colonisation form) the
particle filter differs by about 0.049 (mean absolute, max about 0.31 in the cells around detections), which is
the difference between the paper-form and linear grid filters themselves (0.049): the two prediction forms
differ, not the particle estimate.
"""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge import GridFilter, Odometry, SensorMotionNoise
from pfpeople.particle_filter import ParticleFilter

DETS = [np.array([[3.0, 0.5], [5.0, -1.0]]), np.array([[3.1, 0.4], [6.0, 2.0]]), np.array([[4.0, 0.0]])]
FRAMES = 5
SIZES = (4000, 16_000, 64_000)
NOISELESS = SensorMotionNoise.noiseless()


def _grid(odo: Odometry | None, form: str) -> np.ndarray:
    gf = GridFilter(form=form, noise=NOISELESS)  # type: ignore[arg-type]
    for _ in range(FRAMES):
        gf.step(DETS, odo, 0.1)
    return gf.belief


def _pf(odo: Odometry | None, n: int, seed: int) -> np.ndarray:
    pf = ParticleFilter(n_particles=n, rng=np.random.default_rng(seed), redraw_in_cell=True, noise=NOISELESS)
    for _ in range(FRAMES):
        pf.step(DETS, odo, 0.1)
    return pf.belief


def _slope(odo: Odometry | None) -> tuple[float, list[float]]:
    ref = _grid(odo, "linear")
    errs = [float(np.mean([np.abs(_pf(odo, n, s) - ref).mean() for s in range(3)])) for n in SIZES]
    slope = float(np.polyfit(np.log(SIZES), np.log(errs), 1)[0])
    return slope, errs


def test_standing_robot_error_shrinks_as_inverse_sqrt_n() -> None:
    slope, errs = _slope(None)
    assert -0.65 <= slope <= -0.35, (slope, errs)
    assert errs[-1] < 0.008


def test_moving_robot_error_shrinks_then_floor_is_small() -> None:
    odo = Odometry(v=0.75, omega=0.3)
    slope, errs = _slope(odo)
    assert -0.65 <= slope <= -0.35, (slope, errs)
    # Floor: the average of 8 independent runs has ~1/sqrt(8) of the Monte Carlo noise; what remains is the
    # grid warp's discretisation plus that reduced noise. Bound stated in the module docstring.
    ref = _grid(odo, "linear")
    mean_belief = np.mean([_pf(odo, SIZES[-1], 10 + s) for s in range(8)], axis=0)
    floor = float(np.abs(mean_belief - ref).mean())
    assert floor < 4e-3, floor
    assert floor < 0.6 * errs[-1]


@pytest.mark.parametrize("odo", [None, Odometry(v=0.75, omega=0.3)])
def test_difference_to_paper_form_is_the_form_difference(odo: Odometry | None) -> None:
    paper, linear = _grid(odo, "paper"), _grid(odo, "linear")
    pf = _pf(odo, 256_000, 0)
    d_pf = float(np.abs(pf - paper).mean())
    d_forms = float(np.abs(linear - paper).mean())
    # Recorded: both about 0.049-0.050 in this scenario; the PF sits on the linear filter (error ~0.003).
    assert 0.03 < d_pf < 0.07, d_pf
    assert abs(d_pf - d_forms) < 0.006, (d_pf, d_forms)
    assert float(np.abs(pf - linear).mean()) < 0.25 * d_forms
