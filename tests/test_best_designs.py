"""The best designs of a run, pairwise distinct by ``optimiser.distinct_distance``: one home
(:mod:`whisker_opt.optimise.best`) behind the report, ``best.json``, ``verify --top``, robustness and
``view --rank``; checked on handmade records with near-copies and on converged analytic GA runs,
whose hall of fame holds near-copies of the optimum."""

from __future__ import annotations

import itertools
import json

import pytest

from whisker_opt.config.model import ConfigError
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GENE_NAMES
from whisker_opt.optimise.best import best_designs, gene_distance, run_best_designs
from whisker_opt.optimise.executors import SerialExecutor
from whisker_opt.optimise.ga import GeneticAlgorithm
from whisker_opt.optimise.runner import run_optimisation
from whisker_opt.report import report
from tests.analytic_fitness import AnalyticFitness

BOUNDS = OptimiserConfig().genes.bounds()


def _rec(i, x, fp, status="ok"):
    return {"eval_id": i, "generation": 0, **dict(zip(GENE_NAMES, x)), "f1": fp / 2, "F_p": fp, "status": status}


def _pairwise_min(designs) -> float:
    vecs = [[d["genes"][g] for g in GENE_NAMES] for d in designs]
    return min(gene_distance(a, b, BOUNDS) for a, b in itertools.combinations(vecs, 2))


def test_near_copies_of_the_best_are_not_listed_twice():
    # the optimum and four near-copies (0.2 % .. 1.5 % of a gene's range away), then three far designs
    opt = [4.0, 12.0, 3.0, 0.1]
    span = [hi - lo for lo, hi in BOUNDS]
    recs = [_rec(0, opt, 1e-4)]
    for k, frac in enumerate((0.002, 0.005, 0.01, 0.015), start=1):
        recs.append(_rec(k, [x + frac * s for x, s in zip(opt, span)], 1e-4 * (1 + k / 10)))
    far = [[3.0, 11.0, 5.0, 0.05], [5.5, 14.0, 2.5, 0.15], [2.8, 10.5, 4.0, 0.02]]
    recs += [_rec(10 + k, x, 1e-3 * (k + 1)) for k, x in enumerate(far)]
    recs.append(_rec(20, [x + 0.5 * s for x, s in zip(far[0], span)][:4], 5e-5, status="solve_failed"))
    recs.append({**recs[0], "eval_id": 21})  # a cache hit of the optimum

    got = best_designs(recs, BOUNDS, n=4, distance=0.02)
    assert [d["eval_id"] for d in got] == [0, 10, 11, 12]  # the optimum, then the far ones
    assert _pairwise_min(got) >= 0.02
    assert got[0]["distance_to_better"] is None and all(d["distance_to_better"] >= 0.02 for d in got[1:])
    assert [d["rank"] for d in got] == [1, 2, 3, 4]
    # a smaller distance lets in the copy 1 % away, not the one 1.5 % away (0.5 % from that one)
    got = best_designs(recs, BOUNDS, n=4, distance=0.008)
    assert [d["eval_id"] for d in got] == [0, 3, 10, 11] and _pairwise_min(got) >= 0.008
    # distance 0: every genome once (the cache hit is no second design), failures never
    got = best_designs(recs, BOUNDS, n=100, distance=0.0)
    assert sorted(d["eval_id"] for d in got) == [0, 1, 2, 3, 4, 10, 11, 12]
    # fewer distinct designs than asked for: fewer returned
    assert len(best_designs(recs, BOUNDS, n=10, distance=0.5)) == 2


def test_greedy_each_design_is_the_best_one_far_enough_from_the_better_ones():
    import random

    rng = random.Random(4)
    recs = [_rec(i, [lo + (hi - lo) * rng.random() for lo, hi in BOUNDS], rng.random()) for i in range(300)]
    got = best_designs(recs, BOUNDS, n=12, distance=0.15)
    assert len(got) == 12 and _pairwise_min(got) >= 0.15
    taken = []
    for r in sorted(recs, key=lambda r: r["F_p"]):
        x = [r[g] for g in GENE_NAMES]
        if all(gene_distance(x, t, BOUNDS) >= 0.15 for t in taken):
            taken.append(x)
    assert [[d["genes"][g] for g in GENE_NAMES] for d in got] == taken[:12]


def test_bad_arguments_and_config_values_name_the_range():
    with pytest.raises(ValueError, match=r"distance=1.5 outside the allowed range \[0, 1\]"):
        best_designs([], BOUNDS, 3, 1.5)
    with pytest.raises(ValueError, match="n=0"):
        best_designs([], BOUNDS, 0, 0.02)
    import whisker_opt as wo

    with pytest.raises(ConfigError, match=r"optimiser.distinct_distance.*-0.1.*\[0, 1\]"):
        wo.load_config({"optimiser": {"distinct_distance": -0.1}})
    assert OptimiserConfig().distinct_distance == 0.02


