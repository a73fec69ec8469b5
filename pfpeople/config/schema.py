"""The machinery of the configuration's tables: typed, frozen dataclasses validated by pydantic.

Each table of a run configuration (``[filter]``, ``[classifier]`` ...) is a class decorated with :func:`table`: a
frozen, keyword-only :func:`pydantic.dataclasses.dataclass` that refuses unknown keys and values of the wrong type
(a string for a number, ``1`` for ``true``, NaN), checks its fields' bounds (``pydantic.Field(ge=...)``) and then
calls the class's ``check()`` for what involves several fields. Any of these errors is a :class:`ConfigError`, a
``ValueError`` of one line naming the table and the field: ``[filter] seed: must be greater than or equal to 0, got
-1``. ``dataclasses.replace`` builds a new, checked table.

The field types below carry the unit (:mod:`pfpeople.units`) that the configuration reference shows.
"""

from __future__ import annotations

import dataclasses
import functools
import typing
from collections.abc import Callable, Mapping, Sequence
from typing import Annotated, Any, ClassVar, TypeVar, cast, dataclass_transform

from pydantic import AllowInfNan, ConfigDict, Field, Strict, ValidationError
from pydantic.dataclasses import dataclass as pydantic_dataclass
from pydantic_core import ArgsKwargs

from pfpeople.units import Unit

__all__ = [
    "CellsF",
    "ConfigError",
    "Count",
    "Flag",
    "Metres",
    "Number",
    "PerSecond",
    "Radians",
    "Ratio",
    "Seconds",
    "Table",
    "Text",
    "check_tree",
    "class_in",
    "error_line",
    "field_default",
    "fill_defaults",
    "is_table",
    "table",
    "table_fields",
]

T = TypeVar("T")

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, arbitrary_types_allowed=False)

#: A finite number (an integer is taken as a float; not a bool, not a string).
Number = Annotated[float, Strict(), AllowInfNan(False)]
Metres = Annotated[float, Unit("m"), Strict(), AllowInfNan(False)]
Seconds = Annotated[float, Unit("s"), Strict(), AllowInfNan(False)]
Radians = Annotated[float, Unit("rad"), Strict(), AllowInfNan(False)]
PerSecond = Annotated[float, Unit("1/s"), Strict(), AllowInfNan(False)]
#: A probability or a fraction (no unit).
Ratio = Annotated[float, Unit("1"), Strict(), AllowInfNan(False)]
CellsF = Annotated[float, Unit("cells"), Strict(), AllowInfNan(False)]
#: An integer (not a bool, not a float).
Count = Annotated[int, Strict()]
Flag = Annotated[bool, Strict()]
Text = Annotated[str, Strict()]


class ConfigError(ValueError):
    """A bad configuration value: one line naming the table and the field."""


class Table:
    """What every table has (for type checkers): its TOML name and its check of several fields."""

    TABLE: ClassVar[str] = ""

    def check(self) -> None:
        """Checks that involve several fields (raise :class:`ConfigError`); nothing by default."""


@dataclass_transform(kw_only_default=True, frozen_default=True, field_specifiers=(dataclasses.field, Field))
def table(cls: type[T]) -> type[T]:
    """``cls`` as a checked configuration table (see the module docstring); ``cls.TABLE`` names it in errors."""
    out = pydantic_dataclass(frozen=True, kw_only=True, config=_STRICT)(cls)
    init = out.__init__

    @functools.wraps(init)
    def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
        try:
            init(self, *args, **kwargs)
        except ValidationError as exc:
            raise ConfigError(error_line(exc, type(self))) from None
        check_tree(self)

    out.__init__ = __init__  # type: ignore[method-assign]
    return cast(type[T], out)


def fill_defaults(data: Any, fill: Callable[[dict[str, Any]], dict[str, Any]]) -> Any:
    """For a ``model_validator(mode="before")``: ``fill`` applied to the given keys (keyword arguments, or the
    mapping a table is built from); anything else unchanged (pydantic reports it)."""
    if isinstance(data, ArgsKwargs):
        return ArgsKwargs(data.args, fill(dict(data.kwargs or {})))
    if isinstance(data, Mapping):
        return fill(dict(data))
    return data


def is_table(obj: object) -> bool:
    """Whether ``obj`` (an instance or a class) is a configuration table."""
    cls = obj if isinstance(obj, type) else type(obj)
    return dataclasses.is_dataclass(cls) and hasattr(cls, "__pydantic_fields__") and hasattr(cls, "TABLE")


def check_tree(obj: Any) -> None:
    """Run ``check()`` of ``obj`` and of every table inside it (tables built from mappings by pydantic are not built
    through ``__init__``)."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        for item in value if isinstance(value, tuple) else (value,):
            if is_table(item):
                check_tree(item)
    check = getattr(obj, "check", None)
    if check is not None:
        check()


def table_fields(cls: type) -> dict[str, Any]:
    """``{name: annotation}`` of a table's fields, with their ``Annotated`` metadata (units, bounds)."""
    hints = typing.get_type_hints(cls, include_extras=True)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls)}


