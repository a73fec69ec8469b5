"""The run configuration (pfpeople.config): TOML round trip and errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from pfpeople.config import BagConfig, DetectorConfig, builtin_config_path, config_from_mapping, load_config


def test_config_round_trip_and_errors(tmp_path: Path) -> None:
    cfg = load_config(builtin_config_path("person_following_outdoor_1"))
    assert cfg.driver == "/scan_base2" and cfg.time_source == "bag"
    assert [d.kind for d in cfg.detectors] == ["leg", "boosted", "single-legs"]
    assert config_from_mapping(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match=r"unknown keys \['drivr'\] in \[frames\]"):
        config_from_mapping({"frames": {"drivr": "/scan"}})
    with pytest.raises(ValueError, match=r"driver .* is required"):
        config_from_mapping({"frames": {}})
    with pytest.raises(ValueError, match="sync_tolerance_s must be a number >= 0"):
        BagConfig(driver="/s", detectors=(DetectorConfig(name="a", kind="leg", topic="/s"),), sync_tolerance_s=-1)
    with pytest.raises(ValueError, match=r"DetectorConfig\(p\).model must give ppv and fnr"):
        DetectorConfig(name="p", kind="topic", topic="/p")
    with pytest.raises(ValueError, match=r"model has unknown fields \['pvv'\]"):
        DetectorConfig(name="p", kind="leg", topic="/p", model={"pvv": 0.3})
    with pytest.raises(ValueError, match="names must be unique"):
        BagConfig(driver="/s", detectors=(DetectorConfig(name="a", kind="leg", topic="/s"),) * 2)
    bad = tmp_path / "bad.toml"
    bad.write_text("[frames\n")
    with pytest.raises(ValueError, match=r"bad.toml' is not valid TOML"):
        load_config(bad)
    with pytest.raises(FileNotFoundError, match=r"available: \['person_following_outdoor_1'"):
        builtin_config_path("nope")
    with pytest.raises(ValueError, match=r"\[tf\] topics must be an array"):  # not the characters of "/tf"
        config_from_mapping({"frames": {"driver": "/s"}, "tf": {"topics": "/tf"}})
