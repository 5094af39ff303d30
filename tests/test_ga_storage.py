"""Results directory: every file written, consistent with the GA state; report and plots."""

from __future__ import annotations

import json
import math

import pytest

from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GENE_NAMES
from whisker_opt.output.plots import plot_convergence, plot_curves
from whisker_opt.optimise.runner import run_optimisation
from whisker_opt.report import report
from whisker_opt.output.storage import read_csv, write_csv, write_json
from tests.analytic_fitness import AnalyticFitness, FailureRegion


def _strict_json(path):
    def _bad(token):
        raise ValueError(f"non-standard JSON token {token} in {path}")

    return json.loads(path.read_text(), parse_constant=_bad)


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("run")
    cfg = OptimiserConfig.model_validate(
        {"ga": {"population": 10}, "stopping": {"max_generations": 5, "target_fp": 0.0}}
    )
    ev = AnalyticFitness(failures=(FailureRegion("alpha", 5.0, "mesh_failed"),), with_curves=True)
    summary = run_optimisation(cfg, run_dir, ev, seed=2, progress=True)
    return cfg, run_dir, summary


def test_run_directory_holds_every_file(finished_run):
    _, run_dir, _ = finished_run
    for name in (
        "optimiser.json", "environment.json", "checkpoint.json", "evaluations.csv", "generations.csv",
        "best.json", "convergence.png", "best_curves.csv", "best_curves.png",
    ):
        assert (run_dir / name).is_file(), name
        assert (run_dir / name).stat().st_size > 0, name
    assert not list(run_dir.glob(".*.tmp"))


def test_tables_match_the_run(finished_run):
    cfg, run_dir, s = finished_run
    evals = read_csv(run_dir / "evaluations.csv")
    assert list(evals[0]) == [
        "eval_id", "generation", *GENE_NAMES, "f1", "kappa_Q_i", "kappa_t", "kappa_alpha", "F_p",
        "f1_uncalibrated", "F_p_uncalibrated", "status", "reason", "time_s", "cache_hit",
    ]
    assert len(evals) == s.n_evaluations + s.n_cache_hits
    assert sum(r["cache_hit"] == "True" for r in evals) == s.n_cache_hits
    failed = [r for r in evals if r["status"] != "ok"]
    assert len(failed) == s.n_failures > 0
    assert all(r["f1"] == "" and r["reason"] for r in failed)
    ok = next(r for r in evals if r["status"] == "ok")
    f1 = float(ok["f1"])  # F_p = f1 + Σ C_j κ_j, recomputed from the table
    assert float(ok["F_p"]) == pytest.approx(
        f1 + 0.5 * float(ok["kappa_Q_i"]) + 0.2 * float(ok["kappa_t"]) + 0.2 * float(ok["kappa_alpha"]), rel=1e-12
    )
    gens = read_csv(run_dir / "generations.csv")
    assert [int(r["generation"]) for r in gens] == list(range(s.generations + 1))
    assert sum(int(r["evals"]) for r in gens) == s.n_evaluations
    assert float(gens[-1]["best_fp"]) == s.best["F_p"]


def test_json_files_are_strict_and_complete(finished_run):
    _, run_dir, s = finished_run
    best = _strict_json(run_dir / "best.json")
    assert best["genes"] == s.best["genes"] and best["F_p"] == s.best["F_p"]
    assert best["stop_reason"] == "max_generations" and best["status"] == "ok"
    env = _strict_json(run_dir / "environment.json")
    assert env["seed"] == 2 and env["libraries"]["deap"] and env["python"]
    meta = _strict_json(run_dir / "optimiser.json")
    assert meta["seed"] == 2 and OptimiserConfig.model_validate(meta["optimiser"]).ga.population == 10
    curves = read_csv(run_dir / "best_curves.csv")
    gap = [abs(float(r["eps_i"]) - float(r["eps_c"])) for r in curves[1:]]
    assert sum(gap) / len(gap) == pytest.approx(best["f1"], rel=1e-9)


def test_report_prints_the_summary_and_rebuilds_plots(finished_run):
    _, run_dir, s = finished_run
    (run_dir / "convergence.png").unlink()
    text = report(run_dir)
    assert (run_dir / "convergence.png").is_file()
    assert "finished: max_generations" in text and "best design" in text and "best designs" in text
    assert "mesh_failed" in text
    for name in GENE_NAMES:
        assert f"{s.best['genes'][name]:.6g}" in text
    assert len([ln for ln in text.splitlines() if ln.strip().startswith(tuple("0123456789"))]) >= s.generations + 1
    # every strain figure says which strain it is in: f1 and F_p calibrated, the target in its own strain
    lines = [ln.strip() for ln in text.splitlines()]
    f1_line = next(ln for ln in lines if ln.startswith("f1 "))
    fp_line = next(ln for ln in lines if ln.startswith("F_p "))
    assert f1_line.startswith(f"f1     {s.best['f1']:.6g} calibrated"), f1_line
    assert fp_line.startswith(f"F_p    {s.best['F_p']:.6g} calibrated"), fp_line
    assert fp_line.endswith("target_fp 0 uncalibrated")  # the fixture's target, no ξ known (analytic evaluator)
    assert any(ln.startswith("rank ") and ln.endswith("(f1, F_p calibrated)") for ln in lines)
    assert "generations (F_p calibrated)" in lines
    from whisker_opt.config.optimiser import StoppingConfig
    from whisker_opt.report import _fp_line

    best = {"F_p": 3.9e-3, "F_p_uncalibrated": 1e-3, "status": "ok", "generation_found": 2, "eval_id": 7}
    assert _fp_line(best, StoppingConfig(target_fp=1e-3), 3.9).strip() == (
        "F_p    0.0039 calibrated (0.001 uncalibrated); ok, generation 2, eval 7; "
        "target_fp 0.001 uncalibrated (0.0039 calibrated)")
    assert _fp_line(best, StoppingConfig(target_fp=3.9e-3, target_strain="calibrated"), 3.9).endswith(
        "target_fp 0.0039 calibrated (0.001 uncalibrated)")


def test_plot_helpers_and_atomic_writers(tmp_path):
    p = plot_curves(tmp_path / "c.png", [0, 1, 2], [0, 1e-3, 2e-3], [0, 1.5e-3, 2.5e-3], "t")
    assert p.read_bytes()[:4] == b"\x89PNG"
    q = plot_convergence(tmp_path / "g.png", [0, 1, 2], [1.0, 0.5, 0.0], [math.nan, 1.0, 0.7], [False, True, True], 1e-3)
    assert q.stat().st_size > 0
    write_json(tmp_path / "x.json", {"a": math.nan, "b": (1.0, math.inf)})
    assert _strict_json(tmp_path / "x.json") == {"a": None, "b": [1.0, None]}
    write_csv(tmp_path / "x.csv", ["a", "b"], [{"a": 0.1, "b": None}, {"a": math.nan}])
    assert read_csv(tmp_path / "x.csv") == [{"a": "0.1", "b": ""}, {"a": "nan", "b": ""}]
    assert not list(tmp_path.glob(".*.tmp"))