def class_in(annotation: Any, accept: Callable[[type], bool]) -> type | None:
    """The first class inside an annotation that ``accept`` takes (``FilterConfig`` in ``tuple[FilterConfig, ...]``,
    ``LegDetectorParams`` in ``LegDetectorParams | None``), else None."""
    if isinstance(annotation, type) and accept(annotation):
        return annotation
    for arg in typing.get_args(annotation):
        inner = class_in(arg, accept)
        if inner is not None:
            return inner
    return None


def field_default(cls: type, name: str) -> Any:
    """The default of field ``name`` of dataclass ``cls`` (``dataclasses.MISSING`` when required)."""
    info = getattr(cls, "__pydantic_fields__", {}).get(name)
    if info is not None:
        if info.default_factory is not None:
            return info.default_factory()
        return dataclasses.MISSING if info.is_required() else info.default
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return f.default


def _nested_class(annotation: Any) -> type | None:
    """The table class inside an annotation, else None."""
    return class_in(annotation, is_table)


def _where(cls: type, loc: Sequence[str | int]) -> tuple[str, type | None]:
    """The table and key a pydantic error location names (``"[filter] seed"``, ``"[detectors.model] ppv of
    [[detectors]] #2"``), and the class of the last table."""
    current: type = cls
    table_name: str = cls.TABLE  # type: ignore[attr-defined]
    entry = ""
    keys: list[str] = []
    for part in loc:
        if isinstance(part, int):
            entry = f"{table_name} #{part + 1}"
            continue
        nested = _nested_class(table_fields(current)[part]) if part in table_fields(current) else None
        if nested is not None:
            current, table_name, keys = nested, nested.TABLE, []  # type: ignore[attr-defined]
            continue
        keys.append(part)
    label = getattr(cls, "label", None)
    if current is cls and keys and label is not None:
        return label(keys[0]) + "".join(f".{k}" for k in keys[1:]), current
    where = (entry if entry.startswith(table_name + " #") else table_name) + (" " + ".".join(keys) if keys else "")
    if entry and not entry.startswith(table_name + " #"):
        where += f" of {entry}"
    return where, current


def _allowed(cls: type | None) -> str:
    if cls is None or not is_table(cls):
        return ""
    return f"; allowed: {sorted(f.name for f in dataclasses.fields(cls) if f.init)}"


def error_line(exc: ValidationError, cls: type) -> str:
    """One line for a pydantic error of table ``cls``: where (table and key), what is wrong, the value given.

    The errors of one key's alternatives (``0.5`` or ``"auto"``) are one message: ``must be a valid integer or
    'auto'``."""
    errors = exc.errors(include_url=False)
    errors = [e for e in errors if not _consequence(e, errors)] or errors
    locs = list(dict.fromkeys(_field_loc(e["loc"]) for e in errors))
    mine = [e for e in errors if _field_loc(e["loc"]) == locs[0]]
    where, at = _where(cls, locs[0])
    kinds = {e["type"] for e in mine}
    if kinds & {"unexpected_keyword_argument", "extra_forbidden"}:
        what = "unknown key" + _allowed(at)
    elif any(k.startswith("missing") for k in kinds):
        what = "required"
    elif "too_short" in kinds:
        what = f"at least one entry is required, got {_shown(mine[0].get('input'))}"
    elif "value_error" in kinds:  # a validator's own words
        what = "; ".join(_reason(e) for e in mine if e["type"] == "value_error")
    else:
        msgs = [_reason(e) for e in mine if e["type"] != "none_required"]
        what = f"must be {' or '.join(dict.fromkeys(msgs))}, got {_shown(mine[0].get('input'))}"
    more = f" (and {len(locs) - 1} more error(s))" if len(locs) > 1 else ""
    return f"{where}: {what}{more}"


def _consequence(error: Mapping[str, Any], errors: Sequence[Mapping[str, Any]]) -> bool:
    """Whether ``error`` only follows from another: an array too short because an entry of it failed."""
    loc = tuple(error["loc"])
    return error["type"] == "too_short" and any(tuple(e["loc"])[: len(loc)] == loc and e is not error for e in errors)


def _field_loc(loc: Sequence[str | int]) -> tuple[str | int, ...]:
    """A pydantic error location without the tags of a union's alternatives (``constrained-float``)."""
    return tuple(p for p in loc if isinstance(p, int) or p.isidentifier())


def _reason(error: Mapping[str, Any]) -> str:
    msg = str(error["msg"])
    for prefix in ("Value error, ", "Input should be "):
        msg = msg.removeprefix(prefix)
    return msg


def _shown(value: Any) -> str:
    text = repr(dict(value) if isinstance(value, Mapping) else value)
    return text if len(text) <= 80 else text[:77] + "..."
