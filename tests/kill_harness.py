"""SIGKILL a GA run at chosen moments, resume it, and compare it with an uninterrupted run.

Shared by ``tests/test_kill_resume.py`` and ``benchmarks/reliability/kill_resume.py``. The run is
:func:`whisker_opt.optimise.runner.run_optimisation` with the analytic evaluator
(:class:`tests.analytic_fitness.AnalyticFitness`, ``sleep_s`` per evaluation) on the serial
executor, in a child process (:data:`CHILD`; its arguments: the run directory, the optimiser section as
JSON, the sleeps per evaluation and per fsync, the seed, and optionally a :class:`tests.analytic_fitness.Hold`
as JSON). The child emulates a slow disk by sleeping in
every ``os.fsync``, so that the temporary file of an atomic write (the checkpoint's among
them) lives long enough to be seen and killed in. The parent watches the run directory and
sends SIGKILL at the moment (:class:`Moment`); the run is then resumed in this process with
:func:`whisker_opt.optimise.runner.resume_optimisation` (the same evaluator without its
sleep, which changes no result) and compared (:func:`differences`) with an uninterrupted
run of the same seed.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from tests.analytic_fitness import AnalyticFitness, FailureRegion
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.optimise.checkpoint import CHECKPOINT_NAME, load_checkpoint
from whisker_opt.optimise.runner import resume_optimisation, run_optimisation
from whisker_opt.output import storage

REPO = Path(__file__).resolve().parents[1]

#: The optimiser section of the killed runs: generations 0 … 6 of 10 individuals.
CFG = {
    "ga": {"population": 10},
    "stopping": {"max_generations": 6, "target_fp": 0.0, "stall_generations": 100},
    "executor": {"kind": "serial"},
}
SEED = 13
FAILS = (FailureRegion("alpha", 5.5, "invalid_geometry"),)
#: Sleep per evaluation [s] and per fsync [s] in the child.
SLEEP_S = 0.01
FSYNC_S = 0.02

CHILD = """
import json, os, sys, time
from pathlib import Path
fsync_s = float(sys.argv[4])
_fsync = os.fsync
def slow_fsync(fd):
    _fsync(fd)
    time.sleep(fsync_s)
os.fsync = slow_fsync
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.optimise.runner import run_optimisation
from tests.analytic_fitness import AnalyticFitness, FailureRegion, Hold
cfg = OptimiserConfig.model_validate(json.loads(sys.argv[2]))
hold = Hold(**json.loads(sys.argv[6])) if len(sys.argv) > 6 else None
ev = AnalyticFitness(failures=(FailureRegion("alpha", 5.5, "invalid_geometry"),), sleep_s=float(sys.argv[3]),
                     hold=hold)
