"""What the opt-in detectors add to a run: each scene run twice, as ``pfpeople inspect --write-config`` configures
it and as ``pfpeople inspect --write-config --opt-in`` does (the learned detector fused too), and the two runs'
reported people scored against the same ground truth.

Scenes: the scan-level scenes (simulated at a seed; their people with three or more returns on them, the "seen"
people, in the run's grid: :func:`evaluation.harness.detector_ap.run_frames`), ``positive_bags`` (leg_tracker's six
labelled bags, leave one bag out, pooled: :func:`positive_rows`) and ``negative_2:all`` (leg_tracker's bag with
nobody in it, its three lasers in one run: false people per scan; the shipped learned model was trained on it).

Usage::

    python -m evaluation.harness.opt_in --seed 0    # every scan-level scene, the labelled bags and negative_2
    python -m evaluation.harness.opt_in --scenes scan:lobby --seed 1  # one scene
    python -m evaluation.harness.opt_in --seed 3 --set tracking.confirm_evidence=off learned.params.threshold=0.4

``--set KEY=VALUE`` changes both configurations before they run (an ablation): a key of the run's TOML
(``tracking.confirm_evidence``, ``tracking.params.hit_gain``) or of every detector of one kind
(``learned.params.threshold``, ``learned.model.fnr``); VALUE is JSON, else a string.

A row's recall and precision count every person the run reported; AP0.5 ranks them by their belief.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from evaluation.harness.detector_ap import grid_box, rows_from_frames, run_frames
from pfpeople.detect.learned.samples import LabelledScan, Region, simulated_scans
from pfpeople.detect.precision_recall import ScoredFrame, pr_curve

__all__ = [
    "CONFIGS",
    "OptInRow",
    "apply_settings",
    "format_opt_in_rows",
    "negative_rows",
    "opt_in_rows",
    "positive_rows",
    "scan_rows",
]

#: The two configurations compared: the starter config and the starter config with its opt-in detectors active.
CONFIGS = ("starter", "starter --opt-in")
#: The scan-level scenes compared by default.
SCAN_SCENES = ("scan:lobby", "scan:wheelchair", "scan:hall", "scan:corridor", "scan:crowd")


@dataclass(frozen=True)
class OptInRow:
    """One run's reported people scored: ``recall`` / ``precision`` of every reported person (matched within 0.5 m;
    NaN without people), ``ap_05`` ranked by belief, ``recall_standing`` / ``recall_walking`` (below / above
    0.3 m/s), ``false_per_scan`` (reported people matched to nobody, per scan)."""

    scene: str
    config: str
    frames: int
    ap_05: float
    recall: float
    precision: float
    recall_standing: float
    recall_walking: float
    false_per_scan: float


def _config_texts(bag: Path) -> dict[str, str]:
    """Each configuration of :data:`CONFIGS` for ``bag`` (TOML), from one inspection of it."""
    from pfpeople.io.bag.inspect import inspect_path, starter_config

    report = inspect_path(bag)
    return {c: starter_config(report, opt_in=c != CONFIGS[0]) for c in CONFIGS}


def apply_settings(config: Any, settings: Sequence[str]) -> Any:
    """``config`` (a :class:`~pfpeople.config.BagConfig`) with each ``KEY=VALUE`` of ``settings`` set (module
    docstring); a detector key applies to every detector of that kind (none: nothing to set). Raises
    ``ValueError`` for a setting without ``=`` and :class:`~pfpeople.config.ConfigError` for a bad key or value."""
    from pfpeople.config import KINDS, config_from_mapping

    if not settings:
        return config
    data = config.to_dict()
    for setting in settings:
        key, eq, raw = setting.partition("=")
        if not eq or not key:
            raise ValueError(f"--set {setting!r}: expected KEY=VALUE")
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
            value = raw
        path = key.split(".")
        targets = [d for d in data["detectors"] if d["kind"] == path[0]] if path[0] in KINDS else [data]
        for target in targets:
            node = target
            for part in path[1 if path[0] in KINDS else 0 : -1]:
                node = node.setdefault(part, {})
            node[path[-1]] = value
    return config_from_mapping(data)


def _run(bag: Path, text: str, out: Path, frames: int | None = None, settings: Sequence[str] = ()) -> Path:
    """Run ``bag`` with the configuration ``text`` (written beside ``out``) and ``settings``
    (:func:`apply_settings`) into the run directory ``out``."""
    from pfpeople.config import load_config

    out.parent.mkdir(parents=True, exist_ok=True)
    cfg = out.with_suffix(".toml")
    cfg.write_text(text, encoding="utf-8")
    return _run_config(bag, apply_settings(load_config(cfg), settings) if settings else cfg, out, frames)


def _run_config(bag: Path, config: Any, out: Path, frames: int | None) -> Path:
    """Run ``bag`` with ``config`` (a :class:`~pfpeople.config.BagConfig` or its file) into ``out``."""
    from pfpeople.pipeline.bag_run import run_bag

    run_bag(bag, config, out_dir=out, overwrite=True, max_frames=frames)
    return out


def _row(scene: str, config: str, scored: Sequence[ScoredFrame], scans: Sequence[LabelledScan]) -> OptInRow:
    """A run's reported people ``scored`` against the people of ``scans`` (module docstring)."""
    ap = rows_from_frames(scene, config, scored, scans, threshold=-math.inf)
    curve = pr_curve(scored, 0.5)
    last = curve.recall.size > 0
    return OptInRow(
        scene=scene,
        config=config,
        frames=len(scans),
        ap_05=ap.ap_05,
        recall=float(curve.recall[-1]) if last else math.nan,
        precision=float(curve.precision[-1]) if last else math.nan,
        recall_standing=ap.recall_standing,
        recall_walking=ap.recall_walking,
        false_per_scan=ap.false_per_scan,
    )


