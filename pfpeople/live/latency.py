"""Per-scan latency and dropped scans of a live run.

A scan's latency is the time from its arrival at the node's transport (the subscriber's callback) to the
publication of its frame's results (their messages handed to the transport), wall clock of one machine. Scans the
node cannot keep up with are dropped (a newer scan of the driving laser was already waiting) and counted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["LatencyStats"]


@dataclass
class LatencyStats:
    """What a live run measured.

    Attributes
    ----------
    latencies_ms : list of float
        Per published frame, its scan's latency (ms); the warm-up frames are left out (their wait is the
        set-up's, or at the end the input's, not the node's).
    frames : int
        Frames published.
    dropped : int
        Driving scans dropped because a newer one was waiting.
    warm_up_frames : int
        Frames of the scans that arrived before the run was set up, and those still waiting for later messages
        when the node stopped.
    """

    latencies_ms: list[float] = field(default_factory=list)
    frames: int = 0
    dropped: int = 0
    warm_up_frames: int = 0

    def record(self, latency_ns: int, *, warm_up: bool = False) -> None:
        """One published frame."""
        self.frames += 1
        if warm_up:
            self.warm_up_frames += 1
        else:
            self.latencies_ms.append(latency_ns * 1e-6)

    def percentile(self, q: float) -> float:
        """The ``q``-th percentile (0-100) of the latencies (ms; NaN: none yet)."""
        return float(np.percentile(self.latencies_ms, q)) if self.latencies_ms else float("nan")

    def as_dict(self) -> dict[str, Any]:
        """Counts, p50 / p90 / p99 / max latency (ms) and every frame's (``per_frame``, ms, in order)."""
        lat = self.latencies_ms
        return {
            "frames": self.frames,
            "dropped": self.dropped,
            "warm_up_frames": self.warm_up_frames,
            "latency_ms": {
                "n": len(lat),
                "p50": self.percentile(50),
                "p90": self.percentile(90),
                "p99": self.percentile(99),
                "max": max(lat) if lat else float("nan"),
                "per_frame": [round(v, 3) for v in lat],
            },
        }

    def summary(self) -> str:
        """One line for the log."""
        return (
            f"{self.frames} frames published, {self.dropped} scans dropped; latency per scan p50 "
            f"{self.percentile(50):.1f} ms, p99 {self.percentile(99):.1f} ms (n = {len(self.latencies_ms)})"
        )
