"""Subcommands of ``pfpeople-eval``: one module each, discovered by :mod:`evaluation.cli`."""
