"""People who stand: groups talking, queues, people waiting, for the scan-level simulator.

In an office, a corridor or a station most people stand most of the time, and standing people are not still:
they shuffle, shift their weight and turn (0.1-0.4 m over 2-4 s). A scene's ``[people]`` table can place
groups and queues beside its walkers (:class:`~evaluation.scenarios.scan.scene.PeopleConfig`):

* ``groups`` rows ``(x, y, n, t_start, t_end)``: ``n`` people standing on a circle around ``(x, y)`` (world,
  m), 0.65 m apart (a conversation), from ``t_start`` to ``t_end`` (s);
* ``queues`` rows ``(x, y, yaw, n, t_start, t_end)``: ``n`` people in a line from ``(x, y)`` backwards along
  ``yaw`` (rad), 0.75 m apart (waiting at a counter or a door).

Each person walks in from the nearest border of the region (arriving at ``t_start``; already there when
``t_start <= 0``), stands with the shuffle below, and at ``t_end`` walks out through the nearest border
(people stay to the end of the scene when ``t_end`` is beyond it).

Shuffle, sampled every ``_KNOT_S`` s: the standing point follows an Ornstein-Uhlenbeck process around its
anchor (stationary sd ``shuffle_sd``, time constant 2 s), and with rate ``step_rate`` per second the anchor
itself moves 0.1-0.4 m in a random direction, the move taking 2-4 s.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from evaluation.scenarios.tracks import Track
from evaluation.scenarios.walkers import polyline_knots

__all__ = ["standing_tracks"]

_KNOT_S = 0.5
_OU_TAU_S = 2.0
_GROUP_SPACING = 0.65
_QUEUE_SPACING = 0.75


def _border_point(p: NDArray[np.float64], region: tuple[float, float, float, float]) -> NDArray[np.float64]:
    """The point of the region's border nearest to ``p`` (m)."""
    x0, x1, y0, y1 = region
    q = np.clip(p, [x0, y0], [x1, y1])
    cands = [np.array([x0, q[1]]), np.array([x1, q[1]]), np.array([q[0], y0]), np.array([q[0], y1])]
    return min(cands, key=lambda e: float(np.hypot(*(e - q))))


def _shuffle(
    anchor: NDArray[np.float64],
    t0: float,
    t1: float,
    *,
    shuffle_sd: float,
    step_rate: float,
    rng: np.random.Generator,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Knots ``(t (K,), xy (K, 2))`` of a person standing at ``anchor`` from ``t0`` to ``t1`` (s, m)."""
    n = max(2, math.ceil((t1 - t0) / _KNOT_S) + 1)
    t = np.linspace(t0, t1, n)
    h = float(t[1] - t[0])
    a = math.exp(-h / _OU_TAU_S)
    ou = np.zeros((n, 2))
    for k in range(1, n):
        ou[k] = a * ou[k - 1] + shuffle_sd * math.sqrt(1.0 - a * a) * rng.standard_normal(2)
    base = np.repeat(anchor[None, :], n, axis=0)
    k = 0
    while step_rate > 0:
        k += max(1, round(rng.exponential(1.0 / step_rate) / h))
        if k >= n - 1:
            break
        ang, dist = rng.uniform(-math.pi, math.pi), rng.uniform(0.1, 0.4)
        span = max(1, round(rng.uniform(2.0, 4.0) / h))
        ramp = np.clip((np.arange(n) - k) / span, 0.0, 1.0)[:, None]
        base = base + ramp * dist * np.array([math.cos(ang), math.sin(ang)])
    return t, base + ou


def _stander(
    person_id: int,
    spot: NDArray[np.float64],
    t_start: float,
    t_end: float,
    *,
    region: tuple[float, float, float, float],
    speed: float,
    duration: float,
    shuffle_sd: float,
    step_rate: float,
    rng: np.random.Generator,
) -> Track:
    """One person: walk in to ``spot`` (arriving at ``t_start``), stand until ``t_end``, walk out."""
    t_from = t_start if t_start > 0 else -1.0
    t_to = min(t_end, duration + 1.0)
    st, sxy = _shuffle(spot, t_from, t_to, shuffle_sd=shuffle_sd, step_rate=step_rate, rng=rng)
    times, xy = [st], [sxy]
    if t_start > 0:  # walk in from the nearest border
        door = _border_point(spot, region)
        walk_t = float(np.hypot(*(spot - door))) / speed
        times.insert(0, np.array([t_from - walk_t]))
        xy.insert(0, door[None, :])
    if t_end <= duration:  # walk out through the nearest border
        door = _border_point(sxy[-1], region)
        kt, kxy = polyline_knots(float(st[-1]), np.array([sxy[-1], door]), speed, {})
        times.append(kt[1:])
        xy.append(kxy[1:])
    return Track(person_id, np.concatenate(times), np.concatenate(xy))


def _spots(row: tuple[float, ...], *, queue: bool) -> tuple[list[NDArray[np.float64]], float, float]:
    """The standing spots of a group or queue row, and its start and end times."""
    if queue:
        x, y, yaw, n, t0, t1 = row
        back = -np.array([math.cos(yaw), math.sin(yaw)])
        return [np.array([x, y]) + k * _QUEUE_SPACING * back for k in range(int(n))], t0, t1
    x, y, n, t0, t1 = row
    m = int(n)
    radius = 0.0 if m == 1 else 0.5 * _GROUP_SPACING / math.sin(math.pi / m)
    return (
        [
            np.array([x + radius * math.cos(2 * math.pi * k / m), y + radius * math.sin(2 * math.pi * k / m)])
            for k in range(m)
        ],
        t0,
        t1,
    )


def standing_tracks(
    groups: tuple[tuple[float, ...], ...],
    queues: tuple[tuple[float, ...], ...],
    *,
    region: tuple[float, float, float, float],
    speed: float,
    duration: float,
    first_id: int,
    shuffle_sd: float,
    step_rate: float,
    rng: np.random.Generator,
) -> list[Track]:
    """The tracks of the people of ``groups`` and ``queues`` (see the module docstring).

    Parameters
    ----------
    groups : rows (x, y, n, t_start, t_end)
    queues : rows (x, y, yaw, n, t_start, t_end)
    region : (x_min, x_max, y_min, y_max)
        Walkable area (m, world): people come in and leave through its border.
    speed : float
        Walking speed (m/s) on the way in and out.
    duration : float
        Scene length (s).
    first_id : int
        Id of the first person (the others follow).
    shuffle_sd, step_rate : float
        Sd (m) of the sway around the standing point; rate (1/s) of 0.1-0.4 m shifts of the point.
    rng : numpy.random.Generator

    Returns
    -------
    list of Track
    """
    out: list[Track] = []
    pid = first_id
    for rows, queue in ((groups, False), (queues, True)):
        for row in rows:
            spots, t0, t1 = _spots(row, queue=queue)
            if t0 >= duration:  # arrives after the scene's end
                pid += len(spots)
                continue
            for spot in spots:
                out.append(
                    _stander(
                        pid,
                        spot,
                        t0,
                        t1,
                        region=region,
                        speed=speed,
                        duration=duration,
                        shuffle_sd=shuffle_sd,
                        step_rate=step_rate,
                        rng=rng,
                    )
                )
                pid += 1
    return out
