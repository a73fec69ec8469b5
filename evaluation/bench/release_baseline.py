"""The previous release checked out beside this one, for same-run speed ratios in the benchmarks.

A benchmark measures a case twice in one run: with this checkout's packages and with the previous release's,
by running its own worker (the same timing code) in a subprocess whose import path starts at the release's
checkout. The checkout is a detached ``git worktree`` under ``.bench/`` (ignored by git), made once per
revision and reused::

    root = release_checkout()                      # .bench/release-<rev>/
    out = run_worker(root, "evaluation.bench.grid", ["--worker", "--sizes", "30"])

The worker prints one JSON document on its last line of standard output; :func:`run_worker` returns it parsed.
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

#: The last release that landed (round three, stop 11); ``--baseline REV`` on a benchmark overrides it.
PREVIOUS_RELEASE = "0a8dd9a"

REPO = Path(__file__).resolve().parents[2]


class BaselineError(RuntimeError):
    """The previous release could not be checked out or its worker failed."""


def release_checkout(rev: str = PREVIOUS_RELEASE, repo: Path = REPO) -> Path:
    """Check out revision ``rev`` of ``repo`` under ``repo/.bench/release-<rev>`` (once) and return its path.

    Parameters
    ----------
    rev : str
        A git revision of ``repo`` (commit, tag or branch).
    repo : pathlib.Path
        The git repository (this checkout by default).

    Returns
    -------
    pathlib.Path
        The release's work tree, importable by putting it first on ``PYTHONPATH``.

    Raises
    ------
    BaselineError
        If ``repo`` is not a git repository or ``rev`` is unknown there.
    """
    git = ["git", "-C", str(repo)]
    try:
        full = subprocess.run(
            [*git, "rev-parse", "--verify", f"{rev}^{{commit}}"], check=True, capture_output=True, text=True
        )
    except (OSError, subprocess.CalledProcessError) as exc:
        raise BaselineError(f"cannot resolve the baseline revision {rev!r} in {repo}: {exc}") from exc
    commit = full.stdout.strip()
    dest = repo / ".bench" / f"release-{commit[:10]}"
    if (dest / "pfpeople").is_dir():
        return dest
    dest.parent.mkdir(parents=True, exist_ok=True)
    try:
        subprocess.run(
            [*git, "worktree", "add", "--detach", "--force", str(dest), commit],
            check=True,
            capture_output=True,
            text=True,
        )
    except subprocess.CalledProcessError as exc:
        raise BaselineError(f"git worktree add {dest} {commit} failed: {exc.stderr.strip()}") from exc
    return dest


def run_worker(root: Path, module: str, args: list[str], *, timeout: float = 3600.0, cpu: int | None = None) -> Any:
    """Run ``python -m module args`` with ``root`` first on the import path and return its last line as JSON.

    Parameters
    ----------
    root : pathlib.Path
        The work tree whose packages the worker imports (e.g. from :func:`release_checkout`).
    module : str
        The worker's module, looked up in *this* checkout and run as a file, so a worker added after the
        release still measures the release's packages.
    args : list of str
        The worker's arguments.
    timeout : float
        Seconds before the worker is killed.
    cpu : int, optional
        The one CPU the worker may run on (``os.sched_setaffinity``); None: any.

    Returns
    -------
    Any
        The JSON value printed on the worker's last line of standard output.

    Raises
    ------
    BaselineError
        If the worker exits non-zero, times out or prints no JSON.
    """
    script = REPO / (module.replace(".", "/") + ".py")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(REPO)]))
    code = (
        f"import runpy, sys; sys.path.insert(0, {str(root)!r}); "
        f"sys.argv = [{str(script)!r}, *sys.argv[1:]]; runpy.run_path({str(script)!r}, run_name='__main__')"
    )
    try:
        proc = subprocess.run(
            [sys.executable, "-c", code, *args],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=root,
            preexec_fn=None if cpu is None else functools.partial(os.sched_setaffinity, 0, {cpu}),
        )
    except subprocess.TimeoutExpired as exc:
        raise BaselineError(f"{module} in {root} ran over {timeout:g} s") from exc
    if proc.returncode != 0:
        raise BaselineError(f"{module} in {root} exited {proc.returncode}: {proc.stderr.strip()[-2000:]}")
    lines = [line for line in proc.stdout.splitlines() if line.strip()]
    try:
        return json.loads(lines[-1])
    except (IndexError, json.JSONDecodeError) as exc:
        raise BaselineError(f"{module} in {root} printed no JSON on its last line: {proc.stdout[-500:]!r}") from exc
