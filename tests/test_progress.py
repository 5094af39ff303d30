"""Progress of the long jobs: the executors' per-result callback, the run's per-evaluation
progress (count, closing at 100 %, no effect on the results), the compensation table's row
progress, the run directory's ``run.log``, and the progress lines (count, elapsed time, ETA) that
reach a console that is no terminal, one per generation of a run."""

from __future__ import annotations

import logging
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from geometry.design import WhiskerDesign
from whisker_opt import compensation as comp_job, workflows
from whisker_opt.analysis import compensation as comp
from whisker_opt.analysis.beam import BeamResponse
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.optimise import runner
from whisker_opt.optimise.executors import ProcessExecutor, SerialExecutor
from whisker_opt.optimise.ga import EvaluationProgress, GeneticAlgorithm
from whisker_opt.optimise.runner import run_optimisation
from whisker_opt.output import progress
from whisker_opt.output.progress import PROGRESS_LOGGER, Progress, format_duration
from whisker_opt.output.storage import read_csv
from tests.analytic_fitness import AnalyticFitness, FailureRegion

REPO = Path(__file__).resolve().parents[1]
EV = AnalyticFitness(failures=(FailureRegion("alpha", 5.5, "mesh_failed"),))
GENES = [{"alpha": 3.0 + 0.4 * k, "l": 12.0, "t": 4.0, "Q_i": 0.05} for k in range(8)]
SEEDS = list(range(100, 108))


def _strip(outcomes):
    return [(o.status, o.f1, o.reason) for o in outcomes]


@pytest.mark.parametrize("kind", ["serial", "processes"])
def test_executor_callback_sees_each_design_once_and_changes_nothing(kind):
    make = (lambda: SerialExecutor(EV)) if kind == "serial" else (lambda: ProcessExecutor(EV, n_workers=2))
    with make() as ex:
        plain = ex.map(GENES, SEEDS)
        seen = []
        observed = ex.map(GENES, SEEDS, on_result=lambda i, out: seen.append((i, out.status)))
    assert _strip(observed) == _strip(plain)  # same outcomes, input order
    assert sorted(i for i, _ in seen) == list(range(len(GENES)))
    assert dict(seen) == {i: o.status for i, o in enumerate(plain)}


def test_a_failing_callback_is_ignored(caplog):
    def boom(i, out):
        raise RuntimeError("display broke")

    with SerialExecutor(EV) as ex, caplog.at_level(logging.WARNING):
        got = ex.map(GENES[:3], SEEDS[:3], on_result=boom)
    assert _strip(got) == _strip(SerialExecutor(EV).map(GENES[:3], SEEDS[:3]))
    assert sum("per-result callback failed" in r.getMessage() for r in caplog.records) == 3


def _no_time(records):
    return [{k: v for k, v in r.items() if k != "time_s"} for r in records]


class _Recorder(EvaluationProgress):
    def __init__(self):
        self.batches, self.results = [], []

    def start_generation(self, state, generation, n_to_run, n_cached):
        self.batches.append((generation, n_to_run, n_cached))

    def result(self, state, generation, genes, outcome, fp):
        self.results.append((generation, outcome.status, fp))


def _cfg(gens=4, target=0.0, kind="serial"):
    return OptimiserConfig.model_validate({"ga": {"population": 8, "n_elite": 1},
                                           "stopping": {"max_generations": gens, "target_fp": target},
                                           "executor": {"kind": kind, "n_workers": 2}})


def test_ga_progress_counts_every_evaluation_and_leaves_the_run_alone():
    cfg = _cfg()
    states = []
    for progress in (None, _Recorder()):
        ga = GeneticAlgorithm(cfg, 7)
        state = ga.new_state()
        with SerialExecutor(EV) as ex:
            ga.run(state, ex, progress=progress)
        states.append((state, progress))
    (plain, _), (watched, rec) = states
    assert len(rec.results) == watched.n_evaluations == sum(n for _, n, _ in rec.batches)
    assert sum(c for _, _, c in rec.batches) == watched.n_cache_hits
    assert _no_time(plain.records) == _no_time(watched.records)
    assert plain.rng_py == watched.rng_py and plain.logbook[-1]["best_fp"] == watched.logbook[-1]["best_fp"]
    feasible = [fp for _, status, fp in rec.results if status == "ok"]
    assert all(fp is not None for fp in feasible)
    assert [fp for _, status, fp in rec.results if status != "ok"] == [None] * (len(rec.results) - len(feasible))


