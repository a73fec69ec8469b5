"""Benchmark: time per :meth:`pfpeople.track.MultiPersonTracker.update` with 5, 20 and 50 people in view.

``python -m evaluation.bench.tracking [--people 5 20 50] [--frames 200] [--repeats 5] [--cpu-time]``

A synthetic crowd (seeded): ``P`` people walking at 0.5-1.5 m/s inside a 9 x 9 m box (reflected at its
walls), detected each frame with 0.1 m noise, a 10 % miss rate and one clutter point per frame on average,
seen by a robot turning at 0.1 rad/s (so the ego-motion step runs); a missed person leaves one single leg
(0.12 m from the centre), the support positions of column ``+legs ms`` (the update given them, as the pipeline
gives it the laser detectors' single legs). The tracker is warmed up for 20 frames;
then the median over ``--repeats`` of the mean time per update over ``--frames`` frames is reported, on one
core (run it with ``OMP_NUM_THREADS=1``, set here before numpy loads when not set).

The pipeline also gives the tracker the weaker belief peaks (:func:`pfpeople.track.tracker_inputs`: the
classifier's candidate peaks above ``[tracking] peak_threshold`` = 0.5, and for those up to the classifier's 0.7
their suppression and centroids): column ``inputs ms`` times that on a belief grid of the scan-level scenes'
size (58 x 68 cells of 0.3 m) with a Gaussian blob (sd 0.2 m, peak uniform in [0.55, 0.95], so most frames with
many people have a weak one) at every person of the frame, the people (peaks above 0.7) given; ``total ms``
is what tracking adds to a pipeline frame (inputs + update with single legs).

Baseline measured in the same run: a plain-loop nearest-neighbour tracker (greedy association of every
track to its nearest unused detection within the gate, position-only) on the same detections, i.e. the
cheapest thing a tracker can do per frame. The ratio says what the Kalman model, the gating and the optimal
assignment cost on top of it. Target: <= 1 ms per update with 20 people.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Callable, Sequence

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from pfpeople.track import MultiPersonTracker

DT = 0.1
#: The timer (``--cpu-time`` switches it to :func:`time.process_time`).
_clock = time.perf_counter
OMEGA = 0.1


def crowd(
    n_people: int, n_frames: int, *, rng: np.random.Generator
) -> tuple[list[NDArray[np.float64]], list[NDArray[np.float64]]]:
    """Per frame the detections ``(M, 2)`` (m, sensor frame of that frame) of a walking crowd, and the single legs
    ``(K, 2)`` of the people missed in that frame."""
    pos = rng.uniform([0.5, -4.0], [8.5, 4.0], size=(n_people, 2))
    ang = rng.uniform(-math.pi, math.pi, n_people)
    vel = rng.uniform(0.5, 1.5, n_people)[:, None] * np.column_stack((np.cos(ang), np.sin(ang)))
    frames, legs = [], []
    heading = 0.0
    for _ in range(n_frames):
        pos = pos + vel * DT
        for d, (lo, hi) in enumerate(((0.5, 8.5), (-4.0, 4.0))):
            out = (pos[:, d] < lo) | (pos[:, d] > hi)
            vel[out, d] *= -1.0
            pos[:, d] = np.clip(pos[:, d], lo, hi)
        heading += OMEGA * DT
        c, s = math.cos(-heading), math.sin(-heading)  # world -> sensor (the robot turns on the spot)
        hit = rng.random(n_people) > 0.1
        seen = pos[hit] @ np.array([[c, s], [-s, c]])
        det = seen + rng.normal(0.0, 0.1, seen.shape)
        clutter = rng.uniform([0.0, -4.5], [9.0, 4.5], size=(rng.poisson(1.0), 2))
        frames.append(np.concatenate([det, clutter]))
        side = rng.uniform(-math.pi, math.pi, int(np.count_nonzero(~hit)))
        one_leg = pos[~hit] + 0.12 * np.column_stack((np.cos(side), np.sin(side)))
        legs.append(one_leg @ np.array([[c, s], [-s, c]]))
    return frames, legs


class NearestNeighbour:
    """Baseline: greedy nearest-neighbour association in plain Python loops, position-only tracks."""

    def __init__(self, gate: float = 1.0) -> None:
        self.gate = gate
        self.tracks: dict[int, tuple[float, float]] = {}
        self.next_id = 1

    def update(self, positions: NDArray[np.float64], dt: float, *, ego: Pose2D | None = None) -> None:
        if ego is not None and self.tracks:
            moved = ego.inverse().apply(np.array(list(self.tracks.values())))
            self.tracks = {k: (float(p[0]), float(p[1])) for k, p in zip(self.tracks, moved, strict=True)}
        used: set[int] = set()
        new: dict[int, tuple[float, float]] = {}
        pts = positions.tolist()
        for tid, (tx, ty) in self.tracks.items():
            best, best_d = -1, self.gate
            for j, (x, y) in enumerate(pts):
                if j in used:
                    continue
                d = math.hypot(x - tx, y - ty)
                if d < best_d:
                    best, best_d = j, d
            if best >= 0:
                used.add(best)
                new[tid] = (pts[best][0], pts[best][1])
        for j, (x, y) in enumerate(pts):
            if j not in used:
                new[self.next_id] = (x, y)
                self.next_id += 1
        self.tracks = new


GRID = GridSpec(nx=58, ny=68, resolution=0.3, x0=-7.2, y0=-10.2)


def belief_grids(frames: Sequence[NDArray[np.float64]], *, rng: np.random.Generator) -> list[NDArray[np.float64]]:
    """A belief grid per frame (``GRID``): 0.01 with a blob (sd 0.2 m, peak uniform in [0.55, 0.95]) per detection."""
    gx, gy = GRID.cell_centres()
    out = []
    for z in frames:
        b = np.full(GRID.shape, 0.01)
        for x, y in z:
            b = np.maximum(b, rng.uniform(0.55, 0.95) * np.exp(-((gx - x) ** 2 + (gy - y) ** 2) / (2 * 0.2**2)))
        out.append(b)
    return out


def time_inputs(grids: Sequence[NDArray[np.float64]], *, repeats: int) -> float:
    """Median over repeats of the mean seconds of :func:`pfpeople.track.tracker_inputs` per grid (people given)."""
    from gridbridge.classifiers import PeakClassifier
    from pfpeople.config import TrackingConfig
    from pfpeople.pipeline.assembly import PEAK_THRESHOLD
    from pfpeople.track import tracker_inputs

    pt = TrackingConfig().peaks_above
    high = PeakClassifier(threshold=PEAK_THRESHOLD)
    low = PeakClassifier(threshold=0.5 if pt is None else pt)
    people = [high.classify(b, GRID) for b in grids]
    out = []
    for _ in range(repeats):
        t0 = _clock()
        for b, pp in zip(grids, people, strict=True):
            tracker_inputs(pp, b, GRID, low=low, high=PEAK_THRESHOLD)
        out.append((_clock() - t0) / max(1, len(grids)))
    return float(np.median(out))


def time_updates(
    make: Callable[[], object],
    frames: Sequence[NDArray[np.float64]],
    *,
    warmup: int,
    repeats: int,
    support: Sequence[NDArray[np.float64]] | None = None,
) -> float:
    """Median over repeats of the mean seconds per update after ``warmup`` frames (fresh tracker each repeat);
    with ``support``, each update is given that frame's support positions."""
    ego = Pose2D(yaw=OMEGA * DT)
    kw: list[dict[str, NDArray[np.float64]]] = (
        [{} for _ in frames] if support is None else [{"support": s} for s in support]
    )
    out = []
    for _ in range(repeats):
        tracker = make()
        upd = tracker.update  # type: ignore[attr-defined]
        for z, k in zip(frames[:warmup], kw, strict=False):
            upd(z, DT, ego=ego, **k)
        t0 = _clock()
        for z, k in zip(frames[warmup:], kw[warmup:], strict=True):
            upd(z, DT, ego=ego, **k)
        out.append((_clock() - t0) / max(1, len(frames) - warmup))
    return float(np.median(out))


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m evaluation.bench.tracking", description=__doc__.split("\n\n")[0])
    ap.add_argument("--people", type=int, nargs="+", default=[5, 20, 50], help="people in view (default 5 20 50)")
    ap.add_argument("--frames", type=int, default=200, help="timed frames per repeat (default 200)")
    ap.add_argument("--repeats", type=int, default=5, help="repeats (median; default 5)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--cpu-time",
        action="store_true",
        help="time with the process's CPU time (time.process_time): on a shared, loaded machine wall-clock time "
        "counts the waits for a core",
    )
    args = ap.parse_args(argv)
    global _clock
    _clock = time.process_time if args.cpu_time else time.perf_counter
    warmup = 20
    what = "CPU time" if args.cpu_time else "wall-clock time"
    print(f"tracker {what}, {args.frames} frames x {args.repeats} repeats (median), dt = {DT} s, one core")
    print(
        f"{'people':>7}{'tracks':>8}{'tracker ms':>12}{'NN-loop ms':>12}{'ratio':>8}{'+legs ms':>10}{'inputs ms':>10}"
        f"{'total ms':>10}"
    )
    for n in args.people:
        if n < 1:
            raise SystemExit(f"--people must be positive, got {n}")
        frames, legs = crowd(n, args.frames + warmup, rng=np.random.default_rng(args.seed))
        t_mot = time_updates(MultiPersonTracker, frames, warmup=warmup, repeats=args.repeats)
        t_leg = time_updates(MultiPersonTracker, frames, warmup=warmup, repeats=args.repeats, support=legs)
        t_nn = time_updates(NearestNeighbour, frames, warmup=warmup, repeats=args.repeats)
        probe = MultiPersonTracker()
        ego = Pose2D(yaw=OMEGA * DT)
        for z in frames:
            probe.update(z, DT, ego=ego)
        grids = belief_grids(frames[warmup : warmup + 50], rng=np.random.default_rng(args.seed))
        t_pk = time_inputs(grids, repeats=args.repeats)
        print(
            f"{n:>7}{len(probe.confirmed()):>8}{1e3 * t_mot:>12.3f}{1e3 * t_nn:>12.3f}{t_mot / t_nn:>8.2f}"
            f"{1e3 * t_leg:>10.3f}{1e3 * t_pk:>10.3f}{1e3 * (t_leg + t_pk):>10.3f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
