"""Progress off a terminal (pfpeople.progress): a line per tenth of the run, not one per frame.

The stream of a test's captured stderr is not a terminal, as a log file or a pipe is not.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pytest

from evaluation.bench.batch import write_synthetic_bag
from pfpeople.progress import LineStream, is_terminal, progress_bar

CONFIG = '[frames]\ndriver = "/scan"\n[[detectors]]\nname = "laser_legs"\nkind = "leg"\ntopic = "/scan"\n'


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _lines(text: str) -> list[str]:
    return [line for line in re.split(r"[\r\n]", text) if line.strip()]


@pytest.mark.parametrize("total", [3, 10, 57, 1000])
def test_known_total_prints_a_line_per_tenth(total: int) -> None:
    out = io.StringIO()
    for _ in progress_bar(range(total), desc="x", unit="frame", file=out):
        pass
    text = out.getvalue()
    assert "\r" not in text  # whole lines, for log files
    lines = _lines(text)
    assert 2 <= len(lines) <= 12
    assert lines[0].startswith("x:   0%") and f"{total}/{total}" in lines[-1]


def test_unknown_total_prints_a_line_every_n_steps() -> None:
    out = io.StringIO()
    with progress_bar(desc="m", unit="msg", file=out, every=100) as bar:
        for _ in range(1000):
            bar.update(1)
    assert len(_lines(out.getvalue())) <= 12


def test_a_terminal_keeps_the_live_bar() -> None:
    term = _Terminal()
    assert is_terminal(term) and not is_terminal(io.StringIO())
    with progress_bar(total=1000, file=term) as bar:
        assert bar.dynamic_miniters  # tqdm's own redraw policy
    assert "\r" in term.getvalue()  # a live bar, redrawn in place
    assert LineStream(term).isatty() is False
    with progress_bar(total=1000, disable=True, file=io.StringIO()) as bar:
        bar.update(1000)


def test_pfpeople_run_with_stderr_not_a_terminal(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from pfpeople.cli import main

    bag = write_synthetic_bag(tmp_path / "walk.bag", n_scans=60, rng=np.random.default_rng(3))
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(CONFIG)
    assert main(["run", str(bag), "--config", str(cfg), "--out", str(tmp_path / "run"), "--one-process"]) == 0
    progress = [line for line in _lines(capsys.readouterr().err) if "frame/s" in line or "?frame" in line]
    assert 2 <= len(progress) <= 11 + 2, progress
    assert "60/60" in progress[-1]
    assert main(["run", str(bag), "--config", str(cfg), "--out", str(tmp_path / "q"), "--one-process", "-q"]) == 0
    assert "frame" not in capsys.readouterr().err  # -q: no progress bar
