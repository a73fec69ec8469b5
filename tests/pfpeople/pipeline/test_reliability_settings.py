"""Issue 46, findings 13 and 15 (settings): limits and one-line errors for configurations and the environment.

- ``[classifier] smooth = 1e9`` asked scipy for a 60 GiB kernel (MemoryError); the limit now holds for the library's
  classifier too, with the same message;
- 5,000 nested inline tables or 100,000 nested arrays in a TOML ended in a RecursionError, a non-UTF-8 file in a
  UnicodeDecodeError naming no file;
- ``PFPEOPLE_MAX_MEMORY_BYTES=1e400`` ended in an OverflowError;
- ``--blas-threads 64`` under an address-space limit crashed OpenBLAS (no cap at the CPU count);
- ``[filter] seed = -1`` failed in numpy without naming the setting.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import write_scan_bag

from gridbridge.classifiers import PeakClassifier, classify_peaks
from gridbridge.grid import GridSpec
from gridbridge.limits import ResourceLimitError
from pfpeople.cli import main
from pfpeople.config import config_from_mapping, load_config
from pfpeople.pipeline.blas import resolve_blas_threads, usable_cpus

BASE = {"frames": {"driver": "/scan"}, "detectors": [{"name": "l", "kind": "leg", "topic": "/scan"}]}
SMOOTH = r"smooth = 1e\+09 cells is more than the limit of 10 cells"


def test_a_huge_smoothing_is_refused_in_the_config_and_in_the_library_with_the_same_message() -> None:
    with pytest.raises(ResourceLimitError, match=rf"\[classifier\] {SMOOTH}"):
        config_from_mapping({**BASE, "classifier": {"smooth": 1e9}})
    with pytest.raises(ResourceLimitError, match=rf"PeakClassifier\.{SMOOTH}"):
        PeakClassifier(smooth=1e9)
    with pytest.raises(ResourceLimitError, match=rf"^{SMOOTH}"):
        classify_peaks(np.full((30, 30), 0.5), GridSpec(), smooth=1e9)
    assert len(classify_peaks(np.full((30, 30), 0.5), GridSpec(), smooth=10.0).positions) <= 1  # the limit itself runs


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("x = " + "{a = " * 5000 + "1" + "}" * 5000 + "\n", r"nests tables or arrays too deeply"),
        ("x = " + "[" * 100_000 + "]" * 100_000 + "\n", r"nests tables or arrays too deeply"),
    ],
    ids=["inline-tables", "arrays"],
)
def test_a_deeply_nested_toml_is_a_one_line_error_naming_the_file(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "deep.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=rf"config file '.*deep\.toml' {match}"):
        load_config(path)


def test_a_config_that_is_not_utf8_is_named(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "latin1.toml"
    path.write_bytes('[frames]\ndriver = "/scan" # caf\xe9\n'.encode("latin-1"))
    with pytest.raises(ValueError, match=r"config file '.*latin1\.toml' is not UTF-8 text \(byte 0xe9 at line 2\)"):
        load_config(path)
    write_scan_bag(tmp_path / "b.bag", 2)  # an existing bag: the configuration is what is refused
    assert main(["run", str(tmp_path / "b.bag"), "--config", str(path), "--out", str(tmp_path / "r")]) == 2
    assert "is not UTF-8 text" in capsys.readouterr().err


def test_a_negative_seed_is_refused_naming_the_setting() -> None:
    with pytest.raises(ValueError, match=r"\[filter\] seed: must be greater than or equal to 0, got -1"):
        config_from_mapping({**BASE, "filter": {"kind": "particle", "seed": -1}})


@pytest.mark.parametrize("value", ["1e400", "inf", "-1", "x"])
def test_a_memory_budget_in_the_environment_that_is_no_number_is_named(
    monkeypatch: pytest.MonkeyPatch, value: str
) -> None:
    monkeypatch.setenv("PFPEOPLE_MAX_MEMORY_BYTES", value)
    with pytest.raises(ValueError, match=rf"environment variable PFPEOPLE_MAX_MEMORY_BYTES='{value}' must be a finite"):
        config_from_mapping({**BASE, "grid": {"nx": 30, "ny": 30, "x0": 0.0, "y0": -4.5}})  # a grid of known size


def test_blas_threads_are_capped_at_the_usable_cpus(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING):
        assert resolve_blas_threads(64 * usable_cpus()) == usable_cpus()
    assert f"is more than the {usable_cpus()} CPU(s) this process may use" in caplog.text
    assert resolve_blas_threads(1) == 1 and resolve_blas_threads(0) == 0
