"""The robot's own returns (pfpeople.perception.self_returns.SelfReturns) on hand-made scans with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfpeople.perception.clutter_map import ClutterConfig, ClutterSuppressor
from pfpeople.perception.self_returns import SelfReturns
from pfpeople.sensors import Pose2D

FORWARD = Pose2D(x=0.1, y=0.0, yaw=0.0)  # 0.1 m forward per scan (1 m/s at 10 Hz)
BODY = np.array([-0.2, 0.25])  # a bracket of the robot, fixed in the laser frame


def _scan(body: np.ndarray, post: np.ndarray) -> np.ndarray:
    """Three beams: the body, a world-fixed post, no return."""
    return np.array([body, post, [np.nan, np.nan]])


def test_body_found_after_travel_and_world_post_never() -> None:
    own = SelfReturns(travel=0.5)
    post = np.array([0.8, -0.3])  # world-fixed: it comes 0.1 m closer in the laser frame each scan
    masks = []
    for _ in range(7):
        masks.append(own.update(_scan(BODY, post), FORWARD).tolist())
        post = post - [0.1, 0.0]
    # travel 0.1 per scan of the streak (the first scan starts it): 0.5 m after the 6th scan
    assert [m[0] for m in masks] == [False] * 5 + [True] * 2
    assert not any(m[1] or m[2] for m in masks)
    assert own.is_self([[-0.2, 0.1], [-0.2, 0.5], [0.8, -0.3]]).tolist() == [True, False, False]
    np.testing.assert_allclose(own.points, [BODY])


def test_rotation_counts_as_travel() -> None:
    """Turning on the spot at 0.5 rad per scan: a world point at 0.32 m moves 0.16 m per scan."""
    own = SelfReturns(travel=0.5)
    turn = Pose2D(x=0.0, y=0.0, yaw=0.5)
    r = float(np.hypot(*BODY))
    step = 2 * r * math.sin(0.25)
    need = math.ceil(0.5 / step)
    masks = [bool(own.update(_scan(BODY, np.array([np.nan, np.nan])), turn)[0]) for _ in range(need + 2)]
    assert masks == [False] * need + [True] * 2


@pytest.mark.parametrize(
    ("ego", "label"),
    [(Pose2D(), "standing still"), (None, "unknown ego-motion")],
)
def test_no_travel_no_self(ego: Pose2D | None, label: str) -> None:
    own = SelfReturns()
    for _ in range(50):
        assert not own.update(_scan(BODY, np.array([0.5, 0.0])), ego).any(), label
    assert not own.is_self([BODY]).any()


def test_swinging_leg_beside_the_robot_is_not_self() -> None:
    """A person walking beside the robot at its speed: the leg's return swings by 0.12 m within a step."""
    own = SelfReturns()
    for k in range(60):
        leg = np.array([0.1 + 0.12 * math.sin(k * 0.8), 0.7])
        assert not own.update(_scan(leg, np.array([np.nan, np.nan])), FORWARD)[0]


def test_beyond_max_range_and_interruption() -> None:
    own = SelfReturns(max_range=1.0, travel=0.3)
    far = np.array([0.0, 1.2])  # fixed in the laser frame but beyond max_range
    for _ in range(10):
        mask = own.update(np.array([BODY, far]), FORWARD)
    assert mask.tolist() == [True, False]
    # a person steps in front of the body's beam: the streak restarts and takes the travel again
    assert own.update(np.array([BODY * 0.5, far]), FORWARD).tolist() == [False, False]
    masks = [bool(own.update(np.array([BODY, far]), FORWARD)[0]) for _ in range(5)]
    assert masks == [False, False, False, True, True]
    # a scan with a different number of beams restarts every streak
    assert not own.update(np.array([BODY, far, far]), FORWARD).any()
    own.reset()
    assert own.points.shape == (0, 2) and not own.is_self([BODY]).any()


@pytest.mark.parametrize("name", ["max_range", "tolerance", "travel", "radius"])
def test_bad_parameters_named(name: str) -> None:
    with pytest.raises(ValueError, match=name):
        SelfReturns(**{name: 0.0})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=name):
        SelfReturns(**{name: "1"})  # type: ignore[arg-type]


def test_clutter_suppressor_drops_detections_on_the_robot() -> None:
    """A 'person' detected on the body is suppressed once the robot has driven 0.5 m; with self_range = 0 never
    (the static map alone does not: in the odometry frame the body moves with the robot)."""
    wall = np.column_stack((np.full(40, 3.0), np.linspace(-2.0, 2.0, 40)))
    kept = {}
    for self_range in (1.0, 0.0):
        sup = ClutterSuppressor(ClutterConfig(self_range=self_range))
        keep = []
        for k in range(10):
            pts = np.concatenate(([BODY], wall - [0.1 * k, 0.0]))
            st = sup.step(pts, [np.array([BODY, [1.5, 0.0]])], ego=FORWARD, dt=0.1)
            keep.append(st.keep[0].tolist())
        kept[self_range] = keep
    assert [k[0] for k in kept[1.0]] == [True] * 5 + [False] * 5
    assert all(k == [True, True] for k in kept[0.0])
    with pytest.raises(ValueError, match="self_range"):
        ClutterConfig(self_range=-1.0)


def test_leg_beside_a_wall_the_robot_drives_along_is_not_self() -> None:
    """Driving along a wall 0.6 m to the left: the wall keeps its place in the laser frame and is called the
    robot's. A leg centred 0.18 m from it (within ``radius``) is not: its own returns are nearer to its centre; a
    detection on the wall is."""
    own = SelfReturns(radius=0.2)
    wall = np.column_stack((np.linspace(-0.5, 0.5, 21), np.full(21, 0.6)))
    arc = np.linspace(0.0, np.pi, 5)
    near_half = np.column_stack((0.05 * np.cos(arc), -0.05 * np.sin(arc)))  # the half of a 0.1 m leg facing the laser
    for k in range(10):
        centre = np.array([0.06 * (-1) ** k, 0.42])  # the leg swings 0.12 m every scan
        mask = own.update(np.concatenate((wall, centre + near_half)), FORWARD)
    assert mask[:21].all() and not mask[21:].any()
    assert own.is_self([centre, [0.0, 0.6], [0.3, 0.62]]).tolist() == [False, True, True]
