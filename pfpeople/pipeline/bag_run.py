"""A bag run from Python: :func:`run_bag` returns a :class:`Run` with every frame's people, tracks and grid.

::

    import pfpeople

    run = pfpeople.run_bag("my.bag", "my.toml")  # a TOML file, a built-in config's name, a BagConfig, or None
    print(run.summary.frames, run.summary.fps)
    for frame in run.frames:  # one per driver message that made a frame
        frame.stamp_ns, frame.people, frame.tracks  # (P, 2) m and Track snapshots, grid frame
    run.grids  # (N, nx, ny) float32 belief, run.spec places its cells

With ``out_dir`` (and ``bag_out``) the run writes its run directory (and result bag) as ``pfpeople run`` does;
:func:`pfpeople.io.run_dir.load_run` reads a run directory back (people, tracks, grids, detections). Without a
config the bag is inspected and configured as ``pfpeople inspect --write-config`` configures it.
"""

from __future__ import annotations

import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge.grid import GridSpec
from pfpeople.config import BagConfig, builtin_config_path, config_from_mapping, load_config
from pfpeople.pipeline.sinks import RunInfo, RunOutcome
from pfpeople.run_state import FrameResult, RunSummary
from pfpeople.track.multi_person import Track

__all__ = ["Run", "RunFrame", "resolve_config", "run_bag"]


@dataclass(frozen=True, eq=False)
class RunFrame:
    """One frame of a :class:`Run` (grid frame, m).

    Attributes
    ----------
    index : int
        The frame's number in the run (0, 1, ...).
    stamp_ns : int
        The frame's stamp (ns; the driver message's).
    people : ndarray, shape (P, 2)
        The people the run reports.
    people_probability : list of float
        Their belief.
    tracks : list of Track
        The confirmed tracks (ids, positions, velocities, covariance; empty with tracking off).
    detections : list of ndarray (M_k, 2) or None
        Per detector, its detections (None: no data in the frame).
    """

    index: int
    stamp_ns: int
    people: NDArray[np.float64]
    people_probability: list[float]
    tracks: list[Track]
    detections: list[NDArray[np.float64] | None]


@dataclass(frozen=True, eq=False)
class Run:
    """What :func:`run_bag` returns.

    Attributes
    ----------
    config : BagConfig
        The configuration the run used.
    summary : RunSummary
        The run's counts (``frames``, ``fps``, ``no_data``, ... as ``run.json`` ``stats``).
    spec : GridSpec
        The grid of every belief.
    grid_frame : str
        The frame of the grid and of every position.
    detector_names : tuple of str
        The detectors, in the order of :attr:`RunFrame.detections`.
    frames : list of RunFrame
        Every frame.
    grids : ndarray, shape (N, nx, ny)
        The belief of every frame (float32, as ``grids.npy``).
    out_dir : Path or None
        The run directory written (None: none).
    results : list of FrameResult
        With ``keep_results=True``, every frame's whole result (the filter's step included); else empty.
    """

    config: BagConfig
    summary: RunSummary
    spec: GridSpec
    grid_frame: str
    detector_names: tuple[str, ...]
    frames: list[RunFrame]
    grids: NDArray[np.float32]
    out_dir: Path | None = None
    results: list[FrameResult] = field(default_factory=list)

    @property
    def stamps_ns(self) -> NDArray[np.int64]:
        """``(N,)`` the frames' stamps (ns)."""
        return np.array([f.stamp_ns for f in self.frames], dtype=np.int64)


