"""Input checks shared by every package: every error names the argument that was wrong.

The public home of the checks (gridbridge, pfpeople and evaluation all use them). Bad values raise
``ValueError`` naming the input, as the README's Architecture section states for the whole project; values of
the wrong type raise ``TypeError`` (from :func:`check_int` and :func:`check_real` an :class:`InputTypeError`,
which is both). :func:`check_int` and :func:`check_real` are the checks of one count or one number with its
bounds; their messages name the argument and the bound (``"TrackerConfig.gate_distance must be a number > 0,
got -1.0"``).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "InputTypeError",
    "check_choice",
    "check_finite",
    "check_grid_array",
    "check_int",
    "check_number",
    "check_positions",
    "check_positive",
    "check_probability",
    "check_real",
    "check_real_array",
    "finite_rows",
]


class InputTypeError(TypeError, ValueError):
    """A value of the wrong type (a string, a bool, a float for a count), raised by :func:`check_int` and
    :func:`check_real`.

    A ``TypeError``, and a ``ValueError`` too: the configurations and the command lines catch bad input as
    ``ValueError`` (the README's "bad values raise ValueError"), and a wrong type is bad input to them.
    """


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
    if not np.isfinite(arr).all():
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
    if not np.isfinite(pts).all():
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


def _bound_text(low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    """The bounds as text: ``"> 0"``, ``"<= 10"`` or ``"in [0, 1)"``."""
    if low is not None and high is not None:
        return f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    if low is not None:
        return f"{'>' if low_open else '>='} {low:g}"
    return f"{'<' if high_open else '<='} {high:g}"


def check_real(
    value: object,
    name: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """Check a finite real number within optional bounds; returns it as a float.

    Parameters
    ----------
    value : object
        The value to check: a real number (Python or NumPy), not a bool, a string or a complex number.
    name : str
        The argument's name, used in the error messages (e.g. ``"TrackerConfig.process_noise"``).
    low, high : float or None
        Lower and upper bounds; None: unbounded on that side.
    low_open, high_open : bool
        Whether ``low`` / ``high`` themselves are excluded.

    Returns
    -------
    float
        ``value`` as a float.

    Raises
    ------
    InputTypeError
        A ``TypeError`` (and ``ValueError``) naming ``name``, for a value that is not a real number
        (:func:`check_number`).
    ValueError
        Naming ``name``, for NaN or infinity, and naming ``name`` and the bound for a value outside the bounds.
    """
    try:
        v = check_number(value, name)
    except TypeError as exc:
        raise InputTypeError(str(exc)) from None
    below = low is not None and (v < low or (low_open and v == low))
    above = high is not None and (v > high or (high_open and v == high))
    if below or above:
        raise ValueError(f"{name} must be a number {_bound_text(low, high, low_open, high_open)}, got {value!r}")
    return v


def check_int(value: object, name: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """Check an integer within optional inclusive bounds; returns it as an ``int``.

    Parameters
    ----------
    value : object
        The value to check: a Python ``int`` or a NumPy integer, not a bool, a float or a string.
    name : str
        The argument's name, used in the error messages (e.g. ``"TrackerConfig.confirm_hits"``).
    minimum, maximum : int or None
        Smallest and largest allowed value; None: unbounded on that side.

    Returns
    -------
    int
        ``value`` as an ``int``.

    Raises
    ------
    InputTypeError
        A ``TypeError`` (and ``ValueError``) naming ``name``, for a value that is not an integer (a bool
        included: True is not a count).
    ValueError
        Naming ``name`` and the bound, for a value outside the bounds.
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputTypeError(f"{name} must be an integer, got {type(value).__name__}")
    v = int(value)
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        if minimum is not None and maximum is not None:
            bound = f"an integer in [{minimum}, {maximum}]"
        elif minimum == 1:
            bound = "a positive integer (>= 1)"
        else:
            bound = f"an integer >= {minimum}" if minimum is not None else f"an integer <= {maximum}"
        raise ValueError(f"{name} must be {bound}, got {value!r}")
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


def finite_rows(points: NDArray[np.float64]) -> NDArray[np.bool_]:
    """``np.isfinite(points).all(axis=1)`` of a 2-D array ``(N, k)``, column by column: the same mask, several
    times faster than the reduction along rows (this runs on every scan)."""
    if points.ndim != 2:
        raise ValueError(f"points must be a 2-D array, got shape {points.shape}")
    if points.shape[1] == 0:
        return np.ones(points.shape[0], dtype=bool)
    out = np.isfinite(points[:, 0])
    for c in range(1, points.shape[1]):
        out &= np.isfinite(points[:, c])
    return out
