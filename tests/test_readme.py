"""The README's example code runs and its commands name real subcommands."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import numpy as np
import pytest

from evaluation.cli import main as eval_main
from pfpeople.cli import main as pf_main

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()
#: Every ```python block of the README, in order.
BLOCKS = re.findall(r"```python\n(.*?)```", README, re.S)


def _run(block: str) -> tuple[dict[str, object], str]:
    """Execute one README block in a fresh namespace; its namespace and what it printed."""
    namespace: dict[str, object] = {"__name__": "__readme__"}
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(block, "README.md", "exec"), namespace)
    return namespace, printed.getvalue()


def _block(marker: str) -> str:
    (block,) = [b for b in BLOCKS if marker in b]
    return block


def test_readme_has_the_library_examples() -> None:
    assert len(BLOCKS) >= 3
    for marker in ("ParticleFilter(", "pfpeople.recommended(", "MultiPersonTracker("):
        _block(marker)


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_every_python_block_runs_and_prints(index: int) -> None:
    _, printed = _run(BLOCKS[index])
    assert printed.strip(), f"README python block {index + 1} prints nothing"


def test_paper_filters_example() -> None:
    namespace, printed = _run(_block("ParticleFilter("))
    out, pout = namespace["out"], namespace["pout"]
    assert out.posterior.shape == pout.posterior.shape == (30, 30)  # type: ignore[attr-defined]
    assert np.all((out.posterior >= 0) & (out.posterior <= 1))  # type: ignore[attr-defined]
    assert len(namespace["detections"]) == len(namespace["f"].detectors) == 3  # type: ignore[arg-type,attr-defined]
    i, j = namespace["i"], namespace["j"]
    assert out.posterior[i, j] > 0.5 and pout.posterior[i, j] > 0.5  # type: ignore[attr-defined]
    assert printed.startswith("belief there: grid ")


def test_recommended_example_finds_and_tracks_the_person() -> None:
    namespace, printed = _run(_block("pfpeople.recommended("))
    frame = namespace["frame"]
    assert len(frame.people) == 1  # type: ignore[attr-defined]
    assert np.hypot(*(frame.people.positions[0] - [3.0, 0.45])) < 0.3  # type: ignore[attr-defined]
    (track,) = frame.tracks  # type: ignore[attr-defined]
    assert np.hypot(track.x - 3.0, track.y - 0.45) < 0.3
    lines = printed.strip().splitlines()
    assert lines[0].startswith("People(n=1, positions=[(") and lines[1].startswith("[(1, ")


def test_tracker_example_tracks_one_walker_at_1_m_s() -> None:
    namespace, printed = _run(_block("MultiPersonTracker("))
    lines = printed.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("track 1: at (")
    vx, vy = (float(v) for v in re.findall(r"velocity \((-?[0-9.]+), (-?[0-9.]+)\) m/s", lines[0])[0])
    assert np.hypot(vx - 1.0, vy) < 0.2
    (track,) = namespace["tracks"]  # type: ignore[misc]
    assert np.hypot(track.vx - 1.0, track.vy) < 0.2


def test_command_section_names_real_subcommands(capsys) -> None:
    expected = {
        "pfpeople": {"run", "inspect", "view", "batch", "train-detector"},
        "pfpeople-eval": {"evaluate", "benchmark", "score", "calibrate", "track", "sweep", "simulate-bag"},
    }
    for prog, main in (("pfpeople", pf_main), ("pfpeople-eval", eval_main)):
        found = set(re.findall(rf"\.venv/bin/{prog} ([a-z-]+)", README))
        assert expected[prog] <= found, f"README does not show {sorted(expected[prog] - found)} of {prog}"
        for sub in sorted(found):
            try:
                main([sub, "--help"])
            except SystemExit as exc:  # argparse exits 0 after printing help
                assert exc.code == 0, f"{prog} {sub}"
            assert "usage:" in capsys.readouterr().out
