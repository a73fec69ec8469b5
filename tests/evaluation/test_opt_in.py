"""The opt-in comparison runs the starter config and the starter config with the learned detector, and scores both."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from evaluation.harness.opt_in import CONFIGS, format_opt_in_rows, opt_in_rows, scan_rows


def test_a_scene_runs_with_and_without_the_opt_in_detectors(tmp_path: Path) -> None:
    rows = scan_rows("scan:corridor", tmp_path, seed=0, frames=40)
    assert [r.config for r in rows] == list(CONFIGS)
    detectors = [
        json.loads((tmp_path / f"corridor_0_{s}" / "run.json").read_text())["detectors"] for s in ("starter", "opt_in")
    ]
    assert "laser_learned" not in detectors[0] and detectors[1] == [*detectors[0], "laser_learned"]
    for r in rows:
        assert r.frames == 40 and 0.0 <= r.recall <= 1.0 and 0.0 <= r.precision <= 1.0 and r.false_per_scan >= 0.0
        assert r.ap_05 <= r.recall + 1e-9  # AP is at most the recall of every reported person
    table = format_opt_in_rows(rows)
    assert "starter --opt-in" in table and table.count("scan:corridor") == 2


def test_bad_scenes_are_named(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="'eth'"):
        opt_in_rows(["eth"], tmp_path, seed=0, data=tmp_path)
    with pytest.raises(FileNotFoundError, match=r"negative_2\.bag"):
        opt_in_rows(["negative_2"], tmp_path, seed=0, data=tmp_path)


def test_settings_change_both_configurations_by_key_or_detector_kind(tmp_path: Path) -> None:
    from evaluation.harness.opt_in import apply_settings
    from pfpeople.config import ConfigError, config_from_mapping

    base = config_from_mapping(
        {
            "frames": {"driver": "/scan"},
            "detectors": [
                {"name": "legs", "kind": "leg", "topic": "/scan"},
                {"name": "learned", "kind": "learned", "topic": "/scan"},
            ],
        }
    )
    got = apply_settings(
        base, ["tracking.confirm_evidence=off", "learned.params.threshold=0.4", "learned.model.fnr=0.45"]
    )
    assert got.tracking.confirm_evidence == "off" and base.tracking.confirm_evidence == 0.6
    learned = next(d for d in got.detectors if d.kind == "learned")
    legs = next(d for d in got.detectors if d.kind == "leg")
    assert learned.params["threshold"] == 0.4 and learned.model.fnr == 0.45
    assert legs.params == {} and legs.model.fnr is None
    assert apply_settings(base, ["motion.params.x=1"]) == base  # no detector of that kind: nothing set
    assert apply_settings(base, []) is base
    with pytest.raises(ValueError, match="KEY=VALUE"):
        apply_settings(base, ["tracking.confirm_evidence"])
    with pytest.raises(ConfigError, match="confirm_evidence"):
        apply_settings(base, ["tracking.confirm_evidence=2"])
