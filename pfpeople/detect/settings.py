"""Constructor arguments of a detector from its ``[detectors.params]`` table, checked against the type hints.

A TOML value must fit the constructor's annotation (numbers, integers, booleans, strings, paths, literals,
unions, ``None``); a table becomes the annotated dataclass, recursively (tables of any depth), its keys
checked against the dataclass's fields. A mismatch raises ``ValueError`` naming ``detectors.params.KEY``
(``detectors.params.KEY.SUB`` in a nested table) and the expected type.
"""

from __future__ import annotations

import dataclasses
import inspect
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["RESERVED", "kwargs_from_table"]

#: Constructor arguments a run sets itself, not ``[detectors.params]``: the model (``[detectors.model]``) and the
#: mounting of a detector that places its positions itself (from TF, ``[mounts]`` or ``[detectors.model] mount_*``).
RESERVED = ("model", "mounting")


def _type_name(hint: Any) -> str:
    args = typing.get_args(hint)
    if args:
        return " or ".join(_type_name(a) for a in args)
    if hint is type(None):
        return "None"
    if hint is float:
        return "a number"
    if hint is int:
        return "an integer"
    if hint is bool:
        return "true/false"
    if hint is str:
        return "a string"
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return f"a table ({hint.__name__})"
    return getattr(hint, "__name__", str(hint))


def _matches(value: Any, hint: Any) -> bool:
    """Whether a TOML value fits a constructor annotation (unknown annotations accept anything)."""
    if hint is Any or hint is None:
        return True
    args = typing.get_args(hint)
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, a) for a in args)
    if origin is typing.Literal:
        return value in args
    if hint is type(None):
        return value is None
    if hint is bool:
        return isinstance(value, bool)
    if hint is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if hint is str:
        return isinstance(value, str)
    if hint is Path or (isinstance(hint, type) and issubclass(hint, Path)):
        return isinstance(value, str | Path)
    if isinstance(hint, type) and dataclasses.is_dataclass(hint):
        return isinstance(value, Mapping | hint)
    if isinstance(hint, type):
        return isinstance(value, hint)
    return True


def _dataclass_from_table(cls: type, value: Mapping[str, Any], where: str) -> Any:
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for key, item in value.items():
        if key not in names:
            raise ValueError(f"{where}: {cls.__name__} has no field {key!r}; it has {sorted(names)}")
        hint = hints.get(key)
        if isinstance(item, Mapping):
            options = typing.get_args(hint) or (hint,)
            sub = [t for t in options if isinstance(t, type) and dataclasses.is_dataclass(t)]
            if not sub:
                raise ValueError(f"{where}.{key} does not take a table; expected {_type_name(hint)}")
            item = _dataclass_from_table(sub[0], item, f"{where}.{key}")
        elif not _matches(item, hint):
            raise ValueError(f"{where}.{key} must be {_type_name(hint)}, got {item!r} ({type(item).__name__})")
        kwargs[key] = item
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise ValueError(f"{where}: {exc}") from None


def kwargs_from_table(cls: type, table: Mapping[str, Any]) -> dict[str, Any]:
    """Constructor keyword arguments from ``[detectors.params]``; tables become the annotated dataclass.

    Values are checked against the constructor's annotations: a wrong type raises ValueError naming
    ``detectors.params.KEY`` and the expected type.
    """
    sig = inspect.signature(cls)
    hints = typing.get_type_hints(cls.__init__)  # type: ignore[misc]
    kwargs: dict[str, Any] = {}
    for key, value in table.items():
        if key not in sig.parameters or key in RESERVED:
            allowed = sorted(k for k in sig.parameters if k not in RESERVED)
            raise ValueError(f"{cls.__name__} has no constructor argument {key!r}; it takes {allowed}")
        where = f"detectors.params.{key}"
        hint = hints.get(key)
        if isinstance(value, Mapping):
            options = typing.get_args(hint) or (hint,)
            candidates: list[Any] = [t for t in options if isinstance(t, type) and dataclasses.is_dataclass(t)]
            if not candidates:
                raise ValueError(f"{cls.__name__}.{key} does not take a table ({where} must be {_type_name(hint)})")
            value = _dataclass_from_table(candidates[0], value, where)
        elif not _matches(value, hint):
            raise ValueError(f"{where} must be {_type_name(hint)}, got {value!r} ({type(value).__name__})")
        kwargs[key] = value
    return kwargs
