"""Run a scan-level scene: robot, odometry, people with legs, and the lasers' scans with ground truth.

Time line: the simulation steps at the odometry rate ``dt = 1 / odometry.rate_hz`` from t = 0; laser ``L``
scans are stamped at ``t = 0.1 + k / rate_hz`` s (the stamp is the first beam's time, as ROS drivers stamp).
Without ``sweep`` every beam of a scan is taken at the stamp; with ``sweep`` beam ``i`` is taken
``(angle_i - angle_min) / (2 pi rate_hz)`` s later (one mirror revolution per scan period), simulated in
``sweep_blocks`` angular blocks, each cast from the robot pose and the people at the block's mean time: a
turning robot or a walking person is distorted in the scan as by a real laser. People's legs are computed on
the step grid (:mod:`evaluation.scenarios.scan.gait`) and interpolated linearly to the scan (block) times.
The ground truth is at the stamp, for the first laser: every person whose centre is inside its field of view
(bearing in ``[angle_min, angle_max]``, range in ``[range_min, range_max]``, as
:func:`gridbridge.measurement.in_field_of_view` tests) whether or not it is occluded; ``hit_beams`` counts
the beams that returned from the person's legs (0 for an occluded person).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from evaluation.scenarios.scan.gait import leg_positions
from evaluation.scenarios.scan.people import scene_tracks
from evaluation.scenarios.scan.raycast import beam_angles, cast_rays, measure_ranges
from evaluation.scenarios.scan.returns import incidence_cosines, return_probability
from evaluation.scenarios.scan.route import drive_route, interpolate_poses, odometry_from_controls
from evaluation.scenarios.scan.scene import LaserConfig, SceneConfig, load_scene
from evaluation.scenarios.tracks import sample_tracks
from gridbridge.geometry import compose, to_frame
from gridbridge.measurement import in_field_of_view
from gridbridge.params import DetectorModel

__all__ = ["LaserRecord", "SceneSim", "laser_field_of_view", "simulate_scene", "to_frame"]

#: Time of the first scan after the scene start (s): odometry and TF exist before it.
FIRST_SCAN_S = 0.1


def _compose(base: NDArray[np.float64], mount: tuple[float, float, float]) -> NDArray[np.float64]:
    """World poses ``(T, 3)`` of a frame mounted at ``mount`` on bodies at world poses ``base`` ``(T, 3)``."""
    return compose(base, mount, wrap=False)


def laser_field_of_view(laser: LaserConfig) -> DetectorModel:
    """The laser's field of view as a :class:`DetectorModel` in its own frame (for the FOV test)."""
    return DetectorModel(
        name=laser.frame_id,
        ppv=0.5,
        fnr=0.5,
        fov_min=laser.angle_min,
        fov_max=laser.angle_max,
        min_range=laser.range_min,
        max_range=laser.range_max,
    )


