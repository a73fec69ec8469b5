"""TOML files read with one-line errors naming the file.

:func:`load_toml` reads a file with :mod:`tomllib` and turns what can go wrong into a ``ValueError`` naming the file
(``FileNotFoundError`` for a missing one): bytes that are not UTF-8 (with the first bad byte and its position), a
syntax error (tomllib's line and column), and tables or arrays nested so deeply (5,000 inline tables, 100,000 arrays)
that the parser runs out of recursion, which raised a bare ``RecursionError``.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

__all__ = ["load_toml"]


def load_toml(path: str | Path, what: str = "TOML file") -> dict[str, Any]:
    """The TOML document in ``path``; ``what`` names the file in errors (e.g. ``"config file"``).

    Raises
    ------
    FileNotFoundError
        ``path`` is not a file.
    ValueError
        Naming the file: not UTF-8, not valid TOML, or nested too deeply.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} {str(path)!r} does not exist")
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ValueError(
            f"{what} {str(path)!r} is not UTF-8 text (byte {data[exc.start]:#04x} at line {line}); TOML files are UTF-8"
        ) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{what} {str(path)!r} is not valid TOML: {exc}") from None
    except RecursionError:
        raise ValueError(
            f"{what} {str(path)!r} nests tables or arrays too deeply for a TOML parser (thousands of levels)"
        ) from None