run_optimisation(cfg, Path(sys.argv[1]), ev, seed=int(sys.argv[5]), progress=False)
"""


@dataclass(frozen=True)
class Moment:
    """When the child is killed.

    Attributes
    ----------
    kind : str
        ``metadata``: as soon as ``optimiser.json`` exists (before ``environment.json``);
        ``gen0``: ``delay`` s after ``environment.json`` appeared (generation 0's evaluations);
        ``checkpoint``: while the checkpoint of ``generation`` is being written (its
        temporary file exists); ``after``: ``delay`` s after the checkpoint of ``generation``
        appeared; ``finish``: once the last checkpoint exists (the final tables and plots);
        ``time``: ``delay`` s after ``optimiser.json`` appeared.
    generation : int
    delay : float
        [s]
    """

    kind: str
    generation: int = 0
    delay: float = 0.0

    def label(self) -> str:
        """Short text of the moment."""
        if self.kind in ("metadata", "finish"):
            return self.kind
        if self.kind == "checkpoint":
            return f"checkpoint {self.generation} write"
        if self.kind == "after":
            return f"checkpoint {self.generation} +{self.delay:.3f}s"
        return f"{self.kind} +{self.delay:.3f}s"


def moments(n: int, seed: int = 0) -> list[Moment]:
    """``n`` kill moments (``n`` >= 5): the fixed edge cases, then seeded random ones.

    The fixed ones are ``metadata``, ``gen0``, the checkpoint writes of generation 0 and of
    the last generation, and ``finish``.
    """
    last = CFG["stopping"]["max_generations"]
    gen_s = CFG["ga"]["population"] * SLEEP_S + 4 * FSYNC_S  # evaluations + 4 atomic writes
    out = [Moment("metadata"), Moment("gen0", 0, 0.5 * CFG["ga"]["population"] * SLEEP_S),
           Moment("checkpoint", 0), Moment("checkpoint", last), Moment("finish")]
    rng = random.Random(seed)
    while len(out) < n:
        kind = rng.choice(("checkpoint", "after", "time"))
        if kind == "checkpoint":
            out.append(Moment(kind, rng.randint(0, last)))
        elif kind == "after":
            out.append(Moment(kind, rng.randint(0, last - 1), round(rng.uniform(0.0, gen_s), 3)))
        else:
            out.append(Moment(kind, 0, round(rng.uniform(0.0, (last + 1) * gen_s + 2 * FSYNC_S), 3)))
    return out[:n]


class _Watch:
    """The generation and stop reason of a run directory's checkpoint, re-read when it changes."""

    def __init__(self, run_dir: Path) -> None:
        self.path = run_dir / CHECKPOINT_NAME
        self.stamp = None
        self.generation = -1
        self.stop_reason = None

    def poll(self) -> int:
        try:
            st = self.path.stat()
        except FileNotFoundError:
            return self.generation
        stamp = (st.st_ino, st.st_mtime_ns, st.st_size)
        if stamp != self.stamp:
            try:
                state, _ = load_checkpoint(self.path.parent)
            except Exception:  # noqa: BLE001 - replaced while read; checked again at the next poll
                return self.generation
            self.stamp, self.generation, self.stop_reason = stamp, state.generation, state.stop_reason
        return self.generation


def _checkpoint_temporary(run_dir: Path) -> bool:
    """True while the temporary file of the next checkpoint exists."""
    try:
        return any(p.name.startswith(f".{CHECKPOINT_NAME}.") and storage.is_temporary(p.name)
                   for p in run_dir.iterdir())
    except FileNotFoundError:
        return False


def kill_when(proc: subprocess.Popen, fire, timeout: float, poll: float,
              on_timeout: Exception | None = None) -> str:
    """SIGKILL ``proc`` as soon as ``fire()`` is true; wait for it and return its stderr text.

    Past ``timeout`` seconds ``on_timeout`` is raised (None: stop watching and let the child finish). A child
    still running when this returns or raises is killed.
    """
    deadline = time.monotonic() + timeout
    try:
        while proc.poll() is None:
            if time.monotonic() > deadline:
                if on_timeout is not None:
                    raise on_timeout
                break
            if fire():
                os.kill(proc.pid, signal.SIGKILL)
                break
            time.sleep(poll)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(30)
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    return err


def kill_at(run_dir: Path, moment: Moment, timeout: float = 60.0) -> dict:
    """Start the child run into ``run_dir`` and SIGKILL it at ``moment``.

    Returns
    -------
    dict
        ``killed`` (False when the run ended first), ``generation`` (of the checkpoint left,
        -1 for none), ``finished`` (that checkpoint is the last one), ``seconds`` (child's life),
        ``temporaries`` (names of the temporary files the kill left) and ``environment``
        (``environment.json`` was written).
    """
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    t_start = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(run_dir), json.dumps(CFG), str(SLEEP_S), str(FSYNC_S), str(SEED)],
        cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    watch = _Watch(run_dir)
    t0 = None  # when the moment's reference event was seen

    def fire() -> bool:
        nonlocal t0
        if moment.kind in ("metadata", "time"):
            if t0 is None and (run_dir / storage.OPTIMISER_JSON).exists():
                t0 = time.monotonic()
            return t0 is not None and time.monotonic() - t0 >= moment.delay
        if moment.kind == "gen0":
            if t0 is None and (run_dir / storage.ENVIRONMENT_JSON).exists():
                t0 = time.monotonic()
            return t0 is not None and time.monotonic() - t0 >= moment.delay
        if moment.kind == "checkpoint":
            return watch.poll() == moment.generation - 1 and _checkpoint_temporary(run_dir)
        if moment.kind == "after":
            if t0 is None and watch.poll() >= moment.generation:
                t0 = time.monotonic()
            return t0 is not None and time.monotonic() - t0 >= moment.delay
        if moment.kind == "finish":
            watch.poll()
            return watch.stop_reason is not None
        raise ValueError(f"unknown moment kind {moment.kind!r}")

    err = kill_when(proc, fire, timeout, 0.001, TimeoutError(f"{moment.label()}: the moment never came"))
    if proc.returncode not in (0, -signal.SIGKILL):
        raise RuntimeError(f"child run failed ({proc.returncode}): {err}")
    watch.stamp = None
    watch.poll()
    names = sorted(p.name for p in run_dir.iterdir()) if run_dir.is_dir() else []
    return {"killed": proc.returncode == -signal.SIGKILL, "generation": watch.generation,
            "finished": watch.stop_reason is not None, "seconds": time.monotonic() - t_start,
            "temporaries": [n for n in names if storage.is_temporary(n)],
            "environment": storage.ENVIRONMENT_JSON in names}


