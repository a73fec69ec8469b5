"""Training the learned detector with PyTorch (the ``[train]`` extra); the result runs without it.

The network (:mod:`pfpeople.detect.learned.net`: a layer list) is built as a ``torch.nn.Sequential`` of the same
layers on ``(B, channels, points)`` tensors, trained on :class:`~pfpeople.detect.learned.dataset.TrainingArrays`,
and exported back to a NumPy :class:`~pfpeople.detect.learned.net.Network` (weights copied as float32).

Loss per row, with the row's weight ``w``: ``w BCE(logit, label)`` plus, for a person's return, the smooth-L1 loss
(``beta`` 0.1 m) of its vote's canonical offset (DROW3's two heads). Adam with a one-cycle learning-rate schedule,
mini-batches of 512; each batch is mirrored (cut-outs reversed, ``dx`` negated) with probability 1/2 and given
Gaussian range noise (``noise_m`` / depth), so the network does not learn one laser's side or noise. Training is
deterministic: one thread, ``torch.manual_seed(seed)``, deterministic algorithms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pfpeople.detect.learned.dataset import TrainingArrays
from pfpeople.detect.learned.net import Layer, Network
from pfpeople.extras import require

__all__ = ["ARCHITECTURES", "FitParams", "architecture", "fit_network", "torch_module_of"]

#: The architectures the ablation compares (``docs/learned_detector.md``): layer lists without parameters.
ARCHITECTURES: dict[str, list[dict[str, Any]]] = {
    "mlp": [
        {"type": "flatten"},
        {"type": "linear", "out": 64},
        {"type": "relu"},
        {"type": "linear", "out": 64},
        {"type": "relu"},
        {"type": "linear", "out": 3},
    ],
    "cnn": [
        {"type": "conv", "out": 8, "kernel": 3},
        {"type": "relu"},
        {"type": "maxpool"},
        {"type": "conv", "out": 16, "kernel": 3},
        {"type": "relu"},
        {"type": "maxpool"},
        {"type": "conv", "out": 32, "kernel": 3},
        {"type": "relu"},
        {"type": "maxpool"},
        {"type": "flatten"},
        {"type": "linear", "out": 32},
        {"type": "relu"},
        {"type": "linear", "out": 3},
    ],
}


def architecture(name: str) -> list[dict[str, Any]]:
    """A copy of the layer list :data:`ARCHITECTURES` ``[name]`` (ValueError naming the known ones)."""
    if name not in ARCHITECTURES:
        raise ValueError(f"unknown architecture {name!r}; known: {sorted(ARCHITECTURES)}")
    return [dict(entry) for entry in ARCHITECTURES[name]]


@dataclass(frozen=True, kw_only=True)
class FitParams:
    """Optimisation settings (module docstring)."""

    epochs: int = 10
    batch: int = 512
    max_lr: float = 3e-3
    noise_m: float = 0.01
    seed: int = 0


def _torch_module(spec: Sequence[dict[str, Any]], points: int, channels: int) -> Any:
    torch = require("train", "training the learned detector")
    nn = torch.nn
    mods: list[Any] = []
    c, n = channels, points
    for entry in spec:
        t = entry["type"]
        if t == "conv":
            mods.append(nn.Conv1d(c, entry["out"], entry["kernel"], padding=entry["kernel"] // 2))
            c = entry["out"]
        elif t == "relu":
            mods.append(nn.ReLU())
        elif t == "maxpool":
            mods.append(nn.MaxPool1d(2))
            n //= 2
        elif t == "flatten":
            mods.append(nn.Flatten())
            c, n = c * n, 1
        elif t == "linear":
            mods.append(nn.Linear(c, entry["out"]))
            c = entry["out"]
        else:
            raise ValueError(f"unknown layer type {t!r}")
    return nn.Sequential(*mods)


def _export(module: Any, spec: Sequence[dict[str, Any]], points: int, channels: int) -> Network:
    layers = []
    for entry, mod in zip(spec, module, strict=True):
        if entry["type"] in ("conv", "linear"):
            layers.append(
                Layer(
                    type=entry["type"],
                    out=int(entry["out"]),
                    kernel=int(entry.get("kernel", 0)),
                    weight=mod.weight.detach().cpu().numpy().astype(np.float32),
                    bias=mod.bias.detach().cpu().numpy().astype(np.float32),
                )
            )
        else:
            layers.append(Layer(type=entry["type"]))
    return Network(layers, points=points, channels=channels)


def torch_module_of(network: Network) -> Any:
    """The PyTorch module of a NumPy ``network`` (its weights copied), on ``(B, channels, points)`` tensors: to
    check the two agree, or to train further."""
    torch = require("train", "training the learned detector")
    spec = network.spec()
    module = _torch_module(spec, network.points, network.channels)
    with torch.no_grad():
        for layer, mod in zip(network.layers, module, strict=True):
            if layer.type in ("conv", "linear"):
                mod.weight.copy_(torch.from_numpy(layer.weight))
                mod.bias.copy_(torch.from_numpy(layer.bias))
    return module.eval()


def _batch_loss(torch: Any, module: Any, data: dict[str, Any], b: Any, p: FitParams, depth: float) -> Any:
    x, y, r, w = data["x"][b], data["y"][b], data["r"][b].clone(), data["w"][b]
    flip = torch.rand(len(b)) < 0.5
    x = torch.where(flip[:, None, None], x.flip(-1), x)
    r[:, 0] = torch.where(flip, -r[:, 0], r[:, 0])
    if p.noise_m > 0:
        x = (x + torch.randn_like(x) * (p.noise_m / depth)).clamp(-1.0, 1.0)
    out = module(x)
    loss = torch.nn.functional.binary_cross_entropy_with_logits(out[:, 0], y, weight=w, reduction="sum")
    pos = y > 0
    if pos.any():
        reg = torch.nn.functional.smooth_l1_loss(out[pos, 1:], r[pos], beta=0.1, reduction="none").sum(dim=1)
        loss = loss + (reg * w[pos]).sum()
    return loss / w.sum().clamp(min=1e-6)


def fit_network(
    arrays: TrainingArrays, spec: Sequence[dict[str, Any]], *, depth: float, params: FitParams | None = None
) -> Network:
    """Train a network of layer list ``spec`` on ``arrays`` (module docstring); ``depth`` is the cut-outs' range
    clip (m), the scale of the noise augmentation."""
    torch = require("train", "training the learned detector")
    p = params if params is not None else FitParams()
    torch.set_num_threads(1)
    torch.manual_seed(p.seed)
    torch.use_deterministic_algorithms(True)
    _, points, channels = arrays.x.shape
    module = _torch_module(spec, points, channels)
    data = {
        "x": torch.from_numpy(np.ascontiguousarray(arrays.x.transpose(0, 2, 1))),
        "y": torch.from_numpy(arrays.label),
        "r": torch.from_numpy(arrays.offset),
        "w": torch.from_numpy(arrays.weight),
    }
    n = len(arrays)
    steps = p.epochs * ((n + p.batch - 1) // p.batch)
    opt = torch.optim.Adam(module.parameters(), lr=p.max_lr / 10)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=p.max_lr, total_steps=steps)
    module.train()
    for _ in range(p.epochs):
        perm = torch.randperm(n)
        for i in range(0, n, p.batch):
            b = perm[i : i + p.batch]
            loss = _batch_loss(torch, module, data, b, p, depth)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
    module.eval()
    return _export(module, spec, points, channels)
