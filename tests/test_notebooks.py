"""The benchmark notebooks run from top to bottom (small sizes) and hold their figures."""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
@pytest.mark.parametrize("name", ["speed.ipynb", "ab_evaluation.ipynb"])
def test_notebook_executes(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PFPEOPLE_NOTEBOOK_QUICK", "1")
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel draws inline
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell('print("quick sizes:", QUICK)'))  # the kernel saw the setting
    NotebookClient(nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOKS)}}).execute()
    outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    text = "".join(o.get("text", "") for o in outputs if o.get("output_type") == "stream")
    if name == "speed.ipynb":
        assert "ms/" in text or " ms" in text
        assert any("image/png" in o.get("data", {}) for o in outputs)
    else:
        assert "Detector laser_legs" in text and "grid (paper) + blobs" in text
        assert any("image/png" in o.get("data", {}) for o in outputs)
    assert "quick sizes: True" in text  # the kernel ran the small sizes (the variable reached it)
