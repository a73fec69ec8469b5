"""Input checks shared by every package: every error names the argument that was wrong.

The public home of the checks (gridbridge, pfpeople and evaluation all use them). Bad values raise
``ValueError`` naming the input, as the README's Architecture section states for the whole project.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "check_choice",
    "check_finite",
    "check_grid_array",
    "check_number",
    "check_positions",
    "check_positive",
    "check_probability",
    "check_real_array",
]


def check_grid_array(
    array: ArrayLike,
    name: str,
    *,
    shape: Sequence[int] | None = None,
    ndim: int | None = 2,
    probability: bool = True,
) -> NDArray[np.float64]:
    """Return ``array`` as float64 after checking shape, finiteness and (optionally) [0, 1] range."""
    arr = np.asarray(array)
    if arr.dtype == bool:
        arr = arr.astype(float)
    if not np.issubdtype(arr.dtype, np.number):
        raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    arr = arr.astype(float, copy=False)
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array, got shape {arr.shape}")
    if shape is not None and tuple(arr.shape) != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {arr.shape}")
    if probability and arr.size:
        lo, hi = arr.min(), arr.max()
        if lo >= 0.0 and hi <= 1.0:  # False for NaN too: one check of two passes (this runs on every grid)
            return arr
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")
    if probability and arr.size:
        raise ValueError(f"{name} must hold probabilities in [0, 1], got values in [{arr.min():.6g}, {arr.max():.6g}]")
    return arr


def check_real_array(values: ArrayLike, name: str) -> NDArray[np.float64]:
    """Return ``values`` as a float64 array after checking that they are real numbers.

    Raises ``TypeError`` naming ``name`` for complex, bool, string or other non-number elements (NumPy would
    drop an imaginary part, read True as 1 or parse ``"1.5"`` silently).
    """
    try:
        arr = np.asarray(values)
    except ValueError as exc:  # ragged nesting
        raise TypeError(f"{name} must be an array of real numbers: {exc}") from None
    if arr.dtype.kind not in "iuf" and not (arr.dtype.kind == "O" and arr.size == 0):
        what = {"b": "bool", "c": "complex", "U": "string", "S": "bytes"}.get(arr.dtype.kind, f"{arr.dtype} values")
        raise TypeError(f"{name} must hold real numbers, got {what} (dtype {arr.dtype})")
    return arr.astype(float, copy=False)


def check_positions(positions: ArrayLike, name: str) -> NDArray[np.float64]:
    """Return an ``(N, 2)`` float array of (x, y) positions (m); empty input gives shape (0, 2).

    Raises TypeError naming ``name`` for elements that are not real numbers (:func:`check_real_array`),
    ValueError for another shape or NaN / infinite values.
    """
    pts = check_real_array(positions, name)
    if pts.size == 0:
        return np.zeros((0, 2))
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2) of (x, y) positions in metres, got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"{name} contains NaN or infinite positions")
    return pts


def check_probability(value: float, name: str, *, open_low: bool = False, open_high: bool = False) -> float:
    """Check one probability; ``open_low``/``open_high`` exclude 0 / 1."""
    v = float(value)
    if not math.isfinite(v) or v < 0.0 or v > 1.0 or (open_low and v == 0.0) or (open_high and v == 1.0):
        lo = "(0" if open_low else "[0"
        hi = "1)" if open_high else "1]"
        raise ValueError(f"{name} must be a probability in {lo}, {hi}, got {value!r}")
    return v


def check_positive(value: float, name: str, *, allow_zero: bool = False) -> float:
    """Check a finite positive (or non-negative) number."""
    v = float(value)
    if not math.isfinite(v) or v < 0.0 or (v == 0.0 and not allow_zero):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be a finite {kind} number, got {value!r}")
    return v


def check_number(value: object, name: str) -> float:
    """Check a finite real number given as a number (not a bool, not a string); returns it as a float.

    Raises ``TypeError`` naming ``name`` for another type, ``ValueError`` for NaN or infinity.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def check_finite(value: float, name: str) -> float:
    """Check a finite number (any sign)."""
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def check_choice(value: str, name: str, choices: Sequence[str]) -> str:
    """Check that ``value`` is one of ``choices``."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}; got {value!r}")
    return value
