"""Training with PyTorch (the ``[train]`` extra; skipped without it): the exported NumPy network computes what the
trained module computes, and a small real training writes a model that loads and runs without PyTorch."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pfpeople.detect.learned.dataset import TrainingArrays
from pfpeople.detect.learned.training import FitParams, architecture, fit_network, torch_module_of

torch = pytest.importorskip("torch")


def _arrays(rng: np.random.Generator, n: int = 600, points: int = 16, channels: int = 2) -> TrainingArrays:
    x = rng.uniform(-1, 1, (n, points, channels)).astype(np.float32)
    label = (x[:, points // 2 - 1, 0] + x[:, points // 2, 0] < 0).astype(np.float32)  # "in front at the centre"
    return TrainingArrays(
        x=x,
        label=label,
        offset=np.zeros((n, 2), np.float32) + label[:, None] * 0.1,
        weight=np.ones(n, np.float32),
        source=np.zeros(n, np.int64),
        sources=("t",),
    )


@pytest.mark.parametrize("arch", ["mlp", "cnn"])
def test_numpy_network_equals_the_trained_module(rng: np.random.Generator, arch: str) -> None:
    a = _arrays(rng)
    net = fit_network(a, architecture(arch), depth=0.5, params=FitParams(epochs=10, batch=64))
    module = torch_module_of(net)
    with torch.no_grad():
        want = module(torch.from_numpy(np.ascontiguousarray(a.x.transpose(0, 2, 1)))).numpy()
    np.testing.assert_allclose(net(a.x), want, rtol=1e-4, atol=1e-5)
    logits = net(a.x)[:, 0]
    assert ((logits > 0) == (a.label > 0)).mean() > 0.65  # it learned the rule (chance: 0.5)


def test_training_is_deterministic(rng: np.random.Generator) -> None:
    a = _arrays(rng)
    n1 = fit_network(a, architecture("mlp"), depth=0.5, params=FitParams(epochs=1, batch=64))
    n2 = fit_network(a, architecture("mlp"), depth=0.5, params=FitParams(epochs=1, batch=64))
    np.testing.assert_array_equal(n1(a.x), n2(a.x))


def test_a_small_real_training_writes_a_model_that_runs(shared_data: Path, tmp_path: Path) -> None:
    from pfpeople.detect.learned.build import train_learned_from_directory
    from pfpeople.detect.learned.detector import LearnedPeopleDetector
    from pfpeople.detect.learned.recipe import LearnedRecipe
    from pfpeople.detect.leg_tracker_bags import load_labelled_scans

    recipe = LearnedRecipe(fit=FitParams(epochs=1), followed_step=200)
    card = train_learned_from_directory(
        shared_data / "leg_tracker", tmp_path / "m.npz", recipe=recipe, leave_one_out=False
    )
    assert card["scans"]["positive_bags"] == 1204 and "placeholders" in card["calibration"]["measured_on"]
    det = LearnedPeopleDetector(tmp_path / "m.npz")
    scan = load_labelled_scans(shared_data / "leg_tracker" / "positive_1_extracted.bag")[5].scan
    centres, scores = det.detect_scored(scan)
    assert centres.shape[1] == 2 and np.all((scores >= 0) & (scores <= 1))
