"""The two modes of a run and the defaults each gives: the one place where a default depends on the mode.

``[filter] mode`` chooses the defaults of the fields a configuration leaves out: every field's own default is the
recommended mode's (the product's, chosen on the benchmark across every scene); :data:`PAPER_DEFAULTS` lists the
fields whose default differs in the paper mode (Batista & Pereira 2015 as written). A field that is given is used
as given in either mode. The configuration reference shows both defaults.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["MODES", "PAPER_DEFAULTS", "for_mode", "mode_defaults", "mode_of"]

#: The modes of ``[filter] mode``.
MODES = ("recommended", "paper")

#: Per table, the defaults of the paper mode that differ from the fields' own (the recommended mode's): the paper's
#: prediction and initial belief, its memoryless people motion for the particles (resampling whenever births
#: overflow), its blob classifier, the classified people reported as they are (no snapping, every track written),
#: no static-clutter suppression.
PAPER_DEFAULTS: dict[str, dict[str, Any]] = {
    "filter": {"form": "paper", "initial": 0.5, "motion_model": "paper", "max_overflow": 0.0},
    "classifier": {"kind": "blobs"},
    "tracking": {"people": "classified", "snap_radius": 0.0, "observed_tracks_only": False, "see_through": False},
    "clutter": {"enabled": False},
}


def mode_defaults(mode: str, table: str) -> dict[str, Any]:
    """The defaults of ``table`` (``"filter"``, ``"classifier"`` ...) in ``mode`` that differ from the fields' own."""
    return dict(PAPER_DEFAULTS.get(table, {})) if mode == "paper" else {}


def for_mode(mode: str, table: str, given: Mapping[str, Any]) -> dict[str, Any]:
    """The keys ``given`` for ``table`` completed with ``mode``'s defaults (a given key wins)."""
    return {**mode_defaults(mode, table), **given}


def mode_of(filter_table: object) -> str:
    """The mode of a ``[filter]`` table given as a mapping, an object with ``mode``, or absent (None)."""
    if filter_table is None:
        return "recommended"
    mode = filter_table.get("mode") if isinstance(filter_table, Mapping) else getattr(filter_table, "mode", None)
    return mode if isinstance(mode, str) else "recommended"
