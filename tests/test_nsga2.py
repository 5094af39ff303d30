"""The multi-objective mode (NSGA-II) on the analytic fitness: known front, archive, stopping, resume, outputs."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest
from pydantic import ValidationError

from whisker_opt.config.model import format_validation_error
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GENE_NAMES
from whisker_opt.optimise.executors import SerialExecutor
from whisker_opt.optimise.ga import GeneticAlgorithm
from whisker_opt.optimise.nsga2 import HV_REFERENCE, NSGA2, finer_preset, make_algorithm
from whisker_opt.optimise.pareto import dominates, hypervolume, non_dominated
from whisker_opt.optimise.runner import resume_optimisation, run_optimisation
from whisker_opt.report import report
from whisker_opt.output.storage import read_csv
from tests.analytic_fitness import AnalyticFitness, FailureRegion, Hold, Interrupt

REPO = Path(__file__).resolve().parents[1]
X_STAR = (4.2, 11.0, 3.5, 0.15)
Q_LO, Q_HI = 0.01, 0.2


def make_cfg(pop=24, gens=40, objectives=("f1", "Q_i"), stall_n=1000, stall_tol=0.0, **sections) -> OptimiserConfig:
    return OptimiserConfig.model_validate({
        "algorithm": "nsga2", "objectives": list(objectives), "ga": {"population": pop, **sections.pop("ga", {})},
        "stopping": {"max_generations": gens, "stall_generations": stall_n, "stall_tol": stall_tol}, **sections})


def run(cfg, evaluator, seed=1, callbacks=()):
    ga = NSGA2(cfg, seed)
    state = ga.new_state()
    with SerialExecutor(evaluator) as ex:
        ga.run(state, ex, callbacks)
    return ga, state


def _true_hypervolume(scale: float, f1_ref: float) -> float:
    """HV of the exact front of (f1, d_Q) for the analytic bowl, in the run's normalised objectives.

    With every other gene at its optimum, f1 = scale·(d* − d)² for d ∈ [0, d*], d* the optimum's d_Q;
    in z = (f1/f1_ref, d) the front is z1 = c (d* − z2)², c = scale/f1_ref, and against r = (1.1, 1.1)
    HV = 1.1² − 1.1 z0 − c (d* − z0)³/3 with z0 = max(0, d* − sqrt(1.1/c)) (where the front leaves the box).
    """
    ds = (X_STAR[3] - Q_LO) / (Q_HI - Q_LO)
    c = scale / f1_ref
    r = HV_REFERENCE
    z0 = max(0.0, ds - math.sqrt(r / c))
    return r * r - r * z0 - c * (ds - z0) ** 3 / 3.0


@pytest.mark.parametrize("seed", [1, 2])
def test_front_approaches_the_known_front_of_a_convex_pair(seed):
    ev = AnalyticFitness(optimum=X_STAR)
    ga, state = run(make_cfg(), ev, seed=seed)
    assert state.stop_reason == "max_generations" and state.generation == 40
    f1_ref = state.extra["f1_ref"]
    hv_true = _true_hypervolume(ev.scale, f1_ref)
    hv = state.logbook[-1]["hypervolume"]
    # every feasible design lies on or behind the exact front, so its HV is an upper bound
    assert hv <= hv_true + 1e-12
    assert hv >= 0.99 * hv_true, (hv, hv_true)
    ds = (X_STAR[3] - Q_LO) / (Q_HI - Q_LO)
    arch = [state.records[i] for i in state.extra["archive"]]
    d = [(r["Q_i"] - Q_LO) / (Q_HI - Q_LO) for r in arch]
    gap = [(r["f1"] - ev.scale * max(ds - di, 0.0) ** 2) / f1_ref for r, di in zip(arch, d)]
    assert min(gap) >= -1e-12 and max(gap) < 0.03, max(gap)  # near the front everywhere
    assert min(d) < 0.02 and max(d) > 0.95 * ds  # and spread along all of it
    hvs = [r["hypervolume"] for r in state.logbook]
    assert all(b >= a for a, b in zip(hvs, hvs[1:])), "the archive's hypervolume never decreases"


def test_archive_is_the_non_dominated_set_of_every_feasible_evaluation():
    ev = AnalyticFitness(optimum=X_STAR, failures=(FailureRegion("alpha", 5.5),))
    cfg = make_cfg(pop=12, gens=8, objectives=("f1", "Q_i", {"name": "t", "prefer": "high"}))
    ga, state = run(cfg, ev, seed=4)
    assert state.n_failures > 0
    feas = {}
    for r in state.records:
        if r["status"] == "ok":
            feas.setdefault(tuple(r[g] for g in GENE_NAMES), r)
    recs = list(feas.values())
    pts = [(r["f1"], (r["Q_i"] - Q_LO) / (Q_HI - Q_LO), (6.0 - r["t"]) / 4.0) for r in recs]
    want = sorted(recs[i]["eval_id"] for i in non_dominated(pts))
    assert sorted(state.records[i]["eval_id"] for i in state.extra["archive"]) == want
    z = [(p[0] / state.extra["f1_ref"], p[1], p[2]) for p in (pts[i] for i in non_dominated(pts))]
    assert state.logbook[-1]["hypervolume"] == pytest.approx(hypervolume(z, [HV_REFERENCE] * 3), rel=1e-12)
    assert state.logbook[-1]["front_size"] == len(want)


def test_failures_are_dominated_by_every_feasible_design():
    ev = AnalyticFitness(optimum=X_STAR, failures=(FailureRegion("alpha", 4.0),))
    ga, state = run(make_cfg(pop=10, gens=0), ev, seed=3)
    pop = state.population  # generation 0: every drawn design, failures included
    bad = [ind for ind in pop if ind.info["f1"] is None]
    good = [ind for ind in pop if ind.info["f1"] is not None]
    assert bad and good
    assert all(dominates(g.fitness.values, b.fitness.values) for g in good for b in bad)
    assert all(b.fitness.values[0] >= OptimiserConfig().failure_penalty for b in bad)


def test_same_seed_same_run_and_the_initial_draw_is_the_gas():
    ev = AnalyticFitness(optimum=X_STAR)
    cfg = make_cfg(pop=10, gens=5)
    _, a = run(cfg, ev, seed=9)
    _, b = run(cfg, ev, seed=9)
    def strip(recs):
        return [{k: v for k, v in r.items() if k != "time_s"} for r in recs]

    assert strip(a.records) == strip(b.records) and [list(i) for i in a.population] == [list(i) for i in b.population]
    ga = GeneticAlgorithm(OptimiserConfig.model_validate({"ga": {"population": 10}}), 9)
    st = ga.new_state()
    with SerialExecutor(ev) as ex:
        ga.run_generation(st, ex)
    assert [r[g] for r in st.records for g in GENE_NAMES] == [r[g] for r in a.records[:10] for g in GENE_NAMES]
    assert isinstance(make_algorithm(OptimiserConfig(), 1), GeneticAlgorithm)
    assert not isinstance(make_algorithm(OptimiserConfig(), 1), NSGA2)


def test_stall_rule_on_the_hypervolume():
    ga = NSGA2(make_cfg(pop=4, gens=100, stall_n=3, stall_tol=0.01), 1)

    class S:
        generation = 5
        logbook = [{"hypervolume": h} for h in (0.5, 0.9, 0.905, 0.91, 0.912)]

    # window of 3: improvements 0.905/0.9−1, 0.91/0.905−1, 0.912/0.91−1, mean 0.0040 <= 0.01
    assert ga.stop_reason(S) == "stall"
    S.logbook = [{"hypervolume": h} for h in (0.5, 0.6, 0.9, 0.91)]
    assert ga.stop_reason(S) is None  # mean (0.2 + 0.5 + 0.011)/3 > 0.01
    S.logbook = [{"hypervolume": 0.0}] * 4  # no feasible design for the whole window: no improvement
    assert ga.stop_reason(S) == "stall"
    S.logbook, S.generation = [{"hypervolume": 1.0}], 100
    assert ga.stop_reason(S) == "max_generations"


def _tables(run_dir: Path) -> dict[str, list[dict]]:
    skip = {"time_s", "elapsed_s"}
    return {name: [{k: v for k, v in r.items() if k not in skip} for r in read_csv(run_dir / name)]
            for name in ("evaluations.csv", "generations.csv", "pareto.csv")}


def test_interrupted_and_resumed_run_equals_uninterrupted(tmp_path):
    cfg = make_cfg(pop=10, gens=7)
    ev = AnalyticFitness(optimum=X_STAR, failures=(FailureRegion("alpha", 5.5),))
    ref = run_optimisation(cfg, tmp_path / "ref", ev, seed=5, progress=False)
    with pytest.raises(KeyboardInterrupt):
        run_optimisation(cfg, tmp_path / "cut", ev, seed=5, progress=False, callbacks=[Interrupt(3)])
    resumed = resume_optimisation(tmp_path / "cut", ev, progress=False)
    assert (resumed.population, resumed.fitness, resumed.best, resumed.n_evaluations) == (
        ref.population, ref.fitness, ref.best, ref.n_evaluations)
    assert _tables(tmp_path / "ref") == _tables(tmp_path / "cut")
    assert "hypervolume" in read_csv(tmp_path / "ref" / "generations.csv")[0]


def test_extending_a_finished_run_equals_running_to_the_longer_limit(tmp_path):
    ev = AnalyticFitness(optimum=X_STAR)
    run_optimisation(make_cfg(pop=10, gens=4), tmp_path / "ref", ev, seed=5, progress=False)
    longer = run_optimisation(make_cfg(pop=10, gens=6), tmp_path / "long", ev, seed=5, progress=False)
    ext = resume_optimisation(tmp_path / "ref", ev, progress=False, max_generations=6)
    assert (ext.population, ext.fitness, ext.n_evaluations) == (longer.population, longer.fitness, longer.n_evaluations)


def test_pareto_outputs_verification_and_report(tmp_path):
    cfg = make_cfg(pop=10, gens=4)
    ev = AnalyticFitness(optimum=X_STAR)
    run_optimisation(cfg, tmp_path, ev, seed=2, progress=False, fidelity={"preset": "coarse", "f1_resolution": 1e-3})
    for name in ("pareto.csv", "pareto.png", "hypervolume.png"):
        assert (tmp_path / name).is_file(), name
    rows = read_csv(tmp_path / "pareto.csv")
    front = [r for r in rows if r["on_front"] == "True"]
    assert front and all(r["verified_preset"] == "" for r in rows)
    assert sum(r["penalised_optimum"] == "True" for r in rows) == 1
    # the penalised optimum is the design of least F_p among all evaluations
    evals = [r for r in read_csv(tmp_path / "evaluations.csv") if r["status"] == "ok"]
    best = min(evals, key=lambda r: float(r["F_p"]))
    opt = next(r for r in rows if r["penalised_optimum"] == "True")
    assert [float(opt[g]) for g in GENE_NAMES] == [float(best[g]) for g in GENE_NAMES]
    # verify with a "finer" evaluator whose f1 differs: verified values and non-domination recomputed on them
    from whisker_opt.optimise.checkpoint import load_checkpoint
    from whisker_opt.optimise.recorder import verify_front

    finer = AnalyticFitness(optimum=(3.0, 12.0, 4.0, 0.10), offset=1e-4)
    state, _ = load_checkpoint(tmp_path)
    vrows = verify_front(tmp_path, NSGA2(cfg, 2), state, finer, "default")
    rows = read_csv(tmp_path / "pareto.csv")
    assert len(rows) == len(vrows) and all(r["verified_preset"] == "default" for r in rows)
    for r in rows:
        genes = {g: float(r[g]) for g in GENE_NAMES}
        assert float(r["f1_verified"]) == pytest.approx(finer.f1(genes), rel=1e-12)
    pts = [(float(r["f1_verified"]), float(r["Q_i"])) for r in rows]
    want = set(non_dominated(pts))
    assert {i for i, r in enumerate(rows) if r["on_front_verified"] == "True"} == want
    # rows already verified are kept (no evaluator call), and the report shows the front
    verify_front(tmp_path, NSGA2(cfg, 2), state, AnalyticFitness(offset=1.0), "default")
    assert [r["f1_verified"] for r in read_csv(tmp_path / "pareto.csv")] == [r["f1_verified"] for r in rows]
    text = report(tmp_path)
    assert "Pareto front" in text and "verified at preset default" in text and "penalised optimum" in text


def test_spread_keeps_both_ends_and_the_count():
    from whisker_opt.optimise.nsga2 import spread

    assert spread(list(range(10)), 3) == [0, 4, 9]
    assert spread(list(range(10)), 2) == [0, 9]
    assert spread(list(range(10)), 10) == list(range(10)) == spread(list(range(10)), 50)
    for n in range(2, 30):
        for k in range(2, n + 1):
            got = spread(list(range(n)), k)
            assert len(got) == k and got[0] == 0 and got[-1] == n - 1 and got == sorted(set(got))


def test_finer_preset():
    assert finer_preset("coarse") == "default" and finer_preset("default") == "level2"
    assert finer_preset("level2") == "fine" and finer_preset("fine") == "level3"
    assert finer_preset("level4") == "reference"
    assert finer_preset("reference") is None and finer_preset(None) is None


@pytest.mark.parametrize("data, key, words", [
    ({"algorithm": "nsga3"}, "algorithm", "'ga', 'nsga2'"),
    ({"objectives": ["f1"]}, "objectives", "1 objective(s) ['f1']; allowed 2..5 items"),
    ({"objectives": ["Q_i", "t"]}, "objectives", "must include f1"),
    ({"objectives": ["f1", "Q_i", "Q_i"]}, "objectives", "repeated: ['Q_i']"),
    ({"objectives": ["f1", "Q"]}, "objectives.1.name", "name='Q' is neither a measure (f1, sensitivity"),
    ({"objectives": [{"name": "f1", "prefer": "high"}, "Q_i"]}, "objectives.0", "f1 is minimised"),
    ({"objectives": ["f1", {"name": "t", "prefer": "up"}]}, "objectives.1.prefer", "'low', 'high'"),
    ({"pareto": {"verify_max": 0}}, "pareto.verify_max", "0 is outside 1..10000"),
])
def test_config_errors_are_one_line_naming_the_key(data, key, words):
    with pytest.raises(ValidationError) as info:
        OptimiserConfig.model_validate(data)
    text = format_validation_error(info.value, "optimiser")
    assert f"optimiser: {key}:" in text and words in text, text
    assert "\n" not in text.strip(), text


def test_bad_objective_on_the_command_line_is_one_line_exit_2(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("optimiser:\n  algorithm: nsga2\n  objectives: [f1, pressure]\n")
    res = subprocess.run([sys.executable, "-m", "whisker_opt.cli", "run", str(path)], capture_output=True, text=True,
                         cwd=REPO, timeout=120)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "optimiser.objectives.1.name" in lines[0] and "'pressure'" in lines[0], res.stderr
    assert "Traceback" not in res.stderr


def test_sigkilled_run_resumes_to_the_uninterrupted_result(tmp_path):
    import dataclasses
    import json
    import os
    import signal

    from tests import kill_harness as kh
    from whisker_opt.optimise.checkpoint import load_checkpoint

    data = {"algorithm": "nsga2", "ga": {"population": 10}, "executor": {"kind": "serial"},
            "stopping": {"max_generations": 6, "stall_generations": 100, "stall_tol": 0.0}}
    ev = AnalyticFitness(failures=(FailureRegion("alpha", 5.5, "invalid_geometry"),))
    ref = run_optimisation(OptimiserConfig.model_validate(data), tmp_path / "ref", ev, seed=kh.SEED, progress=False)
    cut = tmp_path / "cut"
    (tmp_path / "hold").mkdir()
    hold = Hold(str(tmp_path / "hold"), run_dir=str(cut), generation=2)  # in generation 3
    child = subprocess.Popen([sys.executable, "-c", kh.CHILD, str(cut), json.dumps(data), "0.0", "0.0",
                              str(kh.SEED), json.dumps(dataclasses.asdict(hold))], cwd=REPO,
                             env={**os.environ, "PYTHONPATH": str(REPO)})
    try:
        hold.wait_held(child)
        os.kill(child.pid, signal.SIGKILL)
    finally:
        child.wait(timeout=60)
    assert child.returncode == -signal.SIGKILL
    assert load_checkpoint(cut)[0].generation == 2 and load_checkpoint(cut)[0].stop_reason is None
    resumed = resume_optimisation(cut, ev, progress=False)
    assert (resumed.population, resumed.fitness, resumed.best, resumed.n_evaluations) == (
        ref.population, ref.fitness, ref.best, ref.n_evaluations)
    assert _tables(tmp_path / "ref") == _tables(cut)


class _WithSensitivity(AnalyticFitness):
    """The analytic bowl with a sensitivity ε_c(δ_max)/δ_max = 0.002·l/t [1/mm] (a stand-in measure)."""

    def __call__(self, genes):
        from whisker_opt.experiment.outcome import EvalOutcome

        out = super().__call__(genes)
        if not out.ok:
            return out
        extra = dict(out.extra or {}, eps_c_max=0.01 * genes["l"] / genes["t"], deflection=5.0)
        return EvalOutcome.success(out.f1, timings=out.timings, extra=extra)


def test_the_front_lists_every_objective_and_the_hypervolume_says_what_it_is_measured_in(tmp_path):
    from whisker_opt.optimise.nsga2 import hypervolume_basis, objective_terms

    cfg = make_cfg(pop=8, gens=2, objectives=("f1", {"name": "sensitivity", "prefer": "high"}))
    from whisker_opt.optimise.checkpoint import load_checkpoint

    run_optimisation(cfg, tmp_path, _WithSensitivity(optimum=X_STAR), seed=3, progress=False)
    state, _ = load_checkpoint(tmp_path)
    f1_ref, s_ref = state.extra["f1_ref"], state.extra["measure_refs"]["sensitivity"]
    basis = hypervolume_basis(objective_terms(cfg), state)
    assert basis.startswith("z = (f1 / ") and ", −sensitivity / " in basis
    assert basis.endswith("; reference point z = (1.1, 1.1)")
    assert float(basis.split("f1 / ")[1].split(",")[0]) == pytest.approx(f1_ref, rel=0.01)
    assert float(basis.split("sensitivity / ")[1].split(")")[0]) == pytest.approx(s_ref, rel=0.01)
    # in those coordinates: z_f1 >= 0, z_s >= −(largest sensitivity)/s_ref, so the volume is at most the box's
    s_max = max(float(r["sensitivity"]) for r in state.records if r["status"] == "ok")
    hv = state.logbook[-1]["hypervolume"]
    assert 0 < hv <= HV_REFERENCE * (HV_REFERENCE + s_max / s_ref) + 1e-12
    # the report's front: genes, f1, the sensitivity it optimised (with its unit) and F_p, row by row
    text = report(tmp_path).splitlines()
    k = next(i for i, ln in enumerate(text) if ln.startswith("Pareto front"))
    assert f"hypervolume {hv:.6g} ({basis})" in text[k]
    assert text[k + 1] == "  f1 and F_p in calibrated strain; sensitivity [1/mm]"
    head = next(ln for ln in text[k:] if ln.startswith("  rank "))
    assert head.split()[1:] == [*GENE_NAMES, "f1", "sensitivity", "F_p", "note"]
    front = read_csv(tmp_path / "pareto.csv")
    rows = text[text.index(head) + 1:text.index(head) + 1 + len(front)]
    for line, r in zip(rows, front):
        cells = line.split()
        assert float(cells[6]) == pytest.approx(float(r["sensitivity"]), rel=1e-3)
        assert float(cells[6]) == pytest.approx(0.002 * float(r["l"]) / float(r["t"]), rel=1e-3)