def _evaluations(run_dir):
    return [{k: v for k, v in row.items() if k != "time_s"} for row in read_csv(run_dir / "evaluations.csv")]


def _spy_on_progress_bars(monkeypatch) -> list:
    """The run's progress bars, each appended to the returned list as it is made."""
    bars = []

    class Spy(runner._Progress):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            bars.append(self)

    monkeypatch.setattr(runner, "_Progress", Spy)
    return bars


@pytest.mark.parametrize("kind", ["serial", "processes"])
def test_run_progress_ticks_per_evaluation_and_results_do_not_depend_on_it(tmp_path, monkeypatch, kind):
    bars = _spy_on_progress_bars(monkeypatch)
    on = run_optimisation(_cfg(kind=kind), tmp_path / "on", EV, seed=5, progress=True)
    off = run_optimisation(_cfg(kind=kind), tmp_path / "off", EV, seed=5, progress=False)
    assert _evaluations(tmp_path / "on") == _evaluations(tmp_path / "off")
    assert on.best == off.best and on.stop_reason == off.stop_reason == "max_generations"
    for bar in bars:
        assert bar.done == on.n_evaluations  # one tick per evaluation
        assert bar.bar.total == bar.done  # closed at 100 %


def test_run_ended_early_by_a_rule_closes_at_100_percent(tmp_path, monkeypatch):
    bars = _spy_on_progress_bars(monkeypatch)
    s = run_optimisation(_cfg(gens=40, target=1e-3), tmp_path / "r", AnalyticFitness(scale=1e-3), seed=1,
                         progress=True)
    assert s.stop_reason == "target_fp" and s.generations < 40
    (bar,) = bars
    assert bar.done == s.n_evaluations and bar.bar.total == s.n_evaluations
    assert bar._expected(0, None) > s.n_evaluations  # what was expected before the rule fired


def test_compensation_table_progress_ticks_per_row(caplog):
    trims = comp_job._table_trims(3.0, 1.0)
    assert trims == [0.0, 1.0, 2.0, 3.0] and comp_job._table_trims(3.0, 2.0) == [0.0, 2.0, 3.0]
    rows = comp_job._TableProgress(BeamResponse(), trims, enabled=False)
    with caplog.at_level(logging.INFO, logger="whisker_opt"):
        table = comp.compensation_table(WhiskerDesign(), 0.2, 3.0, rows, step=1.0, method="root")
        rows.close(finished=True)
    assert rows.done == len(table.rows) == 4
    logged = [r.getMessage() for r in caplog.records if r.getMessage().startswith("compensate: row")]
    assert logged == ["compensate: row 2/4, trim Δ = 1 mm", "compensate: row 3/4, trim Δ = 2 mm",
                      "compensate: row 4/4, trim Δ = 3 mm"]
    plain = comp.compensation_table(WhiskerDesign(), 0.2, 3.0, BeamResponse(), step=1.0, method="root")
    np.testing.assert_array_equal(table.pressures, plain.pressures)


def test_run_log_writes_info_and_leaves_the_console_as_it_was(tmp_path):
    root = logging.getLogger()
    seen = []

    class ListHandler(logging.Handler):
        def emit(self, record):
            seen.append(record.getMessage())

    h = ListHandler()
    old_root = root.level
    root.addHandler(h)
    root.setLevel(logging.WARNING)
    pkg = logging.getLogger("whisker_opt")
    before = (pkg.level, pkg.propagate, list(pkg.handlers))
    try:
        with workflows.run_log(tmp_path) as path:
            logging.getLogger("whisker_opt.optimise.ga").info("an info line")
            logging.getLogger("whisker_opt.optimise.ga").warning("a warning line")
        with workflows.run_log(tmp_path):
            logging.getLogger("whisker_opt").info("appended on reopening")
    finally:
        root.removeHandler(h)
        root.setLevel(old_root)
    text = path.read_text()
    assert path.name == "run.log"
    assert "INFO whisker_opt.optimise.ga: an info line" in text and "WARNING" in text and "appended on reopening" in text
    assert seen == ["a warning line"]  # the console saw what it saw before, nothing more
    assert (pkg.level, pkg.propagate, list(pkg.handlers)) == before


