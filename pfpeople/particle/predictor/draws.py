"""Random draws inside the compiled particle-filter step (:mod:`gridbridge.jit`): SplitMix64, a ziggurat normal,
and the paper's walker velocity.

A people-motion model that draws inside its compiled pass (``draws_inside``: the paper's, the persistent one with
``compiled_draws``; :class:`pfpeople.particle.predictor.compiled.DrawingPredictor`) makes the people motion, the
births and the sensor motion's noise inside the kernels instead of taking numpy ``Generator`` arrays from the caller:
each kernel call gets 64-bit seeds from the filter's ``Generator`` (``rng.integers(2**64, dtype=np.uint64)``), so a
seeded filter is still deterministic, but its draws are not the reference form's (the distributions are the same;
``tests/pfpeople/particle/test_compiled_draws.py`` tests them).

Generator: SplitMix64 (Steele, Lea & Flood 2014; Java's ``SplittableRandom``, the seeder of the xoshiro family):
the state advances by the odd constant ``GAMMA`` and each output is a bijective 64-bit mix of the state; it passes
BigCrush, and one step of it is two multiplications and three shifts. Draw ``k`` of a stream with key ``s`` is
``mix(s + (k + 1) GAMMA)``, so a loop over particles can compute its draws independently of one another
(:func:`hashed`, vectorisable) or in sequence (:func:`next_u64`); the two give the same numbers. A kernel call takes
three or four independent 64-bit keys: two streams of a few million words each overlap with a probability below
1e-11.

Derived draws:

* uniform on [0, 1): the top 53 bits, ``(z >> 11) 2^-53`` (numpy's ``next_double``);
* standard normal: the 256-layer ziggurat of Marsaglia & Tsang (2000) in numpy's form (``random_standard_normal``;
  the tables of ``_zig_tables``, numpy's to about 1e-15);
* a uniform direction without trigonometric calls: a sector of 256 from the top bits, its tabled cosine and sine
  turned by the offset within the sector (the other 56 bits) by angle addition and Taylor series (:func:`direction`);
* the paper's walking speed, N(mu, sigma) truncated to [0, v_max]: standard normals drawn until one falls in
  ``[-mu / sigma, (v_max - mu) / sigma]`` (exact rejection; with the paper's values 99 % are accepted).

:func:`sincos` evaluates a sine and cosine by the same sector table (the sensor motion's drawn displacements, within
7e-16 of the C library's).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit
from gridbridge.params import PeopleMotion

__all__ = [
    "GAMMA",
    "WalkParams",
    "direction",
    "hashed",
    "next_u64",
    "sincos",
    "speed_from",
    "standard_normal",
    "uniform",
    "walk_of",
    "walk_params",
    "walker_velocity",
    "ziggurat_fast",
]

#: SplitMix64's increment (2^64 / golden ratio, odd) and its two mixing multipliers.
GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S8, _S11, _S27, _S30, _S31 = (np.uint64(s) for s in (8, 11, 27, 30, 31))
_ONE = np.uint64(1)
_LOW8 = np.uint64(0xFF)
_LOW52 = np.uint64(0x000FFFFFFFFFFFFF)

#: The walker model as the kernels take it: ``(p_stationary, mu, sigma, v_max, z_lo, z_hi)`` (-, m/s, m/s, m/s,
#: -, -), ``z_lo, z_hi`` the standard-normal bounds of the speed's truncation (:func:`walk_params`).
WalkParams = tuple[float, float, float, float, float, float]


def _zig_tables() -> tuple[NDArray[np.uint64], NDArray[np.float64], NDArray[np.float64]]:
    """The 256-layer ziggurat tables ``(ki, wi, fi)`` of numpy's normal sampler: Marsaglia & Tsang's construction
    with the base strip's edge ``r = 3.6541528853610088`` and layer area ``v = r f(r) + int_r^inf f`` (``f(x) =
    exp(-x^2 / 2)``), 52-bit magnitudes. Computed in double precision, the tables agree with numpy's to about
    1e-15 (relative), which moves the draws by as much, not their distribution."""
    m1, r, v = 2.0**52, 3.6541528853610088, 0.004928673233974655
    ki, wi, fi = np.zeros(256, np.uint64), np.zeros(256), np.zeros(256)
    q = v / math.exp(-0.5 * r * r)
    ki[0], wi[0], wi[255] = np.uint64(r / q * m1), q / m1, r / m1
    fi[0], fi[255] = 1.0, math.exp(-0.5 * r * r)
    dn = tn = r
    for i in range(254, 0, -1):
        dn = math.sqrt(-2.0 * math.log(v / dn + math.exp(-0.5 * dn * dn)))
        ki[i + 1] = np.uint64(dn / tn * m1)
        tn = dn
        fi[i], wi[i] = math.exp(-0.5 * dn * dn), dn / m1
    return ki, wi, fi


_KI, _WI, _FI = _zig_tables()
_ZIG_R = 3.6541528853610088
_ZIG_INV_R = 1.0 / _ZIG_R


def walk_params(p_stationary: float, mu: float, sigma: float, v_max: float) -> WalkParams:
    """The kernels' :data:`WalkParams` of the paper's people motion (:class:`gridbridge.PeopleMotion`'s fields)."""
    return (float(p_stationary), float(mu), float(sigma), float(v_max), -mu / sigma, (v_max - mu) / sigma)


def walk_of(motion: PeopleMotion) -> WalkParams:
    """:func:`walk_params` of a :class:`gridbridge.PeopleMotion`."""
    return walk_params(motion.p_stationary, motion.mu, motion.sigma, motion.v_max)


@jit
def _mix(z: np.uint64) -> np.uint64:
    """SplitMix64's output function: a bijection of 64-bit words."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@jit
def next_u64(state: np.uint64) -> tuple[np.uint64, np.uint64]:
    """One SplitMix64 step: the new state and a uniform 64-bit word."""
    state = state + GAMMA
    return state, _mix(state)


@jit
def hashed(key: np.uint64, k: int) -> np.uint64:
    """Draw ``k`` (>= 0) of the stream with state ``key``: what ``k + 1`` calls of :func:`next_u64` return last."""
    return _mix(key + np.uint64(k + 1) * GAMMA)


@jit
def uniform(z: np.uint64) -> float:
    """A uniform double on [0, 1) from the top 53 bits of ``z``."""
    return float(z >> _S11) * (1.0 / 9007199254740992.0)


@jit
def ziggurat_fast(r: np.uint64) -> tuple[bool, float, np.intp, np.uint64]:
    """The ziggurat's first look at word ``r``: ``(accepted, x, layer, magnitude)``; ``x`` is the draw when
    accepted (about 99.3 % of the words), else :func:`_zig_slow` decides. Branch-free (a loop of it vectorises)."""
    idx = np.intp(r & _LOW8)
    rabs = ((r >> _S8) >> _ONE) & _LOW52
    x = float(rabs) * _WI[idx]
    x = -x if (r >> _S8) & _ONE else x
    return rabs < _KI[idx], x, idx, rabs


@jit
def _zig_slow(state: np.uint64, x: float, idx: np.intp, rabs: np.uint64) -> tuple[np.uint64, bool, float]:
    """The rest of a ziggurat attempt that :func:`ziggurat_fast` did not accept: the wedge test of layer ``idx`` or
    the tail beyond r (Marsaglia's exponential rejection). Returns the state, whether the attempt is accepted and
    the draw."""
    if idx == 0:
        while True:
            state, z1 = next_u64(state)
            state, z2 = next_u64(state)
            xx = -_ZIG_INV_R * math.log1p(-uniform(z1))
            yy = -math.log1p(-uniform(z2))
            if yy + yy > xx * xx:
                return state, True, -(_ZIG_R + xx) if (rabs >> _S8) & _ONE else _ZIG_R + xx
    state, z1 = next_u64(state)
    return state, (_FI[idx - 1] - _FI[idx]) * uniform(z1) + _FI[idx] < math.exp(-0.5 * x * x), x


@jit
def standard_normal(state: np.uint64) -> tuple[np.uint64, float]:
    """A standard normal draw (numpy's ziggurat on SplitMix64 words); returns the new state and the draw."""
    while True:
        state, r = next_u64(state)
        ok, x, idx, rabs = ziggurat_fast(r)
        if ok:
            return state, x
        state, ok, x = _zig_slow(state, x, idx, rabs)
        if ok:
            return state, x


@jit
def speed_from(state: np.uint64, r: np.uint64, walk: WalkParams) -> tuple[np.uint64, float]:
    """A walking speed (m/s), N(mu, sigma) truncated to [0, v_max], whose first normal attempt is word ``r``; any
    further words come from the stream ``state`` (returned advanced)."""
    _, mu, sigma, v_max, z_lo, z_hi = walk
    ok, z, idx, rabs = ziggurat_fast(r)
    if not ok:
        state, ok, z = _zig_slow(state, z, idx, rabs)
    while not (ok and z_lo <= z <= z_hi):  # rejected by the ziggurat or the truncation: fresh normals
        state, z = standard_normal(state)
        ok = True
    return state, min(max(mu + sigma * z, 0.0), v_max)  # round-off only: z is within the bounds


#: cos and sin of the 256 sector starts ``2 pi j / 256`` of :func:`direction`.
_SECTOR_COS = np.cos(np.arange(256) * (2.0 * math.pi / 256.0))
_SECTOR_SIN = np.sin(np.arange(256) * (2.0 * math.pi / 256.0))
_LOW56 = np.uint64((1 << 56) - 1)
_S56 = np.uint64(56)


@jit
def direction(z: np.uint64) -> tuple[float, float]:
    """``(cos h, sin h)`` of a uniform heading ``h = 2 pi (j + f) / 256`` from one word: sector j the top 8 bits,
    ``f`` the other 56 bits as a fraction. Angle addition from the sector's tabled cosine and sine and the Taylor
    series of the offset ``d = 2 pi f / 256 < 0.0246`` (to ``d^8``: the next terms are below 1e-20), no
    trigonometric call and no branch."""
    j = np.intp(z >> _S56)
    d = float(z & _LOW56) * (2.0 * math.pi / 256.0 / 72057594037927936.0)
    d2 = d * d
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0 - d2 * (1.0 / 40320.0))))
    sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0))))
    c0, s0 = _SECTOR_COS[j], _SECTOR_SIN[j]
    return c0 * cd - s0 * sd, s0 * cd + c0 * sd


