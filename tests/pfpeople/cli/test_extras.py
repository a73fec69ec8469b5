"""Optional dependencies: a missing extra is named, with the pip command that installs it."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from evaluation.metrics.clear_mot import FrameData, clear_mot
from pfpeople.cli import main
from pfpeople.config import builtin_config_path
from pfpeople.extras import EXTRAS, MissingExtraError, require
from pfpeople.pipeline.batch import dask_client


def test_each_extra_is_declared_in_pyproject() -> None:
    import tomllib
    from pathlib import Path

    meta = tomllib.loads((Path(__file__).resolve().parents[3] / "pyproject.toml").read_text())["project"]
    extras = meta["optional-dependencies"]
    assert set(EXTRAS) <= set(extras)
    assert not any(d.startswith(("dask", "motmetrics", "pandas")) for d in meta["dependencies"])
    assert "pfpeople[batch,eval]" in extras["dev"]


@pytest.mark.parametrize(("extra", "module"), sorted(EXTRAS.items()))
def test_a_missing_extra_names_the_pip_command(monkeypatch: pytest.MonkeyPatch, extra: str, module: str) -> None:
    monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
    with pytest.raises(MissingExtraError, match=rf"pip install 'pfpeople\[{extra}\]'"):
        require(extra, "this")


def test_without_dask_batch_and_mot_say_which_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    monkeypatch.setitem(sys.modules, "motmetrics", None)
    with pytest.raises(MissingExtraError, match=r"pfpeople\[batch\]"), dask_client(workers=1):
        pass
    frame: FrameData = (np.array([1]), np.array([[1.0, 0.0]]))
    with pytest.raises(MissingExtraError, match=r"pfpeople\[eval\]"):
        clear_mot([frame], [frame])


def test_the_cli_reports_a_missing_extra_in_one_line(monkeypatch, capsys, tmp_path) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    bag = tmp_path / "a.bag"
    bag.write_bytes(b"")
    config = builtin_config_path("person_following_outdoor_1")
    code = main(["batch", str(bag), "--config", str(config), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert "pip install 'pfpeople[batch]'" in err and "Traceback" not in err