@dataclass(frozen=True, eq=False)
class LaserRecord:
    """The scans of one laser.

    Attributes
    ----------
    laser : LaserConfig
    times : ndarray, shape (F,)
        Scan times (s from the scene start).
    stamps_ns : ndarray, shape (F,), int64
        Header stamps (ns).
    ranges : ndarray, shape (F, N), float32
        Reported ranges (m; no-return codes per ``laser.no_return``).
    poses : ndarray, shape (F, 3)
        True world pose of the laser frame per scan.
    """

    laser: LaserConfig
    times: NDArray[np.float64]
    stamps_ns: NDArray[np.int64]
    ranges: NDArray[np.float32]
    poses: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class SceneSim:
    """A simulated scene.

    Attributes
    ----------
    config : SceneConfig
        The scene (with ``frames`` set when overridden).
    seed : int
    step_times : ndarray, shape (M,)
        Simulation / odometry times (s).
    step_stamps_ns : ndarray, shape (M,), int64
    robot : ndarray, shape (M, 3)
        True ``base_link`` world pose per step.
    odom : ndarray, shape (M, 3)
        Odometry pose of ``base_link`` in the odom frame per step (drifts).
    v_odom, omega_odom : ndarray, shape (M,)
        Reported velocities (m/s, rad/s).
    lasers : tuple of LaserRecord
    person_ids : ndarray, shape (P,), int64
    gt_scan, gt_person : ndarray, shape (R,), int64
        Ground truth rows of the first laser: scan index and person id.
    gt_xy : ndarray, shape (R, 2)
        Person centre in the first laser's frame (m).
    gt_beams : ndarray, shape (R,), int64
        Beams of that scan returned from the person's legs.
    gt_speed : ndarray, shape (R,)
        The person's walking speed (m/s, world) at the scan, over +-0.5 s (standing people shuffle at
        0.0-0.2 m/s, walkers 0.5 m/s and more); NaN within 0.5 s of appearing or leaving.
    ms_per_scan : float
        Wall-clock time to simulate one scan of the first laser (people, ray casting, noise), ms.
    """

    config: SceneConfig
    seed: int
    step_times: NDArray[np.float64]
    step_stamps_ns: NDArray[np.int64]
    robot: NDArray[np.float64]
    odom: NDArray[np.float64]
    v_odom: NDArray[np.float64]
    omega_odom: NDArray[np.float64]
    lasers: tuple[LaserRecord, ...]
    person_ids: NDArray[np.int64]
    gt_scan: NDArray[np.int64]
    gt_person: NDArray[np.int64]
    gt_xy: NDArray[np.float64]
    gt_beams: NDArray[np.int64]
    gt_speed: NDArray[np.float64]
    ms_per_scan: float

    @property
    def n_frames(self) -> int:
        return int(self.lasers[0].times.size)


def _lost_returns(
    true_r: NDArray[np.float64],
    hit: NDArray[np.int64],
    person_of_beam: NDArray[np.int64],
    person_rho: NDArray[np.float64],
    circles: NDArray[np.float64],
    segments: NDArray[np.float64],
    angles: NDArray[np.float64],
    reflectivity: tuple[float, float],
    rng: np.random.Generator,
) -> NDArray[np.float64]:
    """The true ranges with the hits that return no echo set to ``inf`` (:mod:`evaluation.scenarios.scan.returns`:
    each person's reflectivity, the walls' and furniture's, the range and the angle of incidence);
    ``reflectivity`` is ``(the laser's range_at_10pct, the static surfaces' reflectivity)``."""
    r10, static_rho = reflectivity
    rho = np.where(person_of_beam >= 0, person_rho[np.maximum(person_of_beam, 0)], static_rho)
    cos_inc = incidence_cosines(np.cos(angles), np.sin(angles), true_r, hit, circles, segments)
    p = return_probability(rho, cos_inc, true_r, r10)
    return np.where(rng.random(true_r.size) < p, true_r, np.inf)


