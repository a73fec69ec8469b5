"""People-motion prediction (eqs. 5-9): kernels and both prediction forms against references."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from gridbridge import GridSpec, PeopleMotion, people_motion_kernel, predict_people
from gridbridge.reference import predict_people_loop


def normal_pdf(x: float, mu: float, sigma: float) -> float:
    return math.exp(-0.5 * ((x - mu) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi))


def test_paper_kernel_hand_values() -> None:
    k = people_motion_kernel(GridSpec(), form="paper")
    assert k.shape == (7, 7)  # v_max dt = 1.044 m reaches 3 cells of 0.3 m
    assert k[3, 3] == pytest.approx(0.85)
    # One cell away: 0.3 m in 0.1 s is 3 m/s.
    assert k[4, 3] == pytest.approx(0.15 * normal_pdf(3.0, 1.46, 0.63), rel=1e-12)
    assert k[4, 4] == pytest.approx(0.15 * normal_pdf(math.hypot(0.3, 0.3) / 0.1, 1.46, 0.63), rel=1e-12)
    assert k[6, 4] > 0.0  # distance 0.949 m <= 1.044 m
    assert k[6, 5] == 0.0  # distance 1.082 m > v_max dt: outside G


def test_integrated_kernel_sums_to_one_and_is_symmetric() -> None:
    for dt in (0.1, 0.05, 0.25):
        k = people_motion_kernel(GridSpec(), dt=dt, form="integrated")
        # The tent functions form a partition of unity, so no mass leaves the neighbourhood: the bound is
        # round-off.
        assert abs(k.sum() - 1.0) < 1e-12
        assert k.min() >= 0.0
        np.testing.assert_allclose(k, k[::-1, :], atol=1e-15)
        np.testing.assert_allclose(k, k[:, ::-1], atol=1e-15)
        np.testing.assert_allclose(k, k.T, atol=1e-15)
        r = k.shape[0] // 2
        assert k[r, r] > 0.85  # p_stationary plus movers that stay in their cell


def test_integrated_kernel_matches_monte_carlo_of_the_model() -> None:
    """The integrated kernel is the probability of the cell offset for a start uniform in the cell."""
    motion = PeopleMotion()
    spec = GridSpec()
    k = people_motion_kernel(spec, motion, form="integrated")
    r = k.shape[0] // 2
    rng = np.random.default_rng(7)
    n = 400_000
    a, b = (0 - motion.mu) / motion.sigma, (motion.v_max - motion.mu) / motion.sigma
    speed = stats.truncnorm.rvs(a, b, loc=motion.mu, scale=motion.sigma, size=n, random_state=rng)
    heading = rng.uniform(0, 2 * np.pi, n)
    moving = rng.random(n) >= motion.p_stationary
    start = rng.random((n, 2))
    disp = np.where(moving, speed * motion.dt / spec.resolution, 0.0)
    end = np.floor(start + np.column_stack((disp * np.cos(heading), disp * np.sin(heading)))).astype(int)
    counts = np.zeros_like(k)
    np.add.at(counts, (end[:, 0] + r, end[:, 1] + r), 1.0)
    sd = np.sqrt(k * (1 - k) / n)
    assert np.all(np.abs(counts / n - k) <= 5 * sd + 2e-5)


@pytest.mark.parametrize("form", ["paper", "linear"])
@pytest.mark.parametrize("kernel_form", ["paper", "integrated"])
def test_vectorised_prediction_equals_brute_force(form: str, kernel_form: str) -> None:
    rng = np.random.default_rng(3)
    spec = GridSpec(nx=9, ny=7)
    kernel = people_motion_kernel(spec, form=kernel_form)  # type: ignore[arg-type]
    for outside in (0.5, 0.1):
        bel = rng.random(spec.shape)
        fast = predict_people(bel, kernel, outside=outside, form=form)  # type: ignore[arg-type]
        ref = predict_people_loop(bel, kernel, outside, form)
        assert np.max(np.abs(fast - ref) / np.abs(ref)) < 1e-12


@pytest.mark.parametrize("form", ["paper", "linear"])
def test_asymmetric_kernel_moves_mass_the_right_way(form: str) -> None:
    """A kernel that only moves people by +1 cell in x: displacement sign convention checked by brute force."""
    kernel = np.zeros((3, 3))
    kernel[1, 1], kernel[2, 1] = 0.6, 0.3
    bel = np.zeros((5, 4))
    bel[2, 1] = 0.8
    out = predict_people(bel, kernel, outside=0.0, form=form)  # type: ignore[arg-type]
    np.testing.assert_allclose(out, predict_people_loop(bel, kernel, 0.0, form), rtol=1e-12, atol=1e-15)
    assert out[3, 1] > 0.0 and out[1, 1] == 0.0


def test_linear_prediction_keeps_uniform_half() -> None:
    k = people_motion_kernel(GridSpec(), form="integrated")
    out = predict_people(np.full((30, 30), 0.5), k, outside=0.5, form="linear")
    np.testing.assert_allclose(out, 0.5, atol=1e-12)


def test_paper_prediction_hand_value() -> None:
    """One occupied cell in an empty world (outside 0): eq. 6 / eq. 8 by hand at its neighbour."""
    k = people_motion_kernel(GridSpec(), form="paper")
    bel = np.zeros((30, 30))
    bel[10, 10] = 0.6
    out = predict_people(bel, k, outside=0.0, form="paper")
    q = k[4, 3] * 0.6
    s = q / (1 - q)
    assert out[11, 10] == pytest.approx(s / (1 + s), rel=1e-12)
    assert out[10, 10] == pytest.approx(0.85 * 0.6, rel=1e-12)  # nobody else can colonise it


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"belief": np.full((4, 4), np.nan)}, "belief"),
        ({"belief": np.full((4, 4), 1.2)}, "belief"),
        ({"belief": np.zeros(4)}, "belief"),
        ({"kernel": np.ones((2, 2)) * 0.1}, "kernel"),
        ({"outside": -0.1}, "outside"),
        ({"form": "cubic"}, "form"),
    ],
)
def test_predict_bad_input(kwargs: dict[str, object], name: str) -> None:
    args: dict[str, object] = {"belief": np.zeros((4, 4)), "kernel": np.full((3, 3), 0.1)}
    args.update(kwargs)
    belief, kernel = args.pop("belief"), args.pop("kernel")
    with pytest.raises(ValueError, match=name):
        predict_people(belief, kernel, **args)  # type: ignore[arg-type]


def test_kernel_bad_input() -> None:
    with pytest.raises(ValueError, match="form"):
        people_motion_kernel(GridSpec(), form="gaussian")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="dt"):
        people_motion_kernel(GridSpec(), dt=-0.1)
    with pytest.raises(ValueError, match=r"PeopleMotion\.p_stationary"):
        PeopleMotion(p_stationary=1.5)
