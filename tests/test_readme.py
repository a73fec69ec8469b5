"""The README's example code runs and its commands name real subcommands."""

from __future__ import annotations

import contextlib
import io
import json
import re
import tempfile
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
def test_every_python_block_runs_and_prints(index: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # a block's temporary files go under tmp_path
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


def test_the_three_commands_run_as_written_on_a_simulated_bag(tmp_path: Path, monkeypatch, capsys) -> None:
    """The README's "bag to people in three commands", verbatim, with ``my.bag`` an 8-scan simulated lobby bag."""
    import shlex

    section = README.split("## From your bag to people in three commands", 1)[1]
    (block,) = re.findall(r"```bash\n(.*?)```", section, re.S)[:1]
    assert eval_main(["simulate-bag", "lobby", "--out", str(tmp_path / "sim"), "--frames", "8", "--no-progress"]) == 0
    (tmp_path / "sim" / "lobby.bag").rename(tmp_path / "my.bag")
    monkeypatch.chdir(tmp_path)
    commands = [line.split("#", 1)[0].strip() for line in block.strip().splitlines()]
    assert [c.split()[:2] for c in commands] == [[".venv/bin/pfpeople", s] for s in ("inspect", "run", "view")]
    for command in commands:
        argv = shlex.split(command)[1:]
        assert pf_main([*argv, "--no-progress"] if argv[0] == "run" else argv) == 0, command
    capsys.readouterr()
    assert (tmp_path / "my.toml").is_file()
    run = tmp_path / "runs" / "my"
    assert json.loads((run / "run.json").read_text())["frames"] == 8
    assert (run / "view.mp4").stat().st_size > 0 and (run / "summary.png").stat().st_size > 0


def test_readme_names_every_notebook() -> None:
    notebooks = sorted(p.name for p in (Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))
    assert notebooks and all(f"notebooks/{name}" in README or f"`{name}`" in README for name in notebooks)
    assert "## Notebooks" in README