#: The sector width 2 pi / 256 of :func:`sincos` in two parts (Cody & Waite): ``_H_HI`` of 24 significant bits (so
#: ``j _H_HI`` is exact for ``|j| < 2^29``), ``_H_LO`` the rest to double precision (from pi to 50 digits).
_H_HI = 0.02454369328916073
_H_LO = -6.829904687791004e-10
_INV_H = 256.0 / (2.0 * math.pi)


@jit
def _sector_sincos(j: int, d: float) -> tuple[float, float]:
    """``(sin, cos)`` of ``2 pi j / 256 + d`` for ``|d| <= pi / 256``: the sector's tabled values turned by ``d``
    (angle addition; Taylor series of ``d`` to ``d^9``, the rest below 1e-19)."""
    d2 = d * d
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0 - d2 * (1.0 / 40320.0))))
    sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0 - d2 * (1.0 / 362880.0)))))
    c0, s0 = _SECTOR_COS[j & 255], _SECTOR_SIN[j & 255]
    return s0 * cd + c0 * sd, c0 * cd - s0 * sd


@jit
def sincos(x: float) -> tuple[float, float]:
    """``(sin x, cos x)`` without the C library: the nearest of 256 sectors, the offset by a two-part reduction, then
    :func:`_sector_sincos` (within 7e-16 of ``math.sin`` / ``math.cos``, absolute). The C library's beyond
    ``|x| > 1000`` (and for NaN)."""
    if not abs(x) <= 1000.0:
        return math.sin(x), math.cos(x)
    j = round(x * _INV_H)
    d = (x - j * _H_HI) - j * _H_LO
    return _sector_sincos(int(j), d)


@jit
def walker_velocity(state: np.uint64, walk: WalkParams) -> tuple[np.uint64, float, float]:
    """A walker's velocity (m/s) of the paper's prior, all from the stream ``state``: :func:`speed_from`
    (truncated-normal speed) in the :func:`direction` of the next word.

    Parameters
    ----------
    state : uint64
        The SplitMix64 state.
    walk : WalkParams
        ``(p_stationary, mu, sigma, v_max, z_lo, z_hi)``; ``p_stationary`` is not used here.

    Returns
    -------
    state : uint64
        The new state.
    vx, vy : float
        The velocity (m/s): speed in [0, v_max], direction uniform on the circle.
    """
    state, r = next_u64(state)
    state, speed = speed_from(state, r, walk)
    state, r = next_u64(state)
    c, s = direction(r)
    return state, speed * c, speed * s
