"""The user documentation: its index reaches every page, its links resolve, its Python runs, no heading is dated,
and the changelog's newest version is the package's."""

from __future__ import annotations

import contextlib
import io
import re
import sys
import tempfile
import tomllib
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.glob("*.md"))
LIBRARY_BLOCKS = re.findall(r"```python\n(.*?)```", (DOCS / "library.md").read_text(), re.S)
#: A heading with a date, or a round / stop label of the project's history.
DATED = re.compile(r"\b\d{4}-\d{2}-\d{2}\b|\b(round|stop)\b|\b(first|second|third|[a-z]+th) stop\b", re.I)


def test_the_index_leads_to_every_page() -> None:
    index = (DOCS / "index.md").read_text()
    linked = set(re.findall(r"\]\(([\w.-]+\.md)", index))
    assert {p.name for p in PAGES} - {"index.md"} <= linked
    for topic in ("getting_started.md", "cli.md", "configuration.md", "library.md", "architecture.md"):
        assert topic in linked
    assert {"benchmarks.md", "failure_modes.md", "CHANGELOG.md", "design.md"} <= linked


@pytest.mark.parametrize("page", [*PAGES, ROOT / "README.md"], ids=lambda p: p.name)
def test_links_resolve_and_no_heading_is_dated(page: Path) -> None:
    text = page.read_text()
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
        if "://" not in target:
            assert (page.parent / target).exists(), f"{page.name}: broken link {target}"
    headings = [h for h in re.findall(r"^#+ .*$", text, re.M) if not h.startswith("#!")]
    code = re.findall(r"```.*?```", text, re.S)
    fenced = {line for block in code for line in block.splitlines()}
    for heading in headings:
        if heading not in fenced:  # a shell comment in a code block is not a heading
            assert not DATED.search(heading), f"{page.name}: dated heading {heading!r}"
    assert "shared/GUIDE.md" not in text, f"{page.name} points at a design guide outside the repository"


@pytest.mark.parametrize("index", range(len(LIBRARY_BLOCKS)))
def test_every_python_block_of_the_library_page_runs(index: int, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    module = types.ModuleType("docs_library_block")  # a real module: dataclasses look their module up
    monkeypatch.setitem(sys.modules, module.__name__, module)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(LIBRARY_BLOCKS[index], "docs/library.md", "exec"), module.__dict__)
    if "print(" in LIBRARY_BLOCKS[index]:
        assert printed.getvalue().strip()


def test_the_changelog_goes_by_version_and_its_newest_is_the_package_version() -> None:
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    sections = re.findall(r"^## (.+)$", (DOCS / "CHANGELOG.md").read_text(), re.M)
    assert sections and all(re.match(r"\d+\.\d+\.\d+\b", s) for s in sections), sections
    assert sections[0].split()[0] == version