def scan_rows(
    scene: str, work: Path, *, seed: int, frames: int | None = None, settings: Sequence[str] = ()
) -> list[OptInRow]:
    """The two rows (:data:`CONFIGS`) of a scan-level scene (``scan:NAME``) simulated at ``seed`` into ``work``
    (both configurations with ``settings``, :func:`apply_settings`)."""
    from evaluation.scenarios.scan import write_scene_bag

    name = scene.split(":", 1)[1]
    sb = write_scene_bag(name, work / f"{name}_{seed}", seed=seed, frames=frames, overwrite=True)
    texts, labelled = _config_texts(sb.bag), simulated_scans(sb.bag, sb.gt_csv)
    rows = []
    for config in CONFIGS:
        run = _run(sb.bag, texts[config], work / f"{name}_{seed}_{_slug(config)}", settings=settings)
        box = grid_box(run)
        scans = [dataclasses.replace(s, region=Region(box=box)) for s in labelled]
        rows.append(_row(scene, config, run_frames(run, scans), scans))
    return rows


def negative_rows(bag: Path, work: Path, settings: Sequence[str] = ()) -> list[OptInRow]:
    """``negative_2:all`` (nobody there) run with each configuration of :data:`CONFIGS` (and ``settings``): false
    people per scan."""
    rows = []
    for config, text in _config_texts(bag).items():
        run = _run(bag, text, work / f"negative_2_{_slug(config)}", settings=settings)
        with (run / "people.csv").open(newline="", encoding="utf-8") as fh:
            people = sum(1 for _ in csv.DictReader(fh))
        with (run / "frames.csv").open(newline="", encoding="utf-8") as fh:
            frames = sum(1 for _ in csv.DictReader(fh))
        nan = math.nan
        rows.append(OptInRow("negative_2:all", config, frames, nan, nan, nan, nan, nan, people / max(frames, 1)))
    return rows


