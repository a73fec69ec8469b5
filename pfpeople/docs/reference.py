"""The configuration reference page, generated from the schema: ``docs/configuration.md``.

Every table of a run configuration with each field's type (and bounds), default (the paper mode's where it
differs), unit and meaning (the classes' numpydoc). Run::

    python -m pfpeople.docs.reference --write   # writes docs/configuration.md
    python -m pfpeople.docs.reference --check   # exit 1 when docs/configuration.md is not current

``tests/pfpeople/config/test_reference.py`` checks that the page in the repository is current.
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import math
import sys
import types
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from annotated_types import Ge, Gt, Le, Lt, MinLen

from pfpeople.config.schema import class_in, field_default
from pfpeople.docs.docstrings import field_meanings
from pfpeople.units import Unit

__all__ = ["REFERENCE_PATH", "Row", "Section", "field_count", "main", "render", "sections"]

#: Where the page lives in the repository.
REFERENCE_PATH = Path(__file__).resolve().parents[2] / "docs" / "configuration.md"


@dataclass(frozen=True)
class Row:
    """One field: its key in the TOML table, type, default, unit and meaning (Markdown, one line each)."""

    key: str
    type: str
    default: str
    unit: str
    meaning: str


@dataclass(frozen=True)
class Section:
    """One table of the reference."""

    title: str
    intro: str
    rows: tuple[Row, ...]


# -- types, bounds, units, defaults as text ----------------------------------------------------------------------


def _bounds(meta: Sequence[Any]) -> str:
    """``>= 0``, ``in (0, 1)`` from annotated-types constraints (also inside pydantic ``FieldInfo`` metadata)."""
    items: list[Any] = []
    for m in meta:
        items.extend(getattr(m, "metadata", None) or [m])
    lo = next((("[", m.ge) for m in items if isinstance(m, Ge)), None) or next(
        (("(", m.gt) for m in items if isinstance(m, Gt)), None
    )
    hi = next(((m.le, "]") for m in items if isinstance(m, Le)), None) or next(
        ((m.lt, ")") for m in items if isinstance(m, Lt)), None
    )
    if lo and hi:
        return f" in {lo[0]}{lo[1]:g}, {hi[0]:g}{hi[1]}"
    if lo:
        return f" {'>=' if lo[0] == '[' else '>'} {lo[1]:g}"
    if hi:
        return f" {'<=' if hi[1] == ']' else '<'} {hi[0]:g}"
    if any(isinstance(m, MinLen) and m.min_length >= 1 for m in items):
        return " (not empty)"
    return ""


def type_text(annotation: Any, meta: Sequence[Any] = ()) -> tuple[str, str]:
    """``(type, unit)`` of an annotation as the reference shows them (``number in (0, 1)``, ``m``)."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is Annotated:
        base, *inner = args
        text, unit = type_text(base, [*inner, *meta])
        return text, unit or next((m.symbol for m in inner if isinstance(m, Unit)), "")
    if origin in (typing.Union, types.UnionType):
        parts = [type_text(a) for a in args if a is not type(None)]
        return " or ".join(p[0] for p in parts) + _bounds(meta), next((p[1] for p in parts if p[1]), "")
    if origin is Literal:
        return " or ".join(f'`"{a}"`' if isinstance(a, str) else f"`{a}`" for a in args), ""
    if origin in (tuple, list) or annotation in (tuple, list):
        item, item_unit = type_text(args[0]) if args else ("value", "")
        plural = {"number": "numbers", "string": "strings", "integer": "integers"}.get(item.split(" ")[0], item)
        return f"array of {plural}" + _bounds(meta), item_unit
    if origin in (dict, Mapping) or annotation in (dict, Mapping) or origin is getattr(typing, "Mapping", None):
        return "table", ""
    names = {float: "number", int: "integer", bool: "true/false", str: "string", Path: "path"}
    if annotation in names:
        return names[annotation] + _bounds(meta), ""
    if isinstance(annotation, type) and dataclasses.is_dataclass(annotation):
        return "table", ""
    return getattr(annotation, "__name__", str(annotation)), ""


