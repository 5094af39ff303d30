"""The aggregator of an evaluation over variants (whisker_opt/optimise/aggregate.py): its reductions against
hand-computed values, every measure reduced over the variants and none taken from one of them, the nominal
design's f1 kept as f1, and the names of what a run minimises."""

from __future__ import annotations

import math

import pytest

from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS
from whisker_opt.experiment.measures import MEASURE_NAMES, MEASURES, measure_values
from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.optimise.aggregate import (REDUCTIONS, AggregateEvaluator, LawVariants, Spread, aggregate_columns,
                                            objective_column, reduce)

GENES = {"alpha": 4.0, "l": 11.0, "t": 2.6, "Q_i": 0.2}

# values 1, 2, 6: mean 3, std (ddof 1) sqrt(((−2)² + (−1)² + 3²)/2) = sqrt(7)
SPREAD = Spread((1.0, 2.0, 6.0), 3.0, math.sqrt(7.0))


def test_the_reductions_are_the_modules_of_their_package_in_order():
    """Every module of whisker_opt/optimise/reductions/ is registered by its NAME, ordered by its ORDER; an
    unknown name is refused in one line listing them all."""
    import importlib
    import pkgutil

    import whisker_opt.optimise.reductions as pkg

    mods = [importlib.import_module(f"{pkg.__name__}.{m.name}") for m in pkgutil.iter_modules(pkg.__path__)]
    assert set(REDUCTIONS) == {m.NAME for m in mods} and len(REDUCTIONS) == len(mods)
    assert tuple(REDUCTIONS)[:3] == ("mean", "worst", "mean_plus_k_std")
    assert all(REDUCTIONS[m.NAME] is m.reduce for m in mods)
    with pytest.raises(ValueError, match=f"reduction 'no_such_reduction' is not one of {', '.join(REDUCTIONS)}$"):
        reduce("no_such_reduction", SPREAD)


def test_every_reduction_against_hand_computed_values():
    assert reduce("mean", SPREAD) == 3.0
    assert reduce("worst", SPREAD) == 6.0  # larger is worse
    assert reduce("worst", SPREAD, worse=-1.0) == 1.0  # smaller is worse (a sensitivity)
    assert reduce("mean_plus_k_std", SPREAD, k=2.0) == pytest.approx(3.0 + 2.0 * math.sqrt(7.0), rel=1e-15)
    assert reduce("mean_plus_k_std", SPREAD, k=0.0) == 3.0
    assert reduce("worst", Spread((1.0, math.nan, 4.0), 2.5, 2.1)) == 4.0  # an unread variant is left out
    assert math.isnan(reduce("worst", Spread((math.nan,), math.nan, math.nan)))


def _outcome(f1, sens, dl, vm, line, centroid):
    """A successful outcome holding every key of a scene evaluator's ``extra`` (so every measure reads):
    sensitivity = eps_c_max / deflection (deflection 1)."""
    readings = {"line": {"intact": line, "trimmed": line + 1e-4}, "centroid": {"intact": centroid,
                                                                             "trimmed": centroid - 1e-4}}
    for k, name in enumerate(n for n in GAUGE_VARIANTS if n not in readings):  # every other registered reading
        readings[name] = {"intact": line * (1.1 + 0.1 * k), "trimmed": centroid * (0.9 - 0.1 * k)}
    return EvalOutcome.success(f1, {"total": 1.0}, {"genes": dict(GENES, Q_i=0.1 + dl / 10), "eps_c_max": sens,
                                                    "eps_i_max": sens + 1e-4, "deflection": 1.0, "delta_l": dl,
                                                    "iterations": 20,
                                                    "von_mises_max": {"intact": vm, "trimmed": vm / 2},
                                                    "readings": readings})


class _Fixed:
    """A stand-in evaluator returning a fixed outcome."""

    def __init__(self, out):
        self.out = out

    def __call__(self, genes):
        return self.out


NOMINAL = _outcome(5e-3, 0.2, 0.5, 0.3, 1e-3, 2e-3)
LAWS = (_outcome(1e-3, 0.1, 1.0, 0.4, 3e-3, 4e-3), _outcome(3e-3, 0.3, 2.0, 0.2, 5e-3, 8e-3))


@pytest.mark.parametrize("reduction", ["mean", "worst"])
def test_every_measure_is_the_reduction_over_the_laws_and_f1_is_the_nominal_designs(reduction):
    variants = LawVariants(tuple(_Fixed(o) for o in LAWS), ("embedded", "sliding"))
    out = AggregateEvaluator(_Fixed(NOMINAL), variants, reduction, f"{reduction}_over_laws")(GENES)
    assert out.ok and out.f1 == 5e-3 and out.extra["delta_l"] == 0.5  # the nominal design's own
    per_law = [measure_values(o, MEASURE_NAMES) for o in LAWS]
    for n in MEASURE_NAMES:
        a, b = per_law[0][n], per_law[1][n]
        smaller_is_worse = MEASURES[n].worse < 0  # the sensitivity
        want = (a + b) / 2 if reduction == "mean" else (min(a, b) if smaller_is_worse else max(a, b))
        assert out.measures[f"{n}_{reduction}_over_laws"] == pytest.approx(want, rel=1e-15), n
    assert out.measures["f1_mean"] == pytest.approx(2e-3, rel=1e-15)
    assert out.measures["f1_std"] == pytest.approx(math.sqrt(2.0) * 1e-3, rel=1e-12)
    assert measure_values(out, ("f1", f"f1_{reduction}_over_laws")) == {
        "f1": 5e-3, f"f1_{reduction}_over_laws": out.measures[f"f1_{reduction}_over_laws"]}
    assert out.extra["variant_evaluations"] == 3  # the nominal design and one per law