def _converged_run(tmp_path, distance=0.02):
    """A GA converged on the analytic bowl: its hall of fame crowds round the optimum."""
    cfg = OptimiserConfig.model_validate({"ga": {"population": 16, "hall_of_fame": 8},
                                          "stopping": {"max_generations": 25, "target_fp": 0.0},
                                          "distinct_distance": distance, "executor": {"kind": "serial"}})
    run = tmp_path / "run"
    run_optimisation(cfg, run, AnalyticFitness(), seed=2, progress=False)
    return cfg, run


def test_a_converged_run_lists_distinct_designs_where_its_hall_of_fame_holds_near_copies(tmp_path):
    cfg, run = _converged_run(tmp_path)
    from whisker_opt.optimise.runner import load_run

    state = load_run(run)[0]
    hof = [[float(x) for x in ind] for ind in state.hof]
    assert min(gene_distance(a, b, BOUNDS) for a, b in itertools.combinations(hof, 2)) < 0.02  # near-copies
    listed = run_best_designs(state, cfg)
    assert len(listed) == 8 and _pairwise_min(listed) >= 0.02
    assert listed[0]["genes"] == dict(zip(GENE_NAMES, hof[0]))  # the run's best design first
    best = json.loads((run / "best.json").read_text())
    assert best["distinct_distance"] == 0.02
    assert [d["genes"] for d in best["best_designs"]] == [d["genes"] for d in listed]
    text = report(run)
    assert "best designs   8 of at most 8, pairwise >= 0.02 apart" in text
    rows = text.split("best designs")[1].splitlines()[2:10]
    assert [int(r.split()[0]) for r in rows] == list(range(1, 9))


def test_verify_robustness_and_view_rank_take_the_same_designs(tmp_path, monkeypatch):
    from whisker_opt import robustness as rb
    from whisker_opt import wiring
    from whisker_opt.analysis.verify import verify_run
    from whisker_opt.viewer.evaluations import evaluation_row

    cfg, run = _converged_run(tmp_path)
    (run / "config.yaml").write_text("fidelity: {preset: coarse}\noptimiser: {ga: {hall_of_fame: 8}}\n")
    monkeypatch.setattr(wiring, "evaluator", lambda *a, **k: AnalyticFitness())  # no FE: the same bowl
    listed = json.loads((run / "best.json").read_text())["best_designs"]
    rows = verify_run(run, "default", top=3, progress=False)
    assert [{g: r[g] for g in GENE_NAMES} for r in rows] == [d["genes"] for d in listed[:3]]
    assert _pairwise_min([{"genes": {g: r[g] for g in GENE_NAMES}} for r in rows]) >= 0.02
    assert all(r["f1_verify"] == pytest.approx(r["f1_run"]) for r in rows)
    studied = rb.run_designs(run, 3)
    assert [d.genes for d in studied] == [d["genes"] for d in listed[:3]]
    for k in (1, 2, 3):
        row = evaluation_row(run, rank=k)
        assert int(row["eval_id"]) == listed[k - 1]["eval_id"]


def test_ga_run_without_a_feasible_design_lists_none(tmp_path):
    from tests.analytic_fitness import FailureRegion

    cfg = OptimiserConfig.model_validate({"ga": {"population": 4, "n_elite": 1}, "stopping": {"max_generations": 0}})
    ga = GeneticAlgorithm(cfg, 1)
    state = ga.new_state()
    with SerialExecutor(AnalyticFitness(failures=(FailureRegion("alpha", 0.0),))) as ex:
        ga.run(state, ex)
    assert run_best_designs(state, cfg) == []


def test_a_run_recorded_before_the_new_keys_resumes_as_unchanged(tmp_path):
    """A run directory of the previous version records no distinct_distance nor resolution_generations:
    its unedited config.yaml is the same config (the new keys at their defaults), an edited one is not."""
    import copy

    import whisker_opt as wo
    from whisker_opt.optimise.rundir import ConfigChanged, check_config, config_digest

    cfg = wo.load_config({"fidelity": {"preset": "coarse"}, "optimiser": {"ga": {"population": 6}}})
    new = cfg.model_dump(mode="json")
    old = copy.deepcopy(new)
    del old["optimiser"]["distinct_distance"], old["optimiser"]["stopping"]["resolution_generations"]
    extra = {"run_config": old, "run_config_sha256": config_digest(old)}
    assert check_config(tmp_path, extra, 3, new, cfg.optimiser, allow=False) is None
    edited = copy.deepcopy(new)
    edited["optimiser"]["ga"]["population"] = 8
    with pytest.raises(ConfigChanged, match="optimiser.ga.population: 6 -> 8"):
        check_config(tmp_path, extra, 3, edited, cfg.optimiser, allow=False)
