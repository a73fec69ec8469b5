"""Prediction based on people motion (Batista & Pereira 2015, Sect. 3.1.1, eqs. 5-9).

Two kernel forms
----------------
``form="paper"``
    The paper's p_k: ``p_stationary`` at distance 0 and, for a cell k at cell-centre distance d > 0,

        p_k = (1 - p_stationary) * N(d / dt; mu, sigma)                                    (p_k model)

    a *speed density* (units s/m), not a probability. The neighbourhood G holds the cells whose centre lies
    within ``v_max * dt`` of the centre cell.
``form="integrated"``
    The probability that a person placed uniformly in cell k is in cell c after ``dt``. With displacement
    ``u = s dt (cos a, sin a)``, ``s`` ~ N(mu, sigma) truncated to [0, v_max], ``a`` uniform, and a start
    uniform in the cell, the probability of moving by ``(di, dj)`` cells is ``E[tri(u_x/r - di) tri(u_y/r - dj)]``
    with ``tri(t) = max(0, 1 - |t|)`` (the 1-D overlap of a unit box with its shifted copy). This is evaluated
    with Gauss-Legendre nodes in speed and equally spaced headings (a multiple of 8, so the kernel keeps the
    grid's symmetries exactly). Because ``sum_d tri(t - d) = 1`` for every t, the kernel sums to one up to
    round-off; the neighbourhood reaches ``ceil(v_max dt / r) + 1`` cells so no displacement leaves it. This is
    what a particle filter samples.

Two predictions
---------------
``form="paper"`` (eq. 6 with eqs. 7-9)
    ``bel'_c = p_stationary * bel_c + P_col,c * (1 - bel_c)``. In eq. 8 p_free cancels:

        P_col = 1 - p_free / (p_free + sum_k p_free q_k / (1 - q_k)) = S / (1 + S),
        S = sum_{k in G, k != c} q_k / (1 - q_k),   q_k = p_k bel_k.

    The centre cell is left out of G (the colonisation term is conditioned on c being empty at t - 1).
    Both kernel forms may be used with it; the paper used the paper-form kernel.
``form="linear"``
    The Chapman-Kolmogorov sum ``bel'_c = sum_k T(c <- k) bel_k`` with the integrated kernel: the expected
    occupancy when people move independently. This is the grid filter that the particle filter estimates.

Outside the grid the belief is ``outside`` (0.5 in the paper: nothing is known there).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage, special

from gridbridge import jit, kernels
from gridbridge.grid import GridSpec
from gridbridge.limits import check_motion_step
from gridbridge.params import PeopleMotion
from gridbridge.validation import check_choice, check_grid_array, check_positive, check_probability

__all__ = [
    "DT_QUANTUM_S",
    "check_people_step",
    "outside_inflow",
    "people_motion_kernel",
    "predict_people",
    "quantise_dt",
    "truncated_speed_pdf",
]

KernelForm = Literal["paper", "integrated"]
PredictForm = Literal["paper", "linear"]

#: Time steps are quantised to this (s) before a kernel is computed and cached.
DT_QUANTUM_S = 1e-3

#: Quadrature sizes of the integrated kernel: Gauss-Legendre nodes per speed interval, headings (multiple of 8).
_N_SPEED = 96
_N_HEADING = 256
#: The integrated kernel's tents are computed for every quadrature point and offset (one matrix product) up to this
#: many entries (32 MiB an array: steps up to about 0.7 s at 0.3 m cells), from the two offsets a tent covers beyond.
_DENSE_TENT_ENTRIES = 2**22


def truncated_speed_pdf(speed: ArrayLike, motion: PeopleMotion) -> NDArray[np.float64]:
    """Density (s/m) of walking speed: N(mu, sigma) truncated to [0, v_max] and renormalised.

    This is the speed distribution of a *moving* person, shared by the integrated kernel and the particle
    sampler (:mod:`pfpeople.particle.predictor.paper`).
    """
    s = np.asarray(speed, dtype=float)
    a = (0.0 - motion.mu) / motion.sigma
    b = (motion.v_max - motion.mu) / motion.sigma
    z = special.ndtr(b) - special.ndtr(a)
    pdf = np.exp(-0.5 * ((s - motion.mu) / motion.sigma) ** 2) / (motion.sigma * math.sqrt(2 * math.pi) * z)
    return np.where((s >= 0.0) & (s <= motion.v_max), pdf, 0.0)


def people_motion_kernel(
    spec: GridSpec,
    motion: PeopleMotion | None = None,
    *,
    dt: float | None = None,
    form: KernelForm = "paper",
) -> NDArray[np.float64]:
    """The people motion kernel as a centred 2-D array (odd side, centre = no displacement).

    Parameters
    ----------
    spec : GridSpec
        Grid whose resolution sets the cell size.
    motion : PeopleMotion, optional
        Motion model (Table 1 defaults).
    dt : float, optional
        Time step (s); defaults to ``motion.dt``. Quantised to ``DT_QUANTUM_S`` (1 ms).
    form : {"paper", "integrated"}
        See the module docstring.

    Returns
    -------
    ndarray, shape (2R + 1, 2R + 1)
        ``kernel[R + di, R + dj]`` is the weight of a displacement of ``(di, dj)`` cells (x, y). Read-only.

    Raises
    ------
    ResourceLimitError
        A neighbourhood wider than :data:`gridbridge.limits.MAX_KERNEL_RADIUS_CELLS` or a prediction over the grid
        costing more than :data:`gridbridge.limits.MAX_STEP_OPERATIONS` (:func:`gridbridge.limits.check_motion_step`).
    """
    motion = PeopleMotion() if motion is None else motion
    if not isinstance(spec, GridSpec):
        raise ValueError(f"spec must be a GridSpec, got {type(spec).__name__}")
    dt_ = motion.dt if dt is None else check_positive(dt, "dt")
    check_choice(form, "form", ("paper", "integrated"))
    check_people_step(spec, motion, dt_)
    # Kernels are cached per (resolution, motion, dt, form). Real sensor clocks jitter (0.0998 s, 0.1003 s, ...),
    # so dt is quantised to DT_QUANTUM_S: the kernel of a 0.1003 s step is the 0.100 s kernel (a 0.3 % change of
    # the reachable distance, far below the speed model's spread) and is computed once, not every frame.
    return _kernel_cached(spec.resolution, motion, quantise_dt(dt_), form)


def check_people_step(spec: GridSpec, motion: PeopleMotion, dt: float) -> None:
    """Refuse a people-motion step of ``dt`` (s) on ``spec`` whose neighbourhood is too wide or too costly
    (:func:`gridbridge.limits.check_motion_step`, naming the step): both filters call it before a step changes
    anything, and :func:`people_motion_kernel` before a kernel is computed."""
    check_motion_step(spec.n_cells, spec.resolution, v_max=motion.v_max, dt=dt, where=f"people motion over {dt:g} s")


def quantise_dt(dt: float) -> float:
    """``dt`` (s) on the ``DT_QUANTUM_S`` grid (at least one quantum): the key of kernels and their caches."""
    return round(max(DT_QUANTUM_S, round(dt / DT_QUANTUM_S) * DT_QUANTUM_S), 9)


@lru_cache(maxsize=64)
def _kernel_cached(resolution: float, motion: PeopleMotion, dt: float, form: str) -> NDArray[np.float64]:
    kernel = _paper_kernel(resolution, motion, dt) if form == "paper" else _integrated_kernel(resolution, motion, dt)
    kernel.setflags(write=False)
    return kernel


def _paper_kernel(resolution: float, motion: PeopleMotion, dt: float) -> NDArray[np.float64]:
    reach = motion.v_max * dt
    radius = max(1, math.floor(reach / resolution + 1e-9))
    d = np.arange(-radius, radius + 1) * resolution
    dist = np.hypot(d[:, None], d[None, :])
    density = np.exp(-0.5 * ((dist / dt - motion.mu) / motion.sigma) ** 2) / (motion.sigma * math.sqrt(2 * math.pi))
    kernel = np.where(dist <= reach + 1e-12, (1.0 - motion.p_stationary) * density, 0.0)
    kernel[radius, radius] = motion.p_stationary
    return kernel


@lru_cache(maxsize=4)
def _gauss_legendre(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss-Legendre nodes and weights on [-1, 1] (numpy's ``leggauss`` solves an eigenproblem: 10 ms)."""
    return np.polynomial.legendre.leggauss(n)