def value_text(value: Any) -> str:
    """A default as TOML would write it (``true``, ``"grid"``, ``["/tf"]``, ``inf``); None as *unset*."""
    if value is None:
        return "unset"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, float):
        return "`inf`" if math.isinf(value) else f"`{value:g}`"
    if isinstance(value, tuple | list):
        return "`[" + ", ".join(value_text(v).strip("`") for v in value) + "]`"
    if isinstance(value, Mapping):
        return "`{}`" if not value else f"`{dict(value)}`"
    if dataclasses.is_dataclass(value):
        return "its table"
    return f"`{value}`"


def class_rows(
    cls: type,
    *,
    prefix: str = "",
    only: Sequence[str] | None = None,
    keys: Mapping[str, str] | None = None,
    paper: Mapping[str, Any] | None = None,
    notes: Mapping[str, str] | None = None,
    nested: bool = True,
) -> list[Row]:
    """The rows of a dataclass's fields (``only`` these, named ``keys[name]``); a field whose type is a dataclass
    becomes the rows of its own fields (``prefix.field.sub``) when ``nested``.

    ``paper``: the paper mode's defaults; ``notes``: a default's text in place of the field's own."""
    hints = typing.get_type_hints(cls, include_extras=True)
    meanings = field_meanings(cls)
    pyd = getattr(cls, "__pydantic_fields__", {})
    rows: list[Row] = []
    for f in dataclasses.fields(cls):
        if (only is not None and f.name not in only) or not f.init:
            continue
        key = prefix + (keys or {}).get(f.name, f.name)
        ann = hints[f.name]
        sub = _dataclass_in(ann)
        if nested and sub is not None:
            rows += class_rows(sub, prefix=f"{key}.")
            continue
        meta = getattr(pyd.get(f.name), "metadata", [])
        text, unit = type_text(ann, meta)
        default = field_default(cls, f.name)
        shown = "required" if default is dataclasses.MISSING else value_text(default)
        if notes and f.name in notes:
            shown = notes[f.name]
        if paper and f.name in paper:
            shown += f"; paper mode: {value_text(paper[f.name])}"
        meaning = meanings.get(f.name, "")
        rows.append(Row(key, text, shown, "" if unit == "1" else unit, meaning))
    return rows


def _dataclass_in(annotation: Any) -> type | None:
    """The dataclass an annotation names (``LegDetectorParams | None`` too), else None."""
    return class_in(annotation, dataclasses.is_dataclass)


# -- the tables ---------------------------------------------------------------------------------------------------


def _strip_key(meaning: str) -> str:
    """A :class:`BagConfig` meaning without its leading `` `[table] key`: `` (the row says it)."""
    head, sep, rest = meaning.partition(": ")
    return rest[:1].upper() + rest[1:] if sep and head.startswith("`[") else meaning


def _bag_sections() -> list[Section]:
    from pfpeople.config.run import FRAMES_KEYS, BagConfig

    def rows(names: Sequence[str], keys: Mapping[str, str] | None = None) -> tuple[Row, ...]:
        return tuple(
            dataclasses.replace(r, meaning=_strip_key(r.meaning)) for r in class_rows(BagConfig, only=names, keys=keys)
        )

    mounts = field_meanings(BagConfig)["mounts"]
    return [
        Section("[frames]", "The frames and their synchronisation (required: `driver`).", rows(FRAMES_KEYS)),
        Section("[odometry]", "", rows(["odometry"], {"odometry": "topic"})),
        Section("[tf]", "", rows(["tf_topics"], {"tf_topics": "topics"})),
        Section(
            "[mounts]",
            "",
            (Row("FRAME", "array of 3 numbers", "none", "m, m, rad", _strip_key(mounts)),),
        ),
    ]


