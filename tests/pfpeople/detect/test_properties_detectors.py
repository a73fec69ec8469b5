"""Property-based tests (Hypothesis) of the laser detectors and the scan conversion on random LaserScans.

Random lengths (0-200 beams), ranges with NaN, +-inf, negatives and huge values, either sign of
``angle_increment``, random valid-range intervals. Invariants: no exception (LaserScan's own ValueError
for an invalid scan is the only documented one and is not generated), detections an ``(M, 2)`` array of
finite positions, and the same scan always gives the same bytes. Deterministic: ``derandomize=True``.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pfpeople.detect import FEATURE_NAMES, BoostedSegmentDetector, LegDetector, segment_features, segment_scan
from pfpeople.sensors import LaserScan

SETTINGS = settings(
    max_examples=30,
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)

_range = st.one_of(
    st.floats(min_value=0.0, max_value=12.0),
    st.sampled_from([math.nan, math.inf, -math.inf, -1.0, 0.0, 1e30]),
)


@st.composite
def scans(draw: st.DrawFn) -> LaserScan:
    n = draw(st.integers(min_value=0, max_value=200))
    base = draw(st.lists(_range, min_size=n, max_size=n))
    ranges = np.asarray(base, dtype=float)
    if n > 10 and draw(st.booleans()):  # smooth stretches (segments that pass min_points) between the noise
        ranges[: n // 2] = np.linspace(1.0, 3.0, n // 2) + 0.05 * np.sin(np.arange(n // 2))
    inc = draw(st.floats(min_value=1e-4, max_value=0.05)) * draw(st.sampled_from([1.0, -1.0]))
    lo = draw(st.floats(min_value=0.0, max_value=1.0))
    hi = draw(st.floats(min_value=lo, max_value=60.0) | st.just(math.inf))
    return LaserScan(
        ranges=ranges,
        angle_min=draw(st.floats(min_value=-math.pi, max_value=math.pi)),
        angle_increment=inc,
        range_min=lo,
        range_max=hi,
    )


LEGS = LegDetector()
BOOSTED = BoostedSegmentDetector()


@SETTINGS
@given(scans())
def test_detectors_on_random_scans_give_finite_positions(scan: LaserScan) -> None:
    for det in (LEGS, BOOSTED):
        out = det.detect(scan)
        assert out.ndim == 2 and out.shape[1] == 2
        assert np.all(np.isfinite(out))
        assert np.array_equal(out, det.detect(scan))  # deterministic
    segs = segment_scan(scan)
    feats = segment_features(segs)
    assert feats.shape == (len(segs), len(FEATURE_NAMES)) and np.all(np.isfinite(feats))
    assert segs.counts.sum() == segs.points.shape[0] and np.all(segs.counts >= 3)
    # the segment points are the scan's own end points (positions unchanged whatever the beam order)
    a = scan.angle_min + scan.angle_increment * segs.beams
    r = scan.ranges[segs.beams]
    np.testing.assert_array_equal(segs.points, np.column_stack((r * np.cos(a), r * np.sin(a))))
    if scan.angle_increment < 0 and len(segs):  # walked counter-clockwise: beam indices decrease
        assert np.all(np.diff(segs.beams[segs.starts[0] : segs.starts[0] + segs.counts[0]]) < 0)
