"""The compiled kernels (numba) and their numpy fallbacks give the same floats, bit for bit."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gridbridge import jit
from gridbridge.kernels import pairwise_sum
from pfpeople.detect import segment_kernels as _kernels
from pfpeople.detect import segments as seg
from pfpeople.perception import clutter_kernels
from pfpeople.sensors import LaserScan

pytestmark = pytest.mark.skipif(not jit.enabled("pfpeople"), reason="numba is not installed or PFPEOPLE_NUMBA=0")


def _scans(n: int = 40) -> list[LaserScan]:
    """Cluttered random scans: walls, leg-like arcs, noise, NaN / inf / out-of-range beams, either turn direction."""
    rng = np.random.default_rng(7)
    out = []
    for k in range(n):
        beams = int(rng.choice([5, 64, 361, 768]))
        rng_m = np.full(beams, 8.0) + rng.normal(0, 0.5, beams).cumsum() * 0.05
        for _ in range(rng.integers(0, 12)):  # small near objects (legs, chair legs)
            c, w = int(rng.integers(0, beams)), int(rng.integers(1, 12))
            rng_m[c : c + w] = rng.uniform(0.3, 9.0) + 0.05 * np.sin(np.linspace(0, np.pi, len(rng_m[c : c + w])))
        rng_m += rng.normal(0, 0.01, beams)
        bad = rng.random(beams)
        rng_m[bad < 0.03] = np.nan
        rng_m[(bad >= 0.03) & (bad < 0.06)] = np.inf
        rng_m[(bad >= 0.06) & (bad < 0.07)] = 40.0
        inc = (-1 if k % 3 == 0 else 1) * float(rng.choice([0.0061, 0.0087, 0.0175]))
        out.append(
            LaserScan(ranges=rng_m, angle_min=-inc * beams / 2, angle_increment=inc, range_min=0.05, range_max=30.0)
        )
    return out


def _both(fn: Callable[[], Any], monkeypatch: pytest.MonkeyPatch) -> tuple[Any, Any]:
    with jit.override(True, "pfpeople"):
        compiled = fn()
    with jit.override(False, "pfpeople"):
        return compiled, fn()


def _same_segments(a: seg.Segments, b: seg.Segments) -> None:
    for name in ("points", "beams", "starts", "counts", "range_before", "range_after"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert np.array_equal(x, y, equal_nan=True), name
    assert (a.n_invalid, a.n_dropped_small) == (b.n_invalid, b.n_dropped_small)


@pytest.mark.parametrize("min_points", [None, 1])
def test_segment_scan_compiled_equals_numpy(monkeypatch: pytest.MonkeyPatch, min_points: int | None) -> None:
    for scan in _scans():
        for params in (seg.SegmentationParams(), seg.SegmentationParams(jump_distance=0.3, max_range=6.0)):
            c, f = _both(lambda: seg.segment_scan(scan, params=params, min_points=min_points), monkeypatch)  # noqa: B023
            _same_segments(c, f)


@pytest.mark.parametrize("jump", [0.13, 0.3, 1e-170, 1e170])
def test_jump_segments_at_the_jump_distance(jump: float) -> None:
    """Gaps within a few ulps and within the kernel's margin of ``jump``, in every direction: the compiled runs
    are numpy's (``np.hypot(gap) > jump``)."""
    rng = np.random.default_rng(13)
    rel = np.array([0.0, 1e-16, -1e-16, 2.2e-16, -2.2e-16, 5e-10, -5e-10, 1e-9, -1e-9, 2e-9, -2e-9, 0.5, -0.5])
    steps = jump * (1.0 + rng.choice(rel, 3000))
    theta = rng.uniform(0, 2 * np.pi, 3000)
    x = np.concatenate(([0.0], np.cumsum(steps * np.cos(theta))))
    y = np.concatenate(([0.0], np.cumsum(steps * np.sin(theta))))
    r = np.hypot(x, y)
    beams = np.arange(x.size, dtype=np.intp)
    for min_points in (1, 3):
        pts, kb, starts, counts, before, after, n_small = _kernels.jump_segments(x, y, r, beams, jump, min_points)
        ref = seg._runs_numpy(np.column_stack((x, y)), r, beams, jump, min_points, 0)
        assert np.array_equal(starts, ref.starts) and np.array_equal(counts, ref.counts)
        assert np.array_equal(kb, ref.beams) and before.tobytes() == ref.range_before.tobytes()
        assert after.tobytes() == ref.range_after.tobytes()
        assert pts.tobytes() == ref.points.tobytes() and n_small == ref.n_dropped_small
        assert 0 < len(starts) < x.size


