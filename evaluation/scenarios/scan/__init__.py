"""Scan-level simulation: a 2-D laser ray caster over walls, furniture and walking people (two legs each),
a moving robot with drifting odometry and mounted lasers, written as ROS1 / ROS2 bags with ground truth.

The detections of a run on these bags come from the real pipeline (``pfpeople run``: raw scans -> built-in
leg / boosted detectors -> filter -> classification), so detector failures (a leg hidden by the other leg,
chair legs, an off-axis yawed laser, 7.5 Hz scans) reach the filter. Built-in scenes: ``scenes/*.toml``.

The lasers are simulated as they are specified (2 cm range noise, mixed pixels at depth edges, dropouts, the
drivers' no-return codes) and the wheel odometry drifts, slips in turns and is stamped late (:mod:`.scene`);
people walk, stop, and stand in groups and queues (:mod:`.people`, :mod:`.standing`). What the detectors and
the pipeline find on the built-in scenes is in ``docs/benchmarks.md`` (``pfpeople-eval benchmark``).

Modules: :mod:`.raycast` (ray caster, range noise, mixed pixels), :mod:`.gait` (legs), :mod:`.scene`
(configuration), :mod:`.people` (people tracks), :mod:`.standing` (groups and queues), :mod:`.motion` (robot
route, odometry), :mod:`.simulate` (the run), :mod:`.bagfile` (bag, GT CSV, run TOML).
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