def evaluator() -> AnalyticFitness:
    """The child's evaluator without its sleep (the same results)."""
    return AnalyticFitness(failures=FAILS)


def reference_run(run_dir: Path):
    """The uninterrupted run (in this process); returns its summary."""
    return run_optimisation(OptimiserConfig.model_validate(CFG), run_dir, evaluator(), seed=SEED, progress=False)


def resume(run_dir: Path):
    """Resume a killed run in this process; returns its summary."""
    return resume_optimisation(run_dir, evaluator(), progress=False)


def _hall_of_fame(run_dir: Path) -> list:
    state, _ = load_checkpoint(run_dir)
    return [(tuple(ind), tuple(ind.fitness.values)) for ind in state.hof]


def _evaluations(run_dir: Path) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "time_s"} for r in storage.read_csv(run_dir / storage.EVALUATIONS_CSV)]


def leftovers(run_dir: Path) -> list[str]:
    """Temporaries and missing outputs of a resumed run directory."""
    out = sorted(p.name for p in run_dir.iterdir() if storage.is_temporary(p.name))
    for name in (storage.OPTIMISER_JSON, storage.ENVIRONMENT_JSON, CHECKPOINT_NAME, storage.EVALUATIONS_CSV,
                 storage.GENERATIONS_CSV, storage.BEST_JSON, "convergence.png"):
        if not (run_dir / name).is_file():
            out.append(f"missing {name}")
    return out


def differences(ref_dir: Path, ref, run_dir: Path, summary) -> list[str]:
    """What differs between the uninterrupted and the resumed run (empty when identical).

    Compared: final population and its fitness, best design, counters, hall of fame (genes
    and fitness), every column of ``evaluations.csv`` but ``time_s``, and the resumed
    directory's completeness (:func:`leftovers`).
    """
    out = []
    if (summary.population, summary.fitness) != (ref.population, ref.fitness):
        out.append("population")
    if summary.best != ref.best:
        out.append("best")
    if (summary.stop_reason, summary.generations, summary.n_evaluations, summary.n_cache_hits,
            summary.n_failures) != (ref.stop_reason, ref.generations, ref.n_evaluations, ref.n_cache_hits,
                                    ref.n_failures):
        out.append("counters")
    if _hall_of_fame(run_dir) != _hall_of_fame(ref_dir):
        out.append("hall of fame")
    if _evaluations(run_dir) != _evaluations(ref_dir):
        out.append("evaluations.csv")
    out += leftovers(run_dir)
    return out
