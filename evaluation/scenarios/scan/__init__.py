"""Scan-level simulation: a 2-D laser ray caster over walls, furniture and walking people (two legs each),
a moving robot with drifting odometry and mounted lasers, written as ROS1 / ROS2 bags with ground truth.

The detections of a run on these bags come from the real pipeline (``pfpeople run``: raw scans -> built-in
leg / boosted detectors -> filter -> classification), so detector failures (a leg hidden by the other leg,
chair legs, an off-axis yawed laser, 7.5 Hz scans) reach the filter. Built-in scenes: ``scenes/*.toml``.

Measured on the built-in scenes at their default length and seed (``pfpeople-eval simulate-bag SCENE --out D``,
``python -m pfpeople.cli run D/SCENE.bag --config D/SCENE.toml --out R``, ``pfpeople-eval score R --gt
D/SCENE_gt.csv --frame laser``; recall / precision of the built-in detectors against every person in the laser's
field of view and range, gate 0.5 m):

==========  ======  ==========  =====  =====  =============  =============  =============
scene       scans   people/scn  ms/sc  MB     laser-legs     laser-boosted  filter (paper)
==========  ======  ==========  =====  =====  =============  =============  =============
wheelchair  675     3.18        3.5    6.5    0.30 / 0.54    0.24 / 0.96    0.10 / 0.51
corridor    1200    4.36        3.1    5.1    0.14 / 0.97    0.09 / 0.95    0.02 / 1.00
crowd       1800    5.82        2.9    11.7   0.15 / 0.99    0.11 / 1.00    0.003 / 1.00
==========  ======  ==========  =====  =====  =============  =============  =============

Within 5 m of the laser the detectors' recall is 0.36 / 0.30 (wheelchair), 0.45 / 0.28 (corridor), 0.28 / 0.24
(crowd). The leg detector's false people in the wheelchair room are the 0.3 m column (two legs together) and
box corners; the 3.6 cm chair legs are below its minimum segment width.

Modules: :mod:`.raycast` (ray caster, range noise), :mod:`.gait` (legs), :mod:`.scene` (configuration),
:mod:`.people` (people tracks), :mod:`.motion` (robot route, odometry), :mod:`.simulate` (the run),
:mod:`.bagfile` (bag, GT CSV, run TOML).
"""

from evaluation.scenarios.scan.bagfile import SceneBag, write_scene_bag, write_sim_bag
from evaluation.scenarios.scan.gait import GaitParams, leg_positions
from evaluation.scenarios.scan.raycast import beam_angles, cast_rays, measure_ranges
from evaluation.scenarios.scan.scene import (
    LaserConfig,
    OdometryNoise,
    PeopleConfig,
    RobotRoute,
    SceneConfig,
    builtin_scan_scenes,
    load_scene,
)
from evaluation.scenarios.scan.simulate import SceneSim, simulate_scene

__all__ = [
    "GaitParams",
    "LaserConfig",
    "OdometryNoise",
    "PeopleConfig",
    "RobotRoute",
    "SceneBag",
    "SceneConfig",
    "SceneSim",
    "beam_angles",
    "builtin_scan_scenes",
    "cast_rays",
    "leg_positions",
    "load_scene",
    "measure_ranges",
    "simulate_scene",
    "write_scene_bag",
    "write_sim_bag",
]