def test_segment_features_compiled_equals_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    for scan in _scans():
        segs = seg.segment_scan(scan)
        c, f = _both(lambda: seg.segment_features(segs), monkeypatch)  # noqa: B023
        assert c.shape == f.shape == (len(segs), len(seg.FEATURE_NAMES))
        assert np.array_equal(c, f, equal_nan=True)
        assert c.tobytes() == f.tobytes()  # the sign of zero too


def test_context_features_compiled_equals_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    """Random centroids, and ties: repeated centroids, equal distances (a grid), points exactly 0.6 m apart."""
    rng = np.random.default_rng(5)
    cases = [rng.uniform(-4, 4, (n, 2)) for n in (0, 1, 2, 3, 4, 30, 50) for _ in range(20)]
    cases += [np.repeat(rng.uniform(-1, 1, (k, 2)), 3, axis=0) for k in (1, 2, 5)]
    gx, gy = np.meshgrid(np.arange(4) * 0.3, np.arange(3) * 0.6)
    cases += [np.column_stack((gx.ravel(), gy.ravel())), np.array([[0.0, 0.0], [0.6, 0.0], [0.0, 3.5]])]
    ring = np.array([[np.cos(t), np.sin(t)] for t in np.linspace(0, 2 * np.pi, 13)[:-1]]) * 0.6  # near-equal
    cases += [ring, ring + np.array([0.6, 0.0]), np.concatenate(([[0.0, 0.0]], ring))]  # and hypot at 0.6 +- rounding
    base = rng.uniform(-3, 3, (6, 2))
    for scale in (1e-160, 1e-15, 1e150, 1e160):  # underflowing and overflowing squares, ulp-close distances
        cases += [base * scale, base + rng.normal(0, 1, (6, 2)) * scale]
    cases += [np.array([[0.0, 0.0], [np.nan, 1.0], [0.5, 0.0]]), np.array([[0.0, 0.0], [np.inf, 1.0], [0.5, 0.0]])]
    for c in cases:
        w = rng.uniform(0.02, 0.6, c.shape[0])
        with np.errstate(invalid="ignore", over="ignore"):  # the numpy twin on the non-finite centroids
            a, b = _both(lambda: seg.context_features(c, w), monkeypatch)  # noqa: B023
        assert a.shape == b.shape == (c.shape[0], 4)
        assert a.tobytes() == b.tobytes()


def test_near_any_compiled_equals_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    """``near_any``: random points, points exactly at the radius, NaN and inf rows, empty sets."""
    from gridbridge.geometry import near_any as numpy_near_any
    from pfpeople.perception.clutter_kernels import near_any

    rng = np.random.default_rng(9)
    cases = [(rng.uniform(-3, 3, (n, 2)), rng.uniform(-3, 3, (k, 2))) for n in (0, 1, 7, 700) for k in (0, 1, 4)]
    edge = np.array([[0.3, 0.0], [0.0, -0.3], [0.3000000000000001, 0.0], [np.nan, 0.0], [np.inf, 1.0], [1.0, 1.0]])
    cases += [(edge, np.zeros((1, 2))), (edge, np.array([[0.0, 0.0], [np.nan, 0.0]])), (edge, edge)]
    for p, o in cases:
        for radius in (0.3, 0.5, 0.0):
            with np.errstate(invalid="ignore"):
                a, b = _both(lambda: near_any(p, o, radius), monkeypatch)  # noqa: B023
                assert a.dtype == b.dtype == bool and np.array_equal(a, b)
                assert np.array_equal(a, numpy_near_any(p, o, radius))


