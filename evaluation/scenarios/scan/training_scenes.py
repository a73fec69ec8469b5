"""The simulated bags the shipped boosted classifier is trained on (beside the real leg_tracker bags).

Every built-in scan-level scene at seed :data:`TRAINING_SEED` (the benchmark runs seeds 0, 1 and 2: other people,
paths and noise in the same rooms), written as ``pfpeople-eval simulate-bag SCENE --seed 100 --out DIR/SCENE``
does. The shipped model is made by ``make model``::

    for s in corridor crowd lobby wheelchair; do pfpeople-eval simulate-bag $s --seed 100 --out sim-train/$s; done
    pfpeople train-detector --data-dir ../shared/data/leg_tracker --people-bags sim-train --out pfpeople/models/

and the benchmark's held-out models (scene ``positive_bags``) are trained on the same bags.
"""

from __future__ import annotations

from pathlib import Path

from evaluation.scenarios.scan.bagfile import write_scene_bag
from evaluation.scenarios.scan.scene import builtin_scan_scenes

__all__ = ["TRAINING_SEED", "training_people_bags"]

#: Seed of the simulated training bags (never one the benchmark's figures are quoted for).
TRAINING_SEED = 100


def training_people_bags(folder: str | Path) -> list[tuple[Path, Path]]:
    """Write every built-in scan-level scene at :data:`TRAINING_SEED` into ``folder/<scene>/`` (unless it is
    there already) and return the ``(bag, ground-truth CSV)`` pairs, sorted by scene name."""
    out = []
    for scene in sorted(builtin_scan_scenes()):
        d = Path(folder) / scene
        bag, gt = d / f"{scene}.bag", d / f"{scene}_gt.csv"
        if not (bag.is_file() and gt.is_file()):
            write_scene_bag(scene, d, seed=TRAINING_SEED, overwrite=True)
        out.append((bag, gt))
    return out
