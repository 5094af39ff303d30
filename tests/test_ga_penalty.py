"""Dynamic penalty arithmetic, graded failure penalty, outcomes and the cache key."""

from __future__ import annotations

import math
import pickle

import pytest
from deap import tools

from whisker_opt.optimise.evalcache import EvalCache, evaluation_seed, genome_key
from whisker_opt.optimise.ga import Individual
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.experiment.outcome import FAILURE_STATUSES, EvalOutcome
from whisker_opt.optimise.penalty import dynamic_penalty, failure_penalty, fitness_values, penalise, penalty_terms

GENES = {"alpha": 3.2, "l": 12.0, "t": 5.0, "Q_i": 0.1}


def test_dynamic_penalty_matches_hand_computation():
    terms = penalty_terms(OptimiserConfig())
    f1 = 0.02
    kappas, fp = dynamic_penalty(f1, GENES, terms)
    # κ_2 = f1 (Q_i − 0.01)/(0.2 − 0.01); κ_3 = f1 (6 − t)/(6 − 2); κ_4 = f1 (α − 2.5)/(6 − 2.5)
    k_q = 0.02 * 0.09 / 0.19  # 0.009473684...
    k_t = 0.02 * 1.0 / 4.0  # 0.005
    k_a = 0.02 * 0.7 / 3.5  # 0.004
    assert kappas["Q_i"] == pytest.approx(0.00947368421052632, rel=1e-12)
    assert kappas["Q_i"] == pytest.approx(k_q, rel=1e-12)
    assert kappas["t"] == pytest.approx(k_t, rel=1e-12)
    assert kappas["alpha"] == pytest.approx(k_a, rel=1e-12)
    # F_p = 0.02 + 0.5·0.0094736842 + 0.2·0.005 + 0.2·0.004 = 0.0265368421...
    assert fp == pytest.approx(0.02 + 0.5 * k_q + 0.2 * k_t + 0.2 * k_a, rel=1e-12)
    assert fp == pytest.approx(0.026536842105263158, rel=1e-12)


def test_penalty_at_preferred_bounds_and_configurable_direction():
    terms = penalty_terms(OptimiserConfig())
    best_corner = {"alpha": 2.5, "l": 10.0, "t": 6.0, "Q_i": 0.01}
    worst_corner = {"alpha": 6.0, "l": 10.0, "t": 2.0, "Q_i": 0.2}
    assert dynamic_penalty(0.1, best_corner, terms)[1] == pytest.approx(0.1)
    assert dynamic_penalty(0.1, worst_corner, terms)[1] == pytest.approx(0.1 * (1 + 0.5 + 0.2 + 0.2))
    assert dynamic_penalty(0.0, worst_corner, terms)[1] == 0.0  # a perfect match is never penalised
    flipped = OptimiserConfig.model_validate(
        {"penalties": [{"gene": "l", "prefer": "high", "weight": 1.0}], "genes": {"l": [10, 14]}}
    )
    kap, fp = dynamic_penalty(0.5, {**GENES, "l": 11.0}, penalty_terms(flipped))
    assert kap == {"l": pytest.approx(0.5 * 0.75)} and fp == pytest.approx(0.5 + 0.375)


def test_failure_penalty_is_graded_and_worse_than_any_feasible():
    base = 1e3
    ranks = [failure_penalty(s, 0.0, base) for s in FAILURE_STATUSES]
    assert ranks == sorted(ranks) and len(set(ranks)) == len(ranks)
    assert ranks[0] == pytest.approx(base + base / 10)
    # further outside the feasible region is worse, but never crosses into the next kind
    v = [failure_penalty("invalid_geometry", x, base) for x in (0.0, 0.5, 3.0, 1e9)]
    assert v == sorted(v) and v[-1] <= failure_penalty("error", 0.0, base)
    assert failure_penalty("mesh_failed", math.nan, base) == failure_penalty("mesh_failed", 0.0, base)
    terms = penalty_terms(OptimiserConfig())
    worst_feasible = penalise(EvalOutcome.success(10.0), {"alpha": 6, "l": 10, "t": 2, "Q_i": 0.2}, terms, base)
    failed = penalise(EvalOutcome.failure("timeout", "slow"), GENES, terms, base)
    assert worst_feasible.feasible and not failed.feasible
    assert failed.fp > worst_feasible.fp and failed.kappas == {} and failed.f1 is None


def test_failures_rank_below_feasible_even_with_a_tiny_base():
    """Ranking is lexicographic on (infeasible, F_p): a failure cannot be best whatever its F_p."""
    terms = penalty_terms(OptimiserConfig())
    good = Individual([3.0, 12.0, 4.0, 0.05])
    bad = Individual([3.0, 12.0, 4.0, 0.06])
    good.fitness.values = fitness_values(penalise(EvalOutcome.success(5.0), GENES, terms, 1e3))
    bad.fitness.values = fitness_values(penalise(EvalOutcome.failure("error", "x"), GENES, terms, 1e-6))
    assert bad.fitness.values[1] < good.fitness.values[1]
    assert good.fitness > bad.fitness
    assert tools.selBest([bad, good], 1)[0] is good
    hof = tools.HallOfFame(1)
    hof.update([bad, good])
    assert hof[0] == good


def test_outcome_validation_and_pickling():
    with pytest.raises(ValueError, match="status"):
        EvalOutcome("exploded")
    with pytest.raises(ValueError):
        EvalOutcome.failure("ok", "not a failure")
    for bad in (EvalOutcome("ok", math.nan), EvalOutcome("ok", -1.0), EvalOutcome("ok", None)):
        v = bad.validated()
        assert v.status == "error" and "unusable f1" in v.reason
    out = EvalOutcome.success(0.25, timings={"solve": 1.0}, extra={"violation": 0.0}).with_timing(eval_s=2.0)
    assert out.ok and out.validated() is out
    assert pickle.loads(pickle.dumps(out)) == out
    assert out.timings == {"solve": 1.0, "eval_s": 2.0}


def test_cache_key_rounding_and_seed():
    assert genome_key([3.00000049, -0.0, 0.1234567], 6) == (3.0, 0.0, 0.123457)
    assert genome_key([3.0000004], 6) == genome_key([2.9999996], 6)
    k = genome_key([3.0, 12.0, 4.0, 0.05], 6)
    assert evaluation_seed(1, k) == evaluation_seed(1, k) != evaluation_seed(2, k)
    cache = EvalCache(decimals=3, cache_failures=False)
    cache.put(cache.key([1.0001]), EvalOutcome.success(1.0))
    cache.put(cache.key([2.0]), EvalOutcome.failure("timeout", "slow"))
    assert cache.get(cache.key([1.0004])).f1 == 1.0
    assert cache.get(cache.key([2.0])) is None and len(cache) == 1
    again = EvalCache.from_state(pickle.loads(pickle.dumps(cache.to_state())))
    assert again.entries == cache.entries and again.decimals == 3
    off = EvalCache(enabled=False)
    off.put((1.0,), EvalOutcome.success(1.0))
    assert off.get((1.0,)) is None