class _Collect:
    """The sink that keeps what a :class:`Run` holds."""

    def __init__(self, keep_results: bool) -> None:
        self.keep_results = keep_results
        self.frames: list[RunFrame] = []
        self.grids: list[NDArray[np.float32]] = []
        self.results: list[FrameResult] = []

    def open(self, run: RunInfo) -> None:
        """Nothing to open."""

    def write(self, r: FrameResult) -> None:
        self.frames.append(
            RunFrame(
                index=r.frame.index,
                stamp_ns=r.frame.stamp_ns,
                people=np.array(r.people, dtype=float).reshape(-1, 2),
                people_probability=list(r.people_probability),
                tracks=list(r.tracks or []),
                detections=[None if d is None else np.array(d, dtype=float) for d in r.detections],
            )
        )
        self.grids.append(np.asarray(r.belief, dtype=np.float32).copy())
        if self.keep_results:
            self.results.append(r)

    def close(self, outcome: RunOutcome) -> None:
        """Nothing to close."""

    def run(self, config: BagConfig, summary: RunSummary, spec: GridSpec, grid_frame: str, out: Path | None) -> Run:
        """The :class:`Run` of what was kept."""
        grids = np.stack(self.grids) if self.grids else np.zeros((0, *spec.shape), dtype=np.float32)
        return Run(
            config=config,
            summary=summary,
            spec=spec,
            grid_frame=grid_frame,
            detector_names=tuple(d.name for d in config.detectors),
            frames=self.frames,
            grids=grids,
            out_dir=out,
            results=self.results,
        )


def resolve_config(config: BagConfig | str | Path | None, bag: str | Path | Sequence[str | Path]) -> BagConfig:
    """The run configuration: ``config`` itself, a TOML file, a built-in config's name (:mod:`pfpeople.configs`),
    or (None) the starter configuration ``pfpeople inspect --write-config`` writes for ``bag``.

    Raises
    ------
    FileNotFoundError
        If ``config`` names neither a file nor a built-in configuration.
    ValueError
        For a configuration that is not valid (naming the file and the setting).
    """
    if isinstance(config, BagConfig):
        return config
    if config is None:
        from pfpeople.io.bag.inspect import inspect_path, starter_config

        return config_from_mapping(tomllib.loads(starter_config(inspect_path(bag))))
    path = Path(config)
    return load_config(path if path.suffix == ".toml" or path.exists() else builtin_config_path(str(config)))


def run_bag(
    bag: str | Path | Sequence[str | Path],
    config: BagConfig | str | Path | None = None,
    *,
    out_dir: str | Path | None = None,
    bag_out: str | Path | None = None,
    max_frames: int | None = None,
    overwrite: bool = False,
    keep_results: bool = False,
    front_process: bool | None = None,
    **pipeline_options: Any,
) -> Run:
    """Run pfpeople over a bag (see the module docstring).

    Parameters
    ----------
    bag : path or sequence of paths
        A ROS 1 ``.bag``, a ROS 2 bag folder or a ``.zip`` of either (:class:`pfpeople.io.bag.reader.BagSource`).
    config : BagConfig, path, str or None
        See :func:`resolve_config`.
    out_dir, bag_out : path, optional
        Also write a run directory / a result bag (as ``pfpeople run --out / --bag-out``).
    max_frames : int, optional
        Stop after this many frames.
    overwrite : bool
        Replace an existing run directory or result bag.
    keep_results : bool
        Keep every frame's whole :class:`~pfpeople.run_state.FrameResult` in :attr:`Run.results` (memory grows
        with the bag).
    front_process : bool or None
        See :class:`pfpeople.pipeline.runner.Pipeline`.
    **pipeline_options
        More :class:`~pfpeople.pipeline.runner.Pipeline` arguments (``detectors``, ``adapters``, ``sinks``, ...).

    Returns
    -------
    Run

    Raises
    ------
    FileNotFoundError, ValueError, BagReadError
        For a missing bag or config, a bad setting, a bag that cannot be read (naming it); a run that fails
        part-way keeps what it finished in ``out_dir``.
    """
    from pfpeople.pipeline.runner import Pipeline

    cfg = resolve_config(config, bag)
    collect = _Collect(keep_results)
    sinks = [*pipeline_options.pop("sinks", ()), collect]
    pipe = Pipeline(cfg, front_process=front_process, sinks=sinks, **pipeline_options)
    summary, _ = pipe.run(bag, out_dir, max_frames=max_frames, overwrite=overwrite, bag_out=bag_out)
    return collect.run(cfg, summary, pipe.spec, pipe.grid_frame, None if out_dir is None else Path(out_dir))
