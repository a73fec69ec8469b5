"""The motion detector's PPV and FNR, measured as the built-in laser detectors' are
(:func:`pfpeople.detect.learned.scoring.calibration`) on data the benchmark does not score:

* the scan-level scenes simulated at a held-out seed (default 3; the benchmark reports seeds 0-2), with their
  odometry;
* ``negative_2``'s three lasers (nobody there: every detection is false), their ego-motion by scan matching as a
  run's;
* person_following_outdoor_1's followed person (its miss rate is one more scene's; no odometry: scan matching).

PPV is the pooled true over all detections; FNR the mean of the scenes' miss rates. People with fewer than three
returns on them are ignored. Usage::

    python -m evaluation.harness.motion_calibration --seed 3 --data ../shared/data

The figures go into :data:`pfpeople.detect.motion.CALIBRATED_MOTION`.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from evaluation.harness.opt_in import SCAN_SCENES
from pfpeople.detect import MotionDetector
from pfpeople.detect.learned.recipe import NEGATIVE_TOPICS, followed_person_scans
from pfpeople.detect.learned.samples import LabelledScan, negative_scans, simulated_scans, with_scan_matched_motion
from pfpeople.detect.learned.scoring import calibration, counts_at, scored_frames
from pfpeople.detect.precision_recall import ScoredFrame

__all__ = ["MotionCalibration", "calibrate_motion", "format_calibration"]


@dataclass(frozen=True)
class MotionCalibration:
    """PPV and FNR (module docstring), with each scene's recall and precision and each negative laser's false
    detections per scan."""

    ppv: float
    fnr: float
    scenes: dict[str, tuple[float, float]]
    negatives: dict[str, float]


def _scene_scans(scene: str, work: Path, seed: int, frames: int | None) -> list[LabelledScan]:
    from evaluation.scenarios.scan import write_scene_bag

    name = scene.split(":", 1)[1]
    sb = write_scene_bag(name, work / f"{name}_{seed}", seed=seed, frames=frames, overwrite=True)
    return simulated_scans(sb.bag, sb.gt_csv, source=scene)


def _recall_precision(frames: Sequence[ScoredFrame]) -> tuple[float, float]:
    c = counts_at(frames, 0.0)
    found = c.tp + c.fp
    return (c.tp / c.positives if c.positives else float("nan"), c.tp / found if found else float("nan"))


def calibrate_motion(
    data: Path,
    work: Path,
    *,
    seed: int = 3,
    scenes: Sequence[str] = SCAN_SCENES,
    frames: int | None = None,
    followed: bool = True,
) -> MotionCalibration:
    """Measure the motion detector (module docstring); ``data`` holds ``leg_tracker/``, ``work`` takes the
    simulated bags; ``followed``: with person_following_outdoor_1's followed person (when in ``data``).

    Raises
    ------
    FileNotFoundError
        If ``leg_tracker/negative_2.bag`` is not in ``data`` (named).
    """
    leg = Path(data) / "leg_tracker"
    if not (leg / "negative_2.bag").is_file():
        raise FileNotFoundError(f"motion calibration needs {leg / 'negative_2.bag'} (--data names its folder)")
    scored: dict[str, list[ScoredFrame]] = {
        s: scored_frames(MotionDetector(), _scene_scans(s, Path(work), seed, frames)) for s in scenes
    }
    person = followed_person_scans(leg) if followed else []
    if person:
        scored["person_following_outdoor_1"] = scored_frames(MotionDetector(), person)
    negatives = {
        t: scored_frames(MotionDetector(), with_scan_matched_motion(negative_scans(leg / "negative_2.bag", [t])))
        for t in NEGATIVE_TOPICS
    }
    pooled_negatives = [f for frames_ in negatives.values() for f in frames_]
    ppv, fnr = calibration(list(scored.values()), pooled_negatives, 0.0)
    return MotionCalibration(
        ppv=ppv,
        fnr=fnr,
        scenes={s: _recall_precision(f) for s, f in scored.items()},
        negatives={t: counts_at(f, 0.0).fp / max(len(f), 1) for t, f in negatives.items()},
    )


def format_calibration(cal: MotionCalibration) -> str:
    """The figures as lines: each scene's recall / precision, each negative laser's false detections per scan, PPV
    and FNR."""
    lines = [f"{s:<28} recall {r:.3f} precision {p:.3f}" for s, (r, p) in cal.scenes.items()]
    lines += [f"negative_2 {t:<17} false detections per scan {v:.3f}" for t, v in cal.negatives.items()]
    return "\n".join([*lines, f"PPV {cal.ppv:.3f}  FNR {cal.fnr:.3f}"])


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m evaluation.harness.motion_calibration", description=__doc__.split("\n\n")[0]
    )
    p.add_argument("--seed", type=int, default=3, help="simulation seed of the scenes (not 0-2: the benchmark's)")
    p.add_argument("--data", type=Path, default=Path("../shared/data"), help="folder of leg_tracker/")
    p.add_argument("--work", type=Path, default=Path("/tmp/pfpeople-motion-calibration"), help="simulated bags")
    p.add_argument("--frames", type=int, default=None, help="simulate only this many frames per scene")
    args = p.parse_args(argv)
    print(format_calibration(calibrate_motion(args.data, args.work, seed=args.seed, frames=args.frames)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
