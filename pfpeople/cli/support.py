"""Shared command-line plumbing: subcommands discovered from a package of command modules.

Each module in the commands package defines ``register(subparsers) -> None``, which adds one subparser and
sets ``func=callable(args) -> int`` as its default. Used by ``pfpeople`` and ``pfpeople-eval``.

Every subparser is a :class:`SubcommandParser`: it inherits ``-q/--quiet`` and ``-v/--verbose`` from one
parent parser (so they work before and after the subcommand) and keeps the "Examples:" epilog that
:func:`examples` formats as written.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import logging
import pkgutil
import sys
import tomllib
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

from pfpeople.extras import MissingExtraError

__all__ = [
    "SubcommandParser",
    "add_blas_threads_argument",
    "build_parser",
    "examples",
    "package_version",
    "run",
    "verbosity_parser",
]


def package_version() -> str:
    """The installed ``pfpeople`` version; from ``pyproject.toml`` when running from an uninstalled checkout.

    Returns
    -------
    str
        The version (pyproject's ``[project] version`` is the one source of it), or ``"unknown"``.
    """
    try:
        return importlib.metadata.version("pfpeople")
    except importlib.metadata.PackageNotFoundError:
        pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
        try:
            return str(tomllib.loads(pyproject.read_text())["project"]["version"])
        except (OSError, KeyError, tomllib.TOMLDecodeError):
            return "unknown"


def verbosity_parser(*, suppress_defaults: bool) -> argparse.ArgumentParser:
    """The parent parser of ``-q/--quiet`` and ``-v/--verbose``, shared by the command and each subcommand.

    Parameters
    ----------
    suppress_defaults : bool
        True for subcommands: an option not given there leaves the value given before the subcommand
        (argparse would otherwise overwrite ``pfpeople -v run`` with the subparser's default False).

    Returns
    -------
    argparse.ArgumentParser
        A parser without ``-h``, for ``parents=[...]``.
    """
    default: Any = argparse.SUPPRESS if suppress_defaults else False
    parent = argparse.ArgumentParser(add_help=False)
    group = parent.add_argument_group("output")
    group.add_argument(
        "-q", "--quiet", action="store_true", default=default, help="warnings and errors only; no progress bar"
    )
    group.add_argument("-v", "--verbose", action="store_true", default=default, help="log debug messages")
    return parent


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Text with line breaks (the examples epilog, a module docstring) as written; one-line text wrapped."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text.strip("\n"):
            return super()._fill_text(text, width, indent)
        return argparse.HelpFormatter._fill_text(self, text, width, indent)


class SubcommandParser(argparse.ArgumentParser):
    """The parser class of every subcommand: the shared ``-q/-v`` options and the examples-keeping formatter."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs["parents"] = [*kwargs.get("parents", []), verbosity_parser(suppress_defaults=True)]
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)


def examples(*lines: str) -> str:
    """An "Examples:" epilog for a subcommand's ``--help``, one command line per argument.

    Parameters
    ----------
    *lines : str
        Command lines, e.g. ``"pfpeople run my.bag --out runs/my"``.

    Returns
    -------
    str
        The epilog text.
    """
    return "Examples:\n" + "".join(f"  {line}\n" for line in lines)


def add_blas_threads_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--blas-threads N`` (:mod:`pfpeople.pipeline.blas`) to a subcommand that runs the pipeline.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser; the value lands in ``args.blas_threads`` (None when not given).
    """
    parser.add_argument(
        "--blas-threads",
        type=int,
        metavar="N",
        help="BLAS threads per process during a run (numpy's and scipy's OpenBLAS, limited with threadpoolctl; the "
        "front-end process too). Default: $PFPEOPLE_BLAS_THREADS, else 1: on a busy machine a BLAS thread per core "
        "only waits for a core (the particle filter ran 2.5x slower so), and the results are the same. 0: no "
        "limit (OpenBLAS's own thread per core, or $OPENBLAS_NUM_THREADS)",
    )


def build_parser(prog: str, description: str, commands: ModuleType) -> argparse.ArgumentParser:
    """An argument parser with one subcommand per module of the ``commands`` package.

    Parameters
    ----------
    prog : str
        The command's name.
    description : str
        The first line of ``--help``.
    commands : module
        A package whose modules each define ``register(subparsers)``.

    Returns
    -------
    argparse.ArgumentParser
        The parser, with ``--version`` and ``-q/-v`` before or after the subcommand.
    """
    parser = argparse.ArgumentParser(
        prog=prog, description=description, parents=[verbosity_parser(suppress_defaults=False)]
    )
    parser.add_argument("--version", action="version", version=f"pfpeople {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, parser_class=SubcommandParser)
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def run(prog: str, description: str, commands: ModuleType, argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` and run the chosen subcommand.

    ``-q`` logs warnings and errors only and turns progress off (``args.no_progress``); ``-v`` logs debug
    messages; both together are an error.

    Parameters
    ----------
    prog, description, commands
        As :func:`build_parser`.
    argv : sequence of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The subcommand's exit code; 2 for bad input or files (a one-line message on stderr).
    """
    parser = build_parser(prog, description, commands)
    args = parser.parse_args(argv)
    if args.quiet and args.verbose:
        parser.error("-q/--quiet and -v/--verbose contradict each other")
    if args.quiet:
        args.no_progress = True
    level = logging.WARNING if args.quiet else logging.DEBUG if args.verbose else logging.INFO
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    # the packages' loggers at the level asked for while the command runs, also when logging was set up before
    # (basicConfig then does nothing): -v shows their debug messages, -q hides their info messages
    loggers = [logging.getLogger(name) for name in ("pfpeople", "gridbridge", "evaluation")]
    before = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(level)
    try:
        return int(args.func(args) or 0)
    except (ValueError, OSError, KeyError, MissingExtraError) as exc:  # bad input or files, a missing extra
        print(f"{prog} {args.command}: error: {exc}", file=sys.stderr)
        return 2
    finally:
        for lg, old in zip(loggers, before, strict=True):
            lg.setLevel(old)
