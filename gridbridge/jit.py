"""The switch between compiled (numba) kernels and their pure-numpy twins, shared by every package.

Hot loops live in ``kernels`` modules (:mod:`gridbridge.kernels`, :mod:`pfpeople.particle.predictor.passes`) as plain
Python functions compiled with :func:`jit` (``numba.njit(cache=True)``); each has a numpy twin that gives the same
result (bit for bit where the kernels say so, else within a tolerance the tests check). The compiled kernels run when
numba is importable and the environment variable ``PFPEOPLE_NUMBA`` is not ``0``; otherwise the callers take the numpy
path. :func:`enabled` is read at every call, so :func:`override` can switch within a process, for every package or one
(the tests compare the two paths with it).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar, cast

__all__ = ["AVAILABLE", "SCOPES", "enabled", "jit", "override"]

F = TypeVar("F", bound=Callable[..., Any])

_numba: Any
try:  # numba is a core dependency, but the numpy twins keep everything working without it
    import numba as _numba
except ImportError:  # pragma: no cover - exercised only where numba is missing
    _numba = None

#: Whether numba could be imported.
AVAILABLE: bool = _numba is not None

#: The packages with kernels (``evaluation``: the scan simulator's ray caster); each can be switched alone (the
#: tests compare one package's paths at a time).
SCOPES = ("gridbridge", "pfpeople", "evaluation")

_on = AVAILABLE and os.environ.get("PFPEOPLE_NUMBA", "1").strip() != "0"
_state = dict.fromkeys(SCOPES, _on)


def enabled(scope: str = "gridbridge") -> bool:
    """True when ``scope``'s compiled kernels are used (numba importable and ``PFPEOPLE_NUMBA`` not ``0``)."""
    return _state[scope]


@contextmanager
def override(on: bool, scope: str | None = None) -> Iterator[None]:
    """Within the block use the compiled kernels (``on``, if numba is available) or the numpy twins, in every
    package or in ``scope`` (one of :data:`SCOPES`) only."""
    before = dict(_state)
    for name in SCOPES if scope is None else (scope,):
        _state[name] = bool(on) and AVAILABLE
    try:
        yield
    finally:
        _state.update(before)


def jit(fn: F) -> F:
    """``numba.njit(cache=True, nogil=True, error_model="numpy")`` of ``fn``, compiled lazily at its first call
    (IEEE division: no Python zero-division checks); ``fn`` itself without numba."""
    if _numba is None:  # pragma: no cover
        return fn
    return cast(F, _numba.njit(cache=True, nogil=True, error_model="numpy")(fn))
