"""The learned detector's network, run with NumPy (no training library needed at run time).

A network is a list of layers applied to a batch of cut-outs ``(B, L, C)`` (batch, samples along the cut-out,
channels; channels last, float32):

==========  ==========================================================================================
type        what it does
==========  ==========================================================================================
conv        1-D convolution over ``L`` with zero padding ("same" length), odd ``kernel``: weight
            ``(out, in, kernel)`` and bias ``(out,)`` as ``torch.nn.Conv1d`` stores them
relu        ``max(x, 0)``
maxpool     maximum over pairs of samples (``L`` halves; ``L`` must be even)
flatten     ``(B, L, C) -> (B, C L)`` in PyTorch's ``(B, C, L)`` flattening order, so that a linear layer's
            weight means what it means in ``torch.nn.Linear`` after ``torch.flatten``
linear      ``x W^T + b``: weight ``(out, in)``, bias ``(out,)``
==========  ==========================================================================================

The last layer gives three outputs per cut-out: the person logit and the canonical offset ``(dx, dy)`` (m) of the
centre the return votes for (:mod:`pfpeople.detect.learned.votes`). The same list of layers builds the PyTorch
module that trains it (:mod:`pfpeople.detect.learned.training`), and a test checks the two agree.

A model file is a NumPy ``.npz`` (read with ``allow_pickle=False``: it holds arrays only) with the arrays
``layer<k>.weight`` and ``layer<k>.bias`` of the layers that have them, next to a JSON sidecar (the model card)
with the layer list, the cut-out parameters and the training record (:mod:`pfpeople.detect.learned.model_file`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["LAYER_TYPES", "Layer", "Network", "layers_from_spec"]

LAYER_TYPES = ("conv", "relu", "maxpool", "flatten", "linear")


@dataclass(frozen=True, kw_only=True, eq=False)
class Layer:
    """One layer: its ``type`` (:data:`LAYER_TYPES`), its output size ``out`` (conv / linear), its ``kernel``
    (conv) and its parameters (conv / linear; float32)."""

    type: str
    out: int = 0
    kernel: int = 0
    weight: NDArray[np.float32] = field(default_factory=lambda: np.zeros(0, np.float32))
    bias: NDArray[np.float32] = field(default_factory=lambda: np.zeros(0, np.float32))

    def spec(self) -> dict[str, Any]:
        """The layer's description in the model card (no parameters)."""
        out: dict[str, Any] = {"type": self.type}
        if self.type in ("conv", "linear"):
            out["out"] = self.out
        if self.type == "conv":
            out["kernel"] = self.kernel
        return out


def _conv(x: NDArray[np.float32], layer: Layer) -> NDArray[np.float32]:
    """Same-length 1-D convolution of ``x`` ``(B, L, Cin)`` -> ``(B, L, Cout)``: one matrix product per tap."""
    b, n, cin = x.shape
    k = layer.kernel
    pad = k // 2
    xp = np.zeros((b, n + 2 * pad, cin), dtype=np.float32)
    xp[:, pad : pad + n] = x
    taps = layer.weight.transpose(2, 1, 0)  # (K, Cin, Cout)
    out = np.empty((b, n, layer.out), dtype=np.float32)
    out[:] = layer.bias
    for j in range(k):
        out += (xp[:, j : j + n].reshape(-1, cin) @ taps[j]).reshape(b, n, layer.out)
    return out


