"""The meaning of each field of a configuration class, read from its numpydoc docstring.

The schema's documentation is the classes' own numpydoc ``Parameters`` (or ``Attributes``) section: one entry per
field (``name : type`` then the indented description; ``a, b : float`` documents two). :func:`field_meanings`
returns the descriptions as one line each, with the reST roles reduced to Markdown code
(``:class:`gridbridge.grid.GridSpec``` -> `` `GridSpec` ``), for the configuration reference.
"""

from __future__ import annotations

import inspect
import re

__all__ = ["field_meanings", "plain"]

_SECTIONS = ("Parameters", "Attributes")
_ROLE = re.compile(r":(?:class|func|mod|data|attr|meth|obj):`~?([^`]+)`")
_ENTRY = re.compile(r"^([A-Za-z_][\w, ]*?)\s*:\s*(.*)$")


def plain(text: str) -> str:
    """One line of Markdown from a numpydoc description: roles as code (the last dotted name), ``x`` as `x`."""
    text = _ROLE.sub(lambda m: f"`{m.group(1).rsplit('.', 1)[-1]}`", text)
    text = text.replace("``", "`")
    return " ".join(text.split())


def field_meanings(cls: type) -> dict[str, str]:
    """``{field: meaning}`` from the ``Parameters`` / ``Attributes`` section of ``cls``'s docstring."""
    doc = inspect.getdoc(cls) or ""
    lines = doc.splitlines()
    out: dict[str, str] = {}
    k = 0
    while k < len(lines):
        if lines[k].strip() in _SECTIONS and k + 1 < len(lines) and set(lines[k + 1].strip()) == {"-"}:
            out.update(_entries(lines, k + 2))
            k += 2
        k += 1
    return out


def _entries(lines: list[str], start: int) -> dict[str, str]:
    """The entries of one section starting at line ``start`` (until a blank line followed by a new section)."""
    out: dict[str, str] = {}
    names: list[str] = []
    text: list[str] = []

    def flush() -> None:
        for name in names:
            out[name] = plain(" ".join(text))

    for k in range(start, len(lines)):
        line = lines[k]
        if line and not line.startswith(" "):
            if k + 1 < len(lines) and set(lines[k + 1].strip()) == {"-"}:
                break  # the next section
            match = _ENTRY.match(line)
            if match is None:
                continue
            flush()
            names = [n.strip() for n in match.group(1).split(",") if n.strip()]
            text = []
        elif line.strip():
            text.append(line.strip())
    flush()
    return out
