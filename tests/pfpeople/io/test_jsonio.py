"""One JSON convention for every file written: NaN as null, infinities as "inf" / "-inf", strict JSON."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from gridbridge import GridSpec
from pfpeople.io.jsonio import dumps, json_safe
from pfpeople.io.run_dir import RunWriter, load_run


def test_nan_is_null_and_infinity_a_string() -> None:
    value = {"recall": math.nan, "range": math.inf, "low": -math.inf, "n": np.int64(3), "x": np.float64("nan"),
             "arr": np.array([1.0, np.nan]), "path": Path("a/b"), 7: (1.5, float("nan"))}  # fmt: skip
    text = dumps(value)
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {
        "recall": None, "range": "inf", "low": "-inf", "n": 3, "x": None, "arr": [1.0, None], "path": "a/b",
        "7": [1.5, None],
    }  # fmt: skip
    assert json_safe([np.float32(0.5)]) == [0.5]
    with pytest.raises(TypeError):
        dumps({"f": object()})


def test_run_json_writes_nan_as_null(tmp_path: Path) -> None:
    with RunWriter(tmp_path / "run", spec=GridSpec(nx=4, ny=3), detector_names=["a"], metadata={"x": 1}) as w:
        w.update(undefined=math.nan, unbounded=math.inf)
    meta = json.loads((tmp_path / "run" / "run.json").read_text())
    assert meta["undefined"] is None and meta["unbounded"] == "inf"
    assert load_run(tmp_path / "run").meta["undefined"] is None


def test_a_bad_detections_table_reports_its_own_error(tmp_path: Path) -> None:
    with RunWriter(tmp_path / "run", spec=GridSpec(nx=4, ny=3), detector_names=["a"]) as w:
        w.write_frame(
            frame=0, driver_index=0, stamp_ns=0, bag_time_ns=0, dt_s=0.1, odometry=None, forced=False,
            belief=np.zeros((4, 3)), people=np.zeros((0, 2)), people_size=[], people_probability=[],
            detections=[np.array([[1.0, 0.4]])],
        )  # fmt: skip
    table = tmp_path / "run" / "detections.csv"
    lines = table.read_text().splitlines()
    table.write_text("\n".join([lines[0], lines[1].replace("1.0", "one", 1), lines[1]]) + "\n")
    with pytest.raises(ValueError, match="bad value in column"):
        load_run(tmp_path / "run")
