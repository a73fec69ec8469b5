"""The pipeline's replaceable parts: extra sinks, sink factory, adapter registry, odometry integrator, sensor
setup; a bug in a detector ends the run while bad data only makes 'no data'.

One small synthetic bag (5 identical scans of two people at 10 Hz, ``test_reliability_bags.write_scan_bag``)
and a leg detector on ``/scan``; the grid frame is the laser's, so every mount is the identity.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_fixtures import PEOPLE, legs_only, write_bag, write_scan_bag

from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.detect.adapters import LegAdapter
from pfpeople.io.bag.reader import BagSource, MessageDataError
from pfpeople.io.run_dir import load_run
from pfpeople.perception.odometry import OdometryIntegrator
from pfpeople.pipeline.runner import FrameResult, Pipeline, RunSummary, build_detector, make_filter, odometry_between
from pfpeople.pipeline.sensor_setup import SensorSetup, setup_sensors
from pfpeople.pipeline.sinks import RunInfo, RunOutcome
from pfpeople.run_state import FrameResult as StateFrameResult

N_SCANS = 5
FIXED = np.array([[1.5, 0.25], [4.0, -2.0]])


@pytest.fixture(scope="module")
def scan_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("parts") / "scans.bag"
    write_scan_bag(path, N_SCANS)
    return path


class RecordingSink:
    """Remembers what the pipeline gives it."""

    def __init__(self, fail_at: int | None = None) -> None:
        self.fail_at = fail_at
        self.opened: list[RunInfo] = []
        self.frames: list[FrameResult] = []
        self.closed: list[RunOutcome] = []

    def open(self, run: RunInfo) -> None:
        self.opened.append(run)

    def write(self, result: FrameResult) -> None:
        if self.fail_at is not None and len(self.frames) == self.fail_at:
            raise OSError("disk full")
        self.frames.append(result)

    def close(self, outcome: RunOutcome) -> None:
        self.closed.append(outcome)


class FixedDetector:
    """Returns FIXED (m, laser frame) for every scan."""

    def __init__(self) -> None:
        self.model = DetectorModel(name="legs", ppv=0.9, fnr=0.2)
        self.calls = 0

    def detect(self, data: Any, /) -> np.ndarray:
        self.calls += 1
        return FIXED.copy()


class BuggyDetector(FixedDetector):
    def __init__(self, exc: Exception) -> None:
        super().__init__()
        self.exc = exc

    def detect(self, data: Any, /) -> np.ndarray:
        self.calls += 1
        raise self.exc


def test_public_names_still_come_from_pfpeople_pipeline() -> None:
    assert FrameResult is StateFrameResult and RunSummary().frames == 0
    assert callable(build_detector) and callable(make_filter) and callable(odometry_between)


def test_a_custom_sink_receives_every_frame_next_to_the_run_directory(scan_bag: Path, tmp_path: Path) -> None:
    sink = RecordingSink()
    with BagSource(scan_bag) as src:
        summary, kept = Pipeline(legs_only(), sinks=[sink]).run(src, tmp_path / "run", keep=True, metadata={"k": 1})
    assert len(sink.opened) == 1 and len(sink.closed) == 1
    info = sink.opened[0]
    assert (info.grid_frame, info.detector_names, info.metadata, info.max_frames) == (
        "laser",
        ("legs",),
        {"k": 1},
        None,
    )
    assert [r.frame.index for r in sink.frames] == list(range(N_SCANS)) and sink.frames == kept
    assert sink.closed[0].status == "complete" and sink.closed[0].error is None
    assert sink.closed[0].summary is summary and summary.frames == N_SCANS
    run = load_run(tmp_path / "run")
    assert run.n_frames == N_SCANS and run.meta["provenance"]["k"] == 1
    for r in sink.frames:  # the leg detector finds both people in every scan
        (legs,) = r.detections
        assert legs is not None and len(legs) == 2
        assert np.min(np.linalg.norm(legs[:, None] - PEOPLE[None], axis=-1), axis=0).max() < 0.1


def test_a_failing_sink_fails_the_run_and_every_open_sink_records_it(scan_bag: Path, tmp_path: Path) -> None:
    good, bad = RecordingSink(), RecordingSink(fail_at=2)
    with BagSource(scan_bag) as src, pytest.raises(OSError, match="disk full"):
        Pipeline(legs_only(), sinks=[good, bad]).run(src, tmp_path / "run")
    run = load_run(tmp_path / "run")
    # Frame 2 reached the run directory and `good` before `bad` failed on it.
    assert run.meta["status"] == "failed" and run.meta["error"] == "OSError: disk full" and run.n_frames == 3
    assert len(good.frames) == 3 and len(bad.frames) == 2
    assert [o.status for o in good.closed + bad.closed] == ["failed", "failed"]


def test_a_replaced_sink_factory_decides_the_outputs(scan_bag: Path, tmp_path: Path) -> None:
    sink = RecordingSink()
    calls: list[dict[str, Any]] = []

    def factory(out_dir: Any, **kwargs: Any) -> list[Any]:
        calls.append({"out_dir": out_dir, **kwargs})
        return [sink]

    with BagSource(scan_bag) as src:
        Pipeline(legs_only(), sink_factory=factory).run(src, tmp_path / "run", max_frames=2, progress=True)
    assert calls == [
        {
            "out_dir": tmp_path / "run",
            "bag_out": None,
            "bag_format": None,
            "overwrite": False,
            "progress": True,
            "with_input": True,
        }
    ]
    assert not (tmp_path / "run").exists() and len(sink.frames) == 2 and sink.opened[0].max_frames == 2


def test_a_replaced_adapter_registry_entry_is_used(scan_bag: Path) -> None:
    made: list[FixedDetector] = []

    class FixedLegAdapter(LegAdapter):
        def __init__(self, config: Any, mount: Any, detector: Any = None) -> None:
            made.append(FixedDetector())
            super().__init__(config, mount, made[-1])

    with BagSource(scan_bag) as src:
        pipe = Pipeline(legs_only(), adapters={"leg": FixedLegAdapter})
        _, results = pipe.run(src, None, keep=True)
    assert isinstance(pipe.adapters[0], FixedLegAdapter) and len(made) == 1 and made[0].calls == N_SCANS
    for r in results:  # identity mount: the grid-frame detections are the detector's own positions
        assert np.array_equal(r.detections[0], FIXED)
    assert pipe.models[0].name == "legs" and pipe.models[0].ppv == 0.9


@pytest.mark.parametrize("exc", [ZeroDivisionError("float division by zero"), ValueError("bad index in my code")])
def test_a_bug_in_a_detector_ends_the_run_instead_of_becoming_no_data(
    scan_bag: Path, tmp_path: Path, exc: Exception
) -> None:
    det = BuggyDetector(exc)
    pipe = Pipeline(legs_only(), detectors={"legs": det})
    with BagSource(scan_bag) as src, pytest.raises(type(exc), match=str(exc)):
        pipe.run(src, tmp_path / "run")
    assert det.calls == 1 and pipe.summary.no_data == {} and pipe.summary.bad_messages == {}
    run = load_run(tmp_path / "run")
    assert run.meta["status"] == "failed" and run.meta["error"] == f"{type(exc).__name__}: {exc}"


def test_bad_scans_are_no_data_and_the_detector_is_not_called_on_them(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    def hook(k: int, stamp: int, ranges: np.ndarray) -> tuple[int, np.ndarray]:
        return stamp, (np.full_like(ranges, np.nan) if k in (1, 3) else ranges)

    bag = tmp_path / "nan.bag"
    write_bag(bag, n_scans=5, scan_hook=hook, odometry=False)
    det = FixedDetector()
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, results = Pipeline(legs_only(), detectors={"legs": det}).run(src, None, keep=True)
    assert det.calls == 3 and summary.no_data == {"legs": 2} and summary.bad_messages == {"legs": 2}
    assert [r.detections[0] is None for r in results] == [False, True, False, True, False]
    assert caplog.text.count("detector legs: unusable input") == 1  # warned once, counted every time
    assert issubclass(MessageDataError, ValueError)


def test_replaced_odometry_integrator_and_sensor_setup_are_used(scan_bag: Path) -> None:
    begun: list[int] = []

    class CountingIntegrator(OdometryIntegrator):
        def begin(self, frame: Any) -> Any:
            begun.append(frame.index)
            return super().begin(frame)

    spec = GridSpec(nx=10, ny=12, resolution=0.5, x0=0.0, y0=-3.0)

    def setup(config: Any, bag: Any, **kwargs: Any) -> SensorSetup:
        return replace(setup_sensors(config, bag, **kwargs), spec=spec)

    pipe = Pipeline(
        legs_only(),
        sensor_setup=setup,
        odometry_factory=lambda c, base, summary, warn: CountingIntegrator(None, summary=summary, warn=warn),
    )
    with BagSource(scan_bag) as src:
        _, results = pipe.run(src, None, keep=True)
    assert begun == list(range(N_SCANS)) and pipe.spec is spec
    assert all(r.belief.shape == (10, 12) for r in results)
