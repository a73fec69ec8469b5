"""GridSpec: geometry and conversions (the only place that converts world <-> cell)."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge import GridSpec


def test_default_is_the_papers_grid() -> None:
    spec = GridSpec()
    assert spec.shape == (30, 30)
    assert spec.extent == pytest.approx((0.0, 9.0, -4.5, 4.5))
    gx, gy = spec.cell_centres()
    assert gx[0, 0] == pytest.approx(0.15) and gy[0, 0] == pytest.approx(-4.35)
    assert gx[29, 29] == pytest.approx(8.85) and gy[29, 29] == pytest.approx(4.35)
    # The laser sits at the middle of the x = 0 edge: cells 14 and 15 straddle y = 0.
    assert gy[0, 14] == pytest.approx(-0.15) and gy[0, 15] == pytest.approx(0.15)


def test_world_cell_round_trip() -> None:
    spec = GridSpec(nx=7, ny=5, resolution=0.5, x0=-1.0, y0=2.0)
    i, j = np.meshgrid(np.arange(7), np.arange(5), indexing="ij")
    x, y = spec.cell_centre(i, j)
    ii, jj = spec.to_cell(x, y)
    np.testing.assert_array_equal(ii, i)
    np.testing.assert_array_equal(jj, j)
    assert spec.flat_index(np.array([-1.0, 2.49, -1.01]), np.array([2.0, 4.49, 2.0])).tolist() == [0, 6 * 5 + 4, -1]


def test_cells_are_half_open() -> None:
    spec = GridSpec()
    assert spec.contains(0.0, -4.5) and not spec.contains(9.0, 0.0) and not spec.contains(1.0, 4.5)
    assert spec.to_cell(0.3, 0.0) == (1, 15)


def test_centred_on_edge() -> None:
    spec = GridSpec.centred_on_edge(100, 100, 0.09)
    assert spec.extent == pytest.approx((0.0, 9.0, -4.5, 4.5))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"nx": 0}, "nx"), ({"ny": 2.5}, "ny"), ({"resolution": -0.1}, "resolution"), ({"x0": np.nan}, "x0")],
)
def test_bad_values_name_the_field(kwargs: dict[str, float], field: str) -> None:
    with pytest.raises(ValueError, match=f"GridSpec.{field}"):
        GridSpec(**kwargs)  # type: ignore[arg-type]