# ----------------------------------------------------------------------------- progress lines
class _ListHandler(logging.Handler):
    def __init__(self):
        super().__init__()
        self.seen = []

    def emit(self, record):
        self.seen.append(record.getMessage())


def test_a_progress_line_states_the_count_the_elapsed_time_and_the_eta(caplog):
    with caplog.at_level(logging.INFO, logger=PROGRESS_LOGGER):
        with Progress(5, "verify at fine", "scene", enabled=False) as steps:
            steps.t0 -= 30.0  # 30 s into the job
            steps.step("(design 1/3: intact scene solved)")
        with Progress(41, "calibrate", "model evaluation", enabled=False, initial=1, at_most=True) as steps:
            steps.t0 -= 130.0
            steps.step(n=2)
    assert [r.getMessage() for r in caplog.records] == [
        "verify at fine: scene 1/5 (design 1/3: intact scene solved); elapsed 30 s, ETA 2 min 00 s",
        "calibrate: model evaluation 3 of at most 41; elapsed 2 min 10 s, ETA ≤ 41 min 10 s"]  # 38 left at 65 s each
    assert format_duration(2 * 3600 + 7 * 60) == "2 h 07 min" and format_duration(math.inf) == "?"


@pytest.mark.parametrize("enabled", [True, False])
def test_progress_lines_reach_a_console_that_is_no_terminal_and_nothing_else_does(tmp_path, monkeypatch, enabled):
    """At the console's WARNING level: progress lines only (also through a run's log), unless disabled."""
    root, console = logging.getLogger(), _ListHandler()
    old_level = root.level
    root.addHandler(console)
    root.setLevel(logging.WARNING)
    monkeypatch.setattr(progress.sys, "stderr", open(tmp_path / "stderr", "w"))  # not a terminal
    try:
        with progress.show_progress_lines(enabled) as shown:
            Progress(2, "job", "step", bar=False).step()
            logging.getLogger("whisker_opt.optimise.ga").info("an ordinary info line")
            with workflows.run_log(tmp_path):
                Progress(2, "job in a run", "step", bar=False).step()
        assert shown is enabled
    finally:
        root.removeHandler(console)
        root.setLevel(old_level)
        progress.sys.stderr.close()
    want = ["job: step 1/2; elapsed 0 s, ETA 0 s", "job in a run: step 1/2; elapsed 0 s, ETA 0 s"] if enabled else []
    assert console.seen == want
    assert logging.getLogger(PROGRESS_LOGGER).level == logging.NOTSET  # restored
    assert "job in a run: step 1/2" in (tmp_path / "run.log").read_text()  # the run's log has it either way


def test_a_run_with_stderr_to_a_file_logs_one_progress_line_per_generation(tmp_path):
    """As under `nohup whisker-opt run ... > log 2>&1`: the demo at population 2, generations 0 and 1."""
    log = tmp_path / "log"
    args = ["run", str(REPO / "configs" / "demo.yaml"), "--out", str(tmp_path / "run"),
            "--set", "optimiser.ga.population=2", "--set", "optimiser.ga.n_elite=0",
            "--set", "optimiser.stopping.max_generations=1", "--set", "optimiser.executor.kind=serial"]
    with open(log, "w") as f:
        proc = subprocess.run([sys.executable, "-m", "whisker_opt.cli.main", *args], cwd=REPO, stdout=f,
                              stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, timeout=900,
                              env={**os.environ, "OMP_NUM_THREADS": "1"})
    text = log.read_text()
    assert proc.returncode == 0, text
    lines = [ln for ln in text.splitlines() if "run: generations done" in ln]
    assert len(lines) == 2, text
    for k, ln in enumerate(lines):
        assert f"generations done {k + 1} of at most 2 (generation {k}: best F_p " in ln
        assert "; elapsed " in ln and ", ETA" in ln
    assert "evaluation 1/" not in text  # one line per generation, not per evaluation
