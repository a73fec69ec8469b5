"""The local-maximum window of the peak classifiers (``maximum_window``): two people ``min_separation`` apart keep
a peak each, on the compiled and the numpy path."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge import jit
from gridbridge.classifiers import classify_peaks, maximum_window
from gridbridge.grid import GridSpec

SPEC = GridSpec(nx=14, ny=14, resolution=0.3, x0=0.0, y0=-2.1)


def test_the_window_holds_the_cells_closer_than_the_separation_and_the_neighbours() -> None:
    assert maximum_window(0.6, 0.3).tolist() == np.ones((3, 3), dtype=bool).tolist()  # 2 cells away is 0.6 m
    assert maximum_window(0.2, 0.3).shape == (3, 3) and maximum_window(0.2, 0.3).all()  # at least the neighbours
    w = maximum_window(1.2, 0.3)  # cells closer than 4 cells: (3, 2) is (3.6 cells), (3, 3) is not (4.2)
    assert w.shape == (7, 7) and w[3 + 3, 3 + 2] and not w[3 + 3, 3 + 3] and not w.flags.writeable


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize(("second", "people"), [((7, 6), 2), ((7, 5), 2), ((6, 6), 1), ((6, 5), 1)])
def test_two_peaks_min_separation_apart_are_two_people(compiled: bool, second: tuple[int, int], people: int) -> None:
    """Peaks at cells (5, 5) and ``second`` over a 0.3 background: (7, 6) is 0.67 m away, (7, 5) 0.6 m (two
    people at min_separation = 0.6); (6, 6) 0.42 m and (6, 5) 0.3 m are one."""
    g = np.full(SPEC.shape, 0.3)
    g[5, 5], g[second] = 0.9, 0.8
    with jit.override(compiled):
        found = classify_peaks(g, SPEC, threshold=0.5, min_separation=0.6, centroid_radius=0.0)
    assert len(found.positions) == people
    np.testing.assert_allclose(found.positions[0], SPEC.cell_centre(5, 5), atol=1e-12)
