"""Units of the configuration's numbers, as type annotations: ``gate_distance: Metres = 1.0``.

A :class:`Unit` in a field's ``typing.Annotated`` metadata names the field's unit; the configuration reference
(``docs/configuration.md``, :mod:`pfpeople.docs.reference`) shows it. The aliases are plain ``float`` (or
``int``) to Python and to type checkers. SI units throughout (the project's convention): metres, seconds,
radians.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

__all__ = [
    "Cells",
    "CellsF",
    "Metres",
    "MetresPerSecond",
    "PerSecond",
    "Pixels",
    "Radians",
    "Ratio",
    "Seconds",
    "Unit",
    "unit_of",
]


@dataclass(frozen=True)
class Unit:
    """A field's unit (``symbol``: ``"m"``, ``"s"``, ``"rad"``, ``"1/s"``, ``"cells"`` ...)."""

    symbol: str


Metres = Annotated[float, Unit("m")]
Seconds = Annotated[float, Unit("s")]
Radians = Annotated[float, Unit("rad")]
MetresPerSecond = Annotated[float, Unit("m/s")]
PerSecond = Annotated[float, Unit("1/s")]
#: A probability, a fraction or a score in [0, 1] (no unit).
Ratio = Annotated[float, Unit("1")]
Cells = Annotated[int, Unit("cells")]
CellsF = Annotated[float, Unit("cells")]
#: A count of laser beams (returns).
Beams = Annotated[int, Unit("beams")]
Pixels = Annotated[float, Unit("px")]
PixelCount = Annotated[int, Unit("px")]
PerMetre = Annotated[float, Unit("1/m")]
#: Spectral density of a white-noise acceleration.
M2PerS3 = Annotated[float, Unit("m^2/s^3")]


def unit_of(metadata: object) -> str:
    """The unit symbol in an annotation's metadata (a sequence of objects), or ``""``."""
    for item in metadata if isinstance(metadata, list | tuple) else ():
        if isinstance(item, Unit):
            return item.symbol
    return ""