def _legs_at_many(legs: NDArray[np.float64], dt: float, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Legs ``(T, P, 2, 2)`` at times ``t`` ``(T,)`` by linear interpolation of the step grid ``legs``."""
    u = np.asarray(t, dtype=float) / dt
    i = np.minimum(np.floor(u).astype(np.int64), legs.shape[0] - 2)
    a = (u - i)[:, None, None, None]
    return (1.0 - a) * legs[i] + a * legs[i + 1]


def _legs_at(legs: NDArray[np.float64], dt: float, t: float) -> NDArray[np.float64]:
    """Legs ``(P, 2, 2)`` at time ``t`` by linear interpolation of the step grid ``legs`` ``(M, P, 2, 2)``."""
    u = t / dt
    i = min(math.floor(u), legs.shape[0] - 2)
    a = u - i
    return (1.0 - a) * legs[i] + a * legs[i + 1]


def simulate_scene(
    scene: str | Path | SceneConfig,
    *,
    seed: int | None = None,
    frames: int | None = None,
    progress: Callable[[int], object] | None = None,
) -> SceneSim:
    """Simulate a scene.

    Parameters
    ----------
    scene : str, path or SceneConfig
        Built-in scene name (:func:`~evaluation.scenarios.scan.scene.builtin_scan_scenes`), TOML file or config.
    seed : int, optional
        Seed of the run (default the scene's); the robot, odometry, people, gait and laser noise draw from
        independent streams spawned from it.
    frames : int, optional
        Number of scans of the first laser (default the scene's).
    progress : callable, optional
        Called with 1 after every scan of the first laser.

    Returns
    -------
    SceneSim
    """
    cfg = load_scene(scene)
    if frames is not None:
        cfg = replace(cfg, frames=frames)
    seed = cfg.seed if seed is None else seed
    # a sixth stream for the returns model: the five others draw as in scenes without it
    r_robot, r_odom, r_people, r_gait, r_laser, r_return = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(6)
    )
    las0 = cfg.lasers[0]
    n_frames = cfg.n_frames
    duration = FIRST_SCAN_S + (n_frames - 1) / las0.rate_hz
    dt = 1.0 / cfg.odometry.rate_hz
    n_steps = math.ceil((duration + 0.2) / dt) + 2
    step_times = np.arange(n_steps, dtype=np.float64) * dt
    robot, v, w = drive_route(cfg.robot, n_steps, dt, rng=r_robot)
    odom, v_o, w_o = odometry_from_controls(v, w, dt, noise=cfg.odometry, start=(0.0, 0.0, 0.0), rng=r_odom)
    tracks = scene_tracks(cfg.people, robot, dt, duration, rng=r_people)
    ids, centres = sample_tracks(tracks, step_times)  # (M, P, 2)
    n_people = ids.size
    legs = np.full((n_steps, n_people, 2, 2), np.nan)
    radii = np.zeros(n_people)
    lo_r, hi_r = cfg.people.reflectivity
    person_rho = np.exp(r_return.uniform(math.log(lo_r), math.log(hi_r), size=n_people))
    for p, tr in enumerate(tracks):
        radius, width, phase = cfg.people.gait.draw_person(r_gait)
        radii[p] = radius
        d = tr.xy[-1] - tr.xy[0]
        heading0 = math.atan2(d[1], d[0]) if np.hypot(*d) > 1e-6 else float(r_gait.uniform(-math.pi, math.pi))
        legs[:, p] = leg_positions(
            step_times, centres[:, p], params=cfg.people.gait, hip_width=width, phase0=phase, heading0=heading0
        )
    static_c = cfg.static_circles()
    static_s = cfg.static_segments()
    n_static = len(static_c)
    records = []
    gt_scan: list[int] = []
    gt_person: list[int] = []
    gt_xy: list[NDArray[np.float64]] = []
    gt_beams: list[int] = []
    gt_speed: list[float] = []
    half = max(1, round(0.5 / dt))  # speed over +-0.5 s
    with np.errstate(invalid="ignore"):
        shifted = np.concatenate((centres[half:], np.repeat(centres[-1:], half, axis=0)))
        back = np.concatenate((np.repeat(centres[:1], half, axis=0), centres[:-half]))
        speeds = np.hypot(*np.moveaxis(shifted - back, -1, 0)) / (2 * half * dt)  # (M, P); NaN at the ends
    elapsed = 0.0
    for li, las in enumerate(cfg.lasers):
        n_l = n_frames if li == 0 else max(1, math.floor((duration - FIRST_SCAN_S) * las.rate_hz) + 1)
        times = FIRST_SCAN_S + np.arange(n_l) / las.rate_hz
        poses = _compose(interpolate_poses(times, step_times, robot), las.mount)
        angles = beam_angles(las.angle_min, las.angle_max, las.n_beams)
        fov = laser_field_of_view(las)
        ranges = np.empty((n_l, las.n_beams), dtype=np.float32)
        blocks = np.array_split(np.arange(las.n_beams), las.sweep_blocks if las.sweep else 1)
        offsets = las.beam_time_offsets()
        block_dt = np.array([float(offsets[b].mean()) for b in blocks])  # s after the stamp
        block_poses = _compose(
            interpolate_poses((times[:, None] + block_dt[None, :]).ravel(), step_times, robot), las.mount
        ).reshape(n_l, len(blocks), 3)
        n_blocks = len(blocks)
        block_beams = np.array([[b[0], b[-1]] for b in blocks], dtype=np.int64)  # (B, 2)
        leg_r = np.repeat(radii, 2)
        owner = np.concatenate((np.full(n_static, -1, dtype=np.int64), np.repeat(np.arange(n_people), 2)))
        c_bounds = np.repeat(block_beams, n_static + 2 * n_people, axis=0)
        s_bounds = np.repeat(block_beams, len(static_s), axis=0)
        c_radius = np.tile(np.concatenate((static_c[:, 2], leg_r)), n_blocks)
        c_owner = np.tile(owner, n_blocks)
        for k in range(n_l):
            t_start = time.perf_counter()
            # the scene when each block is swept: static circles and every leg (NaN for absent people)
            lg_b = _legs_at_many(legs, dt, times[k] + block_dt)  # (B, P, 2, 2)
            xy = np.concatenate(
                (np.broadcast_to(static_c[:, :2], (n_blocks, n_static, 2)), lg_b.reshape(n_blocks, -1, 2)), axis=1
            )
            pose = block_poses[k][:, None, :]  # (B, 1, 3)
            local_c = to_frame(xy, pose).reshape(-1, 2)
            ok = np.isfinite(local_c[:, 0])
            seg_xy = np.broadcast_to(static_s.reshape(1, -1, 2, 2), (n_blocks, len(static_s), 2, 2))
            local_s = to_frame(seg_xy, pose[:, :, None, :]).reshape(-1, 4)
            true_r, hit = cast_rays(
                angles,
                circles=np.column_stack((local_c[ok], c_radius[ok])),
                segments=local_s,
                circle_beams=c_bounds[ok],
                segment_beams=s_bounds,
            )
            n_circ = int(ok.sum())
            owners = np.append(c_owner[ok], -1)  # index n_circ: no circle
            person_of_beam = owners[np.where((hit >= 0) & (hit < n_circ), hit, n_circ)]
            if las.range_at_10pct > 0:
                circ_xyr = np.column_stack((local_c[ok], c_radius[ok]))
                refl = (las.range_at_10pct, cfg.static_reflectivity)
                true_r = _lost_returns(
                    true_r, hit, person_of_beam, person_rho, circ_xyr, local_s, angles, refl, r_return
                )
            meas = measure_ranges(
                true_r,
                range_min=las.range_min,
                range_max=las.range_max,
                noise_sd=las.noise_sd,
                dropout=las.dropout,
                no_return=las.no_return,
                mixed_pixel=las.mixed_pixel,
                rng=r_laser,
            )
            ranges[k] = meas
            if li == 0:
                returned = np.isfinite(meas) & (meas >= las.range_min) & (meas <= las.range_max)
                beams = np.bincount(person_of_beam[returned & (person_of_beam >= 0)], minlength=n_people)
                lg = _legs_at(legs, dt, float(times[k]))  # the ground truth is at the stamp
                alive = np.flatnonzero(np.all(np.isfinite(lg), axis=(1, 2)))
                c_local = to_frame(0.5 * (lg[alive, 0] + lg[alive, 1]), poses[k])
                inside = in_field_of_view(fov, c_local[:, 0], c_local[:, 1])
                for j in np.flatnonzero(inside):
                    gt_scan.append(k)
                    gt_person.append(int(ids[alive[j]]))
                    gt_xy.append(c_local[j])
                    gt_beams.append(int(beams[alive[j]]))
                    sp = speeds[min(len(step_times) - 1, round(float(times[k]) / dt)), alive[j]]
                    gt_speed.append(float(sp))  # NaN within 0.5 s of appearing or leaving
                elapsed += time.perf_counter() - t_start
                if progress is not None:
                    progress(1)
        stamps = cfg.start_ns + np.rint(times * 1e9).astype(np.int64)
        records.append(LaserRecord(laser=las, times=times, stamps_ns=stamps, ranges=ranges, poses=poses))
    return SceneSim(
        config=cfg,
        seed=seed,
        step_times=step_times,
        step_stamps_ns=cfg.start_ns + np.rint(step_times * 1e9).astype(np.int64),
        robot=robot,
        odom=odom,
        v_odom=v_o,
        omega_odom=w_o,
        lasers=tuple(records),
        person_ids=ids,
        gt_scan=np.array(gt_scan, dtype=np.int64),
        gt_person=np.array(gt_person, dtype=np.int64),
        gt_xy=np.array(gt_xy, dtype=float).reshape(-1, 2),
        gt_beams=np.array(gt_beams, dtype=np.int64),
        gt_speed=np.array(gt_speed, dtype=float),
        ms_per_scan=1e3 * elapsed / n_frames,
    )
