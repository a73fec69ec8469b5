"""People tracks (person centres in the world) for the scan-level simulator.

Three sources (:class:`~evaluation.scenarios.scan.scene.PeopleConfig.source`):

- ``walkers``: synthetic walkers placed relative to the robot's pose at their arrival, in the spirit of
  :mod:`evaluation.scenarios.walkers`: ``towards`` (starts 4-7 m ahead, 0.6-1.8 m to a side, walks towards
  and past the robot), ``cross`` (crosses 1.5-5 m ahead), ``stop_and_go`` (crosses, stops half-way),
  ``pair`` (two people side by side on a ``towards`` or ``cross`` path) and ``stand``;
- ``corridor``: people enter at either end of a corridor along x and walk to the other end on their right
  half (``lane_min .. lane_max`` from the centre line), some in pairs;
- ``eth_ucy``: real ETH/UCY tracks (:func:`evaluation.scenarios.eth_ucy.load_tracks`), time-shifted by
  ``t_offset_s`` and moved by ``offset``.

Synthetic tracks are cut to their longest part inside ``region`` (people appear and leave at its border, as
through doors) and dropped when shorter than 1 s. Walkers go through furniture and do not avoid the robot.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from evaluation.scenarios.eth_ucy import load_tracks
from evaluation.scenarios.robot import sensor_to_world
from evaluation.scenarios.scan.scene import PeopleConfig
from evaluation.scenarios.scan.standing import standing_tracks
from evaluation.scenarios.tracks import Track
from evaluation.scenarios.walkers import polyline_knots, walking_speed
from gridbridge.geometry import rotate

__all__ = ["BEHAVIOURS", "cut_to_region", "scene_tracks"]

BEHAVIOURS = ("towards", "cross", "stop_and_go", "pair", "stand")
_CUT_STEP_S = 0.05
_MIN_TRACK_S = 1.0


def _speed(pc: PeopleConfig, rng: np.random.Generator) -> float:
    return walking_speed(pc.speed_mu, pc.speed_sigma, pc.speed_min, pc.speed_max, rng)


def _knots(
    points: NDArray[np.float64], speed: float, pauses: dict[int, float]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Knot times from 0 for walking the polyline ``points`` at ``speed``, pausing ``pauses[k]`` s at vertex k."""
    return polyline_knots(0.0, points, speed, pauses)


