"""Checkpoint and resume: an interrupted run (Ctrl-C or SIGKILL mid-generation) resumed equals an uninterrupted one."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from whisker_opt.optimise.checkpoint import CHECKPOINT_NAME, RunDirectoryError, load_checkpoint
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.optimise.runner import resume_optimisation, run_optimisation
from whisker_opt.output.storage import read_csv
from tests.analytic_fitness import AnalyticFitness, FailureRegion, Hold, Interrupt

REPO = Path(__file__).resolve().parents[1]

CFG = {
    "ga": {"population": 10},
    "stopping": {"max_generations": 8, "target_fp": 0.0, "stall_generations": 100},
}
FAILS = (FailureRegion("alpha", 5.5, "invalid_geometry"),)


def _same_run(a, b) -> None:
    assert a.population == b.population
    assert a.fitness == b.fitness
    assert a.best == b.best
    assert (a.stop_reason, a.generations, a.n_evaluations, a.n_cache_hits, a.n_failures) == (
        b.stop_reason, b.generations, b.n_evaluations, b.n_cache_hits, b.n_failures
    )


def _same_tables(dir_a: Path, dir_b: Path) -> None:
    for name, skip in (("evaluations.csv", {"time_s"}), ("generations.csv", {"time_s", "elapsed_s"})):
        ra, rb = read_csv(dir_a / name), read_csv(dir_b / name)
        assert len(ra) == len(rb), name
        for x, y in zip(ra, rb):
            assert {k: v for k, v in x.items() if k not in skip} == {k: v for k, v in y.items() if k not in skip}


def test_interrupted_and_resumed_run_equals_uninterrupted(tmp_path):
    cfg = OptimiserConfig.model_validate(CFG)
    ev = AnalyticFitness(failures=FAILS)
    ref = run_optimisation(cfg, tmp_path / "ref", ev, seed=5, progress=False)
    with pytest.raises(KeyboardInterrupt):
        run_optimisation(cfg, tmp_path / "cut", ev, seed=5, progress=False, callbacks=[Interrupt(3)])
    state, _ = load_checkpoint(tmp_path / "cut")
    assert state.generation == 3 and state.stop_reason is None
    with pytest.raises(FileExistsError):
        run_optimisation(cfg, tmp_path / "cut", ev, seed=5, progress=False)
    resumed = resume_optimisation(tmp_path / "cut", ev, progress=False)
    _same_run(ref, resumed)
    _same_tables(tmp_path / "ref", tmp_path / "cut")
    # resuming a finished run changes nothing
    _same_run(ref, resume_optimisation(tmp_path / "cut", ev, progress=False))


def test_run_killed_before_its_first_checkpoint_restarts_identically(tmp_path):
    cfg = OptimiserConfig.model_validate(CFG)
    ev = AnalyticFitness()
    ref = run_optimisation(cfg, tmp_path / "ref", ev, seed=8, progress=False)
    with pytest.raises(KeyboardInterrupt):
        run_optimisation(cfg, tmp_path / "cut", ev, seed=8, progress=False, callbacks=[Interrupt(0)])
    (tmp_path / "cut" / CHECKPOINT_NAME).unlink()  # as if killed during generation 0
    (tmp_path / "cut" / f".{CHECKPOINT_NAME}.junk.tmp").write_bytes(b"torn")
    _same_run(ref, resume_optimisation(tmp_path / "cut", ev, progress=False))
    assert not list((tmp_path / "cut").glob(".*.tmp"))


_CHILD = """
import json, sys
from pathlib import Path
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.optimise.runner import run_optimisation
from tests.analytic_fitness import AnalyticFitness, FailureRegion, Hold
cfg = OptimiserConfig.model_validate(json.loads(sys.argv[2]))
ev = AnalyticFitness(failures=(FailureRegion("alpha", 5.5, "invalid_geometry"),), hold=Hold(**json.loads(sys.argv[3])))
run_optimisation(cfg, Path(sys.argv[1]), ev, seed=13, progress=False)
"""


def _checkpoint_generation(run_dir: Path) -> int:
    try:
        state, _ = load_checkpoint(run_dir)
    except (FileNotFoundError, RunDirectoryError):
        return -1
    return state.generation


@pytest.mark.parametrize("kind", ["serial", "processes"])
def test_sigkill_mid_generation_then_resume_equals_uninterrupted(tmp_path, kind):
    cfg_data = {**CFG, "executor": {"kind": kind, "n_workers": 2}}
    cfg = OptimiserConfig.model_validate(cfg_data)
    ev = AnalyticFitness(failures=FAILS)  # the child's evaluator minus its hold, which changes no result
    run_dir = tmp_path / "killed"
    (tmp_path / "hold").mkdir()
    hold = Hold(str(tmp_path / "hold"), run_dir=str(run_dir), generation=1)  # generation 2's evaluations
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen(
        [sys.executable, "-c", _CHILD, str(run_dir), json.dumps(cfg_data), json.dumps(dataclasses.asdict(hold))],
        cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    try:
        hold.wait_held(proc)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(60)
    assert proc.returncode == -signal.SIGKILL
    cut_at = _checkpoint_generation(run_dir)
    assert cut_at == 1  # killed in generation 2, the checkpoint of generation 1 left
    print(f"killed with the checkpoint at generation {cut_at}")
    resumed = resume_optimisation(run_dir, ev, progress=False)
    ref = run_optimisation(cfg, tmp_path / "ref", ev, seed=13, progress=False)
    _same_run(ref, resumed)
    _same_tables(tmp_path / "ref", run_dir)


def test_a_finished_run_extended_with_max_generations_equals_a_longer_run(tmp_path):
    """resume(max_generations=N) continues a run stopped by max_generations as if N had been set."""
    from whisker_opt.config.optimiser import OptimiserConfig
    from whisker_opt.optimise.runner import resume_optimisation, run_optimisation
    from tests.analytic_fitness import AnalyticFitness

    def cfg(n):
        return OptimiserConfig.model_validate({"ga": {"population": 6, "n_elite": 1},
                                               "stopping": {"max_generations": n, "target_fp": 0.0,
                                                            "stall_generations": 100}})

    ev = AnalyticFitness()
    long = run_optimisation(cfg(4), tmp_path / "long", ev, seed=3, progress=False)
    short = run_optimisation(cfg(2), tmp_path / "short", ev, seed=3, progress=False)
    assert short.generations == 2 and short.stop_reason == "max_generations"
    extended = resume_optimisation(tmp_path / "short", ev, progress=False, max_generations=4)
    assert (extended.population, extended.fitness, extended.best) == (long.population, long.fitness, long.best)
    with pytest.raises(ValueError, match="already bred 4"):
        resume_optimisation(tmp_path / "short", ev, progress=False, max_generations=3)
