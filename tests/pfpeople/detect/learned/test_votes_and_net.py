"""Votes (canonical offsets, grouping) and the NumPy network against direct loops."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gridbridge import jit
from pfpeople.detect.learned.cutouts import CutoutParams
from pfpeople.detect.learned.model_file import FORMAT, load_model, save_model
from pfpeople.detect.learned.net import Layer, Network, layers_from_spec
from pfpeople.detect.learned.votes import canonical_offsets, group_votes, vote_positions


@settings(max_examples=50, deadline=None)
@given(st.floats(-3.0, 3.0), st.floats(0.2, 15.0), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0))
def test_offsets_round_trip(bearing: float, rng: float, dx: float, dy: float) -> None:
    centre = np.array([[rng * math.cos(bearing) + dx, rng * math.sin(bearing) + dy]])
    b, r = np.array([bearing]), np.array([rng])
    off = canonical_offsets(b, r, centre)
    np.testing.assert_allclose(vote_positions(b, r, off), centre, atol=1e-9)


def test_offset_frame_is_along_and_across_the_beam() -> None:
    """A centre 0.1 m behind a return straight ahead is (0, 0.1); 0.1 m to its left (ccw) is (0.1, ~0)."""
    b, r = np.array([0.0, 0.0]), np.array([2.0, 2.0])
    off = canonical_offsets(b, r, np.array([[2.1, 0.0], [2.0, 0.1]]))
    np.testing.assert_allclose(off[0], [0.0, 0.1], atol=1e-12)
    assert off[1, 0] == pytest.approx(0.1, abs=1e-3) and abs(off[1, 1]) < 5e-3


@pytest.mark.parametrize("compiled", [True, False])
def test_grouping_claims_the_best_votes_first(compiled: bool) -> None:
    pos = np.array([[0.0, 0.0], [0.1, 0.0], [1.0, 0.0], [0.35, 0.0], [5.0, 5.0]])
    scores = np.array([0.9, 0.5, 0.8, 0.6, 0.05])
    with jit.override(compiled, "pfpeople"):
        centres, best = group_votes(pos, scores, radius=0.4, min_score=0.1)
    np.testing.assert_allclose(best, [0.9, 0.8])
    w = np.array([0.9, 0.5, 0.6])
    np.testing.assert_allclose(centres[0], [(w * np.array([0.0, 0.1, 0.35])).sum() / w.sum(), 0.0])
    np.testing.assert_allclose(centres[1], [1.0, 0.0])


def test_grouping_paths_agree(rng: np.random.Generator) -> None:
    pos, scores = rng.uniform(0, 4, (300, 2)), rng.random(300)
    out = []
    for compiled in (True, False):
        with jit.override(compiled, "pfpeople"):
            out.append(group_votes(pos, scores, radius=0.4, min_score=0.2))
    np.testing.assert_allclose(out[0][0], out[1][0])
    np.testing.assert_allclose(out[0][1], out[1][1])


def _random_net(rng: np.random.Generator, channels: int = 2, points: int = 8) -> Network:
    layers = [
        Layer(
            type="conv",
            out=3,
            kernel=3,
            weight=rng.normal(size=(3, channels, 3)).astype(np.float32),
            bias=rng.normal(size=3).astype(np.float32),
        ),
        Layer(type="relu"),
        Layer(type="maxpool"),
        Layer(type="flatten"),
        Layer(
            type="linear",
            out=3,
            weight=rng.normal(size=(3, 12)).astype(np.float32),
            bias=rng.normal(size=3).astype(np.float32),
        ),
    ]
    return Network(layers, points=points, channels=channels)


def _loops(net: Network, x: np.ndarray) -> np.ndarray:
    """The same network as plain loops over (C, L) arrays, torch's layout."""
    conv, _, _, _, lin = net.layers
    out = []
    for sample in x:
        h = sample.T.astype(np.float64)  # (C, L)
        c_in, n = h.shape
        pad = np.pad(h, ((0, 0), (1, 1)))
        y = np.zeros((conv.out, n))
        for o in range(conv.out):
            for i in range(n):
                y[o, i] = conv.bias[o] + sum(
                    conv.weight[o, c, k] * pad[c, i + k] for c in range(c_in) for k in range(3)
                )
        y = np.maximum(y, 0).reshape(conv.out, n // 2, 2).max(axis=2)
        out.append(lin.weight @ y.reshape(-1) + lin.bias)
    return np.array(out)


def test_network_equals_direct_loops(rng: np.random.Generator) -> None:
    net = _random_net(rng)
    x = rng.normal(size=(5, 8, 2)).astype(np.float32)
    np.testing.assert_allclose(net(x), _loops(net, x), rtol=1e-5, atol=1e-5)


def test_network_shapes_are_checked(rng: np.random.Generator) -> None:
    net = _random_net(rng)
    with pytest.raises(ValueError, match=r"\(B, 8, 2\)"):
        net(np.zeros((1, 8, 3), np.float32))
    bad = list(net.layers)
    bad[0] = Layer(
        type="conv", out=3, kernel=3, weight=np.full((3, 2, 3), np.nan, np.float32), bias=np.zeros(3, np.float32)
    )
    with pytest.raises(ValueError, match="non-finite"):
        Network(bad, points=8, channels=2)
    with pytest.raises(ValueError, match="needs a flatten"):
        Network(
            [Layer(type="linear", out=1, weight=np.zeros((1, 8), np.float32), bias=np.zeros(1, np.float32))],
            points=8,
            channels=1,
        )
    with pytest.raises(ValueError, match=r"no layer0\.bias"):
        layers_from_spec([{"type": "conv", "out": 3, "kernel": 3}], {"layer0.weight": np.zeros((3, 1, 3))})


def _card() -> dict:
    return {
        "cutout": {"width": 1.0, "depth": 0.5, "points": 8, "max_range": 12.0},
        "past_scans": 1,
        "past_step": 1,
        "group_radius": 0.4,
        "min_vote": 0.1,
        "threshold": 0.6,
        "calibration": {"ppv": 0.8, "fnr": 0.3},
    }


def test_model_file_round_trip(tmp_path: Path, rng: np.random.Generator) -> None:
    net = _random_net(rng)
    save_model(tmp_path / "m.npz", net, _card())
    m = load_model(tmp_path / "m.npz")
    assert m.cutout == CutoutParams(points=8) and m.past_scans == 1 and m.threshold == 0.6
    x = rng.normal(size=(4, 8, 2)).astype(np.float32)
    np.testing.assert_array_equal(m.network(x), net(x))
    assert json.loads((tmp_path / "m.json").read_text())["format"] == FORMAT


def test_bad_model_files_are_named(tmp_path: Path, rng: np.random.Generator) -> None:
    save_model(tmp_path / "m.npz", _random_net(rng), _card())
    card = json.loads((tmp_path / "m.json").read_text())
    (tmp_path / "m.json").write_text(json.dumps({**card, "format": "other/9"}))
    with pytest.raises(ValueError, match="this version reads"):
        load_model(tmp_path / "m.npz")
    (tmp_path / "m.json").write_text(json.dumps({**card, "threshold": float("nan")}))
    with pytest.raises(ValueError, match="threshold"):
        load_model(tmp_path / "m.npz")
    (tmp_path / "m.json").write_text(json.dumps({**card, "past_scans": 0}))
    with pytest.raises(ValueError, match=r"layer 0 \(conv\): weight has shape"):
        load_model(tmp_path / "m.npz")
    (tmp_path / "m.json").unlink()
    with pytest.raises(ValueError, match="no model card"):
        load_model(tmp_path / "m.npz")
    (tmp_path / "x.npz").write_bytes(b"not a zip")
    (tmp_path / "x.json").write_text(json.dumps(card))
    with pytest.raises(ValueError, match=r"not a NumPy \.npz"):
        load_model(tmp_path / "x.npz")
    with pytest.raises(FileNotFoundError):
        load_model(tmp_path / "missing.npz")