def _apply(x: NDArray[np.float32], layer: Layer) -> NDArray[np.float32]:
    t = layer.type
    if t == "conv":
        return _conv(x, layer)
    if t == "relu":
        return np.maximum(x, 0.0, out=x)
    if t == "maxpool":
        b, n, c = x.shape
        return x.reshape(b, n // 2, 2, c).max(axis=2)
    if t == "flatten":
        return x.transpose(0, 2, 1).reshape(x.shape[0], -1)
    return x @ layer.weight.T + layer.bias  # linear


class Network:
    """A checked list of layers for cut-outs of ``points`` samples and ``channels`` channels.

    Raises
    ------
    ValueError
        If the layers do not fit each other or the input (the message names the layer), or a parameter is not
        finite.
    """

    def __init__(self, layers: Sequence[Layer], *, points: int, channels: int) -> None:
        self.layers = tuple(layers)
        self.points = int(points)
        self.channels = int(channels)
        self.outputs = _check_layers(self.layers, self.points, self.channels)

    def __call__(self, x: NDArray[np.float32]) -> NDArray[np.float32]:
        """Outputs ``(B, outputs)`` of cut-outs ``x`` ``(B, points, channels)``."""
        if x.ndim != 3 or x.shape[1:] != (self.points, self.channels):
            raise ValueError(f"network input must be (B, {self.points}, {self.channels}), got {x.shape}")
        h = np.ascontiguousarray(x, dtype=np.float32)
        for layer in self.layers:
            h = _apply(h, layer)
        return h

    def spec(self) -> list[dict[str, Any]]:
        """The layer list of the model card."""
        return [layer.spec() for layer in self.layers]


def _check_param(layer: Layer, k: int, shape: tuple[int, ...], what: str) -> None:
    arr = layer.weight if what == "weight" else layer.bias
    if arr.shape != shape:
        raise ValueError(f"layer {k} ({layer.type}): {what} has shape {arr.shape}, expected {shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"layer {k} ({layer.type}): {what} holds non-finite values")


def _check_layers(layers: Sequence[Layer], points: int, channels: int) -> int:
    """Walk the shapes through ``layers``; return the number of outputs."""
    n, c, flat = points, channels, False
    for k, layer in enumerate(layers):
        if layer.type not in LAYER_TYPES:
            raise ValueError(f"layer {k}: unknown type {layer.type!r}; known {list(LAYER_TYPES)}")
        if layer.type == "conv":
            if flat or layer.kernel < 1 or layer.kernel % 2 == 0:
                raise ValueError(f"layer {k} (conv): needs an odd kernel before flatten, got {layer.kernel}")
            _check_param(layer, k, (layer.out, c, layer.kernel), "weight")
            _check_param(layer, k, (layer.out,), "bias")
            c = layer.out
        elif layer.type == "maxpool":
            if flat or n % 2:
                raise ValueError(f"layer {k} (maxpool): needs an even length before flatten, got {n}")
            n //= 2
        elif layer.type == "flatten":
            c, n, flat = c * n, 1, True
        elif layer.type == "linear":
            if not flat:
                raise ValueError(f"layer {k} (linear): needs a flatten before it")
            _check_param(layer, k, (layer.out, c), "weight")
            _check_param(layer, k, (layer.out,), "bias")
            c = layer.out
    if not flat:
        raise ValueError("the network must end with flatten and linear layers")
    return c


def layers_from_spec(spec: Sequence[Mapping[str, Any]], arrays: Mapping[str, NDArray[Any]]) -> list[Layer]:
    """Layers from the model card's list and the model file's arrays (``layer<k>.weight`` / ``.bias``).

    Raises
    ------
    ValueError
        If an entry is malformed or its arrays are missing (named).
    """
    out = []
    for k, entry in enumerate(spec):
        if not isinstance(entry, Mapping) or not isinstance(entry.get("type"), str):
            raise ValueError(f"layer {k}: expected a table with a 'type', got {entry!r}")
        t = entry["type"]
        if t in ("conv", "linear"):
            names = (f"layer{k}.weight", f"layer{k}.bias")
            missing = [nm for nm in names if nm not in arrays]
            if missing:
                raise ValueError(f"layer {k} ({t}): the model file has no {', '.join(missing)}")
            w = np.asarray(arrays[names[0]], dtype=np.float32)
            out.append(
                Layer(
                    type=t,
                    out=int(entry.get("out", w.shape[0])),
                    kernel=int(entry.get("kernel", 0)),
                    weight=w,
                    bias=np.asarray(arrays[names[1]], dtype=np.float32),
                )
            )
        else:
            out.append(Layer(type=t))
    return out
