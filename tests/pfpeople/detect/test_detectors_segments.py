"""Scan segmentation and geometric features: synthetic scans with known geometry, bad input, brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfpeople.detect.segments import (
    FEATURE_NAMES,
    RADIUS_CAP,
    SegmentationParams,
    segment_features,
    segment_scan,
)
from pfpeople.detect.synthetic import render_scan
from pfpeople.sensors import LaserScan

F = {n: k for k, n in enumerate(FEATURE_NAMES)}


def test_arc_and_wall_features() -> None:
    # a 0.2 m radius post at 3 m and a 2 m wall at 5 m, both fully visible (0.25 deg beams)
    scan = render_scan(circles=[(3.0, -1.0, 0.2)], segments=[(5.0, 0.5, 5.0, 2.5)])
    segs = segment_scan(scan)
    assert len(segs) == 2
    feats = segment_features(segs)
    post = int(np.argmin(np.hypot(*(segs.centroids - [3.0, -1.0]).T)))
    wall = 1 - post
    # exact circle points: the algebraic fit recovers the radius to 1e-9 m, circularity ~ 0
    assert feats[post, F["radius"]] == pytest.approx(0.2, abs=1e-9)
    assert feats[post, F["circularity"]] < 1e-12
    # the visible arc of a circle of radius r seen from distance d spans 2 asin(r/d) below pi: width < 2r
    assert 0.3 < feats[post, F["width"]] < 0.4
    assert feats[post, F["mean_curvature"]] < 0  # convex towards the sensor
    # the wall is straight: no line residual, radius capped, width = its visible length (beam quantised)
    assert feats[wall, F["linearity"]] < 1e-12
    assert feats[wall, F["radius"]] == RADIUS_CAP
    assert feats[wall, F["width"]] == pytest.approx(2.0, abs=0.1)
    assert feats[wall, F["iav"]] == pytest.approx(math.pi, abs=1e-6)  # inscribed angle on a line is pi


def test_features_match_brute_force_loop(rng: np.random.Generator) -> None:
    scan = render_scan(
        circles=[(2.0, 0.3, 0.06), (2.0, 0.6, 0.06), (4.0, -1.0, 0.3)],
        segments=[(6.0, -3.0, 6.0, 3.0), (1.0, -2.0, 3.0, -1.5)],
        noise_sd=0.005,
        rng=rng,
    )
    segs = segment_scan(scan)
    feats = segment_features(segs)
    assert feats.shape == (len(segs), len(FEATURE_NAMES)) and len(segs) >= 5
    for s in range(len(segs)):
        p = segs.segment(s)
        n = p.shape[0]
        c = p.mean(axis=0)
        assert feats[s, F["n_points"]] == n
        assert feats[s, F["std"]] == pytest.approx(math.sqrt(((p - c) ** 2).sum() / (n - 1)), rel=1e-9)
        assert feats[s, F["width"]] == pytest.approx(float(np.hypot(*(p[-1] - p[0]))), rel=1e-12)
        steps = np.hypot(*np.diff(p, axis=0).T)
        assert feats[s, F["boundary_length"]] == pytest.approx(steps.sum(), rel=1e-9)
        sv = np.linalg.svd(p - c, compute_uv=False)
        assert feats[s, F["linearity"]] == pytest.approx(sv[-1] ** 2, rel=1e-6, abs=1e-12)
        med = np.median(p, axis=0)
        assert feats[s, F["distance"]] == pytest.approx(float(np.hypot(*med)), rel=1e-12)
        assert feats[s, F["avg_median_dev"]] == pytest.approx(float(np.hypot(*(p - med).T).mean()), rel=1e-9)
        # Kasa circle fit by least squares
        A = np.column_stack((-2 * p[:, 0], -2 * p[:, 1], np.ones(n)))
        sol = np.linalg.lstsq(A, -(p**2).sum(axis=1), rcond=None)[0]
        r = math.sqrt(sol[0] ** 2 + sol[1] ** 2 - sol[2])
        assert feats[s, F["radius"]] == pytest.approx(min(r, RADIUS_CAP), rel=1e-6)


def test_invalid_beams_are_dropped_not_crashing() -> None:
    base = render_scan(circles=[(2.0, 0.0, 0.1)], range_max=8.0)
    ranges = base.ranges.copy()
    hit = np.flatnonzero(np.isfinite(ranges))
    ranges[hit[len(hit) // 2]] = np.nan  # a drop-out inside the post
    ranges[0], ranges[1], ranges[2] = -np.inf, 99.0, 0.0  # negative inf, beyond range_max, zero (valid: min 0)
    scan = LaserScan(ranges=ranges, angle_min=base.angle_min, angle_increment=base.angle_increment, range_max=8.0)
    segs = segment_scan(scan)
    # the NaN neither creates a segment nor splits the post; the "0.0" beam is a single point, dropped as small
    assert len(segs) == 1
    assert segs.counts[0] == hit.size - 1
    assert segs.n_dropped_small == 1
    assert segs.n_invalid == int(np.count_nonzero(~np.isfinite(ranges))) + 1  # + the 99 m beam
    assert np.all(np.isfinite(segment_features(segs)))


def test_empty_and_all_invalid_scans() -> None:
    for ranges in (np.zeros(0), np.full(50, np.nan), np.full(50, np.inf)):
        scan = LaserScan(ranges=ranges, angle_min=-1.0, angle_increment=0.01)
        segs = segment_scan(scan)
        assert len(segs) == 0
        assert segment_features(segs).shape == (0, len(FEATURE_NAMES))
        assert segs.centroids.shape == (0, 2)


def test_max_range_and_jump_distance() -> None:
    scan = render_scan(circles=[(2.0, 0.0, 0.1), (7.0, 2.0, 0.2)])
    assert len(segment_scan(scan)) == 2
    assert len(segment_scan(scan, params=SegmentationParams(max_range=5.0))) == 1
    # two touching posts 0.05 m apart are one segment with a 0.13 m jump threshold, two with 0.02 m
    two = render_scan(circles=[(2.0, 0.0, 0.1), (2.0, 0.25, 0.1)])
    assert len(segment_scan(two)) == 1
    assert len(segment_scan(two, params=SegmentationParams(jump_distance=0.02))) == 2


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"jump_distance": 0.0}, "jump_distance"), ({"min_points": 2}, "min_points"), ({"max_range": -1.0}, "max_range")],
)
def test_segmentation_params_validation(kwargs: dict[str, float], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        SegmentationParams(**kwargs)  # type: ignore[arg-type]


def test_segment_scan_rejects_non_scan() -> None:
    with pytest.raises(TypeError, match="scan"):
        segment_scan(np.ones(10))  # type: ignore[arg-type]


def test_min_points_override_keeps_short_runs() -> None:
    """``min_points=1`` keeps every run (the far leg blobs' 1-3 returns): the segments cover every valid beam."""
    scan = render_scan(
        circles=[(8.0, 0.0, 0.03), (8.0, 1.0, 0.03)],
        segments=[(3.0, -2.0, 3.0, -1.0)],
        angle_increment=math.radians(0.5),
    )
    default = segment_scan(scan)
    every = segment_scan(scan, min_points=1)
    assert every.points.shape[0] == int(np.count_nonzero(scan.valid))
    assert len(every) == len(default) + default.n_dropped_small
    assert default.n_dropped_small == 2 and every.n_dropped_small == 0  # the two thin posts: 1 return each
    with pytest.raises(ValueError, match="min_points"):
        segment_scan(scan, min_points=0)


def test_context_features_hand_computed() -> None:
    from pfpeople.detect.segments import CONTEXT_CAP, context_features

    c = np.array([[0.0, 0.0], [0.3, 0.0], [2.0, 0.0], [10.0, 0.0]])
    w = np.array([0.10, 0.12, 0.05, 0.20])
    expect = [
        [0.3, 2.0, 1, 0.12],  # the pair of legs: each other's neighbour within 0.6 m
        [0.3, 1.7, 1, 0.10],
        [1.7, 2.0, 0, 0.12],
        [CONTEXT_CAP, CONTEXT_CAP, 0, 0.05],  # 8 m and 9.7 m away: capped
    ]
    np.testing.assert_allclose(context_features(c, w), expect, atol=1e-12)
    np.testing.assert_array_equal(context_features(c[:1], w[:1]), [[CONTEXT_CAP, CONTEXT_CAP, 0, 0]])
    np.testing.assert_array_equal(context_features(c[:2], w[:2])[:, 1], [CONTEXT_CAP, CONTEXT_CAP])
    assert context_features(np.zeros((0, 2)), np.zeros(0)).shape == (0, 4)


def test_segment_features_end_with_the_scan_context() -> None:
    from pfpeople.detect.segments import context_features

    # two legs 0.3 m apart at 2 m and a post at 4 m: brute-force neighbours against the features' last columns
    scan = render_scan(circles=[(2.0, 0.15, 0.06), (2.0, -0.15, 0.06), (4.0, 1.0, 0.1)])
    segs = segment_scan(scan)
    feats = segment_features(segs)
    assert len(segs) == 3 and FEATURE_NAMES[-4:] == (
        "neighbour_distance",
        "second_neighbour_distance",
        "neighbours_within_0_6m",
        "neighbour_width",
    )
    np.testing.assert_array_equal(feats[:, -4:], context_features(segs.centroids, feats[:, F["width"]]))
    legs = np.argsort(np.hypot(*(segs.centroids - [2.0, 0.0]).T))[:2]
    for k in legs:
        other = legs[legs != k][0]
        assert feats[k, F["neighbour_distance"]] == pytest.approx(
            float(np.hypot(*(segs.centroids[k] - segs.centroids[other])))
        )
        assert feats[k, F["neighbours_within_0_6m"]] == 1
        assert feats[k, F["neighbour_width"]] == feats[other, F["width"]]
