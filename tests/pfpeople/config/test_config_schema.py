"""The typed configuration: every field set alone, defaults in one place, one-line errors, old files."""

from __future__ import annotations

import dataclasses
import logging
from typing import Any

import pytest

from pfpeople.config import (
    PAPER_DEFAULTS,
    BagConfig,
    ClassifierConfig,
    ClutterSuppression,
    ConfigError,
    FilterConfig,
    GridConfig,
    OutputConfig,
    TrackingConfig,
    builtin_config_path,
    config_from_mapping,
    load_config,
)
from pfpeople.config.schema import field_default

BASE: dict[str, Any] = {"frames": {"driver": "/scan"}, "detectors": [{"name": "l", "kind": "leg", "topic": "/scan"}]}
TABLES = {
    "grid": GridConfig,
    "filter": FilterConfig,
    "classifier": ClassifierConfig,
    "tracking": TrackingConfig,
    "clutter": ClutterSuppression,
    "output": OutputConfig,
}
#: A valid value other than the default, per field (the default is tried too).
OTHER: dict[str, Any] = {
    "resolution": 0.2, "nx": 40, "ny": 50, "x0": -1.0, "y0": -3.0, "max_range": 6.0,
    "kind": None, "mode": "paper", "form": "paper", "initial": 0.1, "n_particles": 6000, "seed": 4,
    "motion_model": "paper", "compiled_draws": False, "max_overflow": 0.2, "base_rate": 0.05,
    "appearance_rate": 0.1, "belief_max": 0.95, "laser_footprint": 0.2, "threshold": 0.6, "min_separation": 0.5,
    "keep": 0.4, "smooth": 1.0, "enabled": False, "peak_threshold": "off", "people": "classified",
    "coast_frames": 2, "single_legs": False, "snap_radius": 0.0, "static_confirm_s": 0.5, "confirm_evidence": "off",
    "observed_tracks_only": False, "see_through": False, "params": {}, "laser_odometry": False, "frame": "odom",
}  # fmt: skip


def _cases() -> list[tuple[str, str, Any]]:
    out = []
    for table, cls in TABLES.items():
        for f in dataclasses.fields(cls):
            out.append((table, f.name, field_default(cls, f.name)))
            other = OTHER[f.name] if f.name != "kind" else {"filter": "particle", "classifier": "threshold"}[table]
            out.append((table, f.name, other))
    return out


@pytest.mark.parametrize(("table", "key", "value"), _cases())
def test_every_field_can_be_set_alone(table: str, key: str, value: Any) -> None:
    """Each key alone builds a configuration that has it, and every other key at its default (or its mode's)."""
    cfg = config_from_mapping({**BASE, table: {key: value}})
    assert getattr(getattr(cfg, table), key) == value
    default = config_from_mapping(BASE if key != "mode" else {**BASE, "filter": {"mode": value}})
    for other in dataclasses.fields(TABLES[table]):
        if other.name != key and (table, key, other.name) not in DEPENDENT:
            assert getattr(getattr(cfg, table), other.name) == getattr(getattr(default, table), other.name), other.name


#: The defaults that follow another key of the table: the mode's (modes.PAPER_DEFAULTS), the classifier kind's
#: threshold.
DEPENDENT = {("filter", "mode", k) for k in PAPER_DEFAULTS["filter"]} | {("classifier", "kind", "threshold")}


def test_no_default_is_left_to_be_resolved_elsewhere() -> None:
    """A built configuration holds no None: every default is a value, or an explicit word ("auto", "base_rate")."""
    for doc in (BASE, {**BASE, "filter": {"mode": "paper"}}):
        cfg = config_from_mapping(doc)
        for table in TABLES:
            values = dataclasses.asdict(getattr(cfg, table))
            assert None not in values.values(), (table, values)


def test_the_mode_defaults_come_from_one_table() -> None:
    paper = config_from_mapping({**BASE, "filter": {"mode": "paper"}})
    for table, defaults in PAPER_DEFAULTS.items():
        for key, value in defaults.items():
            assert getattr(getattr(paper, table), key) == value, (table, key)
    rec = config_from_mapping(BASE)
    assert rec.filter.form == "linear" and rec.classifier.kind == "peaks" and rec.clutter.enabled


