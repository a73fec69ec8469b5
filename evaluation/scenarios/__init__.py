"""Scenario simulator with ground truth: a robot driving through people, and simulated people detectors.

- :mod:`~evaluation.scenarios.robot`: velocity profile (0-0.6 m/s, turns), path, (noisy) odometry;
- :mod:`~evaluation.scenarios.walkers`: synthetic walkers (stand, walk, cross, stop-and-go, pairs);
- :mod:`~evaluation.scenarios.eth_ucy`: replayed real trajectories (ETH/UCY ``obsmat.txt``);
- :mod:`~evaluation.scenarios.simulated_detectors`: simulated detectors (misses, clutter, noise, laser occlusion);
- :mod:`~evaluation.scenarios.scenario`: :class:`ScenarioConfig` (TOML), :class:`Scenario`, :class:`Frame`,
  the built-in scenarios (``default``, ``corridor``, ``complementary``, ``eth``).

Typical use::

    scenario = Scenario.from_name("corridor", seed=3)
    flt = GridFilter(scenario.spec, detectors=scenario.config.detector_models)
    for frame in scenario:
        step = flt.step(frame.detections, frame.odometry(), scenario.dt)
        truth = frame.truth_grid
"""

from evaluation.scenarios.eth_ucy import DataNotFoundError, default_data_root, load_tracks
from evaluation.scenarios.robot import RobotProfile, integrate_path, robot_controls
from evaluation.scenarios.scenario import (
    EthReplay,
    Frame,
    Scenario,
    ScenarioConfig,
    builtin_scenarios,
    load_scenario_config,
    occupancy_grid,
)
from evaluation.scenarios.simulated_detectors import (
    DetectorOutput,
    SimulatedDetector,
    clutter_for_ppv,
    occluded,
    paper_simulated_detectors,
    simulate_detections,
)
from evaluation.scenarios.tracks import Track, sample_tracks, track_speeds
from evaluation.scenarios.walkers import WalkerConfig, synthetic_tracks

__all__ = [
    "DataNotFoundError",
    "DetectorOutput",
    "EthReplay",
    "Frame",
    "RobotProfile",
    "Scenario",
    "ScenarioConfig",
    "SimulatedDetector",
    "Track",
    "WalkerConfig",
    "builtin_scenarios",
    "clutter_for_ppv",
    "default_data_root",
    "integrate_path",
    "load_scenario_config",
    "load_tracks",
    "occluded",
    "occupancy_grid",
    "paper_simulated_detectors",
    "robot_controls",
    "sample_tracks",
    "simulate_detections",
    "synthetic_tracks",
    "track_speeds",
]
