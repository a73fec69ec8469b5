"""Sensor-motion prediction (eqs. 10-11): velocity motion model and the belief warp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge import (
    GridSpec,
    Odometry,
    SensorMotionNoise,
    ego_motion_sigma_points,
    predict_sensor,
    velocity_displacement,
    warp_belief,
)


def test_velocity_displacement_hand_values() -> None:
    dx, dy, dth = velocity_displacement(1.0, math.pi / 2, 1.0)
    assert (float(dx), float(dy), float(dth)) == pytest.approx((2 / math.pi, 2 / math.pi, math.pi / 2))
    dx, dy, dth = velocity_displacement(0.35, 0.0, 0.1)
    assert (float(dx), float(dy), float(dth)) == pytest.approx((0.035, 0.0, 0.0))
    # Straight-line limit is continuous.
    dx2, dy2, _ = velocity_displacement(0.35, 1e-7, 0.1)
    assert float(dx2) == pytest.approx(0.035, abs=1e-12) and abs(float(dy2)) < 1e-9


def test_whole_cell_translation_without_noise_is_an_exact_shift() -> None:
    spec = GridSpec()
    rng = np.random.default_rng(1)
    bel = rng.random(spec.shape)
    # Drive forward two cells: what was at x is now at x - 0.6 m.
    out = predict_sensor(bel, spec, Odometry(v=6.0, omega=0.0), 0.1, noise=SensorMotionNoise.noiseless())
    np.testing.assert_allclose(out[:-2], bel[2:], rtol=0, atol=1e-12)  # 6.0 * 0.1 = 0.6 + 1 ulp
    np.testing.assert_allclose(out[-2:], 0.5, atol=1e-12)  # entering from outside the grid
    # Sideways: a pure translation of one cell to the left (+y) of the sensor.
    out = warp_belief(bel, spec, [0.0, 0.3, 0.0])
    np.testing.assert_allclose(out[:, :-1], bel[:, 1:], rtol=0, atol=1e-12)


def test_ninety_degree_turn_maps_cells() -> None:
    spec = GridSpec()
    bel = np.zeros(spec.shape)
    bel[7, 18] = 1.0  # centre (2.25, 1.05): ahead and to the left
    out = warp_belief(bel, spec, [0.0, 0.0, math.pi / 2], outside=0.5)
    # After turning left by 90 deg it lies on the right: (1.05, -2.25) = centre of cell [3, 7].
    assert out[3, 7] == pytest.approx(1.0, abs=1e-9)
    assert np.isclose(out[:15, :15], 0.0, atol=1e-9).sum() == 15 * 15 - 1
    # Cells on the left half now look at x < 0 in the old frame, cells beyond x = 4.5 m at y > 4.5 m:
    # both outside the old grid.
    np.testing.assert_allclose(out[:, 15:], 0.5, atol=1e-9)
    np.testing.assert_allclose(out[15:, :15], 0.5, atol=1e-9)


def test_noisy_warp_conserves_mass_away_from_border() -> None:
    spec = GridSpec()
    gx, gy = spec.cell_centres()
    bel = 0.9 * np.exp(-((gx - 5.0) ** 2 + (gy - 0.5) ** 2) / (2 * 0.6**2))
    noise = SensorMotionNoise(alpha1=0.05, alpha2=0.01, alpha3=0.01, alpha4=0.05, alpha5=0.01, alpha6=0.01)
    out = predict_sensor(bel, spec, Odometry(v=0.5, omega=0.4), 0.1, noise=noise, outside=0.0)
    assert out.sum() == pytest.approx(bel.sum(), rel=2e-3)
    # The blob moved towards the robot and to the right: its centroid follows the mean displacement.
    cx = (out * gx).sum() / out.sum()
    assert cx == pytest.approx(5.0 - 0.05, abs=0.02)
    assert out.max() < bel.max()  # noise spreads


def test_sigma_points_match_control_moments() -> None:
    noise = SensorMotionNoise(alpha1=0.04, alpha2=0.0, alpha3=0.0, alpha4=0.0, alpha5=0.0, alpha6=0.0)
    poses, w = ego_motion_sigma_points(Odometry(v=0.5, omega=0.0), 0.1, noise)
    assert w.sum() == pytest.approx(1.0)
    assert poses.shape == (3, 3)  # only v is noisy: centre and two nodes
    mean = w @ poses[:, 0]
    var = w @ (poses[:, 0] - mean) ** 2
    assert mean == pytest.approx(0.05)
    assert var == pytest.approx(0.04 * 0.25 * 0.01)
    poses, w = ego_motion_sigma_points(None, 0.1, SensorMotionNoise())
    np.testing.assert_array_equal(poses, [[0.0, 0.0, 0.0]])  # standing robot: no noise at all


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: warp_belief(np.zeros((3, 3)), GridSpec(), [0, 0, 0]), "belief"),
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), [0, np.nan, 0]), "poses"),
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), np.zeros((0, 3))), "poses"),  # was ZeroDivisionError
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), [0.0, 0.1]), "poses"),
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), [[0, 0, 0]], [-1.0]), "weights"),
        (lambda: predict_sensor(np.zeros((30, 30)), GridSpec(), Odometry(v=1.0), -0.1), "dt"),
        (lambda: Odometry(v=math.inf), "Odometry.v"),
        (lambda: SensorMotionNoise(alpha3=-1.0), "alpha3"),
    ],
)
def test_bad_input(call: object, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        call()  # type: ignore[operator]
