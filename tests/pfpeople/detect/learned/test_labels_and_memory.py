"""Weak labels, training targets, the scan memory's poses and the training rows."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gridbridge.geometry import Pose2D
from pfpeople.detect.learned.cutouts import CutoutParams, cutouts
from pfpeople.detect.learned.dataset import training_arrays
from pfpeople.detect.learned.memory import ScanMemory
from pfpeople.detect.learned.samples import LabelledScan, Region, count_returns, pair_legs_into_people
from pfpeople.detect.learned.targets import beam_targets
from pfpeople.detect.learned.weak_labels import weak_labels
from pfpeople.sensors import LaserScan

N = 361
ANG = np.linspace(-math.pi / 2, math.pi / 2, N)


def _circles(things: list[tuple[float, float, float]], wall: float = 5.0) -> np.ndarray:
    r = wall / np.maximum(np.cos(ANG), 1e-3)
    d = np.column_stack((np.cos(ANG), np.sin(ANG)))
    for cx, cy, rad in things:
        b = d @ np.array([cx, cy])
        disc = b * b - (cx * cx + cy * cy - rad * rad)
        t = b - np.sqrt(np.maximum(disc, 0))
        r = np.minimum(r, np.where((disc >= 0) & (t > 0), t, np.inf))
    return np.where(r <= 10.0, r, np.inf)


def _scan(things: list[tuple[float, float, float]], k: int = 0) -> LaserScan:
    return LaserScan(
        ranges=_circles(things),
        angle_min=float(ANG[0]),
        angle_increment=float(ANG[1] - ANG[0]),
        range_max=10.0,
        stamp_ns=k * 100_000_000,
    )


def _person(x: float, y: float) -> list[tuple[float, float, float]]:
    return [(x, y - 0.12, 0.06), (x, y + 0.12, 0.06)]


def _one_person_in_box(scan: LaserScan) -> LabelledScan:
    """``scan`` labelled with one person at (2, 0) (9 returns) and a labelling box x 0-3 m, y -1-1 m."""
    return LabelledScan(
        scan=scan,
        people=np.array([[2.0, 0.0]]),
        returns=np.array([9]),
        region=Region(box=(0.0, 3.0, -1.0, 1.0)),
        source="t",
        index=0,
    )


def test_weak_labels_find_the_walker_not_the_post() -> None:
    post = [(2.0, 1.0, 0.04)]
    scans = [_scan(post + (_person(3.0, -2.0 + 0.12 * k) if 10 <= k < 45 else []), k) for k in range(60)]
    labelled, report = weak_labels(scans, source="test")
    assert report.people_tracks == 1 and report.labels >= 30
    for k, ls in enumerate(labelled):
        if ls.people.shape[0]:
            assert 10 <= k < 45
            assert np.linalg.norm(ls.people[0] - [3.0, -2.0 + 0.12 * k]) < 0.15
    known = labelled[0].known
    assert known is not None
    pts = labelled[0].scan.points()
    post_beam = np.argmin(np.linalg.norm(np.nan_to_num(pts, nan=1e9) - [2.0, 1.0], axis=1))
    assert known[post_beam]  # the post is background: a known negative
    t = beam_targets(labelled[20], np.flatnonzero(labelled[20].scan.valid))
    assert t.label.sum() >= 4 and (t.weight[t.label > 0] == 1).all()


def test_weak_labels_need_one_laser() -> None:
    a = _scan([])
    b = LaserScan(ranges=np.ones(10), angle_min=0.0, angle_increment=0.1)
    with pytest.raises(ValueError, match="same beams"):
        weak_labels([a, b], source="x")


def test_targets_mask_outside_the_region_and_the_ring() -> None:
    scan = _scan([*_person(2.0, 0.0), (2.0, 0.55, 0.05), (4.0, 1.0, 0.05)])
    ls = _one_person_in_box(scan)
    idx = np.flatnonzero(scan.valid)
    t = beam_targets(ls, idx)
    pts = scan.points()[idx]
    d = np.linalg.norm(pts - [2.0, 0.0], axis=1)
    assert (t.label[d <= 0.4] == 1).all() and (t.label[d > 0.4] == 0).all()
    ring = (d > 0.4) & (d <= 0.7)
    assert ring.any() and (t.weight[ring] == 0).all()  # the object 0.55 m from the person: neither
    far_post = np.linalg.norm(pts - [4.0, 1.0], axis=1) < 0.1
    assert far_post.any() and (t.weight[far_post] == 0).all()  # outside the box: unknown, not negative
    assert count_returns(scan, np.array([[2.0, 0.0]]))[0] == int((d <= 0.4).sum())


def test_legs_pair_into_people() -> None:
    legs = np.array([[1.0, 0.0], [1.0, 0.3], [3.0, 0.0]])
    np.testing.assert_allclose(pair_legs_into_people(legs), [[1.0, 0.15], [3.0, 0.0]])


def test_memory_moves_the_past_with_the_laser() -> None:
    """The laser moves 0.5 m forward per scan past a post at (3, 0) (scan frame of the first scan): the past
    scan's cut-out around the post's current position shows the post where it is now."""
    p = CutoutParams(points=9)
    scans = [_scan([(3.0 - 0.5 * k, 0.0, 0.05)], k) for k in range(3)]
    mem = ScanMemory(past_scans=2, past_step=1)
    for k, s in enumerate(scans):
        mem.advance(s, Pose2D(x=0.5) if k else None)
    idx, x = mem.inputs(scans[-1], p)
    centre = int(np.argmin(np.abs(scans[-1].angles[idx])))
    for ch in range(3):
        assert x[centre, 4, ch] == pytest.approx(0.0, abs=0.02)  # the post, at the same place in every scan
    mem.advance(scans[0], None)  # an unknown motion empties the memory: the current scan stands in
    idx, x = mem.inputs(scans[0], p)
    np.testing.assert_array_equal(x[..., 1], x[..., 0])
    np.testing.assert_array_equal(x[..., 0], cutouts(scans[0], scans[0].angles[idx], scans[0].ranges[idx], p))


def test_training_rows_keep_positives_and_weight_sampled_negatives(rng: np.random.Generator) -> None:
    scans = [
        LabelledScan(
            scan=_scan(_person(2.0, 0.5 - 0.1 * k), k),
            people=np.array([[2.0, 0.5 - 0.1 * k]]),
            returns=np.array([10]),
            region=Region(),
            source="s",
            index=k,
            ego=(0.0, 0.0, 0.0),
        )
        for k in range(5)
    ]
    a = training_arrays(scans, CutoutParams(points=8), past_scans=1, negative_keep=0.5, rng=rng)
    assert a.x.shape[1:] == (8, 2)
    full = training_arrays(scans, CutoutParams(points=8), past_scans=1, negative_keep=1.0, rng=rng)
    assert a.label.sum() == full.label.sum()  # every positive kept
    assert set(np.unique(a.weight[a.label == 0])) <= {1.0, 2.0}  # far negatives weigh 1 / keep
    with pytest.raises(ValueError, match="negative_keep"):
        training_arrays(scans, CutoutParams(), negative_keep=0.0, rng=rng)


def test_static_background_of_a_standing_laser() -> None:
    from pfpeople.detect.learned.weak_labels import static_background

    post = [(2.0, 1.0, 0.04)]
    scans = [_scan(post + (_person(3.0, -2.0 + 0.12 * k) if 10 <= k < 45 else []), k) for k in range(60)]
    bg = static_background(scans)
    assert bg.shape == (60, N)
    pts = scans[20].points()
    near_person = np.linalg.norm(np.nan_to_num(pts, nan=1e9) - [3.0, -2.0 + 0.12 * 20], axis=1) < 0.3
    near_post = np.linalg.norm(np.nan_to_num(pts, nan=1e9) - [2.0, 1.0], axis=1) < 0.1
    assert near_person.any() and not bg[20][near_person].any()  # the walker is not background
    assert near_post.any() and bg[20][near_post].all()  # the post is
    moved = LaserScan(ranges=np.ones(5), angle_min=0.0, angle_increment=0.1)
    assert not static_background([scans[0], moved]).any()  # beams that change: not a standing laser


def test_background_outside_the_region_is_a_known_negative() -> None:
    scan = _scan([*_person(2.0, 0.0), (4.0, 1.0, 0.05)])
    idx = np.flatnonzero(scan.valid)
    pts = scan.points()[idx]
    far_post = np.linalg.norm(pts - [4.0, 1.0], axis=1) < 0.1
    base = _one_person_in_box(scan)
    assert (beam_targets(base, idx).weight[far_post] == 0).all()
    bg = np.zeros(scan.ranges.size, dtype=bool)
    bg[idx[far_post]] = True
    t = beam_targets(dataclasses.replace(base, background=bg), idx)
    assert (t.weight[far_post] == 1).all() and (t.label[far_post] == 0).all()
