"""The command-line conventions shared by ``pfpeople`` and ``pfpeople-eval`` (pfpeople.cli.support).

``--version``; ``-q/-v`` before or after every subcommand; each subcommand's ``--help`` ends in examples that
parse. Parsers only: no subcommand runs, except a stand-in for ``inspect``.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import logging
import shlex
from collections.abc import Callable
from types import ModuleType
from typing import Any

import pytest

import evaluation.commands
import pfpeople.cli.commands
from evaluation.cli import main as eval_main
from pfpeople.cli import main as pf_main
from pfpeople.cli.support import build_parser, package_version

COMMANDS: list[tuple[str, ModuleType, Callable[..., int]]] = [
    ("pfpeople", pfpeople.cli.commands, pf_main),
    ("pfpeople-eval", evaluation.commands, eval_main),
]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _examples(help_text: str) -> list[list[str]]:
    """The example command lines of a ``--help`` text, split into words."""
    assert "\nExamples:\n" in help_text
    lines = help_text.split("\nExamples:\n", 1)[1].strip().splitlines()
    return [shlex.split(line) for line in lines]


def _all_subcommands() -> list[tuple[str, ModuleType, str]]:
    return [
        (prog, commands, name)
        for prog, commands, _ in COMMANDS
        for name in _subparsers(build_parser(prog, "", commands))
    ]


@pytest.mark.parametrize(("prog", "main"), [(prog, main) for prog, _, main in COMMANDS])
def test_version_prints_the_package_version(
    prog: str, main: Callable[..., int], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"pfpeople {importlib.metadata.version('pfpeople')}"
    assert package_version() == importlib.metadata.version("pfpeople")


def test_version_without_installed_metadata_reads_pyproject(monkeypatch: pytest.MonkeyPatch) -> None:
    import tomllib
    from pathlib import Path

    def missing(name: str) -> str:
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", missing)
    pyproject = tomllib.loads((Path(__file__).resolve().parents[3] / "pyproject.toml").read_text())
    assert package_version() == pyproject["project"]["version"]


@pytest.mark.parametrize(("prog", "commands", "name"), _all_subcommands())
def test_help_ends_with_examples_that_parse(prog: str, commands: ModuleType, name: str) -> None:
    parser = build_parser(prog, "", commands)
    help_text = _subparsers(parser)[name].format_help()
    examples = _examples(help_text)
    assert 1 <= len(examples) <= 2 and help_text.rstrip().splitlines()[-1].startswith(f"  {prog} {name}")
    for words in examples:
        assert words[:2] == [prog, name]
        args = parser.parse_args(words[1:])
        assert args.command == name and args.quiet is False and args.verbose is False


@pytest.mark.parametrize(("prog", "commands", "name"), _all_subcommands())
def test_quiet_and_verbose_before_or_after_the_subcommand(prog: str, commands: ModuleType, name: str) -> None:
    parser = build_parser(prog, "", commands)
    words = _examples(_subparsers(parser)[name].format_help())[0][1:]
    for flag, dest in (("-v", "verbose"), ("--verbose", "verbose"), ("-q", "quiet"), ("--quiet", "quiet")):
        for argv in ([flag, *words], [words[0], flag, *words[1:]], [*words, flag]):
            args = parser.parse_args(argv)
            assert getattr(args, dest) is True, argv
            assert getattr(args, "quiet" if dest == "verbose" else "verbose") is False, argv


def _stand_in(monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """Replace ``pfpeople inspect`` by a recorder of its arguments and of the logging level chosen."""
    import pfpeople.cli.commands.inspect_bag as inspect_bag

    seen: dict[str, Any] = {}

    def fake(args: argparse.Namespace) -> int:
        seen["args"] = args
        return 0

    monkeypatch.setattr(inspect_bag, "_run", fake)
    monkeypatch.setattr(logging, "basicConfig", lambda **kw: seen.update(level=kw["level"]))
    return seen


@pytest.mark.parametrize(
    ("argv", "level", "no_progress"),
    [
        (["inspect", "my.bag"], logging.INFO, None),
        (["-q", "inspect", "my.bag"], logging.WARNING, True),
        (["inspect", "my.bag", "--quiet"], logging.WARNING, True),
        (["inspect", "-v", "my.bag"], logging.DEBUG, None),
        (["--verbose", "inspect", "my.bag"], logging.DEBUG, None),
    ],
)
def test_quiet_logs_warnings_only_without_progress_and_verbose_logs_debug(
    monkeypatch: pytest.MonkeyPatch, argv: list[str], level: int, no_progress: bool | None
) -> None:
    seen = _stand_in(monkeypatch)
    assert pf_main(argv) == 0
    assert seen["level"] == level
    assert getattr(seen["args"], "no_progress", None) is no_progress


def test_quiet_and_verbose_together_are_refused(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    seen = _stand_in(monkeypatch)
    with pytest.raises(SystemExit) as exc:
        pf_main(["-q", "inspect", "my.bag", "-v"])
    assert exc.value.code == 2 and "args" not in seen
    assert "contradict" in capsys.readouterr().err
