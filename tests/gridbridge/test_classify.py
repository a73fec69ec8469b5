"""The paper's blob classification (Sect. 4): one test per rule on hand-made grids with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge.blobs import (
    RULE_ASPECT,
    RULE_BORDER,
    RULE_EXTENT,
    RULE_MEAN,
    RULE_MIN_CELL,
    BlobParams,
    classify_blobs,
    classify_threshold,
)
from gridbridge.grid import GridSpec

SPEC12 = GridSpec(nx=12, ny=12, resolution=0.3, x0=0.0, y0=-1.8)


def _grid(fill: float = 0.0, n: int = 12) -> np.ndarray:
    return np.full((n, n), fill)


def _blob_at(result, i: int, j: int):
    label = int(result.labels[i, j])
    return next(b for b in result.blobs if b.label == label)


# --- seeds ----------------------------------------------------------------------------------------------


def test_seed_threshold_is_strict():
    # No cell above 0.26: no seed, no blob, nobody.
    r = classify_blobs(_grid(0.26), spec=SPEC12)
    assert r.blobs == [] and not r.mask.any() and np.all(r.labels == 0)
    # Every cell just above 0.26: all seeds, one blob covering the grid.
    r = classify_blobs(_grid(0.2605), spec=SPEC12)
    assert len(r.blobs) == 1 and r.blobs[0].size == 144


def test_seed_connectivity_8_and_4():
    g = _grid()
    g[4, 4] = g[5, 5] = 0.9  # diagonal neighbours
    r8 = classify_blobs(g, spec=SPEC12)
    assert r8.labels[4, 4] == r8.labels[5, 5]
    r4 = classify_blobs(g, spec=SPEC12, params=BlobParams(connectivity=4))
    assert r4.labels[4, 4] != r4.labels[5, 5]
    assert len(r4.people) == 2 and len(r8.people) == 1


# --- growth -----------------------------------------------------------------------------------------------


def test_growth_difference_below_040_joins_the_blob():
    g = _grid()
    g[5, 5] = 0.6
    g[5, 6] = 0.21  # |0.6 - 0.21| = 0.39 < 0.40: joins
    r = classify_blobs(g, spec=SPEC12)
    assert r.labels[5, 6] == r.labels[5, 5]
    g[5, 6] = 0.19  # 0.41: rejected, ends in another blob
    r = classify_blobs(g, spec=SPEC12)
    assert r.labels[5, 6] != r.labels[5, 5]
    # custom threshold is honoured
    r = classify_blobs(g, spec=SPEC12, params=BlobParams(growth_threshold=0.42))
    assert r.labels[5, 6] == r.labels[5, 5]


def test_growth_joins_the_most_similar_neighbouring_blob():
    # 1 x 3: seeds {0} (0.9) and {2} (0.27); the visited cell 0.2 joins the 0.27 blob (|d| 0.07 < 0.7).
    g = np.array([[0.9, 0.2, 0.27]])
    r = classify_blobs(g, spec=GridSpec(nx=1, ny=3))
    assert r.labels[0, 1] == r.labels[0, 2] != r.labels[0, 0]


@pytest.mark.parametrize(("compare", "joins"), [("closest", True), ("mean", False), ("all", False)])
def test_growth_compare_readings(compare, joins):
    g = _grid()
    g[5, 5], g[5, 6] = 0.9, 0.3  # one seed blob; cell (6, 6) = 0.0 touches both of its cells
    r = classify_blobs(g, spec=SPEC12, params=BlobParams(growth_compare=compare))
    assert bool(r.labels[6, 6] == r.labels[5, 5]) == joins  # differences: closest 0.3, mean 0.6, all 0.9


# --- new blobs ------------------------------------------------------------------------------------------


def test_rejected_visited_cells_form_new_blobs():
    g = _grid()
    g[:, 6] = 0.9  # a wall of high cells: its visited neighbours (columns 5 and 7) are all rejected
    r = classify_blobs(g, spec=SPEC12)
    assert len(r.blobs) == 3
    left, wall, right = r.labels[0, 5], r.labels[0, 6], r.labels[0, 7]
    assert len({left, wall, right}) == 3 and min(left, wall, right) > 0
    assert np.all(r.labels[:, 5] == left) and np.all(r.labels[:, 7] == right)
    # Cells never visited (two or more cells from every seed blob) are in no blob.
    assert np.all(r.labels[:, :5] == 0) and np.all(r.labels[:, 8:] == 0)
    assert _blob_at(r, 0, 5).neighbours == (wall,)


def test_rejected_cells_split_into_new_blobs_by_the_same_similarity_rule():
    g = _grid()
    g[5, 5] = 0.9
    g[4:7, 4] = 0.25  # left side of the ring
    params = BlobParams(growth_threshold=0.1)  # 0.25 vs 0.0 is not similar at this threshold
    r = classify_blobs(g, spec=SPEC12, params=params)
    assert len(r.blobs) == 3
    assert r.labels[4, 4] == r.labels[6, 4] != r.labels[4, 5]
    assert r.labels[4, 5] == r.labels[6, 6] == r.labels[4, 6]  # the zero part of the ring, one blob
    # at the paper's threshold the whole ring is one new blob
    r = classify_blobs(g, spec=SPEC12)
    assert len(r.blobs) == 2 and r.labels[4, 4] == r.labels[6, 6]


def test_growth_passes_reach_farther():
    g = np.array([[0.9, 0.6, 0.3, 0.05, 0.0]])  # seed blob {0, 1, 2}; then 0.05 (joins), 0.0
    spec = GridSpec(nx=1, ny=5)
    r1 = classify_blobs(g, spec=spec)
    assert r1.labels[0, 3] == r1.labels[0, 2] and r1.labels[0, 4] == 0  # one pass: cell 4 is not visited
    r3 = classify_blobs(g, spec=spec, params=BlobParams(growth_passes=3))
    assert np.all(r3.labels == r3.labels[0, 0])


# --- selection ------------------------------------------------------------------------------------------


def test_all_cells_must_be_above_01():
    # A whole 1 x 3 grid is one blob (0.08 joins: |0.45 - 0.08| < 0.4) with no neighbours.
    r = classify_blobs(np.array([[0.45, 0.45, 0.10]]), spec=GridSpec(nx=1, ny=3))
    assert len(r.blobs) == 1 and r.blobs[0].rejected_by == (RULE_MIN_CELL,)
    r = classify_blobs(np.array([[0.45, 0.45, 0.11]]), spec=GridSpec(nx=1, ny=3))
    assert r.blobs[0].selected and r.blobs[0].rejected_by == ()


def test_mean_must_be_above_the_neighbouring_blobs():
    # Blob {0.9, 0.9} and the rejected cell 0.2 forming its own blob: 0.2 < 0.9 fails, 0.9 > 0.2 passes.
    r = classify_blobs(np.array([[0.9, 0.9, 0.2]]), spec=GridSpec(nx=1, ny=3))
    assert len(r.blobs) == 2
    high, low = _blob_at(r, 0, 0), _blob_at(r, 0, 2)
    assert high.neighbours == (low.label,) and low.neighbours == (high.label,)
    assert high.selected and low.rejected_by == (RULE_MEAN,)
    # A blob without neighbours passes.
    r = classify_blobs(np.array([[0.5]]), spec=GridSpec(nx=1, ny=1))
    assert r.blobs[0].neighbours == () and r.blobs[0].selected


def test_mean_is_compared_with_the_mean_of_neighbour_means():
    # 1 x 4: seed blobs {0.6} and {0.95}; visited cells 0.05 and 0.15 are rejected (differences >= 0.45)
    # and form single-cell blobs. The 0.15 blob touches both seed blobs: 0.15 < (0.6 + 0.95) / 2.
    g = np.array([[0.05, 0.6, 0.15, 0.95]])
    r = classify_blobs(g, spec=GridSpec(nx=1, ny=4))
    assert len(r.blobs) == 4
    b06, b015, b095 = _blob_at(r, 0, 1), _blob_at(r, 0, 2), _blob_at(r, 0, 3)
    assert b06.neighbours == tuple(sorted((r.labels[0, 0], b015.label)))
    assert b06.selected and b095.selected  # 0.6 > (0.05 + 0.15) / 2 and 0.95 > 0.15
    assert b015.rejected_by == (RULE_MEAN,)


def test_blobs_of_at_most_three_cells_skip_the_shape_rules():
    g = _grid()
    g[5, 2:5] = 0.9  # 1 x 3 line: aspect 1/3, but only 3 cells
    g[9, 2:6] = 0.9  # 1 x 4 line: shape rules apply, aspect 1/4 fails
    r = classify_blobs(g, spec=SPEC12)
    assert _blob_at(r, 5, 2).selected
    assert _blob_at(r, 9, 2).rejected_by == (RULE_ASPECT,)
    # also on the border: three border cells in a small blob are fine
    g = _grid()
    g[0, 0:3] = 0.9
    assert _blob_at(classify_blobs(g, spec=SPEC12), 0, 0).selected


def test_at_most_three_cells_on_the_border():
    g = _grid()
    g[0:2, 4:7] = 0.9  # 2 x 3 on the i = 0 edge: 3 border cells
    g[0:2, 8:11] = 0.0
    r = classify_blobs(g, spec=SPEC12)
    assert _blob_at(r, 0, 4).border_cells == 3 and _blob_at(r, 0, 4).selected
    g = _grid()
    g[0:2, 4:8] = 0.9  # 2 x 4 on the edge: 4 border cells, aspect 0.5 and extent fine
    b = _blob_at(classify_blobs(g, spec=SPEC12), 0, 4)
    assert b.border_cells == 4 and b.rejected_by == (RULE_BORDER,)


def test_height_and_width_below_eight_cells():
    g = _grid(n=14)
    spec = GridSpec(nx=14, ny=14)
    g[3:10, 3:10] = 0.9  # 7 x 7
    b = _blob_at(classify_blobs(g, spec=spec), 5, 5)
    assert (b.height, b.width) == (7, 7) and b.selected
    g[3:11, 3:11] = 0.9  # 8 x 8
    b = _blob_at(classify_blobs(g, spec=spec), 5, 5)
    assert (b.height, b.width) == (8, 8) and b.rejected_by == (RULE_EXTENT,)


def test_aspect_ratio_min_over_max_at_least_half():
    g = _grid()
    g[4:6, 3:7] = 0.9  # 2 x 4: ratio 0.5 passes
    b = _blob_at(classify_blobs(g, spec=SPEC12), 4, 3)
    assert (b.height, b.width) == (2, 4) and b.selected
    g[4:6, 3:8] = 0.9  # 2 x 5: ratio 0.4 fails
    b = _blob_at(classify_blobs(g, spec=SPEC12), 4, 3)
    assert b.rejected_by == (RULE_ASPECT,)
    g = _grid()
    g[3:8, 4:6] = 0.9  # 5 x 2 (transposed): fails the same way
    assert _blob_at(classify_blobs(g, spec=SPEC12), 3, 4).rejected_by == (RULE_ASPECT,)


# --- outputs ------------------------------------------------------------------------------------------------


def test_paper_centroid_is_the_mean_of_the_peak_cells():
    g = _grid()
    g[4:6, 4:7] = 0.7
    g[4, 5] = g[5, 6] = 0.8  # two peak cells: centroid (4.5, 5.5) in cell indices
    r = classify_blobs(g, spec=SPEC12)
    (person,) = r.people
    np.testing.assert_allclose(person.centroid_cells, [4.5, 5.5])
    x, y = SPEC12.cell_centre(4.5, 5.5)
    np.testing.assert_allclose(person.centroid, [x, y])
    np.testing.assert_allclose(person.centroid, [0.3 * 5.0, -1.8 + 0.3 * 6.0])
    np.testing.assert_allclose(person.mean_cell, [4.5, 5.0])
    assert person.max_probability == pytest.approx(0.8)
    assert person.mean_probability == pytest.approx((4 * 0.7 + 2 * 0.8) / 6)
    assert r.mask.sum() == 6 and r.positions.shape == (1, 2) and r.masks.shape == (1, 12, 12)


def test_two_gaussian_people_on_the_paper_grid():
    spec = GridSpec()
    gx, gy = spec.cell_centres()
    belief = 0.05 + 0.9 * np.exp(-((gx - 3.0) ** 2 + (gy - 1.0) ** 2) / (2 * 0.15**2))
    belief += 0.9 * np.exp(-((gx - 6.0) ** 2 + (gy + 2.0) ** 2) / (2 * 0.15**2))
    r = classify_blobs(np.clip(belief, 0, 1), spec=spec)
    pos = r.positions[np.argsort(r.positions[:, 0])]
    np.testing.assert_allclose(pos, [[3.0, 1.0], [6.0, -2.0]], atol=0.3)
    # Growing until nothing joins (the other reading) swallows both people into the background.
    r = classify_blobs(np.clip(belief, 0, 1), spec=spec, params=BlobParams(growth_passes=100))
    assert r.people == [] and max(b.size for b in r.blobs) > 400


def test_threshold_classifier():
    g = _grid()
    g[2, 2] = 0.6
    g[2, 3] = 0.5  # not strictly above 0.5
    g[8:10, 8:10] = 0.9
    r = classify_threshold(g, 0.5, spec=SPEC12)
    assert len(r.people) == 2 and r.mask.sum() == 5
    assert np.all(r.labels[g <= 0.5] == 0)
    assert classify_threshold(g, 0.95, spec=SPEC12).people == []


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"seed_threshold": 1.5}, "seed_threshold"),
        ({"growth_threshold": -0.1}, "growth_threshold"),
        ({"min_cell_probability": -1}, "min_cell_probability"),
        ({"small_blob_cells": -1}, "small_blob_cells"),
        ({"max_extent_cells": 2.5}, "max_extent_cells"),
        ({"min_aspect_ratio": 2.0}, "min_aspect_ratio"),
        ({"connectivity": 6}, "connectivity"),
        ({"growth_passes": 0}, "growth_passes"),
        ({"growth_compare": "max"}, "growth_compare"),
    ],
)
def test_bad_params_raise_naming_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        BlobParams(**kwargs)


def test_bad_belief_raises_naming_it():
    with pytest.raises(ValueError, match="belief"):
        classify_blobs(np.zeros(5))
    with pytest.raises(ValueError, match="belief"):
        classify_blobs(np.full((3, 3), np.nan), spec=GridSpec(nx=3, ny=3))
    with pytest.raises(ValueError, match="belief"):
        classify_blobs(np.full((3, 3), 1.2), spec=GridSpec(nx=3, ny=3))
    with pytest.raises(ValueError, match="belief"):
        classify_blobs(np.zeros((3, 3)), spec=GridSpec(nx=4, ny=3))
    with pytest.raises(ValueError, match="threshold"):
        classify_threshold(np.zeros((3, 3)), 2.0, spec=GridSpec(nx=3, ny=3))