def cut_to_region(track: Track, region: tuple[float, float, float, float]) -> Track | None:
    """The longest part of ``track`` inside ``region`` (x_min, x_max, y_min, y_max), sampled every 0.05 s
    (knots kept exactly where the track is inside throughout); None when shorter than 1 s."""
    x0, x1, y0, y1 = region
    inside_knots = (track.xy[:, 0] >= x0) & (track.xy[:, 0] <= x1) & (track.xy[:, 1] >= y0) & (track.xy[:, 1] <= y1)
    if np.all(inside_knots):  # a convex region holds the whole polyline
        return track if track.t_end - track.t_start >= _MIN_TRACK_S else None
    n = max(2, math.ceil((track.t_end - track.t_start) / _CUT_STEP_S) + 1)
    t = np.linspace(track.t_start, track.t_end, n)
    xy = track.sample(t)
    inside = (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
    if not np.any(inside):
        return None
    padded = np.concatenate(([False], inside, [False])).astype(np.int8)
    starts = np.flatnonzero(np.diff(padded) == 1)
    ends = np.flatnonzero(np.diff(padded) == -1)
    k = int(np.argmax(ends - starts))
    a, b = int(starts[k]), int(ends[k])
    if t[b - 1] - t[a] < _MIN_TRACK_S:
        return None
    return Track(track.person_id, t[a:b], xy[a:b])


def _local_path(
    kind: str, pc: PeopleConfig, rng: np.random.Generator, speed: float
) -> tuple[NDArray[np.float64], dict[int, float]]:
    """A path in the robot's frame (x forward, y left) at arrival: vertices and pauses (s at vertex)."""
    if kind == "stand":
        p = np.array([rng.uniform(1.5, 5.0), rng.uniform(-2.5, 2.5)])
        return np.array([p, p]), {1: float(rng.uniform(pc.stand_min, pc.stand_max))}
    if kind == "towards":
        side = 1.0 if rng.random() < 0.5 else -1.0
        start = np.array([rng.uniform(4.0, 7.0), side * rng.uniform(0.6, 1.8)])
        heading = math.pi + rng.uniform(-0.15, 0.15)
        return np.array([start, start + 12.0 * np.array([math.cos(heading), math.sin(heading)])]), {}
    side = 1.0 if rng.random() < 0.5 else -1.0
    start = np.array([rng.uniform(1.5, 5.0), side * rng.uniform(2.5, 4.0)])
    angle = rng.uniform(-0.35, 0.35)
    direction = np.array([math.sin(angle), -side * math.cos(angle)])
    end = start + 8.0 * direction
    if kind == "stop_and_go":
        mid = start + rng.uniform(0.3, 0.7) * 8.0 * direction
        return np.array([start, mid, end]), {1: float(rng.uniform(pc.stop_min, pc.stop_max))}
    return np.array([start, end]), {}


def _arrivals(pc: PeopleConfig, duration: float, rng: np.random.Generator) -> list[tuple[float, bool]]:
    arrivals = [(0.0, True)] * pc.initial_people
    if pc.spawn_rate > 0:
        t = rng.exponential(1.0 / pc.spawn_rate)
        while t < duration:
            arrivals.append((float(t), False))
            t += rng.exponential(1.0 / pc.spawn_rate)
    return arrivals


def _walker_tracks(
    pc: PeopleConfig, robot_poses: NDArray[np.float64], dt: float, duration: float, rng: np.random.Generator
) -> list[Track]:
    weights = pc.behaviour_weights() / pc.behaviour_weights().sum()
    tracks: list[Track] = []
    next_id = 0
    for t_arrive, initial in _arrivals(pc, duration, rng):
        kind = BEHAVIOURS[int(rng.choice(len(BEHAVIOURS), p=weights))]
        base = ("towards" if rng.random() < 0.6 else "cross") if kind == "pair" else kind
        speed = _speed(pc, rng)
        path, pauses = _local_path(base, pc, rng, speed)
        kt, kxy = _knots(path, speed, pauses)
        t0 = t_arrive - (rng.uniform(0.0, 0.4) * float(kt[-1]) if initial else 0.0)
        pose = robot_poses[min(len(robot_poses) - 1, max(0, round(t_arrive / dt)))]
        offsets = [np.zeros(2)]
        if kind == "pair":
            d = kxy[-1] - kxy[0]
            normal = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
            offsets = [0.5 * pc.pair_spacing * normal, -0.5 * pc.pair_spacing * normal]
        n_wander = int(rng.integers(pc.wander_min, pc.wander_max + 1))
        extra = [np.array([rng.uniform(*pc.region[:2]), rng.uniform(*pc.region[2:])]) for _ in range(n_wander)]
        waits = [float(rng.uniform(0.0, pc.stop_max)) for _ in range(n_wander)]
        for off in offsets:
            cut = cut_to_region(Track(next_id, kt + t0, sensor_to_world(kxy + off, pose)), pc.region)
            if cut is not None and extra:
                off_world = rotate(off, float(pose[2]))
                cut = _wander(cut, [e + off_world for e in extra], waits, speed, pc.region)
            if cut is not None:
                tracks.append(cut)
            next_id += 1
    return tracks


def _wander(
    track: Track,
    points: list[NDArray[np.float64]],
    pauses: list[float],
    speed: float,
    region: tuple[float, float, float, float],
) -> Track:
    """``track`` continued through ``points`` (pausing ``pauses[k]`` s at each) and out through the nearest
    border of ``region``."""
    x0, x1, y0, y1 = region
    last = np.clip(points[-1], [x0, y0], [x1, y1])
    exits = [np.array([x0, last[1]]), np.array([x1, last[1]]), np.array([last[0], y0]), np.array([last[0], y1])]
    out = min(exits, key=lambda e: float(np.hypot(*(e - last))))
    pts = np.array([track.xy[-1], *[np.clip(p, [x0, y0], [x1, y1]) for p in points], out])
    kt, kxy = _knots(pts, speed, {k + 1: pauses[k] for k in range(len(points))})
    return Track(track.person_id, np.concatenate((track.t, track.t[-1] + kt[1:])), np.concatenate((track.xy, kxy[1:])))


def _corridor_tracks(pc: PeopleConfig, duration: float, rng: np.random.Generator) -> list[Track]:
    x0, x1, y0, y1 = pc.region
    yc = 0.5 * (y0 + y1)
    tracks: list[Track] = []
    next_id = 0
    for t_arrive, initial in _arrivals(pc, duration, rng):
        d = 1.0 if rng.random() < 0.5 else -1.0
        speed = _speed(pc, rng)
        lane = rng.uniform(pc.lane_min, pc.lane_max)
        lanes = [lane]
        if rng.random() < pc.p_pair / max(pc.behaviour_weights().sum(), 1e-12):
            centre = max(lane, pc.lane_min + 0.5 * pc.pair_spacing)
            lanes = [centre - 0.5 * pc.pair_spacing, centre + 0.5 * pc.pair_spacing]
        start_x, end_x = (x0, x1) if d > 0 else (x1, x0)
        length = x1 - x0
        t0 = t_arrive - (rng.uniform(0.0, 0.9) * length / speed if initial else 0.0)
        for ln in lanes:
            y = float(np.clip(yc - d * ln + rng.normal(0.0, 0.05), y0 + 0.25, y1 - 0.25))
            wobble = rng.normal(0.0, 0.1)
            pts = np.array([[start_x, y], [0.5 * (start_x + end_x), y + wobble], [end_x, y]])
            kt, kxy = _knots(pts, speed, {})
            tracks.append(Track(next_id, kt + t0, kxy))
            next_id += 1
    return tracks


def scene_tracks(
    pc: PeopleConfig, robot_poses: NDArray[np.float64], dt: float, duration: float, *, rng: np.random.Generator
) -> list[Track]:
    """The people of a scene as world tracks of their centres, time 0 at the scene start.

    Parameters
    ----------
    pc : PeopleConfig
    robot_poses : ndarray, shape (T, 3)
        True robot poses (world) every ``dt`` s from 0 (``walkers`` are placed relative to them).
    dt : float
        Step of ``robot_poses`` (s).
    duration : float
        Scene length (s).
    rng : numpy.random.Generator

    Returns
    -------
    list of Track
        Tracks that exist at some time in ``[0, duration]``; ids unique and stable for a seed.
    """
    tracks = _source_tracks(pc, robot_poses, dt, duration, rng)
    if pc.groups or pc.queues:
        first = 1 + max((tr.person_id for tr in tracks), default=-1)
        tracks += standing_tracks(
            pc.groups,
            pc.queues,
            region=pc.region,
            speed=pc.speed_mu,
            duration=duration,
            first_id=first,
            shuffle_sd=pc.shuffle_sd,
            step_rate=pc.shuffle_rate,
            rng=rng,
        )
    return [tr for tr in tracks if tr.t_end >= 0.0 and tr.t_start <= duration]


def _source_tracks(
    pc: PeopleConfig, robot_poses: NDArray[np.float64], dt: float, duration: float, rng: np.random.Generator
) -> list[Track]:
    """The tracks of ``pc.source`` (walkers, corridor, ETH/UCY or none)."""
    if pc.source == "none":
        return []
    if pc.source == "walkers":
        tracks = _walker_tracks(pc, robot_poses, dt, duration, rng)
    elif pc.source == "corridor":
        tracks = _corridor_tracks(pc, duration, rng)
    else:
        tracks = []
        for tr in load_tracks(pc.sequence):
            tt = tr.t - pc.t_offset_s
            if tt[-1] < 0.0 or tt[0] > duration:
                continue
            tracks.append(Track(tr.person_id, tt, tr.xy + np.asarray(pc.offset)))
    return tracks
