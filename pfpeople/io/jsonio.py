"""The one JSON convention of every file the project writes: ``run.json``, the A/B record, the benchmark, score,
track and calibration reports, ``pfpeople inspect-bag --json``.

Strict JSON (RFC 8259) has no NaN or infinity. NaN, an undefined value (a recall with no ground truth, a rate
of an empty topic), is written as ``null``; plus or minus infinity, a real value (an unbounded ``max_range``), as
the strings ``"inf"`` / ``"-inf"``, which ``float()`` reads back. NumPy scalars and arrays become numbers and
lists, paths strings. Files written before this convention hold ``"nan"``; readers accept both.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["dumps", "json_safe"]


def json_safe(value: Any) -> Any:
    """``value`` with NaN as None, +-inf as ``"inf"`` / ``"-inf"``, NumPy values as Python ones, paths as strings
    (recursively through dicts, lists and tuples; dict keys that JSON cannot hold become strings)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        if math.isnan(value):
            return None
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return value
    if isinstance(value, dict):
        return {(k if isinstance(k, str | int | float | bool) else str(k)): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    return value


def dumps(value: Any, *, indent: int | None = 2, default: Any = None) -> str:
    """Strict JSON text of ``value`` after :func:`json_safe` (``default`` as for :func:`json.dumps`)."""
    return json.dumps(json_safe(value), indent=indent, default=default, allow_nan=False)
