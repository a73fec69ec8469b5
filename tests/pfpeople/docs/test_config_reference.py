"""The configuration reference page (docs/configuration.md) is generated from the schema and current."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from pfpeople.config import KINDS
from pfpeople.detect.adapters import ADAPTERS
from pfpeople.docs.reference import REFERENCE_PATH, field_count, main, render, sections


def test_the_reference_page_in_the_repository_is_current() -> None:
    assert REFERENCE_PATH.read_text(encoding="utf-8") == render(), (
        "docs/configuration.md is not current: run python -m pfpeople.docs.reference --write"
    )


def test_check_and_write(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    page = tmp_path / "configuration.md"
    assert main(["--check", "--out", str(page)]) == 1  # missing
    assert "is not current" in capsys.readouterr().err
    assert main(["--write", "--out", str(page)]) == 0
    assert main(["--check", "--out", str(page)]) == 0
    page.write_text(page.read_text() + "edited\n")
    assert main(["--check", "--out", str(page)]) == 1


def test_every_field_has_a_type_a_default_and_a_meaning() -> None:
    for section in sections():
        for row in section.rows:
            where = f"{section.title} {row.key}"
            assert row.type and row.default, where
            assert row.meaning, f"{where} has no meaning: document it in its class's numpydoc Parameters"


def test_numbers_with_a_unit_show_it() -> None:
    """Spot checks of the units carried by the annotations (pfpeople.units)."""
    units = {(s.title, r.key): r.unit for s in sections() for r in s.rows}
    assert units[("[frames]", "sync_tolerance_s")] == "s"
    assert units[("[grid]", "resolution")] == "m"
    assert units[("[detectors.model]", "fov_min")] == "rad"
    assert units[("[tracking.params]", "gate_distance")] == "m"
    assert units[("[clutter.params]", "static_time")] == "s"
    assert units[('[detectors.params] of kind = "leg"', "params.max_width")] == "m"
    assert units[("[filter]", "base_rate")] == ""  # a probability


def test_the_paper_modes_defaults_and_the_kinds_are_in_the_page() -> None:
    page = render()
    assert '`"linear"`; paper mode: `"paper"`' in page
    assert "by kind: `true` for boosted, else `false`" in page
    for kind in ("leg", "boosted", "single-legs", "hog"):
        assert f'## [detectors.params] of kind = "{kind}"' in page


def test_the_detector_kinds_are_the_adapters() -> None:
    """A new kind is one entry of KINDS and its adapter in ADAPTERS: the reference documents its params."""
    assert set(KINDS) == set(ADAPTERS)


def test_the_field_count_is_the_rows_less_the_nested_tables() -> None:
    rows = [r for s in sections() for r in s.rows]
    nested = [r.key for r in rows if r.type == "table"]
    assert sorted(nested) == ["model", "params", "params", "params"]
    assert field_count() == len(rows) - 4
    assert f"{field_count()} settable fields" in render()
    assert dataclasses.is_dataclass(sections()[0].rows[0])