@pytest.mark.parametrize("count_single", [False, True])
def test_people_and_single_legs_compiled_equals_numpy(monkeypatch: pytest.MonkeyPatch, count_single: bool) -> None:
    """Random legs (none, one, many; ties in distance; legs together and NaN widths) give the same people and
    single legs, bit for bit."""
    from pfpeople.detect.legs import PairingParams, people_and_single_legs

    rng = np.random.default_rng(21)
    params = PairingParams(count_single_legs=count_single)
    for k in [0, 1, 2, 3, 5, 8, 20] * 15:
        legs = rng.uniform(-2, 2, (k, 2))
        if k > 3 and rng.random() < 0.3:
            legs[1] = legs[0] + [0.3, 0.0]
            legs[2] = legs[0] - [0.3, 0.0]  # equal distances
        widths = rng.uniform(0.05, 0.4, k)
        if k and rng.random() < 0.2:
            widths[0] = np.nan
        a, b = _both(lambda: people_and_single_legs(legs, widths, params=params), monkeypatch)  # noqa: B023
        for x, y in zip(a, b, strict=True):
            assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes()


def test_pairwise_sum_is_numpys_reduceat() -> None:
    rng = np.random.default_rng(3)
    for _ in range(50):
        v = rng.normal(size=700) * 10 ** rng.uniform(-3, 3, size=700)
        lo, n = int(rng.integers(0, 300)), int(rng.integers(1, 400))
        assert v[lo] + pairwise_sum(v, lo + 1, n - 1) == np.add.reduceat(v, [lo, lo + n])[0]
    for _ in range(200):  # long blocks: numpy halves them down to 128 values, the kernel walks the same tree
        n = int(rng.integers(129, 5000))
        v = rng.normal(size=n + 10) * 10 ** rng.uniform(-5, 5, size=n + 10)
        lo = int(rng.integers(0, 10))
        assert pairwise_sum(v, lo, n) == v[lo : lo + n].sum()


