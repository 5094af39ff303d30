"""Progress of the long jobs: the executors' per-result callback, the run's per-evaluation
progress (count, closing at 100 %, no effect on the results), the compensation table's row
progress and the run directory's ``run.log``."""

from __future__ import annotations

import logging

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
from whisker_opt.output.storage import read_csv
from tests.analytic_fitness import AnalyticFitness, FailureRegion

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


@pytest.mark.parametrize("kind", ["serial", "processes"])
def test_run_progress_ticks_per_evaluation_and_results_do_not_depend_on_it(tmp_path, monkeypatch, kind):
    bars = []

    class Spy(runner._Progress):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            bars.append(self)

    monkeypatch.setattr(runner, "_Progress", Spy)
    on = run_optimisation(_cfg(kind=kind), tmp_path / "on", EV, seed=5, progress=True)
    off = run_optimisation(_cfg(kind=kind), tmp_path / "off", EV, seed=5, progress=False)
    assert _evaluations(tmp_path / "on") == _evaluations(tmp_path / "off")
    assert on.best == off.best and on.stop_reason == off.stop_reason == "max_generations"
    for bar in bars:
        assert bar.done == on.n_evaluations  # one tick per evaluation
        assert bar.bar.total == bar.done  # closed at 100 %


def test_run_ended_early_by_a_rule_closes_at_100_percent(tmp_path, monkeypatch):
    bars = []

    class Spy(runner._Progress):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            bars.append(self)

    monkeypatch.setattr(runner, "_Progress", Spy)
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
