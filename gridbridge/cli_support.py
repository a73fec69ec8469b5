"""Shared command-line plumbing: subcommands discovered from a package of command modules.

Each module in the commands package defines ``register(subparsers) -> None``, which adds one subparser and
sets ``func=callable(args) -> int`` as its default. Used by ``pfpeople`` and ``pfpeople-eval``.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import sys
from collections.abc import Sequence
from types import ModuleType


def build_parser(prog: str, description: str, commands: ModuleType) -> argparse.ArgumentParser:
    """An argument parser with one subcommand per module of the ``commands`` package."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def run(prog: str, description: str, commands: ModuleType, argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` and run the chosen subcommand; returns its exit code."""
    parser = build_parser(prog, description, commands)
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    try:
        return int(args.func(args) or 0)
    except (ValueError, OSError, KeyError) as exc:  # bad input or files: a message, not a traceback
        print(f"{prog} {args.command}: error: {exc}", file=sys.stderr)
        return 2
