"""GridFilter: one step exposes every stage; behaviour on simple scenes; bad input leaves the state unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge import (
    GridFilter,
    GridSpec,
    Odometry,
    bayes_update,
    people_motion_kernel,
    predict_people,
    predict_sensor,
)

EMPTY = np.zeros((0, 2))


def test_stages_compose_as_in_the_paper() -> None:
    f = GridFilter()
    f.step([[[3.0, 0.1]], EMPTY, [[3.0, 0.1]]], Odometry(v=0.35, omega=0.1), 0.1)
    prev = f.belief.copy()
    out = f.step([[[3.0, 0.1]], [[6.0, -2.0]], EMPTY], Odometry(v=0.35, omega=0.0), 0.1)
    people = predict_people(prev, people_motion_kernel(f.spec, form="paper"), form="paper")
    np.testing.assert_allclose(out.people_prior, people, rtol=1e-12)
    np.testing.assert_allclose(
        out.sensor_prior, predict_sensor(people, f.spec, Odometry(v=0.35), 0.1, noise=f.noise), rtol=1e-12
    )
    np.testing.assert_allclose(out.posterior, bayes_update(out.sensor_prior, out.likelihood), rtol=1e-12)
    assert out.fired.shape == out.covered.shape == out.detector_likelihoods.shape == (3, 30, 30)
    assert out.likelihood[10, 15] == pytest.approx(1 - 0.05 * 0.6 * 0.5)  # laser 1 fires, camera sees nobody
    np.testing.assert_array_equal(f.belief, out.posterior)


@pytest.mark.parametrize("form", ["paper", "linear"])
def test_person_seen_then_missed_then_gone(form: str) -> None:
    f = GridFilter(form=form)  # type: ignore[arg-type]
    person = [np.array([[4.0, 0.5]]), EMPTY, np.array([[4.0, 0.5]])]
    for _ in range(10):
        out = f.step(person, None, 0.1)
    i, j = f.spec.to_cell(4.0, 0.5)
    assert out.posterior[i, j] > 0.9
    # All detectors miss the person for two frames: the prior keeps them (the paper's Fig. 6r).
    for _ in range(2):
        out = f.step([EMPTY, EMPTY, EMPTY], None, 0.1)
    assert out.posterior[i, j] > 0.2
    assert out.posterior[i, j] > 10 * np.median(out.posterior)
    for _ in range(30):
        out = f.step([EMPTY, EMPTY, EMPTY], None, 0.1)
    assert out.posterior[i, j] < 0.05


def test_false_positive_of_the_weak_detector_stays_low() -> None:
    f = GridFilter()
    for _ in range(5):
        out = f.step([EMPTY, [[6.0, -2.0]], EMPTY], None, 0.1)
    i, j = f.spec.to_cell(6.0, -2.0)
    assert out.likelihood[i, j] == pytest.approx(1 - 0.7 * 0.5 * 0.5)
    assert out.posterior[i, j] > np.median(out.posterior)


def test_reset_and_initial() -> None:
    f = GridFilter(initial=0.2)
    f.step([EMPTY, EMPTY, EMPTY], None, 0.1)
    f.reset()
    np.testing.assert_array_equal(f.belief, 0.2)
    with pytest.raises(ValueError, match="belief"):
        f.reset(np.full((3, 3), 0.1))


@pytest.mark.parametrize(
    ("args", "name"),
    [
        (([EMPTY, EMPTY, EMPTY], None, -0.1), "dt"),
        (([EMPTY, EMPTY], None, 0.1), "one entry per detector"),
        (([[[np.nan, 1.0]], EMPTY, EMPTY], None, 0.1), "NaN"),
        (([np.zeros((2, 4)), EMPTY, EMPTY], None, 0.1), "shape"),
        (([np.zeros((2, 3)), EMPTY, EMPTY], None, 0.1), "third column"),  # (M, 3): a PPV per detection, in (0, 1)
        (([EMPTY, EMPTY, EMPTY], "fast", 0.1), "odometry"),
        (([EMPTY, EMPTY, EMPTY], "ab", 0.1), "odometry"),  # a pair that is not numbers
    ],
)
def test_bad_input_names_it_and_keeps_state(args: tuple[object, object, float], name: str) -> None:
    f = GridFilter()
    f.step([[[3.0, 0.1]], EMPTY, EMPTY], None, 0.1)
    before = f.belief.copy()
    with pytest.raises(ValueError, match=name):
        f.step(*args)  # type: ignore[arg-type]
    np.testing.assert_array_equal(f.belief, before)


def test_constructor_validation() -> None:
    with pytest.raises(ValueError, match="form"):
        GridFilter(form="quadratic")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="detectors"):
        GridFilter(detectors=[])
    with pytest.raises(TypeError, match="detectors"):
        GridFilter(detectors=["laser"])  # type: ignore[list-item]
    with pytest.raises(TypeError, match="spec"):
        GridFilter(spec=(30, 30))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="motion must be a PeopleMotion"):
        GridFilter(motion={"mu": 1.4})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="noise must be a SensorMotionNoise"):
        GridFilter(noise=0.1)  # type: ignore[arg-type]
    assert GridFilter(GridSpec(nx=10, ny=12)).belief.shape == (10, 12)
