"""Subcommands of ``pfpeople``: one module each, discovered by :mod:`pfpeople.cli`."""
