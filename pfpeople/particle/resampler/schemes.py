"""Resampling schemes: plain functions returning ancestor indices, chosen by name (as nchopin/particles).

Each resampler takes weights ``w`` (non-negative, any positive sum; normalised here to ``W``) and a number of
draws ``n`` and returns ``n`` ancestor indices ``a`` with ``E[#{k : a_k = i}] = n W_i``:

``systematic``  one uniform ``u``; positions ``(k + u) / n``.
``stratified``  one uniform per stratum; positions ``(k + u_k) / n``.
``residual``    ``floor(n W_i)`` copies each, the remainder by multinomial draws on the residual weights.
``multinomial`` ``n`` independent draws (sorted uniforms from exponential spacings).

All are vectorised and O(N) apart from a binary search (``np.searchsorted``); systematic resampling counts
offspring directly from the cumulative weights (``ceil(n C_i - u)`` differences), no search. The last
cumulative weight is set to exactly 1 so that round-off (weights summing to 1 - 1e-12) never yields an index
past the end. Ancestors come out sorted. ``systematic`` and ``stratified`` accept the offsets
(``u=``) so they can be compared with ``filterpy.monte_carlo`` on the same random numbers.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.validation import check_int

__all__ = [
    "RESAMPLERS",
    "effective_sample_size",
    "get_resampler",
    "multinomial",
    "residual",
    "stratified",
    "systematic",
]


def _normalised_cumsum(weights: ArrayLike) -> NDArray[np.float64]:
    w = np.asarray(weights, dtype=float)
    if w.ndim != 1 or w.size == 0:
        raise ValueError(f"weights must be a non-empty 1-D array, got shape {w.shape}")
    cum = np.cumsum(w)
    total = cum[-1]
    if not np.isfinite(total) or not np.all(np.isfinite(w)):
        raise ValueError("weights contain NaN or infinite values")
    if total <= 0.0 or w.min() < 0.0:
        raise ValueError("weights must be non-negative with a positive sum")
    cum /= total
    cum[-1] = 1.0  # guard: positions in [0, 1) always fall inside
    return cum


def _count(n: int | None, size: int) -> int:
    return check_int(size if n is None else n, "n", minimum=0)


def _need_rng(rng: np.random.Generator | None) -> np.random.Generator:
    if rng is None:
        raise ValueError("rng (a numpy.random.Generator) is required (systematic and stratified: or the offsets u)")
    return rng


def _from_positions(cum: NDArray[np.float64], positions: NDArray[np.float64]) -> NDArray[np.intp]:
    # First i with position < cum[i] (as filterpy's loops).
    idx = np.searchsorted(cum, positions, side="right")
    return np.minimum(idx, cum.size - 1).astype(np.intp, copy=False)


def systematic(
    weights: ArrayLike,
    n: int | None = None,
    *,
    rng: np.random.Generator | None = None,
    u: float | None = None,
) -> NDArray[np.intp]:
    """Systematic resampling: ``n`` (default ``len(weights)``) ancestors from positions ``(k + u) / n``.

    Parameters
    ----------
    weights : array_like, shape (N,)
        Non-negative, positive sum (normalised here).
    n : int, optional
        Number of draws.
    rng : numpy.random.Generator, optional
        Draws ``u`` when ``u`` is not given.
    u : float in [0, 1), optional
        The offset (filterpy's ``random()``).

    Returns
    -------
    ndarray of intp, shape (n,)
        Sorted ancestor indices.
    """
    cum = _normalised_cumsum(weights)
    m = _count(n, cum.size)
    off = float(_need_rng(rng).random()) if u is None else float(u)
    if not 0.0 <= off < 1.0:
        raise ValueError(f"u must lie in [0, 1), got {u!r}")
    # Number of positions (k + u) / m below cum[i] is ceil(m cum[i] - u), clipped to [0, m].
    below = np.clip(np.ceil(m * cum - off), 0, m).astype(np.intp)
    below[-1] = m
    counts = np.diff(below, prepend=0)
    return np.repeat(np.arange(cum.size, dtype=np.intp), counts)


def stratified(
    weights: ArrayLike,
    n: int | None = None,
    *,
    rng: np.random.Generator | None = None,
    u: ArrayLike | None = None,
) -> NDArray[np.intp]:
    """Stratified resampling: positions ``(k + u_k) / n`` with independent uniforms ``u_k``.

    ``u`` (shape ``(n,)``, values in [0, 1)) may be given instead of ``rng``. Returns sorted ancestors.
    """
    cum = _normalised_cumsum(weights)
    m = _count(n, cum.size)
    off = _need_rng(rng).random(m) if u is None else np.asarray(u, dtype=float)
    if off.shape != (m,) or (m and (off.min() < 0.0 or off.max() >= 1.0)):
        raise ValueError(f"u must be {m} numbers in [0, 1)")
    return _from_positions(cum, (np.arange(m) + off) / m)


def multinomial(
    weights: ArrayLike, n: int | None = None, *, rng: np.random.Generator | None = None
) -> NDArray[np.intp]:
    """Multinomial resampling: ``n`` independent draws by weight. Returns sorted ancestors."""
    cum = _normalised_cumsum(weights)
    m = _count(n, cum.size)
    spacings = np.cumsum(_need_rng(rng).exponential(size=m + 1))
    return _from_positions(cum, spacings[:-1] / spacings[-1])


def residual(weights: ArrayLike, n: int | None = None, *, rng: np.random.Generator | None = None) -> NDArray[np.intp]:
    """Residual resampling: ``floor(n W_i)`` copies, the rest multinomial on the residuals. Sorted output."""
    cum = _normalised_cumsum(weights)
    m = _count(n, cum.size)
    w = np.diff(cum, prepend=0.0)
    scaled = m * w
    copies = np.floor(scaled).astype(np.intp)
    rest = m - int(copies.sum())
    if rest > 0:
        extra = multinomial(scaled - copies, rest, rng=rng)
        copies += np.bincount(extra, minlength=cum.size)
    return np.repeat(np.arange(cum.size, dtype=np.intp), copies)


RESAMPLERS: dict[str, Callable[..., NDArray[np.intp]]] = {
    "systematic": systematic,
    "stratified": stratified,
    "residual": residual,
    "multinomial": multinomial,
}


def get_resampler(name: str) -> Callable[..., NDArray[np.intp]]:
    """The resampler called ``name`` (one of :data:`RESAMPLERS`)."""
    try:
        return RESAMPLERS[name]
    except (KeyError, TypeError):
        raise ValueError(f"resampler must be one of {', '.join(map(repr, RESAMPLERS))}; got {name!r}") from None


def effective_sample_size(weights: ArrayLike) -> float:
    """ESS = (sum w)^2 / sum w^2 (0 for all-zero weights)."""
    w = np.asarray(weights, dtype=float)
    sq = float(np.dot(w, w))
    return float(w.sum()) ** 2 / sq if sq > 0.0 else 0.0
