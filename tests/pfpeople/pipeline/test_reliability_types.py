"""Issue 27 (6): the Python API and the config refuse complex, bool and string numbers, naming the argument.

NumPy and ``float()`` take such values silently (an imaginary part dropped, True read as 1, ``"1.5"`` parsed);
the shared checks of :mod:`gridbridge.validation` (``check_number``, ``check_real_array``) refuse them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from gridbridge import GridFilter, GridSpec, Odometry
from gridbridge.params import PAPER_DETECTORS
from pfpeople.config import config_from_mapping
from pfpeople.particle.filter import ParticleFilter
from pfpeople.track import MultiPersonTracker

SPEC = GridSpec(nx=6, ny=6, resolution=0.5, x0=0.0, y0=-1.5)
BAD = [(1 + 2j, "complex"), (True, "bool"), ("1.0", "str")]


@pytest.mark.parametrize(("value", "kind"), BAD)
@pytest.mark.parametrize("field", ["v", "omega", "vy"])
def test_odometry_refuses_non_real_numbers_naming_the_field(value: Any, kind: str, field: str) -> None:
    with pytest.raises(TypeError, match=rf"Odometry\.{field} must be a number, got {kind}"):
        Odometry(**{"v": 0.0, "omega": 0.0, field: value})


def _filters() -> list[Any]:
    dets = PAPER_DETECTORS[:1]
    return [
        GridFilter(SPEC, detectors=dets),
        ParticleFilter(SPEC, detectors=dets, n_particles=50, rng=np.random.default_rng(0)),
    ]


@pytest.mark.parametrize(
    ("dets", "kind"),
    [([[1 + 1j, 0.5]], "complex"), ([[True, False]], "bool"), ([["1", "0"]], "string")],
)
def test_filter_steps_refuse_detections_that_are_not_real_numbers(dets: Any, kind: str) -> None:
    name = PAPER_DETECTORS[0].name
    for f in _filters():
        with pytest.raises(TypeError, match=rf"detections of {name} must hold real numbers, got {kind}"):
            f.step([np.array(dets)], None, 0.1)
        with pytest.raises(TypeError, match=rf"detections of {name} must hold real numbers, got {kind}"):
            f.update([dets])


@pytest.mark.parametrize(("value", "kind"), BAD)
def test_filter_steps_refuse_an_odometry_pair_of_non_numbers(value: Any, kind: str) -> None:
    for f in _filters():
        with pytest.raises(TypeError, match=rf"odometry omega must be a number, got {kind}"):
            f.step([None], (0.5, value), 0.1)
    assert _filters()[0].step([None], (0.5, np.float32(0.1)), 0.1).posterior.shape == (6, 6)  # NumPy reals are fine


@pytest.mark.parametrize(("value", "kind"), [([[1 + 1j, 0.0]], "complex"), ([[True, True]], "bool")])
def test_tracker_update_refuses_positions_scores_and_support_that_are_not_real(value: Any, kind: str) -> None:
    t = MultiPersonTracker()
    with pytest.raises(TypeError, match=rf"positions must hold real numbers, got {kind}"):
        t.update(value, 0.1)
    with pytest.raises(TypeError, match=rf"support must hold real numbers, got {kind}"):
        t.update([[1.0, 0.0]], 0.1, support=value)
    with pytest.raises(TypeError, match=r"scores must hold real numbers, got string"):
        t.update([[1.0, 0.0]], 0.1, scores=["0.5"])
    with pytest.raises(TypeError, match=r"dt must be a number, got bool"):
        t.update([[1.0, 0.0]], True)
    assert t.update([[1.0, 0.0]], 0.1) == []  # a real frame still goes through (a new track is not confirmed)


@pytest.mark.parametrize(
    ("mount", "error", "match"),
    [
        (["a", 0, 0], ValueError, r"^\[mounts\]: 'laser' x must be a number, got str$"),
        ([0, 0, True], ValueError, r"^\[mounts\]: 'laser' yaw must be a number, got bool$"),
        ([0, 0.1, float("nan")], ValueError, r"^\[mounts\]: 'laser' yaw must be finite"),
        ("x", ValueError, r"^\[mounts\]: 'laser' must be three numbers \[x, y, yaw\]"),
        ([0, 0], ValueError, r"^\[mounts\]: 'laser' must be three numbers \[x, y, yaw\]"),
    ],
)
def test_a_bad_mount_value_in_the_config_names_its_key(mount: Any, error: type, match: str) -> None:
    table = {"frames": {"driver": "/scan"}, "detectors": [{"name": "l", "kind": "leg", "topic": "/scan"}]}
    with pytest.raises(error, match=match):
        config_from_mapping({**table, "mounts": {"laser": mount}})
    assert config_from_mapping({**table, "mounts": {"laser": [0.2, 0, 1]}}).mounts == {"laser": (0.2, 0.0, 1.0)}
