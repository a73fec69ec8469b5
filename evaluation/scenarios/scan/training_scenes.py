"""The simulated bags the shipped boosted classifier is trained on (beside the real leg_tracker bags).

Every built-in scan-level scene at seed :data:`TRAINING_SEED` (the benchmark runs seeds 0, 1 and 2: other people,
paths and noise in the same rooms), written as ``pfpeople-eval simulate-bag SCENE --seed 100 --out DIR/SCENE``
does. The shipped model is made by ``make model``::

    for s in corridor crowd lobby wheelchair; do pfpeople-eval simulate-bag $s --seed 100 --out sim-train/$s; done
    pfpeople train-detector --data-dir ../shared/data/leg_tracker --people-bags sim-train --out pfpeople/models/

and the benchmark's held-out models (scene ``positive_bags``) are trained on the same bags.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from evaluation.scenarios.scan.bagfile import write_scene_bag
from evaluation.scenarios.scan.scene import SceneConfig, builtin_scan_scenes, load_scene

__all__ = [
    "BOOSTED_TRAINING_SCENES",
    "CALIBRATION_SEED",
    "CLUTTER_CLEARANCE_M",
    "LEARNED_TRAINING_SEEDS",
    "TRAINING_SEED",
    "calibration_bags",
    "learned_training_bags",
    "random_clutter",
    "randomized_scene",
    "training_people_bags",
]

#: Seed of the simulated training bags (never one the benchmark's figures are quoted for).
TRAINING_SEED = 100
#: The scenes the shipped boosted classifier is trained on (the built-in scenes when it was made).
BOOSTED_TRAINING_SCENES = ("corridor", "crowd", "lobby", "wheelchair")
#: Seeds of the learned detector's simulated training bags: every built-in scene at each, randomised
#: (:func:`randomized_scene`); the benchmark's seeds are 0-2.
LEARNED_TRAINING_SEEDS = (100, 101, 102)
#: Seed of the built-in scenes the learned detector's PPV and FNR are measured on (neither trained on nor benchmarked).
CALIBRATION_SEED = 50


def training_people_bags(folder: str | Path) -> list[tuple[Path, Path]]:
    """Write the scenes of :data:`BOOSTED_TRAINING_SCENES` at :data:`TRAINING_SEED` into ``folder/<scene>/`` (unless
    it is there already) and return the ``(bag, ground-truth CSV)`` pairs, sorted by scene name."""
    return _scene_bags(folder, BOOSTED_TRAINING_SCENES, TRAINING_SEED)


def _scene_bags(folder: str | Path, scenes: Sequence[str], seed: int) -> list[tuple[Path, Path]]:
    """Each built-in scene of ``scenes`` at ``seed`` written into ``folder/<scene>/`` (unless it is there already):
    the ``(bag, ground-truth CSV)`` pairs, in the order of ``scenes``."""
    out = []
    for scene in scenes:
        d = Path(folder) / scene
        bag, gt = d / f"{scene}.bag", d / f"{scene}_gt.csv"
        if not (bag.is_file() and gt.is_file()):
            write_scene_bag(scene, d, seed=seed, overwrite=True)
        out.append((bag, gt))
    return out


def randomized_scene(scene: str, seed: int) -> SceneConfig:
    """Built-in ``scene`` with its laser, people and clutter drawn at random around their values (domain
    randomisation: the learned detector must not learn one laser's noise, resolution or mount, nor one clothing):

    * beams: 0.25-0.5 deg apart over the scene's field of view, 7.5-15 Hz; range noise 1-3 cm; mixed pixels 0.1-0.5;
      random dropouts 0-1 %; the returns model (:mod:`evaluation.scenarios.scan.returns`) with a range at 10 %
      reflectance of 6-15 m in four scenes of five, off in the fifth;
    * the laser's yaw on the robot turned by up to 30 deg;
    * trousers of reflectivity 0.03-0.5, walls and furniture 0.3-0.8; chair legs 1.5-3.5 cm in radius;
    * walking speeds scaled by 0.8-1.2;
    * clutter of the kinds real rooms hold at knee height, scattered over the people's region at least
      :data:`CLUTTER_CLEARANCE_M` from the robot's route (:func:`random_clutter`).
    """
    base = load_scene(scene)
    rng = np.random.default_rng(np.random.SeedSequence([seed, sum(map(ord, scene))]))
    las = base.lasers[0]
    fov = las.angle_max - las.angle_min
    step = math.radians(float(rng.uniform(0.25, 0.5)))
    mount = (las.mount[0], las.mount[1], las.mount[2] + math.radians(float(rng.uniform(-30.0, 30.0))))
    laser = replace(
        las,
        n_beams=round(fov / step) + 1,
        rate_hz=float(rng.choice([7.5, 10.0, 12.5, 15.0])),
        noise_sd=float(rng.uniform(0.01, 0.03)),
        mixed_pixel=float(rng.uniform(0.1, 0.5)),
        dropout=float(rng.uniform(0.0, 0.01)),
        mount=mount,
        range_at_10pct=float(rng.uniform(6.0, 15.0)) if rng.random() < 0.8 else 0.0,
    )
    speed = float(rng.uniform(0.8, 1.2))
    people = replace(
        base.people,
        speed_mu=base.people.speed_mu * speed,
        speed_min=base.people.speed_min * speed,
        speed_max=base.people.speed_max * speed,
        reflectivity=(0.03, 0.5),
    )
    poles, boxes = random_clutter(base, rng)
    return replace(
        base,
        name=f"{scene}_r{seed}",
        seed=seed,
        lasers=(laser, *base.lasers[1:]),
        people=people,
        static_reflectivity=float(rng.uniform(0.3, 0.8)),
        chair_leg_radius=float(rng.uniform(0.015, 0.035)),
        poles=(*base.poles, *poles),
        boxes=(*base.boxes, *boxes),
    )


#: Random clutter keeps this far (m) from the robot's route: the robot drives through a room, not through its chairs.
CLUTTER_CLEARANCE_M = 0.8


def _clear_of_route(p: NDArray[np.float64], route: NDArray[np.float64]) -> bool:
    """Whether point ``p`` is at least :data:`CLUTTER_CLEARANCE_M` from the closed polyline ``route``."""
    a, b = route, np.roll(route, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0.0, 1.0)
    d = np.linalg.norm(a + t[:, None] * ab - p, axis=1)
    return bool(d.min() >= CLUTTER_CLEARANCE_M)


def random_clutter(
    base: SceneConfig, rng: np.random.Generator
) -> tuple[list[tuple[float, ...]], list[tuple[float, ...]]]:
    """Poles ``(x, y, radius)`` and boxes ``(cx, cy, length, width, yaw)`` (m, rad, world) of 8-20 random objects in
    the scene's people region: stools (three or four legs of 1-3 cm on a 0.3-0.45 m square), posts and coat stands
    (2-5 cm), bins (10-20 cm), plant pots (15-30 cm) and small boxes (0.2-0.6 m)."""
    x0, x1, y0, y1 = base.people.region
    route = np.asarray(base.robot.waypoints, dtype=float).reshape(-1, 2)
    poles: list[tuple[float, ...]] = []
    boxes: list[tuple[float, ...]] = []
    wanted, placed = int(rng.integers(8, 21)), 0
    for _ in range(50 * wanted):
        if placed == wanted:
            break
        p = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
        if len(route) > 1 and not _clear_of_route(p, route):
            continue
        placed += 1
        kind = rng.choice(["stool", "post", "bin", "pot", "box"])
        if kind == "stool":
            half, rad, yaw = rng.uniform(0.15, 0.225), rng.uniform(0.01, 0.03), rng.uniform(0, math.pi)
            n = int(rng.integers(3, 5))
            for k in range(n):
                a = yaw + 2 * math.pi * k / n
                poles.append((float(p[0] + half * math.cos(a)), float(p[1] + half * math.sin(a)), float(rad)))
        elif kind == "box":
            boxes.append((float(p[0]), float(p[1]), *rng.uniform(0.2, 0.6, 2).tolist(), float(rng.uniform(0, math.pi))))
        else:
            lo, hi = {"post": (0.02, 0.05), "bin": (0.1, 0.2), "pot": (0.15, 0.3)}[str(kind)]
            poles.append((float(p[0]), float(p[1]), float(rng.uniform(lo, hi))))
    return poles, boxes


def learned_training_bags(
    folder: str | Path, seeds: tuple[int, ...] = LEARNED_TRAINING_SEEDS
) -> list[tuple[Path, Path]]:
    """Write every built-in scene randomised at each of ``seeds`` (:func:`randomized_scene`) into
    ``folder/<scene>_r<seed>/`` (unless it is there already) and return the ``(bag, ground-truth CSV)`` pairs."""
    out = []
    for seed in seeds:
        for scene in builtin_scan_scenes():
            cfg = randomized_scene(scene, seed)
            d = Path(folder) / cfg.name
            bag, gt = d / f"{cfg.name}.bag", d / f"{cfg.name}_gt.csv"
            if not (bag.is_file() and gt.is_file()):
                write_scene_bag(cfg, d, overwrite=True)
            out.append((bag, gt))
    return out


def calibration_bags(folder: str | Path, seed: int = CALIBRATION_SEED) -> list[tuple[Path, Path]]:
    """Write every built-in scene at ``seed`` (as the benchmark simulates them, other people and noise) into
    ``folder/<scene>/`` (unless it is there already) and return the ``(bag, ground-truth CSV)`` pairs."""
    return _scene_bags(folder, builtin_scan_scenes(), seed)
