"""Ray-cast simple shapes (circles, line segments) into a :class:`~pfpeople.sensors.LaserScan`, for tests and demos.

Each beam returns the nearest intersection with the given circles and segments; beams that hit nothing return
``inf`` (no echo), as many real lasers report "no return".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from pfpeople.sensors import LaserScan

__all__ = ["render_scan", "reversed_scan"]


def render_scan(
    *,
    circles: Sequence[tuple[float, float, float]] = (),
    segments: Sequence[tuple[float, float, float, float]] = (),
    angle_min: float = -math.pi / 2,
    angle_max: float = math.pi / 2,
    angle_increment: float = math.radians(0.25),
    range_max: float = 10.0,
    noise_sd: float = 0.0,
    rng: np.random.Generator | None = None,
) -> LaserScan:
    """A scan of circles ``(x, y, radius)`` and segments ``(x0, y0, x1, y1)`` (m, scan frame).

    Parameters
    ----------
    circles, segments : sequences of tuples
        The scene (m).
    angle_min, angle_max, angle_increment : float
        Beam bearings (rad).
    range_max : float
        Hits beyond this (m) are reported as ``inf``.
    noise_sd : float
        Standard deviation (m) of Gaussian range noise; needs ``rng`` when positive.
    rng : numpy.random.Generator, optional
        Random generator for the noise.
    """
    n = math.floor((angle_max - angle_min) / angle_increment + 1e-9) + 1
    a = angle_min + angle_increment * np.arange(n)
    dx, dy = np.cos(a), np.sin(a)
    r = np.full(n, np.inf)
    for cx, cy, rad in circles:
        b = dx * cx + dy * cy
        disc = b * b - (cx * cx + cy * cy - rad * rad)
        with np.errstate(invalid="ignore"):
            t = b - np.sqrt(disc)
        hit = (disc >= 0) & (t > 0)
        r = np.where(hit & (t < r), t, r)
    for x0, y0, x1, y1 in segments:
        ex, ey = x1 - x0, y1 - y0
        den = dx * (-ey) - dy * (-ex)
        ok = np.abs(den) > 1e-12
        sden = np.where(ok, den, 1.0)
        t = (x0 * (-ey) - y0 * (-ex)) / sden
        s = (dx * y0 - dy * x0) / sden
        hit = ok & (t > 0) & (s >= 0) & (s <= 1)
        r = np.where(hit & (t < r), t, r)
    if noise_sd > 0:
        if rng is None:
            raise ValueError("render_scan: noise_sd > 0 needs rng")
        r = r + rng.normal(0.0, noise_sd, size=n)
    r = np.where(r > range_max, np.inf, r)
    return LaserScan(ranges=r, angle_min=angle_min, angle_increment=angle_increment, range_min=0.0, range_max=range_max)


def reversed_scan(scan: LaserScan) -> LaserScan:
    """The same beams in the opposite order: as a laser turning the other way (a negative ``angle_increment``
    for a counter-clockwise scan) reports them; every beam keeps its bearing and range."""
    n = scan.ranges.size
    return replace(
        scan,
        ranges=scan.ranges[::-1].copy(),
        angle_min=scan.angle_min + scan.angle_increment * (n - 1),
        angle_increment=-scan.angle_increment,
    )