def test_a_variant_equal_to_the_nominal_design_is_solved_once_and_a_failed_one_fails_the_genome():
    calls = []

    class Counting(_Fixed):
        def __call__(self, genes):
            calls.append(self)
            return self.out

    nominal = Counting(LAWS[0])
    out = AggregateEvaluator(nominal, LawVariants((nominal, Counting(LAWS[1])), ("embedded", "sliding")),
                             "mean", "mean_over_laws")(GENES)
    assert len(calls) == 2 and out.f1 == 1e-3 and out.extra["variant_evaluations"] == 2
    bad = EvalOutcome.failure("solve_failed", "intact: no convergence", {"total": 1.0})
    out = AggregateEvaluator(_Fixed(NOMINAL), LawVariants((_Fixed(LAWS[0]), _Fixed(bad)), ("embedded", "sliding")),
                             "worst", "worst_over_laws")(GENES)
    assert not out.ok and out.status == "solve_failed"
    assert out.reason == "worst_over_laws: wall law sliding: intact: no convergence"
    with pytest.raises(ValueError, match="AggregateEvaluator.reduction: 'max' is not one of"):
        AggregateEvaluator(_Fixed(NOMINAL), LawVariants((), ()), "max", "x")


def test_the_names_of_what_a_run_minimises():
    plain = OptimiserConfig()
    assert objective_column(plain) == "f1" and aggregate_columns(plain) == ()
    robust = OptimiserConfig.model_validate({"robust": {"k": 2}})
    assert objective_column(robust) == "f1_robust"
    assert aggregate_columns(robust) == ("f1_robust", "f1_mean", "f1_std")
    worst = OptimiserConfig.model_validate({"wall_laws": {"objective": "worst"}})
    assert objective_column(worst) == "f1_worst_over_laws"
    assert objective_column(OptimiserConfig.model_validate({"wall_laws": {}})) == "f1_mean_over_laws"


def test_an_aggregate_survives_the_checkpoint():
    from whisker_opt.optimise.statefile import _outcome, _outcome_data

    out = EvalOutcome("ok", 1e-3, "", {"total": 1.0}, {"delta_l": 0.5}, {"f1_robust": 2e-3, "f1_std": 4e-4})
    back = _outcome(_outcome_data(out, "test"))
    assert back == out
    assert "measures" not in _outcome_data(NOMINAL, "test")  # a single evaluation's entry is unchanged


class _Law:
    """A stand-in evaluator of one wall law: f1 = scale · (α + l/10), every other measure read from the nominal
    outcome's layout; fails for α above ``fail_above``."""

    def __init__(self, scale, fail_above=math.inf):
        self.scale, self.fail_above = scale, fail_above

    def __call__(self, genes):
        if genes["alpha"] > self.fail_above:
            return EvalOutcome.failure("solve_failed", "no convergence", {"total": 0.0})
        f1 = self.scale * (genes["alpha"] + genes["l"] / 10.0)
        return _outcome(f1, 0.1 * self.scale, 1.0, 0.3, 1e-3, 2e-3)


def test_a_ga_run_over_laws_records_f1_and_the_aggregate_it_minimises(tmp_path):
    from whisker_opt.optimise.penalty import dynamic_penalty, penalty_terms
    from whisker_opt.optimise.runner import run_optimisation
    from whisker_opt.output.storage import read_csv

    opt = OptimiserConfig.model_validate({"wall_laws": {"objective": "mean"}, "ga": {"population": 6, "n_elite": 1},
                                          "stopping": {"max_generations": 1}})
    lo, hi = opt.genes.bounds()[0]
    ev = AggregateEvaluator(_Law(1e-3), LawVariants((_Law(1e-3), _Law(3e-3, fail_above=(lo + hi) / 2)),
                                                    ("embedded", "sliding")), "mean", "mean_over_laws")
    run_optimisation(opt, tmp_path / "run", ev, seed=3, progress=False)
    rows = read_csv(tmp_path / "run" / "evaluations.csv")
    ok = [r for r in rows if r["status"] == "ok"]
    failed = [r for r in rows if r["status"] != "ok"]
    assert ok and failed
    for r in ok:
        g = float(r["alpha"]) + float(r["l"]) / 10.0
        genes = {k: float(r[k]) for k in opt.genes.names()}
        assert float(r["f1"]) == pytest.approx(1e-3 * g, rel=1e-15)  # the nominal design's
        assert float(r["f1_mean_over_laws"]) == pytest.approx(2e-3 * g, rel=1e-15)  # (1 + 3)/2 · 1e-3 · g
        assert float(r["F_p"]) == pytest.approx(
            dynamic_penalty(float(r["f1_mean_over_laws"]), genes, penalty_terms(opt))[1], rel=1e-12)
    for r in failed:
        assert r["f1"] == r["f1_mean_over_laws"] == r["f1_mean"] == "" and "wall law sliding" in r["reason"]
