"""The learned and the motion detector in a bag run: configured by kind, given the ego-motion, the same run in one
and two processes; a starter configuration offers the learned detector (commented out) only where the laser suits it."""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import config, write_bag

from gridbridge.geometry import Pose2D
from pfpeople.cli import main
from pfpeople.config import DetectorConfig, load_config
from pfpeople.detect.adapters import LearnedAdapter, MotionAdapter, SensorMotion
from pfpeople.io.bag.inspect import LASER_DETECTORS, LaserInfo, inspect_path, laser_suits, starter_config
from pfpeople.io.bag.reader import BagSource
from pfpeople.pipeline.runner import Pipeline


def _detections(run: Path) -> dict[str, int]:
    out: dict[str, int] = {}
    with (run / "detections.csv").open(newline="") as fh:
        for row in csv.DictReader(fh):
            out[row["detector"]] = out.get(row["detector"], 0) + 1
    return out


def _cfg() -> object:
    dets = (
        DetectorConfig(name="laser_learned", kind="learned", topic="/scan"),
        DetectorConfig(name="laser_motion", kind="motion", topic="/scan"),
    )
    base = config()
    return replace(base, detectors=(*base.detectors, *dets))


def test_a_run_with_the_learned_and_motion_detectors(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=30)
    outs = []
    for two in (False, True):
        out = tmp_path / f"run{int(two)}"
        with BagSource(bag) as src:
            Pipeline(_cfg(), front_process=two).run(src, out)
        outs.append(out)
    counts = _detections(outs[0])
    assert counts.get("laser_learned", 0) > 0  # the synthetic people are found by the shipped model
    for name in ("detections.csv", "people.csv", "tracks.csv"):
        assert (outs[0] / name).read_bytes() == (outs[1] / name).read_bytes()
    np.testing.assert_array_equal(np.load(outs[0] / "grids.npy"), np.load(outs[1] / "grids.npy"))


class _Spy:
    """A detector with a memory: records what it is told."""

    def __init__(self) -> None:
        from gridbridge.params import DetectorModel

        self.model = DetectorModel(name="spy", ppv=0.5, fnr=0.5)
        self.told: list[Pose2D | None] = []

    def observe_motion(self, motion: Pose2D | None) -> None:
        self.told.append(motion)

    def detect(self, scan: object) -> np.ndarray:
        return np.zeros((0, 2))


def test_temporal_adapters_pass_the_motion_and_forget_on_restarts(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=3)
    spy = _Spy()
    adapter = MotionAdapter(DetectorConfig(name="m", kind="motion", topic="/scan"), Pose2D(), spy)  # type: ignore[arg-type]
    assert adapter.uses_ego_motion and LearnedAdapter.uses_ego_motion
    with BagSource(bag) as src:
        msgs = [m for m in src.messages(["/scan"])][:3]
    adapter.detect([msgs[0]], motion=SensorMotion(ego=Pose2D(x=0.1), dt=0.1, stamp_ns=0, restarted=True))
    adapter.detect([msgs[1]], motion=SensorMotion(ego=Pose2D(x=0.1), dt=0.1, stamp_ns=1))
    adapter.detect([msgs[2]], motion=SensorMotion(ego=None, dt=0.1, stamp_ns=2))
    assert spy.told == [None, Pose2D(x=0.1), None]


def _laser(res_deg: float) -> LaserInfo:
    n = round(270 / res_deg) + 1
    return LaserInfo(
        topic="/scan",
        frame_id="laser",
        beams=n,
        angle_min_deg=-135.0,
        angle_max_deg=135.0,
        angle_increment_deg=res_deg,
        increment_sign=1,
        fov_min_rad=-2.356,
        fov_max_rad=2.356,
        range_min_m=0.05,
        range_max_m=20.0,
        varies=False,
    )


@pytest.mark.parametrize(("res", "suits"), [(0.35, True), (0.25, True), (2.0, False)])
def test_the_learned_detector_goes_where_the_laser_suits_it(res: float, suits: bool) -> None:
    why = laser_suits("learned", _laser(res))
    assert (why == "") == suits
    if not suits:
        assert "trained on" in why and "train-detector --kind learned" in why
    assert laser_suits("leg", _laser(res)) == ""


def _uncommented(text: str) -> str:
    """A starter configuration with its opt-in ``[[detectors]]`` blocks uncommented (what a user does)."""
    out, in_block = [], False
    for line in text.splitlines():
        if line.startswith("# [[detectors]]"):
            in_block = True
        elif not line.startswith("# "):
            in_block = False
        out.append(line[2:] if in_block else line)
    return "\n".join(out) + "\n"


def test_the_starter_config_offers_the_learned_detector_commented_out(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=3)
    text = starter_config(inspect_path(bag))
    default = tmp_path / "default.toml"
    default.write_text(text)
    assert [d.kind for d in load_config(default).detectors] == [k for _, k, _ in LASER_DETECTORS]
    assert "# Opt-in, uncomment to fuse it: the learned whole-scan detector" in text
    chosen = tmp_path / "chosen.toml"
    chosen.write_text(_uncommented(text))
    got = load_config(chosen).detectors
    assert [(d.name, d.kind, d.topic) for d in got][-1] == ("laser_learned", "learned", "/scan")
    assert got[-1].model == got[0].model  # the laser's field of view and range, like the others'
    active = tmp_path / "active.toml"  # pfpeople inspect --write-config --opt-in
    assert main(["inspect", str(bag), "--write-config", str(active), "--opt-in"]) == 0
    assert load_config(active).detectors == got
    assert "# Opt-in (written by --opt-in): the learned whole-scan detector" in active.read_text()


def test_learned_detections_carry_the_ppv_of_their_score_unless_a_ppv_is_configured(tmp_path: Path) -> None:
    from pfpeople.config.detectors import DetectorModelConfig

    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=12)
    with BagSource(bag) as src:
        msgs = [m for m in src.messages(["/scan"])]
    motion = SensorMotion(ego=None, dt=0.1, stamp_ns=0, restarted=True)
    by_score = LearnedAdapter(DetectorConfig(name="l", kind="learned", topic="/scan"), Pose2D(x=0.2))
    fixed = LearnedAdapter(
        DetectorConfig(name="l", kind="learned", topic="/scan", model=DetectorModelConfig(ppv=0.8)), Pose2D(x=0.2)
    )
    off = LearnedAdapter(
        DetectorConfig(name="l", kind="learned", topic="/scan", params={"score_ppv": False}), Pose2D(x=0.2)
    )
    curve = by_score.detector.score_ppv  # type: ignore[union-attr]
    seen = 0
    for m in msgs:
        got = by_score.detect([m], motion=motion)
        _, scores = by_score.detector.detect_scored(by_score.detector_input(got.scan))  # type: ignore[union-attr]
        keep = scores >= by_score.detector.threshold  # type: ignore[union-attr]
        assert got.ppv is not None and curve is not None
        np.testing.assert_array_equal(got.ppv, curve(scores[keep]))
        np.testing.assert_array_equal(got.fused, np.column_stack([got.grid, got.ppv]))
        for plain in (fixed.detect([m], motion=motion), off.detect([m], motion=motion)):
            assert plain.ppv is None and plain.fused is plain.grid
            np.testing.assert_array_equal(plain.grid, got.grid)
        seen += len(got.grid)
    assert seen > 0
    assert fixed.model.ppv == 0.8
