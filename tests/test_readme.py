"""The README's example code runs and its commands name real subcommands."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from evaluation.cli import main as eval_main
from pfpeople.cli import main as pf_main

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def test_python_example_runs() -> None:
    block = re.findall(r"```python\n(.*?)```", README, re.S)[0]
    namespace: dict[str, object] = {}
    exec(compile(block, "README.md", "exec"), namespace)
    out, pout = namespace["out"], namespace["pout"]
    assert out.posterior.shape == pout.posterior.shape == (30, 30)  # type: ignore[attr-defined]
    assert np.all((out.posterior >= 0) & (out.posterior <= 1))  # type: ignore[attr-defined]


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