def positive_rows(leg: Path, work: Path, *, frames: int | None = None, settings: Sequence[str] = ()) -> list[OptInRow]:
    """The two rows of leg_tracker's labelled bags (``positive_bags``), leave one bag out and pooled, as the
    benchmark scores them: each bag run with the boosted model trained without it
    (:func:`evaluation.harness.benchmark.boosted_model_without`) and, opted in, the learned detector's fold model
    that did not see it (:func:`evaluation.harness.benchmark_ap.fold_model_path`); scored in the labelling box.
    ``settings``: :func:`apply_settings`, before the held-out models are put in."""
    from evaluation.harness.benchmark import POSITIVE_BAGS, boosted_model_without
    from evaluation.harness.benchmark_ap import fold_model_path
    from pfpeople.config import load_config
    from pfpeople.detect.learned.samples import positive_bag_scans

    present = [k for k in POSITIVE_BAGS if (leg / f"positive_{k}_extracted.bag").is_file()]
    if not present:
        raise FileNotFoundError(f"scene positive_bags: no positive_<k>_extracted.bag in {leg}")
    frames_by: dict[str, list[ScoredFrame]] = {c: [] for c in CONFIGS}
    scans_by: dict[str, list[LabelledScan]] = {c: [] for c in CONFIGS}
    for k in present:
        bag, held = leg / f"positive_{k}_extracted.bag", f"positive_{k}"
        boosted = boosted_model_without(leg, work, k, present)
        held_out = {"boosted": boosted, "single-legs": boosted, "learned": fold_model_path(held)}
        scans = positive_bag_scans(bag, source=held)[:frames]
        for config, text in _config_texts(bag).items():
            cfg = work / f"{held}_{_slug(config)}.toml"
            cfg.write_text(text, encoding="utf-8")
            loaded = apply_settings(load_config(cfg), settings)
            dets = tuple(
                dataclasses.replace(d, params={**dict(d.params), "model_path": str(held_out[d.kind])})
                if d.kind in held_out
                else d
                for d in loaded.detectors
            )
            run = _run_config(bag, dataclasses.replace(loaded, detectors=dets), cfg.with_suffix(""), frames)
            frames_by[config] += run_frames(run, scans)
            scans_by[config] += scans
    return [_row("positive_bags (all)", c, frames_by[c], scans_by[c]) for c in CONFIGS]


def opt_in_rows(
    scenes: Sequence[str],
    work: Path,
    *,
    seed: int,
    data: Path,
    frames: int | None = None,
    settings: Sequence[str] = (),
) -> list[OptInRow]:
    """The rows of every scene (``scan:NAME`` or ``negative_2``; ``data`` holds ``leg_tracker/negative_2.bag``),
    each configuration with ``settings`` (:func:`apply_settings`)."""
    rows: list[OptInRow] = []
    for scene in scenes:
        if scene.startswith("scan:"):
            rows += scan_rows(scene, work, seed=seed, frames=frames, settings=settings)
        elif scene == "positive_bags":
            rows += positive_rows(data / "leg_tracker", work, frames=frames, settings=settings)
        elif scene == "negative_2":
            bag = data / "leg_tracker" / "negative_2.bag"
            if not bag.is_file():
                raise FileNotFoundError(f"scene negative_2: {bag} is absent (--data names the folder of leg_tracker/)")
            rows += negative_rows(bag, work, settings)
        else:
            raise ValueError(f"scene {scene!r}: not a scan-level scene (scan:NAME), positive_bags nor negative_2")
    return rows


def _slug(config: str) -> str:
    return "opt_in" if config != CONFIGS[0] else "starter"


def _f(v: float) -> str:
    return "-" if math.isnan(v) else f"{v:.3f}"


def format_opt_in_rows(rows: Sequence[OptInRow]) -> str:
    """The table: scene, configuration, frames, AP0.5, recall, precision, standing / walking recall, FP/scan."""
    head = (
        f"{'scene':<21}{'config':<19}{'frames':>7}{'AP0.5':>7}{'recall':>8}{'prec.':>7}"
        f"{'stand':>7}{'walk':>7}{'FP/scan':>8}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r.scene:<21}{r.config:<19}{r.frames:>7}{_f(r.ap_05):>7}{_f(r.recall):>8}{_f(r.precision):>7}"
            f"{_f(r.recall_standing):>7}{_f(r.recall_walking):>7}{_f(r.false_per_scan):>8}"
        )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m evaluation.harness.opt_in", description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--scenes",
        nargs="+",
        default=[*SCAN_SCENES, "positive_bags", "negative_2"],
        help="scan:NAME, positive_bags or negative_2",
    )
    p.add_argument("--seed", type=int, default=0, help="simulation seed of the scan-level scenes")
    p.add_argument("--frames", type=int, default=None, help="simulate only this many frames")
    p.add_argument("--data", type=Path, default=Path("../shared/data"), help="folder of leg_tracker/")
    p.add_argument("--work", type=Path, default=Path("/tmp/pfpeople-opt-in"), help="bags and runs go here")
    p.add_argument(
        "--set",
        nargs="+",
        default=[],
        metavar="KEY=VALUE",
        help="change both configurations (tracking.confirm_evidence=off, learned.params.threshold=0.4)",
    )
    args = p.parse_args(argv)
    rows = opt_in_rows(args.scenes, args.work, seed=args.seed, data=args.data, frames=args.frames, settings=args.set)
    print(format_opt_in_rows(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
