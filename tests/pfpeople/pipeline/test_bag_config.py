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
    with pytest.raises(ValueError, match=r"^\[frames\] drivr: unknown key; allowed: \['base_frame', 'driver'"):
        config_from_mapping({"frames": {"drivr": "/scan"}})
    with pytest.raises(ValueError, match=r"^\[frames\] driver: required"):
        config_from_mapping({"frames": {}})
    with pytest.raises(ValueError, match=r"^\[frames\] sync_tolerance_s: must be greater than or equal to 0, got -1$"):
        BagConfig(driver="/s", detectors=(DetectorConfig(name="a", kind="leg", topic="/s"),), sync_tolerance_s=-1)
    with pytest.raises(ValueError, match=r"^\[\[detectors\]\] 'p': a 'topic' detector must give ppv, fnr"):
        DetectorConfig(name="p", kind="topic", topic="/p")
    with pytest.raises(ValueError, match=r"^\[detectors.model\] pvv: unknown key; allowed: \['fnr'"):
        DetectorConfig(name="p", kind="leg", topic="/p", model={"pvv": 0.3})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^\[detectors.model\] ppv of \[\[detectors\]\] #2: must be less than 1"):
        config_from_mapping(
            {
                "frames": {"driver": "/s"},
                "detectors": [
                    {"name": "a", "kind": "leg", "topic": "/s"},
                    {"name": "b", "kind": "leg", "topic": "/s", "model": {"ppv": 1.5}},
                ],
            }
        )
    with pytest.raises(ValueError, match="names must be unique"):
        BagConfig(driver="/s", detectors=(DetectorConfig(name="a", kind="leg", topic="/s"),) * 2)
    bad = tmp_path / "bad.toml"
    bad.write_text("[frames\n")
    with pytest.raises(ValueError, match=r"bad.toml' is not valid TOML"):
        load_config(bad)
    with pytest.raises(FileNotFoundError, match=r"available: \['person_following_outdoor_1'"):
        builtin_config_path("nope")
    legs = [{"name": "a", "kind": "leg", "topic": "/s"}]
    with pytest.raises(ValueError, match=r"^\[tf\] topics: must be a valid tuple, got '/tf'$"):  # not its characters
        config_from_mapping({"frames": {"driver": "/s"}, "tf": {"topics": "/tf"}, "detectors": legs})
