"""Cut-outs against a brute-force loop, on both paths (numba and numpy), and what they mean."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge import jit
from pfpeople.detect.learned.cutouts import CutoutParams, beam_cutouts, centre_beams, cutouts, scan_cutouts
from pfpeople.sensors import LaserScan


def _brute(scan: LaserScan, bearing: float, rng: float, p: CutoutParams) -> np.ndarray:
    """One cut-out sample by sample, straight from the module docstring."""
    n = scan.ranges.size
    out = np.empty(p.points)
    half = math.atan(0.5 * p.width / max(rng, 0.01))
    full = n * abs(scan.angle_increment) >= 2 * math.pi - 1e-9
    for j in range(p.points):
        t = -1.0 + 2.0 * j / (p.points - 1)
        u = (bearing + half * t - scan.angle_min) / scan.angle_increment
        if full:
            u %= n
        elif u < 0 or u > n - 1:
            out[j] = 1.0
            continue
        lo = min(max(math.floor(u), 0), n - 1)
        hi = (lo + 1) % n if full else min(lo + 1, n - 1)
        frac = min(max(u - lo, 0.0), 1.0)

        def far(k: int) -> float:
            return float(scan.ranges[k]) if scan.valid[k] else math.inf

        a = min(max(far(lo), rng - p.depth), rng + p.depth)
        b = min(max(far(hi), rng - p.depth), rng + p.depth)
        out[j] = (a + frac * (b - a) - rng) / p.depth
    return out


def _scan(rng: np.random.Generator, n: int = 181, fov: float = math.pi) -> LaserScan:
    r = rng.uniform(0.5, 8.0, n)
    r[rng.random(n) < 0.1] = np.inf  # no return
    r[rng.random(n) < 0.05] = np.nan  # unusable
    inc = fov / (n - 1) if fov < 2 * math.pi else fov / n
    return LaserScan(ranges=r, angle_min=-fov / 2, angle_increment=inc, range_min=0.05, range_max=10.0)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("fov", [math.pi, 2 * math.pi])
def test_cutouts_match_brute_force(rng: np.random.Generator, compiled: bool, fov: float) -> None:
    scan = _scan(rng, fov=fov)
    p = CutoutParams(width=1.0, depth=0.5, points=16)
    idx = centre_beams(scan, p)
    with jit.override(compiled, "pfpeople"):
        got = cutouts(scan, scan.angles[idx], scan.ranges[idx], p)
    want = np.array([_brute(scan, float(scan.angles[i]), float(scan.ranges[i]), p) for i in idx])
    assert got.dtype == np.float32 and got.shape == (idx.size, 16)
    np.testing.assert_allclose(got, want, atol=2e-6)


def test_reversed_laser_matches_brute_force(rng: np.random.Generator) -> None:
    base = _scan(rng)
    scan = LaserScan(
        ranges=base.ranges[::-1].copy(),
        angle_min=math.pi / 2,
        angle_increment=-base.angle_increment,
        range_min=0.05,
        range_max=10.0,
    )
    p = CutoutParams(points=8)
    idx = centre_beams(scan, p)
    for compiled in (True, False):
        with jit.override(compiled, "pfpeople"):
            got = cutouts(scan, scan.angles[idx], scan.ranges[idx], p)
        want = np.array([_brute(scan, float(scan.angles[i]), float(scan.ranges[i]), p) for i in idx])
        np.testing.assert_allclose(got, want, atol=2e-6)


def _leg_scan(distance: float, n: int = 768) -> LaserScan:
    """A wall 3 m behind a 0.12 m wide leg at ``distance`` straight ahead (a 270 deg laser)."""
    ang = np.linspace(-3 * math.pi / 4, 3 * math.pi / 4, n)
    r = np.full(n, distance + 3.0)
    r[np.abs(distance * np.tan(ang)) <= 0.06] = distance
    r[np.abs(ang) > 1.2] = np.inf
    return LaserScan(ranges=r, angle_min=float(ang[0]), angle_increment=float(ang[1] - ang[0]), range_max=25.0)


def test_a_leg_looks_alike_near_and_far() -> None:
    """The window is metric: the same leg at 1 m and at 7 m gives nearly the same cut-out."""
    p = CutoutParams(width=1.0, depth=0.5, points=32)
    near, far = _leg_scan(1.0), _leg_scan(7.0)
    cut = [cutouts(s, np.array([0.0]), np.array([d]), p)[0] for s, d in ((near, 1.0), (far, 7.0))]
    assert np.abs(cut[0] - cut[1]).mean() < 0.15
    assert cut[0][16] == pytest.approx(0.0, abs=1e-6)  # the centre is the leg itself
    assert cut[0][0] == pytest.approx(1.0) and cut[0][-1] == pytest.approx(1.0)  # the wall behind: far


def test_no_return_and_outside_read_far() -> None:
    scan = LaserScan(ranges=np.array([2.0, np.inf, np.inf]), angle_min=0.0, angle_increment=0.01)
    p = CutoutParams(width=0.5, depth=0.5, points=5)
    c = cutouts(scan, np.array([0.0]), np.array([2.0]), p)[0]
    assert c[0] == 1.0  # left of the first beam: outside the field of view
    assert c[-1] == 1.0  # beyond the return: nothing there
    assert c[2] == pytest.approx(0.0)


def test_centre_beams_skip_unusable_and_far() -> None:
    scan = LaserScan(
        ranges=np.array([1.0, np.nan, 13.0, np.inf, 3.0]), angle_min=0.0, angle_increment=0.1, range_max=20.0
    )
    assert list(centre_beams(scan, CutoutParams(max_range=12.0))) == [0, 4]
    idx, cut = scan_cutouts(scan, CutoutParams(points=4))
    assert list(idx) == [0, 4] and cut.shape == (2, 4)


def test_beam_cutouts_take_the_nearest_beam() -> None:
    scan = LaserScan(ranges=np.full(11, 2.0), angle_min=-0.5, angle_increment=0.1)
    values = np.zeros(11)
    values[5] = 1.0
    c = beam_cutouts(scan, values, np.array([0.0, -0.5]), np.array([2.0, 2.0]), CutoutParams(width=0.4, points=5))
    assert c[0, 2] == 1.0 and c[0, 0] == 0.0
    assert c[1, 0] == 0.0 and c[1, 1] == 0.0  # outside the field of view reads 0


def test_params_are_checked() -> None:
    with pytest.raises(ValueError, match="points"):
        CutoutParams(points=1)
    with pytest.raises(ValueError, match="width"):
        CutoutParams(width=0.0)
