"""The scan simulator's compiled ray caster (evaluation.scenarios.scan.raycast_kernels) against its numpy code:
the same ranges and hits bit for bit on random scenes, and the same scene bags byte for byte."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.scenarios.scan import beam_angles, builtin_scan_scenes, cast_rays, write_scene_bag
from gridbridge import jit

pytestmark = pytest.mark.skipif(not jit.AVAILABLE, reason="numba is not installed")


def _both(angles: np.ndarray, **scene: np.ndarray) -> None:
    with jit.override(True, "evaluation"):
        r1, h1 = cast_rays(angles, **scene)
    with jit.override(False, "evaluation"):
        r0, h0 = cast_rays(angles, **scene)
    assert r1.tobytes() == r0.tobytes()
    assert h1.dtype == h0.dtype and np.array_equal(h1, h0)


def _scene(rng: np.random.Generator, n_beams: int) -> dict[str, np.ndarray]:
    """Circles and segments around the laser, some duplicated (tied ranges), some with per-primitive beam blocks."""
    nc, ns = int(rng.integers(0, 50)), int(rng.integers(0, 35))
    circles = np.column_stack((rng.uniform(-6, 6, (nc, 2)), rng.uniform(0.01, 1.5, nc)))
    segments = rng.uniform(-6, 6, (ns, 4))
    if nc > 3:
        circles[2] = circles[0]  # the same circle twice: every beam on it ties
        circles[3, :2] = 0.0  # the laser inside a circle
    if ns > 2:
        segments[1] = segments[0, [2, 3, 0, 1]]  # the same wall, end points swapped
    scene = {"circles": circles, "segments": segments}
    if rng.random() < 0.4:
        scene["circle_beams"] = np.sort(rng.integers(0, n_beams, (nc, 2)), axis=1)
        scene["segment_beams"] = np.sort(rng.integers(0, n_beams, (ns, 2)), axis=1)
    return scene


def test_compiled_and_numpy_casts_are_identical_on_random_scenes() -> None:
    rng = np.random.default_rng(26)
    for _ in range(150):
        n = int(rng.integers(2, 1100))
        lo = float(rng.uniform(-math.pi, 0.0))
        angles = beam_angles(lo, lo + float(rng.uniform(0.05, 2 * math.pi)), n)  # full turns cross the +-pi seam
        _both(angles, **_scene(rng, n))


def test_compiled_and_numpy_agree_on_the_edge_cases() -> None:
    a = beam_angles(-math.pi, math.pi, 721)
    _both(a)  # nothing to hit
    _both(a, circles=np.array([[0.0, 0.0, 1.0]]))  # inside the only circle
    graze = math.asin(0.1 / 3.0)
    _both(np.array([graze - 1e-4, graze + 1e-4]), circles=np.array([[3.0, 0.0, 0.1]]))  # two beams: evenly spaced
    _both(a, segments=np.array([[1.0, 0.0, 2.0, 0.0], [-1.0, -1.0, -1.0, 1.0]]))  # along a beam; across the seam
    r, hit = cast_rays(a, segments=np.array([[-1.0, -1.0, -1.0, 1.0]]))
    assert hit[0] == hit[-1] == 0 and r[0] == pytest.approx(1.0)  # the beams at -pi and +pi see the wall behind


@pytest.mark.parametrize("scene", builtin_scan_scenes())
def test_scene_bags_are_the_same_with_the_compiled_caster(scene: str, tmp_path: Path) -> None:
    bags = {}
    for on in (True, False):
        with jit.override(on, "evaluation"):
            bags[on] = write_scene_bag(scene, tmp_path / str(on), frames=25)
    assert bags[True].bag.read_bytes() == bags[False].bag.read_bytes()
    assert bags[True].gt_csv.read_bytes() == bags[False].gt_csv.read_bytes()