@pytest.mark.parametrize("extra", [{}, {"free_stride": 3, "max_range": 6.0}])
def test_clutter_map_update_compiled_equals_numpy(monkeypatch: pytest.MonkeyPatch, extra: dict) -> None:
    """Two maps fed the same scans (a moving sensor, people to exclude, beams without a return) keep the same
    evidence bit for bit, one compiled and one in numpy."""
    from pfpeople.perception.clutter_map import ClutterConfig, StaticClutterMap
    from pfpeople.sensors import Pose2D

    cfg = ClutterConfig(static_time=0.5, **extra)
    maps = {True: StaticClutterMap(cfg), False: StaticClutterMap(cfg)}
    rng = np.random.default_rng(11)
    static = 0
    for k, scan in enumerate(_scans(30)):
        pts = scan.points()
        free = pts[np.isfinite(pts).all(axis=1)][::7] * 1.5
        people = pts[np.isfinite(pts).all(axis=1)][:: max(1, pts.shape[0] // 3)][:3]
        ego = Pose2D(x=float(rng.normal(0, 0.3)), y=float(rng.normal(0, 0.3)), yaw=float(rng.normal(0, 0.1)))
        for on, m in maps.items():
            with jit.override(on, "pfpeople"):
                m.update(pts, ego=ego, exclude=people, dt=0.05 + 0.01 * (k % 5), free=free)
        assert maps[True].evidence.tobytes() == maps[False].evidence.tobytes()
        for name in ("_hit_cells", "_hit_xy"):  # the returns the queries look at
            assert getattr(maps[True], name).tobytes() == getattr(maps[False], name).tobytes()
        q = np.concatenate((pts, rng.normal(0, 20, (50, 2))))  # the map moved: the lookup's pose and window
        with jit.override(True, "pfpeople"):
            compiled = maps[True].static_points(q)
        with jit.override(False, "pfpeople"):
            assert compiled.tobytes() == maps[True].static_points(q).tobytes()
        static += int(compiled.sum())
    assert static > 0
    assert np.any(maps[True].evidence != maps[True].config.unknown_evidence)


def test_warm_up_and_disabled_fallback() -> None:
    """``warm_up`` loads the kernels; with ``PFPEOPLE_NUMBA=0`` the numpy paths run (nothing to warm up)."""
    import subprocess
    import sys

    _kernels.warm_up()
    clutter_kernels.warm_up()
    code = (
        "import sys; from gridbridge import jit; from pfpeople.perception import clutter_kernels; "
        "from pfpeople.detect import segment_kernels as _kernels, segments; "
        "assert not jit.enabled('pfpeople'); _kernels.warm_up(); clutter_kernels.warm_up(); print('ok')"
    )
    env = {**__import__("os").environ, "PFPEOPLE_NUMBA": "0"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "ok"


def test_far_leg_blobs_compiled_equals_numpy(monkeypatch: pytest.MonkeyPatch) -> None:
    from pfpeople.detect.legs import LegDetectorParams, far_leg_blobs

    found = 0
    for scan in _scans():
        for params in (LegDetectorParams(), LegDetectorParams(far_from=1.0, far_max_points=8, far_leg_width=0.05)):
            c, f = _both(lambda: far_leg_blobs(scan, params), monkeypatch)  # noqa: B023
            for x, y in zip(c, f, strict=True):
                assert x.shape == y.shape and x.tobytes() == y.tobytes()
            found += len(c[1])
    assert found > 0


def test_pipeline_run_same_outputs_compiled_and_numpy(tmp_path: Path) -> None:
    """A whole ``pfpeople run`` (simulated 768-beam wheelchair scene, starter config) writes the same tables with
    the front end's kernels and with their numpy twins."""
    from evaluation.scenarios.scan import write_scene_bag
    from pfpeople.config import load_config
    from pfpeople.io.bag.inspect import inspect_path, starter_config
    from pfpeople.io.bag.reader import BagSource
    from pfpeople.pipeline.runner import Pipeline

    sb = write_scene_bag("wheelchair", tmp_path / "scene", frames=40)
    cfg_path = tmp_path / "starter.toml"
    cfg_path.write_text(starter_config(inspect_path(sb.bag)), encoding="utf-8")
    cfg = load_config(cfg_path)
    for on in (True, False):
        with jit.override(on, "pfpeople"), BagSource(sb.bag) as src:
            Pipeline(cfg, front_process=False).run(src, tmp_path / f"run_{on}")
    for name in ("people.csv", "tracks.csv", "detections.csv", "support.csv", "scans.npy", "grids.npy"):
        assert (tmp_path / "run_True" / name).read_bytes() == (tmp_path / "run_False" / name).read_bytes(), name
    assert len((tmp_path / "run_True" / "detections.csv").read_text().splitlines()) > 10


def test_ball_means_equal_the_trees() -> None:
    """``ball_means`` is ``score[cKDTree(xy).query_ball_point(pos, r)].mean()`` bit for bit, also for points at
    exactly the radius (a grid of points and a radius of whole cells) and for clusters of 1 to 300 points."""
    from scipy.spatial import cKDTree

    from pfpeople.perception.clutter_kernels import ball_means

    rng = np.random.default_rng(5)
    grid = np.stack(np.meshgrid(np.arange(-5, 6) * 0.25, np.arange(-5, 6) * 0.25), axis=-1).reshape(-1, 2)
    for k in range(300):
        n = int(rng.integers(1, 700))
        xy = rng.normal(0, 10 ** rng.uniform(-1, 0.5), (n, 2)) if k % 3 else grid
        score = rng.random(xy.shape[0]) * 10 ** rng.uniform(-3, 3)
        pos = np.concatenate((xy[rng.integers(0, xy.shape[0], 4)], rng.normal(0, 1, (3, 2))))
        r = 0.5 if k % 3 == 0 else float(rng.uniform(0.05, 3.0))
        want = np.zeros(pos.shape[0])
        for m, idx in enumerate(cKDTree(xy).query_ball_point(pos, r=r)):
            if idx:
                want[m] = float(score[idx].mean())
        assert ball_means(np.ascontiguousarray(xy), score, pos, r).tobytes() == want.tobytes()


def test_static_scores_compiled_equal_numpy() -> None:
    """The clutter map's queries (``static_score`` and ``static_points``) agree bit for bit between the paths."""
    from pfpeople.perception.clutter_map import StaticClutterMap

    m = StaticClutterMap()
    rng = np.random.default_rng(12)
    for scan in _scans(25):
        pts = scan.points()
        m.update(pts, dt=0.13)
        q = np.concatenate((pts[np.isfinite(pts).all(axis=1)][::5], rng.normal(0, 3, (10, 2))))
        got = {}
        for on in (True, False):
            with jit.override(on, "pfpeople"):
                m._scores = None  # the returns' scores anew on each path (return_scores or numpy)
                got[on] = (m.static_score(q).tobytes(), m.static_points(q).tobytes(), m._return_scores().tobytes())
        assert got[True] == got[False]


@pytest.mark.parametrize("window, hold", [(2.0, 5.0), (None, None), (1.0, None), (None, 0.5)])
def test_moving_people_compiled_equals_numpy(window: float | None, hold: float | None) -> None:
    """Two "people seen moving" sets fed the same detections (walkers, standing objects, clutter, a moving
    sensor, scans without detections) keep the same tracks bit for bit, one compiled and one in numpy."""
    from pfpeople.perception.clutter_map import MovingPeople
    from pfpeople.sensors import Pose2D

    sets = {on: MovingPeople(window=window, hold=hold, max_missed=3) for on in (True, False)}
    rng = np.random.default_rng(21)
    walkers = rng.uniform(-4, 4, (4, 2))
    for k in range(300):
        walkers += rng.normal(0, 0.08, walkers.shape)
        chairs = np.array([[1.0, 1.0], [1.2, 1.0], [-2.0, 0.5]]) + rng.normal(0, 0.02, (3, 2))
        det = np.concatenate((walkers, chairs, rng.uniform(-5, 5, (int(rng.integers(0, 4)), 2))))
        det = det[rng.random(det.shape[0]) < 0.8] if k % 17 else np.zeros((0, 2))
        ego = Pose2D(x=float(rng.normal(0, 0.05)), y=float(rng.normal(0, 0.05)), yaw=float(rng.normal(0, 0.02)))
        out = {}
        for on, mp in sets.items():
            with jit.override(on, "pfpeople"):
                out[on] = mp.update(det, ego=ego, dt=0.1 + 0.05 * (k % 3))
        assert out[True].tobytes() == out[False].tobytes()
        for name in ("_pos", "_anchor_a", "_anchor_b", "_t_b", "_missed", "_moving", "_moved_t"):
            a, b = getattr(sets[True], name), getattr(sets[False], name)
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name


def test_self_returns_compiled_equal_numpy() -> None:
    """Two self-return detectors fed the same scans (a bumper fixed in the laser frame, a wall, NaN beams, unknown
    ego-motions, a change of beam count) keep the same streaks and masks bit for bit, compiled and numpy."""
    from pfpeople.perception.self_returns import SelfReturns
    from pfpeople.sensors import Pose2D

    dets = {on: SelfReturns(max_range=2.0) for on in (True, False)}
    rng = np.random.default_rng(8)
    scans = [s for s in _scans(40) if s.ranges.size > 300]
    seen = False
    for k in range(80):
        scan = scans[0] if k < 50 else scans[1]  # then another beam count (or the same: every streak goes on)
        pts = scan.points() * 0.2 + rng.normal(0, 0.01, (scan.ranges.size, 2))
        pts[::9] = np.array([0.3, 0.1])  # a bracket that keeps its place
        ego = None if k % 7 == 3 else Pose2D(x=float(rng.normal(0.1, 0.05)), yaw=float(rng.normal(0, 0.05)))
        q = pts[np.isfinite(pts).all(axis=1)][::11]
        got = {}
        for on, d in dets.items():
            with jit.override(on, "pfpeople"):
                got[on] = (d.update(pts, ego).tobytes(), d.is_self(q).tobytes(), d.points.tobytes())
        assert got[True] == got[False]
        assert dets[True]._travel.tobytes() == dets[False]._travel.tobytes()
        assert dets[True]._ref.tobytes() == dets[False]._ref.tobytes()
        seen = seen or bool(dets[True].mask.any())
    assert seen


def test_pair_legs_compiled_pairs_as_numpy() -> None:
    """pair_greedy against pair_legs' numpy path: random legs, ties of distance (legs on a lattice), none or one
    admissible pair, duplicates."""
    from pfpeople.detect.legs import pair_legs

    rng = np.random.default_rng(17)
    for t in range(400):
        k = int(rng.integers(0, 12))
        legs = rng.uniform(-2.0, 2.0, (k, 2))
        if t % 3 == 0:
            legs = np.round(legs * 4.0) / 4.0  # a lattice: many equal distances
        if t % 7 == 0 and k > 2:
            legs[1] = legs[0]
        lo, hi = float(rng.choice([0.0, 0.1, 0.25])), float(rng.choice([0.3, 0.6, 1.5]))
        with jit.override(True, "pfpeople"):
            fast = pair_legs(legs, min_separation=lo, max_separation=hi)
        with jit.override(False, "pfpeople"):
            slow = pair_legs(legs, min_separation=lo, max_separation=hi)
        for a, b in zip(fast, slow, strict=True):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), t