def test_the_grid_extent_follows_the_lasers_unless_given() -> None:
    assert config_from_mapping(BASE).grid.fixed is None
    cfg = config_from_mapping({**BASE, "grid": {"nx": 20, "ny": 10, "x0": 0.0, "y0": -1.5, "resolution": 0.2}})
    assert cfg.grid.fixed is not None and cfg.grid.fixed.shape == (20, 10) and cfg.grid.fixed.resolution == 0.2
    from gridbridge.grid import GridSpec

    auto = GridSpec(nx=30, ny=40, resolution=0.2, x0=-2.0, y0=-4.0)
    part = config_from_mapping({**BASE, "grid": {"resolution": 0.2, "nx": 12}}).grid.completed(auto)
    assert (part.nx, part.ny, part.x0, part.y0, part.resolution) == (12, 40, -2.0, -4.0, 0.2)
    assert BagConfig(driver="/s", detectors=cfg.detectors, grid=auto).grid.fixed == auto  # a GridSpec: fixed


def test_hold_arrivals_is_explicit_with_a_default_by_kind() -> None:
    dets = [{"name": k, "kind": k, "topic": "/scan"} for k in ("leg", "boosted", "single-legs")]
    cfg = config_from_mapping({**BASE, "detectors": dets})
    assert [d.hold_arrivals for d in cfg.detectors] == [False, True, False]
    given = [{**dets[0], "hold_arrivals": True}, {**dets[1], "hold_arrivals": False, "model": {"ppv": 0.99}}]
    cfg = config_from_mapping({**BASE, "detectors": given})
    assert [d.hold_arrivals for d in cfg.detectors] == [True, False]  # the PPV does not decide it


def test_errors_are_one_line_config_errors_naming_table_and_key() -> None:
    cases = {
        "filter": ({"n_particles": 0}, r"^\[filter\] n_particles: must be greater than or equal to 1 or 'auto'"),
        "grid": ({"nx": "many"}, r"^\[grid\] nx: must be a valid integer or 'auto', got 'many'$"),
        "tracking": ({"params": {"gate_distance": -1}}, r"^\[tracking.params\]: TrackerConfig.gate_distance"),
        "clutter": ({"params": {"default_dt": 0.1}}, r"^\[clutter.params\] default_dt: unknown key"),
        "classifier": ({"keep": True}, r"^\[classifier\] keep: must be a valid number, got True$"),
    }
    for table, (value, match) in cases.items():
        with pytest.raises(ConfigError, match=match) as info:
            config_from_mapping({**BASE, table: value})
        assert "\n" not in str(info.value)


def test_a_model_name_of_earlier_versions_loads_and_a_different_one_is_refused(
    caplog: pytest.LogCaptureFixture,
) -> None:
    old = {"name": "laser-legs", "kind": "leg", "topic": "/scan", "model": {"name": "laser-legs", "ppv": 0.6}}
    with caplog.at_level(logging.WARNING):
        cfg = config_from_mapping({**BASE, "detectors": [old]})
    assert cfg.detectors[0].name == "laser_legs" and cfg.detectors[0].model.given() == {"ppv": 0.6}
    assert "former default names" in caplog.text
    with pytest.raises(ConfigError, match=r"^\[detectors.model\] name: must be the detector's name 'x'"):
        config_from_mapping({**BASE, "detectors": [{**old, "name": "x", "model": {"name": "y"}}]})


@pytest.mark.parametrize("name", ["person_following_outdoor_1", "person_following_outdoor_1_paper"])
def test_the_built_in_configs_round_trip_with_every_default_written(name: str) -> None:
    cfg = load_config(builtin_config_path(name))
    full = cfg.to_dict()
    assert config_from_mapping(full) == cfg
    assert set(full["filter"]) == {f.name for f in dataclasses.fields(FilterConfig)}  # every default written