def _table_sections() -> list[Section]:
    from pfpeople.config.filtering import FilterConfig
    from pfpeople.config.grid import GridConfig
    from pfpeople.config.modes import PAPER_DEFAULTS
    from pfpeople.config.people import KIND_THRESHOLD, ClassifierConfig, TrackingConfig
    from pfpeople.config.perception import ClutterSuppression, OutputConfig
    from pfpeople.perception.clutter_map import ClutterConfig
    from pfpeople.track.multi_person import TrackerConfig

    thresholds = ", ".join(f"{value_text(v)} ({k})" for k, v in KIND_THRESHOLD.items())
    return [
        Section(
            "[grid]",
            "The local grid (default: the lasers' fields of view at 0.3 m cells).",
            tuple(class_rows(GridConfig)),
        ),
        Section(
            "[filter]",
            "The filter and its mode.",
            tuple(class_rows(FilterConfig, paper=PAPER_DEFAULTS["filter"])),
        ),
        Section(
            "[classifier]",
            "",
            tuple(class_rows(ClassifierConfig, paper=PAPER_DEFAULTS["classifier"], notes={"threshold": thresholds})),
        ),
        Section(
            "[tracking]",
            "",
            tuple(class_rows(TrackingConfig, paper=PAPER_DEFAULTS["tracking"], nested=False)),
        ),
        Section(
            "[tracking.params]",
            "The multi-person tracker (`pfpeople.track.TrackerConfig`). With `[tracking] peak_threshold`, "
            "`birth_min_score` is the classifier's threshold unless given here.",
            tuple(class_rows(TrackerConfig)),
        ),
        Section("[clutter]", "", tuple(class_rows(ClutterSuppression, paper=PAPER_DEFAULTS["clutter"], nested=False))),
        Section(
            "[clutter.params]",
            "The static-clutter map (`pfpeople.perception.clutter_map.ClutterConfig`).",
            tuple(class_rows(ClutterConfig)),
        ),
        Section("[output]", "", tuple(class_rows(OutputConfig))),
    ]


def _detector_sections() -> list[Section]:
    from pfpeople.config.detectors import KINDS, DetectorConfig, DetectorModelConfig

    held = [k for k, v in KINDS.items() if v.hold_arrivals]
    notes = {"hold_arrivals": f"by kind: `true` for {', '.join(held) or 'none'}, else `false`"}
    model_notes = {f.name: "the detector's own" for f in dataclasses.fields(DetectorModelConfig)}
    out = [
        Section(
            "[[detectors]]",
            "One entry per detector (at least one).",
            tuple(class_rows(DetectorConfig, notes=notes, nested=False)),
        ),
        Section(
            "[detectors.model]",
            "The detector's model in the filter; a field left out keeps the detector's own (below).",
            tuple(class_rows(DetectorModelConfig, notes=model_notes)),
        ),
    ]
    for kind in KINDS:
        rows = tuple(_kind_rows(kind))
        if rows:
            title = f'[detectors.params] of kind = "{kind}"'
            out.append(Section(title, _kind_intro(kind), rows))
    return out


def _detector_class(kind: str) -> type | None:
    """The detector class whose constructor takes ``kind``'s ``[detectors.params]`` (its adapter's), or None."""
    import pfpeople.detect
    from pfpeople.detect.adapters import ADAPTERS

    name = getattr(ADAPTERS.get(kind), "detector_class", "")
    return getattr(pfpeople.detect, name, None) if name else None


def _kind_intro(kind: str) -> str:
    from pfpeople.config.detectors import KINDS

    cls = _detector_class(kind)
    spec = KINDS[kind]
    text = f"Input: {spec.input}. Keyword arguments of `{cls.__name__}`" if cls is not None else f"Input: {spec.input}"
    model = _default_model(cls)
    if model is not None:
        text += f"; its own model: PPV {model.ppv:g}, FNR {model.fnr:g}, {model.uncertainty} detections" + (
            " (a laser's field of view and range come from its scans)" if spec.input == "LaserScan" else ""
        )
    return text + "."


def _default_model(cls: type | None) -> Any:
    """The model a detector class gives itself (None where it cannot be built without arguments)."""
    if cls is None:
        return None
    try:
        return cls().model
    except Exception:  # a detector that needs its own files or arguments: its docstring says
        return None