def _integrated_kernel(resolution: float, motion: PeopleMotion, dt: float) -> NDArray[np.float64]:
    reach_cells = motion.v_max * dt / resolution
    radius = math.ceil(reach_cells) + 1
    # Speed quadrature: Gauss-Legendre on sub-intervals of [0, v_max] of at most one cell of travel each,
    # since the integrand (products of tent functions) has kinks at whole-cell displacements.
    n_int = max(1, math.ceil(reach_cells))
    xg, wg = _gauss_legendre(_N_SPEED)
    edges = np.linspace(0.0, motion.v_max, n_int + 1)
    half = 0.5 * np.diff(edges)
    speeds = (edges[:-1, None] + half[:, None] * (xg[None, :] + 1.0)).ravel()
    s_weights = (half[:, None] * wg[None, :]).ravel() * truncated_speed_pdf(speeds, motion)
    s_weights /= s_weights.sum()  # remove quadrature error on the normalisation
    # Headings (k + 0.5) 2 pi / N are symmetric under x <-> y and both sign flips (N a multiple of 8): the sum
    # runs over the first octant (0, pi/4) only and the other seven are its mirror images (8x fewer terms).
    headings = (np.arange(_N_HEADING // 8) + 0.5) * (2 * math.pi / _N_HEADING)
    ux = ((speeds[:, None] * dt / resolution) * np.cos(headings)[None, :]).ravel()
    uy = ((speeds[:, None] * dt / resolution) * np.sin(headings)[None, :]).ravel()
    w = np.broadcast_to(s_weights[:, None] / _N_HEADING, (speeds.size, headings.size)).ravel()
    side = 2 * radius + 1
    if ux.size * side <= _DENSE_TENT_ENTRIES:
        octant = _octant_dense(ux, uy, w, radius)
    else:
        octant = _octant_sparse(ux, uy, w, radius)
    quadrant = octant + octant.T  # heading pi/2 - h swaps x and y
    moving = quadrant + quadrant[::-1, :] + quadrant[:, ::-1] + quadrant[::-1, ::-1]  # pi - h, -h, pi + h
    kernel = (1.0 - motion.p_stationary) * moving
    kernel[radius, radius] += motion.p_stationary
    return kernel


def _octant_dense(
    ux: NDArray[np.float64], uy: NDArray[np.float64], w: NDArray[np.float64], radius: int
) -> NDArray[np.float64]:
    """``E[tri(u_x - di) tri(u_y - dj)]`` over the quadrature points ``(ux, uy)`` (cells) with weights ``w``, shape
    ``(2R + 1, 2R + 1)``: the tents of every point on every offset, summed by one matrix product (memory: three
    arrays of ``points x (2R + 1)``)."""
    offsets = np.arange(-radius, radius + 1, dtype=float)
    tx = np.clip(1.0 - np.abs(ux[:, None] - offsets[None, :]), 0.0, None)  # (Q, 2R+1)
    ty = np.clip(1.0 - np.abs(uy[:, None] - offsets[None, :]), 0.0, None)
    out: NDArray[np.float64] = (tx * w[:, None]).T @ ty
    return out


def _octant_sparse(
    ux: NDArray[np.float64], uy: NDArray[np.float64], w: NDArray[np.float64], radius: int
) -> NDArray[np.float64]:
    """:func:`_octant_dense` from the two offsets each tent covers (``floor(u)`` and ``floor(u) + 1``): the same
    terms (equal to round-off: the sums run in another order), in memory and time linear in the points."""
    side = 2 * radius + 1
    fx, fy = np.floor(ux), np.floor(uy)
    out = np.zeros(side * side)
    for ox in (0.0, 1.0):
        tx = 1.0 - np.abs(ux - (fx + ox))
        for oy in (0.0, 1.0):
            ty = 1.0 - np.abs(uy - (fy + oy))
            index = (fx + ox + radius).astype(np.intp) * side + (fy + oy + radius).astype(np.intp)
            out += np.bincount(index, weights=tx * w * ty, minlength=side * side)
    return out.reshape(side, side)


def outside_inflow(shape: tuple[int, int], kernel: NDArray[np.float64], outside: float) -> NDArray[np.float64]:
    """The mass a linear people prediction brings into each cell from beyond the grid: ``outside * sum_{k outside}
    T(c <- k)``, shape ``shape`` (the linear prediction of an empty grid whose border reads ``outside``).

    Parameters
    ----------
    shape : tuple of int
        The grid's ``(nx, ny)``.
    kernel : ndarray, shape (2R + 1, 2R + 1)
        A people-motion kernel (symmetric under both flips, as :func:`people_motion_kernel`'s).
    outside : float
        The belief beyond the border.

    Notes
    -----
    A kernel up to about the grid's size (side at most ``2 max(nx, ny) + 1``) is applied by
    ``scipy.ndimage.convolve``; for a larger one (a step of seconds) scipy takes memory and time in proportion to the
    kernel's cells times the grid's (850 MB and 2 s for a 10 s step on the paper's grid), so the sum over the taps whose
    source is inside the grid, a rectangle of the kernel for every cell, is read from the kernel's summed-area table
    instead (memory of the kernel's size; equal to round-off).
    """
    nx, ny = int(shape[0]), int(shape[1])
    side = kernel.shape[0]
    if side <= 2 * max(nx, ny) + 1:
        out: NDArray[np.float64] = ndimage.convolve(np.zeros((nx, ny)), kernel, mode="constant", cval=outside)
        return out
    rad = side // 2
    table = np.zeros((side + 1, side + 1))
    table[1:, 1:] = np.cumsum(np.cumsum(kernel, axis=0), axis=1)
    i, j = np.arange(nx)[:, None], np.arange(ny)[None, :]
    a0, a1 = np.clip(i - nx + 1 + rad, 0, side), np.clip(i + rad + 1, 0, side)  # taps whose source row is inside
    b0, b1 = np.clip(j - ny + 1 + rad, 0, side), np.clip(j + rad + 1, 0, side)
    inside = table[a1, b1] - table[a0, b1] - table[a1, b0] + table[a0, b0]
    return np.clip(outside * (table[-1, -1] - inside), 0.0, None)


def predict_people(
    belief: ArrayLike,
    kernel: ArrayLike,
    *,
    outside: float = 0.5,
    form: PredictForm = "paper",
) -> NDArray[np.float64]:
    """People-motion prediction of a belief grid (eq. 6 with eq. 8, or the linear Chapman-Kolmogorov sum).

    Parameters
    ----------
    belief : array_like, shape (nx, ny)
        bel(x_{t-1} = p) per cell.
    kernel : array_like, shape (2R + 1, 2R + 1)
        From :func:`people_motion_kernel`; centred, odd side.
    outside : float
        Belief assumed for cells outside the grid (the paper: 0.5).
    form : {"paper", "linear"}
        See the module docstring.

    Returns
    -------
    ndarray, shape (nx, ny)
        The predicted belief bel'(x_t = p).
    """
    check_choice(form, "form", ("paper", "linear"))
    bel = check_grid_array(belief, "belief")
    k = check_grid_array(kernel, "kernel", probability=False)
    if k.shape[0] != k.shape[1] or k.shape[0] % 2 == 0:
        raise ValueError(f"kernel must be square with an odd side, got shape {k.shape}")
    if k.min() < 0.0:
        raise ValueError("kernel must be non-negative")
    outside = check_probability(outside, "outside")
    if form == "linear":
        if jit.enabled():
            return kernels.convolve_const(np.ascontiguousarray(bel), np.ascontiguousarray(k), outside)
        out = _convolve_numpy(bel, k, outside)
        return np.clip(out, 0.0, 1.0, out=out)
    if jit.enabled():
        _check_paper_kernel(k)
        return kernels.predict_paper(np.ascontiguousarray(bel), np.ascontiguousarray(k), outside)
    return _predict_paper(bel, k, outside)


def _convolve_numpy(bel: NDArray[np.float64], kernel: NDArray[np.float64], outside: float) -> NDArray[np.float64]:
    """The linear prediction's sum on the numpy path: ``scipy.ndimage.convolve`` with ``outside`` beyond the border;
    for a kernel larger than about the grid (whose memory in scipy grows with its cells times the grid's: 1.2 GB for
    a 10 s step), the taps that reach inside the grid by scipy and the rest as :func:`outside_inflow` (equal to
    round-off)."""
    nx, ny = bel.shape
    side = kernel.shape[0]
    if side <= 2 * max(nx, ny) + 1:
        out: NDArray[np.float64] = ndimage.convolve(bel, kernel, mode="constant", cval=outside)
        return out
    keep = max(nx, ny) - 1  # larger displacements leave the grid whatever the cell
    rad = side // 2
    inner = kernel[rad - keep : rad + keep + 1, rad - keep : rad + keep + 1]
    inside: NDArray[np.float64] = ndimage.convolve(bel, inner, mode="constant", cval=0.0)
    return inside + outside_inflow((nx, ny), kernel, outside)


def _check_paper_kernel(kernel: NDArray[np.float64]) -> None:
    """ValueError unless the off-centre values are below 1 (eq. 8 divides by ``1 - p_k bel_k``)."""
    if kernel.max() < 1.0:
        return
    radius = kernel.shape[0] // 2
    off_centre = kernel.copy()
    off_centre[radius, radius] = 0.0
    if off_centre.max() >= 1.0:
        raise ValueError("kernel off-centre values must be below 1 for the paper form (eq. 8 divides by 1 - p_k bel_k)")


def _predict_paper(bel: NDArray[np.float64], kernel: NDArray[np.float64], outside: float) -> NDArray[np.float64]:
    radius = kernel.shape[0] // 2
    _check_paper_kernel(kernel)
    nx, ny = bel.shape
    padded = np.pad(bel, radius, mode="constant", constant_values=outside)
    s = np.zeros_like(bel)
    di, dj = np.nonzero(kernel)
    for a, b in zip(di.tolist(), dj.tolist(), strict=True):
        if a == radius and b == radius:
            continue
        # Displacement (a - R, b - R) carries people from cell c - d into c: source window shifted by -d.
        src = padded[2 * radius - a : 2 * radius - a + nx, 2 * radius - b : 2 * radius - b + ny]
        q = kernel[a, b] * src
        s += q / (1.0 - q)
    p_col = s / (1.0 + s)
    p_stay = kernel[radius, radius]
    return p_stay * bel + p_col * (1.0 - bel)
