"""The learned detector's model files: weights (``.npz``) and model card (``.json``), read without a training library.

``<name>.npz`` holds the network's arrays only (read with ``allow_pickle=False``); ``<name>.json`` beside it is the
model card: the format version, the cut-out window, the layer list, the input channels (the current scan, and past
scans when the model is temporal), how votes are grouped, the operating threshold, and the training record (data
with SHA-256, folds, figures, the lasers it was trained for). Both are checked when loaded: a file that does not
fit this version raises ``ValueError`` naming the file and what is wrong.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfpeople.detect.learned.cutouts import CutoutParams
from pfpeople.detect.learned.net import Network, layers_from_spec

__all__ = ["FORMAT", "LearnedModel", "load_model", "save_model", "sha256_of"]

#: The model card's ``format``: what this version reads.
FORMAT = "pfpeople-learned-detector/1"


@dataclass(frozen=True, kw_only=True, eq=False)
class LearnedModel:
    """A loaded model.

    Attributes
    ----------
    network : Network
    cutout : CutoutParams
    past_scans : int
        Past scans the network sees besides the current one (0: one scan).
    past_step : int
        Frames between the past scans it sees (1: the previous scans).
    motion_input : bool
        Whether it sees the motion detector's moved returns (:mod:`pfpeople.detect.learned.memory`).
    group_radius, min_vote : float
        How votes become detections (:func:`pfpeople.detect.learned.votes.group_votes`; m, score).
    threshold : float
        The operating threshold: detections scoring below it are not reported.
    card : dict
        The whole model card.
    path : Path or None
        The weights file it was read from.
    """

    network: Network
    cutout: CutoutParams
    past_scans: int = 0
    past_step: int = 1
    motion_input: bool = False
    group_radius: float = 0.4
    min_vote: float = 0.1
    threshold: float = 0.5
    card: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None


def sha256_of(path: Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _number(card: Mapping[str, Any], key: str, where: str, *, minimum: float = 0.0) -> float:
    value = card.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or value < minimum:
        raise ValueError(f"{where}: {key!r} must be a finite number >= {minimum}, got {value!r}")
    return float(value)


def _card(path: Path) -> dict[str, Any]:
    side = path.with_suffix(".json")
    if not side.is_file():
        raise ValueError(f"learned model {str(path)!r} has no model card {side.name} beside it")
    try:
        card = json.loads(side.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"model card {str(side)!r} is not valid JSON: {exc}") from None
    if not isinstance(card, dict) or card.get("format") != FORMAT:
        got = card.get("format") if isinstance(card, dict) else type(card).__name__
        raise ValueError(f"model card {str(side)!r}: format {got!r}, this version reads {FORMAT!r}")
    return card


def _arrays(path: Path) -> dict[str, NDArray[Any]]:
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except (OSError, ValueError, EOFError) as exc:
        raise ValueError(f"learned model {str(path)!r} is not a NumPy .npz of arrays: {exc}") from None


def load_model(path: str | Path) -> LearnedModel:
    """Read and check a model (``<name>.npz`` and its card ``<name>.json``).

    Raises
    ------
    FileNotFoundError
        If the weights file does not exist.
    ValueError
        If either file does not fit this version (the message names the file and the field).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"learned model file not found: {path}")
    card = _card(path)
    where = f"model card {str(path.with_suffix('.json'))!r}"
    try:
        cut = CutoutParams(**card.get("cutout", {}))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: cutout: {exc}") from None
    past = int(_number(card, "past_scans", where))
    motion = card.get("motion_input", False)
    if not isinstance(motion, bool):
        raise ValueError(f"{where}: 'motion_input' must be true or false, got {motion!r}")
    layers = card.get("layers")
    if not isinstance(layers, list):
        raise ValueError(f"{where}: 'layers' must be a list of layers")
    try:
        net = Network(layers_from_spec(layers, _arrays(path)), points=cut.points, channels=past + 1 + motion)
    except ValueError as exc:
        raise ValueError(f"learned model {str(path)!r}: {exc}") from None
    if net.outputs != 3:
        raise ValueError(f"learned model {str(path)!r}: the network gives {net.outputs} outputs, expected 3")
    return LearnedModel(
        network=net,
        cutout=cut,
        past_scans=past,
        past_step=int(_number(card, "past_step", where, minimum=1)) if past else 1,
        motion_input=motion,
        group_radius=_number(card, "group_radius", where),
        min_vote=_number(card, "min_vote", where),
        threshold=_number(card, "threshold", where),
        card=card,
        path=path,
    )


def save_model(path: str | Path, network: Network, card: Mapping[str, Any]) -> None:
    """Write ``network``'s arrays to ``path`` (``.npz``) and ``card`` (with ``format`` and ``layers`` set) beside
    it; the written files are read back and checked."""
    path = Path(path)
    arrays: dict[str, Any] = {}
    for k, layer in enumerate(network.layers):
        if layer.type in ("conv", "linear"):
            arrays[f"layer{k}.weight"] = layer.weight
            arrays[f"layer{k}.bias"] = layer.bias
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as fh:
        np.savez(fh, **arrays)
    full = {"format": FORMAT, **card, "layers": network.spec()}
    path.with_suffix(".json").write_text(json.dumps(full, indent=1, sort_keys=False) + "\n", encoding="utf-8")
    load_model(path)