def _kind_rows(kind: str) -> list[Row]:
    """The ``[detectors.params]`` of ``kind``: its detector's constructor arguments (:mod:`pfpeople.detect.settings`
    reserves ``model`` and ``mounting``), a dataclass argument as the rows of its fields."""
    from pfpeople.detect.settings import RESERVED

    cls = _detector_class(kind)
    if cls is None:
        return []
    hints = typing.get_type_hints(cls.__init__, include_extras=True)  # type: ignore[misc]
    meanings = field_meanings(cls)
    rows: list[Row] = []
    for name, p in inspect.signature(cls).parameters.items():
        if name in RESERVED or p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
            continue
        sub = _dataclass_in(hints.get(name))
        if sub is not None:
            rows += class_rows(sub, prefix=f"{name}.")
            continue
        text, unit = type_text(hints.get(name, Any))
        default = "required" if p.default is inspect.Parameter.empty else value_text(p.default)
        rows.append(Row(name, text, default, unit, meanings.get(name, "")))
    return rows


def sections() -> list[Section]:
    """Every table of the reference, in the order of a configuration file."""
    return [*_bag_sections(), *_table_sections(), *_detector_sections()]


# -- the page -----------------------------------------------------------------------------------------------------

_HEAD = """\
# Configuration reference

<!-- Generated from the schema (pfpeople/config/) by `python -m pfpeople.docs.reference --write`; do not edit.
     tests/pfpeople/config/test_reference.py checks that it is current. -->

A run is configured by a TOML file (`pfpeople run BAG --config FILE`, `pfpeople node --config FILE`;
`pfpeople inspect BAG --write-config FILE` writes a starter). Every table is optional except `[frames] driver` and
at least one `[[detectors]]` entry; a key left out takes the default below. A key or value the schema does not
know is an error of one line naming the table and the key (`pfpeople` exits with code 2).

`[filter] mode` chooses the defaults of the keys left out: the recommended mode's (the product's, chosen on the
benchmark across every scene) are the fields' own; where the paper mode's (Batista & Pereira 2015 as written)
differ, the default column says `paper mode: ...`. A key that is given is used as given in either mode.
`"auto"` (the grid's extent, the particle count) is computed for the run as the meaning says. Units are SI
(m, s, rad; REP-103 frames: x forward, y left).

{count} settable fields in {tables} tables (the rows below, less the {nested} that name a table of their own;
`[detectors.params]` counted for each detector kind).
"""


def field_count(secs: Sequence[Section] | None = None) -> int:
    """The settable fields: every row but those that name a table of their own (``params``, ``model``)."""
    return sum(r.type != "table" for s in (sections() if secs is None else secs) for r in s.rows)


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def render() -> str:
    """The reference page (Markdown)."""
    secs = sections()
    nested = sum(r.type == "table" for s in secs for r in s.rows)
    out = [_HEAD.format(count=field_count(secs), tables=len(secs), nested=nested)]
    for s in secs:
        out.append(f"\n## {s.title}\n")
        if s.intro:
            out.append(f"\n{s.intro}\n")
        out.append("\n| key | type | default | unit | meaning |\n|---|---|---|---|---|\n")
        for r in s.rows:
            out.append(f"| `{r.key}` | {_cell(r.type)} | {_cell(r.default)} | {r.unit} | {_cell(r.meaning)} |\n")
    return "".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """``--write``: write the page; ``--check``: exit 1 when it is not current; else print it."""
    parser = argparse.ArgumentParser(prog="python -m pfpeople.docs.reference", description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"write {REFERENCE_PATH.name}")
    parser.add_argument("--check", action="store_true", help="exit 1 when the page is not current")
    parser.add_argument("--out", type=Path, default=REFERENCE_PATH, help="the page (default: docs/configuration.md)")
    args = parser.parse_args(argv)
    text = render()
    if args.check:
        current = args.out.is_file() and args.out.read_text(encoding="utf-8") == text
        if not current:
            print(f"{args.out} is not current: run python -m pfpeople.docs.reference --write", file=sys.stderr)
        return 0 if current else 1
    if args.write:
        args.out.write_text(text, encoding="utf-8")
        return 0
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
