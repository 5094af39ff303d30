"""One way to run the project in a subprocess: the CLI (``whisker-opt``) or any module, from this checkout.

Shared by the tests and the reliability harnesses of ``benchmarks/reliability/`` (bad inputs, the
run-file fuzzer): the child imports this checkout's packages (``PYTHONPATH`` starts with the repository
root), runs one thread of BLAS/OpenMP, sees no display unless a case sets one, and is stopped after
``timeout`` seconds.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: The CLI as a module (what the ``whisker-opt`` console script runs).
CLI_MODULE = "whisker_opt.cli"


def child_env(env: dict | None = None) -> dict:
    """The environment of a child: this one, without a display, with the checkout first on ``PYTHONPATH``,
    one BLAS/OpenMP thread unless set, and ``env`` on top."""
    out = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    out["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)
    out.setdefault("OMP_NUM_THREADS", "1")
    out.update(env or {})
    return out


@dataclass(frozen=True)
class Finished:
    """What a child did: its exit status (None: stopped at the timeout), its output and its wall time."""

    returncode: int | None
    stdout: str
    stderr: str
    seconds: float

    @property
    def timed_out(self) -> bool:
        return self.returncode is None


def run_command(argv: list[str], *, cwd: Path | str = REPO, timeout: float = 300.0, env: dict | None = None,
                stdin: str | None = None) -> Finished:
    """Run ``argv`` with :func:`child_env` and wait at most ``timeout`` seconds; never raises on a timeout.

    Parameters
    ----------
    argv : list of str
        The whole command line.
    cwd : path
        Working folder of the child (default: the repository root).
    timeout : float
        Seconds before the child is killed; its status is then None and its stderr starts with a line
        saying so.
    env : dict, optional
        Variables set for the child on top of :func:`child_env`.
    stdin : str, optional
        Text given on standard input (default: none, the child reads end of file).
    """
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([str(a) for a in argv], cwd=cwd, env=child_env(env), capture_output=True, text=True,
                              errors="replace", timeout=timeout, input=stdin,
                              stdin=None if stdin is not None else subprocess.DEVNULL)
        return Finished(proc.returncode, proc.stdout, proc.stderr, time.perf_counter() - t0)
    except subprocess.TimeoutExpired as exc:
        def text(b):
            return b.decode(errors="replace") if isinstance(b, bytes) else (b or "")
        return Finished(None, text(exc.stdout), f"timed out after {timeout:g} s\n{text(exc.stderr)}",
                        time.perf_counter() - t0)


def run_module(module: str, *args, **kw) -> Finished:
    """``python3 -m module args...`` with :func:`run_command` (same keywords)."""
    return run_command([sys.executable, "-m", module, *map(str, args)], **kw)


def run_cli(*args, cli: list[str] | None = None, **kw) -> Finished:
    """``whisker-opt args...`` with :func:`run_command` (same keywords); ``cli`` replaces the command that
    starts the CLI (default: this interpreter with ``-m whisker_opt.cli``)."""
    return run_command([*(cli or [sys.executable, "-m", CLI_MODULE]), *map(str, args)], **kw)


def tiny_run_file(scene: str = "", trim: float = 5.0, results: str | None = None) -> str:
    """The smallest run file a child runs: coarse preset, a GA of 2 designs and generation 0 only, serial,
    seed 3; ``scene`` holds the lines of a ``scene:`` section (none when empty), ``trim`` is
    ``optimiser.trim``, ``results`` the ``output.results_dir`` (left to its default when None)."""
    text = "fidelity:\n  preset: coarse\n"
    if scene:
        text += "scene:\n" + "".join(f"  {line}\n" for line in scene.splitlines())
    text += (f"optimiser:\n  trim: {trim}\n  ga:\n    population: 2\n    n_elite: 1\n    tournament: 2\n"
             "  stopping:\n    max_generations: 0\n  executor:\n    kind: serial\nseed: 3\n")
    if results is not None:
        text += f"output:\n  results_dir: {results}\n"
    return text
