"""The generation loop on the analytic fitness: convergence, stopping rules, bounds, failures, cache, RNG."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

import numpy as np
import pytest

from whisker_opt.optimise.executors import SerialExecutor
from whisker_opt.optimise.ga import GeneticAlgorithm, Recorder, best_design
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GENE_NAMES
from whisker_opt.experiment.outcome import EvalOutcome
from tests.analytic_fitness import AnalyticFitness, FailureRegion


def make_cfg(pop=20, gens=20, target=0.0, stall_n=1000, stall_tol=0.0, **sections) -> OptimiserConfig:
    data = {
        "ga": {"population": pop, **sections.pop("ga", {})},
        "stopping": {"max_generations": gens, "target_fp": target, "stall_generations": stall_n, "stall_tol": stall_tol},
        **sections,
    }
    return OptimiserConfig.model_validate(data)


def run(cfg: OptimiserConfig, evaluator, seed=3, callbacks=()):
    ga = GeneticAlgorithm(cfg, seed)
    state = ga.new_state()
    with SerialExecutor(evaluator) as ex:
        ga.run(state, ex, callbacks)
    return ga, state


@dataclass(frozen=True)
class Counting:
    """Analytic fitness that remembers every genome it was asked to solve (serial only)."""

    inner: AnalyticFitness = AnalyticFitness()
    calls: list = field(default_factory=list)

    def __call__(self, genes):
        self.calls.append(tuple(genes[n] for n in GENE_NAMES))
        return self.inner(genes)


@pytest.mark.parametrize("seed", [1, 2])
def test_converges_to_the_known_optimum(seed):
    x_star = (4.2, 11.0, 3.5, 0.12)
    cfg = make_cfg(pop=30, gens=40)
    ga, state = run(cfg, AnalyticFitness(optimum=x_star), seed=seed)
    best = best_design(state)
    assert state.stop_reason == "max_generations" and state.generation == 40
    assert best["feasible"] and best["F_p"] < 1e-4
    for (name, xs), (lo, hi) in zip(zip(GENE_NAMES, x_star), cfg.genes.bounds()):
        assert abs(best["genes"][name] - xs) < 0.03 * (hi - lo), (name, best["genes"][name], xs)
    bests = [r["best_fp"] for r in state.logbook]
    assert all(b2 <= b1 for b1, b2 in zip(bests, bests[1:])), "elitism: the best never gets worse"
    assert bests[-1] < 0.05 * bests[0]


def test_target_rule_fires_at_the_first_generation_below_target():
    cfg = make_cfg(pop=20, gens=100, target=1e-4)
    _, state = run(cfg, AnalyticFitness())
    assert state.stop_reason == "target_fp"
    lb = state.logbook
    assert lb[-1]["best_fp"] <= 1e-4 < lb[-2]["best_fp"]
    assert state.generation < 100


def test_stall_rule_fires_exactly_after_the_window_on_a_flat_fitness():
    flat = AnalyticFitness(weights=(0.0, 0.0, 0.0, 0.0), offset=0.5)
    cfg = make_cfg(pop=10, gens=50, target=1e-3, stall_n=5, stall_tol=1e-9, penalties=[])
    _, state = run(cfg, flat)
    assert state.stop_reason == "stall"
    assert state.generation == 5  # generations 0..5: five zero improvements


def _mean_rel_improvement(bests, n):
    w = bests[-(n + 1):]
    return float(np.mean([(a - b) / abs(a) for a, b in zip(w[:-1], w[1:])]))


def test_stall_rule_matches_its_definition_on_an_improving_run():
    n, tol = 4, 0.02
    cfg = make_cfg(pop=12, gens=200, stall_n=n, stall_tol=tol)
    _, state = run(cfg, AnalyticFitness(offset=1e-3), seed=5)
    assert state.stop_reason == "stall"
    bests = [r["best_fp"] for r in state.logbook]
    assert _mean_rel_improvement(bests, n) <= tol
    for g in range(n, len(bests) - 1):  # it did not fire earlier
        assert _mean_rel_improvement(bests[: g + 1], n) > tol


@pytest.mark.parametrize("gens", [0, 3])
def test_max_generations_rule(gens):
    cfg = make_cfg(pop=8, gens=gens, stall_n=50)
    _, state = run(cfg, AnalyticFitness())
    assert state.stop_reason == "max_generations"
    assert state.generation == gens and len(state.logbook) == gens + 1


def test_genes_never_leave_their_bounds():
    """Property over many generations with wide SBX/mutation steps and every gene mutated."""
    cfg = make_cfg(
        pop=16, gens=60,
        ga={"eta_cx": 0.5, "eta_mut": 0.5, "mut_prob": 1.0, "indpb": 1.0, "cx_prob": 1.0, "init": "uniform"},
        genes={"alpha": [2.5, 6.0], "l": [10.0, 10.001], "t": [2, 6], "Q_i": [0.01, 0.2]},
    )
    # optimum on a corner pulls individuals onto the bounds, where the operators are most fragile
    ev = AnalyticFitness(optimum=(2.5, 10.0, 6.0, 0.2), bounds=cfg.genes.bounds())
    seen = []
    _, state = run(cfg, ev, seed=11, callbacks=[lambda st, row: seen.extend(list(i) for i in st.population)])
    bounds = cfg.genes.bounds()
    rows = seen + [[r[n] for n in GENE_NAMES] for r in state.records]
    assert len(rows) > 1000
    for row in rows:
        for x, (lo, hi) in zip(row, bounds):
            assert isinstance(x, float) and lo <= x <= hi, (row, bounds)
    near = sum(1 for row in rows for x, (lo, hi) in zip(row, bounds) if min(x - lo, hi - x) < 1e-3 * (hi - lo))
    assert near > 100  # the property was exercised at the bounds


def test_out_of_bound_parents_are_clamped_before_the_bounded_operators():
    cfg = make_cfg(pop=6, ga={"cx_prob": 1.0, "mut_prob": 1.0, "indpb": 1.0, "n_elite": 0})
    ga = GeneticAlgorithm(cfg, 0)
    from whisker_opt.optimise.ga import Individual, _ga_rng

    pop = []
    for k in range(6):
        ind = Individual([7.0 + k, 20.0, 1.0, -0.5] if k % 2 else [1.0, 5.0, 9.0, 0.9])
        ind.fitness.values = (0.0, float(k))
        pop.append(ind)
    state = ga.new_state()
    with _ga_rng(state):
        children = ga.breed(pop)
    for ind in children:
        for x, lo, hi in zip(ind, ga.low, ga.up):
            assert isinstance(x, float) and lo <= x <= hi
    moved = Individual([100.0, 12.0, 4.0, 0.1])
    assert ga.clamp(moved) and moved[0] == 6.0 and not ga.clamp(moved)


def test_failures_are_recorded_graded_and_never_best():
    ev = AnalyticFitness(
        optimum=(4.9, 12.0, 4.0, 0.05),  # optimum just inside the feasible region alpha <= 5
        failures=(
            FailureRegion("alpha", 5.0, "invalid_geometry"),
            FailureRegion("t", 5.5, "raise"),
            FailureRegion("Q_i", 0.17, "nan"),
            FailureRegion("l", 14.5, "mesh_failed"),
        ),
    )
    cfg = make_cfg(pop=24, gens=12)
    best_each_gen = []
    _, state = run(cfg, ev, callbacks=[lambda st, row: best_each_gen.append(best_design(st))])
    recs = state.records
    statuses = {r["status"] for r in recs}
    assert {"ok", "invalid_geometry", "error", "mesh_failed"} <= statuses
    failed = [r for r in recs if r["status"] != "ok"]
    assert state.n_failures == len(failed) and sum(r["n_failures"] for r in state.logbook) == len(failed)
    assert all(r["reason"] and r["f1"] is None and r["F_p"] >= cfg.failure_penalty for r in failed)
    assert any(r["reason"].startswith("RuntimeError: deliberate failure") for r in failed)
    assert any("unusable f1" in r["reason"] for r in failed)
    worst_ok = max(r["F_p"] for r in recs if r["status"] == "ok")
    assert min(r["F_p"] for r in failed) > worst_ok
    inv = sorted((r["alpha"] - 5.0, r["F_p"]) for r in failed if r["status"] == "invalid_geometry")
    assert [fp for _, fp in inv] == sorted(fp for _, fp in inv), "more violation, more penalty"
    assert all(b["feasible"] and b["status"] == "ok" for b in best_each_gen)
    assert all(ind.info["status"] == "ok" for ind in state.hof)


def test_failures_never_best_even_if_their_penalty_is_smaller():
    ev = AnalyticFitness(offset=10.0, failures=(FailureRegion("alpha", 4.0, "solve_failed"),))
    cfg = make_cfg(pop=16, gens=6, failure_penalty=1e-6)  # failures get a smaller F_p than any f1 >= 10
    best_each_gen = []
    _, state = run(cfg, ev, callbacks=[lambda st, row: best_each_gen.append(best_design(st))])
    assert any(r["status"] == "solve_failed" and r["F_p"] < 1.0 for r in state.records)
    assert all(b["feasible"] for b in best_each_gen)


def test_a_run_where_everything_fails_completes():
    ev = AnalyticFitness(failures=(FailureRegion("alpha", 0.0, "invalid_geometry"),))
    cfg = make_cfg(pop=8, gens=4)
    _, state = run(cfg, ev)
    assert state.stop_reason == "max_generations"
    b = best_design(state)
    assert not b["feasible"] and b["status"] == "invalid_geometry" and b["f1"] is None
    assert math.isnan(state.logbook[-1]["mean_fp"]) and state.logbook[-1]["n_feasible"] == 0


def test_cache_serves_repeats_and_each_design_is_solved_once():
    ev = Counting()
    cfg = make_cfg(pop=16, gens=15, ga={"mut_prob": 0.2, "cx_prob": 0.6})
    _, state = run(cfg, ev)
    calls = ev.calls
    assert len(calls) == state.n_evaluations == sum(r["evals"] for r in state.logbook)
    hits = [r for r in state.records if r["cache_hit"]]
    assert len(hits) == state.n_cache_hits == sum(r["cache_hits"] for r in state.logbook) > 0
    keys = [state.cache.key(c) for c in calls]
    assert len(set(keys)) == len(keys), "no rounded genome solved twice"
    assert len(state.records) == state.n_evaluations + state.n_cache_hits
    for r in hits:
        assert r["time_s"] == 0.0
        assert state.cache.key([r[n] for n in GENE_NAMES]) in set(keys)
    for g in range(1, state.generation + 1):  # elites keep their fitness: never re-evaluated
        assert sum(1 for r in state.records if r["generation"] == g) <= cfg.ga.population - cfg.ga.n_elite


def test_coarse_cache_rounding_and_disabled_cache():
    coarse = Counting()
    _, st1 = run(make_cfg(pop=16, gens=8, cache={"decimals": 1}), coarse)
    off = Counting()
    _, st2 = run(make_cfg(pop=16, gens=8, cache={"enabled": False}), off)
    assert st1.n_cache_hits > st2.n_cache_hits == 0
    assert len(off.calls) == len(st2.records)


def test_ga_stream_is_isolated_from_global_rng_use():
    cfg = make_cfg(pop=12, gens=6)

    def noisy(state, row):
        random.random()
        np.random.rand(3)

    _, a = run(cfg, AnalyticFitness(), seed=9)
    random.seed(12345)
    _, b = run(cfg, AnalyticFitness(), seed=9, callbacks=[noisy])
    assert [list(i) for i in a.population] == [list(i) for i in b.population]
    assert [i.fitness.values for i in a.population] == [i.fitness.values for i in b.population]
    _, c = run(cfg, AnalyticFitness(), seed=10)
    assert [list(i) for i in a.population] != [list(i) for i in c.population]


def test_evaluator_outcome_types_are_checked():
    cfg = make_cfg(pop=6, gens=1)
    _, state = run(cfg, _returns_float)
    assert {r["status"] for r in state.records} == {"error"}
    assert "not EvalOutcome" in state.records[0]["reason"]


def _returns_float(genes):
    return 0.5


def test_evaluator_receives_plain_gene_dict():
    got = []

    def ev(genes):
        got.append(genes)
        return EvalOutcome.success(0.1)

    run(make_cfg(pop=4, gens=0), ev)
    assert all(set(g) == set(GENE_NAMES) and all(type(v) is float for v in g.values()) for g in got)


def _run_with_gauge_factor(target, strain, xi, gens=30):
    cfg = make_cfg(pop=20, gens=gens, target=target)
    # the resolution rule off: these runs test the target rule below the resolution
    cfg = cfg.model_copy(update={"stopping": cfg.stopping.model_copy(update={"target_strain": strain,
                                                                           "resolution_generations": 0})})
    ga = GeneticAlgorithm(cfg, 5)
    state = ga.new_state()
    state.extra["fidelity"] = {"preset": "coarse", "f1_resolution": 2e-3, "calibration": xi}
    with SerialExecutor(AnalyticFitness()) as ex:
        ga.run(state, ex)
    return state


@pytest.mark.parametrize("strain", ["uncalibrated", "calibrated"])
def test_target_is_compared_in_the_strain_it_is_given_in(strain):
    """F_p / ξ against target_fp for 'uncalibrated', F_p itself for 'calibrated'; the records carry both."""
    xi, target = 4.0, 1e-4
    state = _run_with_gauge_factor(target, strain, xi)
    bests = [r["best_fp"] for r in state.logbook]
    scaled = [b / xi if strain == "uncalibrated" else b for b in bests]
    first = next(g for g, v in enumerate(scaled) if v <= target)
    assert state.stop_reason == "target_fp" and state.generation == first
    assert all(v > target for v in scaled[:first])
    for rec in state.records:
        if rec["status"] == "ok":
            assert rec["f1_uncalibrated"] == pytest.approx(rec["f1"] / xi, rel=1e-15)
            assert rec["F_p_uncalibrated"] == pytest.approx(rec["F_p"] / xi, rel=1e-15)
    assert state.logbook[-1]["best_fp_uncalibrated"] == pytest.approx(bests[-1] / xi, rel=1e-15)
    best = best_design(state)
    assert best["F_p_uncalibrated"] == pytest.approx(best["F_p"] / xi) and best["f1_uncalibrated"] == pytest.approx(
        best["f1"] / xi)


def test_uncalibrated_target_stops_earlier_than_the_same_number_calibrated():
    unc = _run_with_gauge_factor(1e-4, "uncalibrated", 4.0)
    cal = _run_with_gauge_factor(1e-4, "calibrated", 4.0)
    assert unc.generation < cal.generation


def test_without_a_gauge_factor_the_uncalibrated_columns_stay_empty():
    cfg = make_cfg(pop=6, gens=1)
    ga, state = run(cfg, AnalyticFitness())
    assert all(r["f1_uncalibrated"] is None for r in state.records)
    assert best_design(state)["F_p_uncalibrated"] is None


# ----------------------------------------------------------------------------- the resolution rule
COARSE = {"preset": "coarse", "f1_resolution": 2e-3, "calibration": 3.9}


def _resolution_run(n, gens=30, offset=0.0, fidelity=COARSE):
    cfg = make_cfg(pop=12, gens=gens)
    cfg = cfg.model_copy(update={"stopping": cfg.stopping.model_copy(update={"resolution_generations": n})})
    ga = GeneticAlgorithm(cfg, 4)
    state = ga.new_state()
    if fidelity:
        state.extra["fidelity"] = dict(fidelity)
    with SerialExecutor(AnalyticFitness(scale=0.2, offset=offset)) as ex:
        ga.run(state, ex)
    return state


@pytest.mark.parametrize("n", [1, 5])
def test_resolution_rule_ends_the_run_after_n_generations_of_best_f1_below_the_resolution(n):
    state = _resolution_run(n)
    f1 = [r["best_f1"] for r in state.logbook]
    first = next(g for g, v in enumerate(f1) if v < 2e-3)
    assert first > 0, f1  # the initial population is above it: the rule waits for the GA
    assert state.stop_reason == "resolution" and state.generation == first + n - 1, f1
    assert all(v < 2e-3 for v in f1[first:])
    detail = state.extra["stop_detail"]
    assert detail.startswith("resolution: ") and f"stopping.resolution_generations = {n}" in detail
    assert f"({first}..{state.generation};" in detail and "preset coarse" in detail
    # in the strain of target_fp first (uncalibrated by default), calibrated beside it
    assert "f1 resolution ~5.13e-4 uncalibrated (2e-3 calibrated) of preset coarse" in detail


def test_resolution_rule_is_off_at_0_above_the_resolution_and_without_a_fidelity():
    assert _resolution_run(0, gens=12).stop_reason == "max_generations"
    assert _resolution_run(5, gens=12, offset=2.5e-3).stop_reason == "max_generations"  # f1 >= 2.5e-3 > 2e-3
    assert _resolution_run(5, gens=12, fidelity=None).stop_reason == "max_generations"


def test_resolution_stop_is_said_in_the_log_report_and_best_json(tmp_path, caplog):
    import json
    import logging

    from whisker_opt.optimise.runner import run_optimisation
    from whisker_opt.report import report

    cfg = OptimiserConfig.model_validate({"ga": {"population": 12}, "stopping": {
        "max_generations": 40, "target_fp": 1e-6, "resolution_generations": 3}, "executor": {"kind": "serial"}})
    run_dir = tmp_path / "run"
    with caplog.at_level(logging.INFO, logger="whisker_opt"):
        s = run_optimisation(cfg, run_dir, AnalyticFitness(scale=0.2), seed=4, progress=False, fidelity=COARSE)
    assert s.stop_reason == "resolution"
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    # before the run: target_fp 1e-6 uncalibrated (3.9e-6 calibrated) lies below the resolution
    assert any(m.startswith("stopping.target_fp = 1e-06 (uncalibrated strain) lies below the f1 resolution")
               for m in warned), warned
    assert any(m.startswith("run stopped by resolution: ") for m in warned), warned
    best = json.loads((run_dir / "best.json").read_text())
    assert best["stop_reason"] == "resolution" and best["stop_detail"].startswith("resolution: the best design's f1")
    text = report(run_dir)
    assert "status         finished: resolution" in text
    assert "stopped by     resolution: the best design's f1" in text
    assert "WARNING stopping.target_fp = 1e-06" in text and "WARNING best f1" in text


class _Seen(Recorder):
    """A recorder that notes what it is handed, and checks it is the state's last generation."""

    def __init__(self) -> None:
        self.seen: list[int] = []

    def generation(self, state, row) -> None:
        assert row is state.logbook[-1] and row["generation"] == state.generation == len(state.logbook) - 1
        self.seen.append(row["generation"])


@pytest.mark.parametrize("algorithm", ["ga", "nsga2"])
def test_a_recorder_sees_each_generation_once_in_order(algorithm):
    from whisker_opt.optimise.nsga2 import make_algorithm

    cfg = make_cfg(pop=6, gens=4, algorithm=algorithm)
    ga = make_algorithm(cfg, 5)
    state, rec, after = ga.new_state(), _Seen(), []
    with SerialExecutor(AnalyticFitness()) as ex:
        ga.run(state, ex, [lambda st, row: after.append((row["generation"], list(rec.seen)))], recorder=rec)
        assert rec.seen == [0, 1, 2, 3, 4] and state.stop_reason == "max_generations"
        # the recorder hears of a generation before the callbacks do
        assert after == [(g, list(range(g + 1))) for g in range(5)]
        # a run that has stopped hands nothing more; one extended continues after its last generation
        ga.run(state, ex, recorder=rec)
        assert rec.seen == [0, 1, 2, 3, 4]
        ga.cfg = cfg.model_copy(update={"stopping": cfg.stopping.model_copy(update={"max_generations": 6})})
        ga.set_stop(state)
        ga.run(state, ex, recorder=rec)
    assert rec.seen == list(range(7))
