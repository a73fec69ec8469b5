"""The shared checks of :mod:`gridbridge.validation` (``check_int``, ``check_real``) and the values they now
refuse where a bool or a string used to slip through (``float("0.5")``, ``isinstance(True, int)``)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from gridbridge.classifiers import PeakClassifier
from gridbridge.grid import GridSpec
from gridbridge.validation import InputTypeError, check_int, check_real
from pfpeople.detect.camera import HogParams
from pfpeople.track import PeopleTracker, TrackerConfig
from pfpeople.track.blob_tracker import TrackerParams


def test_check_int_accepts_python_and_numpy_integers() -> None:
    assert check_int(3, "n") == 3
    got = check_int(np.int64(7), "n", minimum=1, maximum=7)
    assert got == 7 and type(got) is int


@pytest.mark.parametrize("value", [True, 1.0, "1", None, np.float64(2.0)])
def test_check_int_refuses_what_is_not_an_integer_naming_the_argument(value: Any) -> None:
    with pytest.raises(TypeError, match=rf"Thing\.count must be an integer, got {type(value).__name__}"):
        check_int(value, "Thing.count")


@pytest.mark.parametrize(
    ("kwargs", "value", "bound"),
    [
        ({"minimum": 1}, 0, r"a positive integer \(>= 1\)"),
        ({"minimum": 0}, -1, "an integer >= 0"),
        ({"maximum": 5}, 6, "an integer <= 5"),
        ({"minimum": 2, "maximum": 5}, 9, r"an integer in \[2, 5\]"),
    ],
)
def test_check_int_bounds_name_the_argument_and_the_bound(kwargs: dict[str, int], value: int, bound: str) -> None:
    with pytest.raises(ValueError, match=rf"Thing\.count must be {bound}, got {value}"):
        check_int(value, "Thing.count", **kwargs)


def test_check_real_accepts_real_numbers_within_the_bounds() -> None:
    assert check_real(2, "x") == 2.0
    assert check_real(np.float32(0.5), "x", low=0.0, high=1.0, low_open=True, high_open=True) == 0.5
    assert check_real(0.0, "x", low=0.0) == 0.0 and check_real(1.0, "x", high=1.0) == 1.0


@pytest.mark.parametrize("value", [True, "1.0", 1 + 0j, None])
def test_check_real_refuses_what_is_not_a_real_number_naming_the_argument(value: Any) -> None:
    with pytest.raises(TypeError, match=rf"Thing\.gain must be a number, got {type(value).__name__}"):
        check_real(value, "Thing.gain", low=0.0)


@pytest.mark.parametrize(
    ("kwargs", "value", "message"),
    [
        ({}, float("nan"), "must be finite"),
        ({"low": 0.0}, float("inf"), "must be finite"),
        ({"low": 0.0, "low_open": True}, 0.0, "must be a number > 0"),
        ({"low": 0.0}, -0.5, "must be a number >= 0"),
        ({"high": 10.0, "high_open": True}, 10.0, "must be a number < 10"),
        ({"low": 0.0, "high": 1.0, "high_open": True}, 1.0, r"must be a number in \[0, 1\)"),
        ({"low": 0.0, "high": 1.0, "low_open": True}, 0.0, r"must be a number in \(0, 1\]"),
    ],
)
def test_check_real_bounds_name_the_argument_and_the_bound(kwargs: dict[str, Any], value: float, message: str) -> None:
    with pytest.raises(ValueError, match=rf"Thing\.gain {message}"):
        check_real(value, "Thing.gain", **kwargs)


def test_a_wrong_type_is_also_a_value_error_for_the_configs_and_command_lines() -> None:
    with pytest.raises(InputTypeError) as caught:
        check_int("3", "n")
    assert isinstance(caught.value, TypeError) and isinstance(caught.value, ValueError)


@pytest.mark.parametrize(
    ("build", "name"),
    [
        (lambda: PeopleTracker(PeakClassifier(), peak_threshold="0.5"), "peak_threshold"),  # float() read it
        (lambda: PeopleTracker(PeakClassifier(), min_separation=True), "min_separation"),  # True was 1 m
        (lambda: TrackerConfig(region=("0", "5", "-2", "2")), r"TrackerConfig\.region"),
        (lambda: TrackerParams(gate=True), r"TrackerParams\.gate"),
        (lambda: TrackerParams(start_threshold=True), r"TrackerParams\.start_threshold"),
        (lambda: GridSpec(resolution=True), r"GridSpec\.resolution"),
        (lambda: HogParams(hit_threshold=True), r"HogParams\.hit_threshold"),
    ],
)
def test_bools_and_strings_that_used_to_slip_through_are_refused_by_name(build: Any, name: str) -> None:
    with pytest.raises(TypeError, match=rf"{name} must be a number, got (bool|str)"):
        build()


def test_finite_rows_is_the_row_reduction() -> None:
    from gridbridge.validation import finite_rows

    rng = np.random.default_rng(6)
    for k in (0, 1, 2, 3):
        a = rng.normal(size=(50, k))
        a[rng.random((50, k)) < 0.1] = np.nan
        a[rng.random((50, k)) < 0.05] = -np.inf
        assert finite_rows(a).tobytes() == np.isfinite(a).all(axis=1).tobytes()
    assert finite_rows(np.zeros((0, 2))).shape == (0,)
    with pytest.raises(ValueError, match="2-D"):
        finite_rows(np.zeros(3))
