"""Named measures and the open genome: each measure against an independent computation from the scenes,
bad names and bounds refused in one line, extra genes reaching the design and the material, a GA and an
NSGA-II with an added gene / a measure objective end to end on the coarse preset, and the optimum of a GA with an
added gene re-evaluated in every gene by verify, the wall-law spread and ``api.evaluate``."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from pydantic import ValidationError

from whisker_opt.api import load_config
from whisker_opt.config.model import format_validation_error
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS
from whisker_opt.experiment.measures import MEASURE_NAMES, MEASURES, measure, measure_values
from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.genes import GENE_NAMES, gene_keys

REPO = Path(__file__).resolve().parents[1]
GENES = {"alpha": 2.862, "l": 15.0, "t": 3.0, "Q_i": 0.1}


def _coarse_cfg(**optimiser):
    return load_config({"fidelity": {"preset": "coarse"}, "optimiser": {"trim": 5.0, **optimiser}})


@pytest.fixture(scope="module")
def evaluated():
    """One coarse evaluation with its curves, and its two scenes solved again with their states kept."""
    import whisker_opt.wiring as wiring
    from whisker_opt.experiment.scene import run_scene

    ev = wiring.evaluator(_coarse_cfg(), keep_curves=True)
    out = ev(GENES)
    assert out.ok, out.reason
    intact, trimmed = ev.specs(GENES)
    scenes = {"intact": run_scene(intact, keep_states=True), "trimmed": run_scene(trimmed, keep_states=True)}
    return out, scenes


def test_each_measure_against_the_scenes(evaluated):
    from whisker_opt.output.scenes import state_fields

    out, scenes = evaluated
    eps_i, eps_c, delta = (np.asarray(out.extra[k]) for k in ("eps_i", "eps_c", "delta"))
    assert measure("f1")(out) == pytest.approx(np.abs(eps_i - eps_c).sum() / len(delta), rel=1e-12)
    assert measure("sensitivity")(out) == pytest.approx(eps_c[-1] / delta[-1], rel=1e-12)
    assert delta[-1] == pytest.approx(5.0)
    wm = scenes["intact"].mesh
    tip = wm.node_sets["tip"]
    assert measure("delta_l")(out) == pytest.approx(scenes["intact"].states["pressurised"].u[tip, 0].mean(), rel=1e-9)
    peak = max(np.nanmax(state_fields(r.mesh.mesh, r.states["deflected"], r.problem_of("deflected"))[0]["von_mises"])
               for r in scenes.values())
    assert measure("von_mises_max")(out) == pytest.approx(peak, rel=1e-9)
    assert 0.0 < peak < 10.0  # MPa: a soft rubber deflected by 5 mm
    for v in GAUGE_VARIANTS:
        for s, letter in (("intact", "i"), ("trimmed", "c")):
            solved = scenes[s].eps[v]
            assert measure(f"eps_{letter}_{v}")(out) == pytest.approx(solved[-1], rel=1e-9)
    assert measure("eps_c_line")(out) == pytest.approx(eps_c[-1], rel=1e-9)  # the run's gauge_variant is line
    assert out.extra["genes"] == GENES  # the inputs a measure may read: the genome evaluated


def test_every_measure_has_a_name_unit_and_description():
    assert MEASURE_NAMES[:4] == ("f1", "sensitivity", "delta_l", "von_mises_max")
    assert {f"eps_{s}_{v}" for v in GAUGE_VARIANTS for s in "ic"} <= set(MEASURES)
    for name, m in MEASURES.items():
        assert m.name == name and m.unit and m.description


def test_the_measures_are_the_modules_of_their_package_in_order():
    """Every module of whisker_opt/experiment/measures/ is registered: one measure by its NAME, or a family (the
    gauge readings, eps_<i|c>_<variant> of each registered reading); the modules in the order of their ORDER."""
    import importlib
    import pkgutil

    import whisker_opt.experiment.measures as pkg

    mods = sorted((importlib.import_module(f"{pkg.__name__}.{m.name}") for m in pkgutil.iter_modules(pkg.__path__)),
                  key=lambda m: (m.ORDER, m.__name__))
    names = [f["name"] for m in mods for f in (m.family() if hasattr(m, "family") else [{"name": m.NAME}])]
    assert tuple(names) == MEASURE_NAMES
    single = {m.NAME: m for m in mods if not hasattr(m, "family")}
    for name, m in single.items():
        got = MEASURES[name]
        assert (got.unit, got.description, got.read) == (m.UNIT, m.DESCRIPTION, m.read)
        assert (got.calibrated, got.worse) == (getattr(m, "CALIBRATED", False), getattr(m, "WORSE", 1.0))
    assert MEASURES["sensitivity"].worse == -1.0 and MEASURES["f1"].calibrated and not MEASURES["delta_l"].calibrated


def test_a_failed_or_foreign_outcome_has_no_measure():
    failed = EvalOutcome.failure("solve_failed", "diverged")
    with pytest.raises(ValueError, match="failed"):
        measure("f1")(failed)
    foreign = EvalOutcome.success(0.01)  # an evaluator that fills no extra
    assert measure("f1")(foreign) == 0.01
    with pytest.raises(ValueError, match="sensitivity: the outcome holds no 'eps_c_max'"):
        measure("sensitivity")(foreign)
    got = measure_values(foreign, ("f1", "delta_l"))
    assert got["f1"] == 0.01 and np.isnan(got["delta_l"])
    assert measure_values(failed, ("f1",)) == {"f1": None}


def test_an_unknown_measure_is_refused_in_one_line_listing_the_names():
    with pytest.raises(ValueError) as exc:
        measure("sensitivty")
    msg = str(exc.value)
    assert "\n" not in msg and "'sensitivty'" in msg and all(n in msg for n in MEASURE_NAMES)


def _one_line(data) -> str:
    with pytest.raises(ValidationError) as exc:
        OptimiserConfig.model_validate(data)
    msg = format_validation_error(exc.value, "run.yaml", {"optimiser": data})
    assert len(msg.splitlines()) == 1, msg
    return msg


def test_bad_objective_gene_and_bounds_are_refused_in_one_line():
    msg = _one_line({"algorithm": "nsga2", "objectives": ["f1", "sensitvity"]})
    assert "'sensitvity'" in msg and "sensitivity" in msg and "delta_l" in msg
    msg = _one_line({"genes": {"fibre_pich": [2, 4]}})
    assert "'fibre_pich'" in msg and "fibre_pitch" in msg and "C10" in msg
    msg = _one_line({"genes": {"fibre_pitch": [0, 4]}})
    assert "fibre_pitch" in msg and "[0, 4]" in msg and "(0, 100]" in msg
    msg = _one_line({"genes": {"C10": [0.1, 200]}})
    assert "C10" in msg and "(0, 100]" in msg
    msg = _one_line({"genes": {"n_fibres": [1, 3]}})  # an integer: not a real number
    assert "'n_fibres'" in msg
    msg = _one_line({"genes": {"L": [80, 60]}})
    assert "L" in msg and "lo=80" in msg
    msg = _one_line({"algorithm": "nsga2", "objectives": ["f1", "L"]})  # a gene, but not of this genome
    assert "'L'" in msg and "alpha, l, t, Q_i" in msg


def test_the_default_genome_is_unchanged_and_genes_are_added_in_order():
    cfg = OptimiserConfig()
    assert cfg.genes.names() == GENE_NAMES
    assert cfg.genes.bounds() == ((2.5, 6.0), (10.0, 15.0), (2.0, 6.0), (0.01, 0.2))
    cfg = OptimiserConfig.model_validate({"genes": {"fibre_pitch": [2, 4], "C10": {"lo": 0.1, "hi": 0.2}},
                                          "penalties": [{"gene": "fibre_pitch", "prefer": "high", "weight": 0.1}]})
    assert cfg.genes.names() == (*GENE_NAMES, "fibre_pitch", "C10")
    assert cfg.genes.bounds()[4:] == ((2.0, 4.0), (0.1, 0.2))
    again = OptimiserConfig.model_validate(cfg.model_dump())  # a checkpoint's config reads back
    assert again.genes.names() == cfg.genes.names() and again.genes.bounds() == cfg.genes.bounds()
    keys = gene_keys()
    assert {"L", "D", "fibre_pitch", "fibre_radius_frac", "C10", "D1", "wall_slope"} <= set(keys)
    assert "n_fibres" not in keys and "rubber" not in keys


def test_added_genes_reach_the_design_and_the_material():
    import whisker_opt.wiring as wiring

    ev = wiring.evaluator(_coarse_cfg())
    intact, trimmed = ev.specs({**GENES, "fibre_pitch": 2.5, "L": 65.0, "C10": 0.2})
    for s in (intact, trimmed):
        assert (s.design.fibre_pitch, s.design.L, s.c10) == (2.5, 65.0, 0.2)
    assert (intact.Q, trimmed.Q, intact.design.trim, trimmed.design.trim) == (0.1, 0.0, 0.0, 5.0)
    base, _ = ev.specs(GENES)
    assert (base.design.fibre_pitch, base.design.L, base.c10) == (3.0, 70.0, 0.14)


def _run(tmp_path: Path, name: str, *sets: str) -> Path:
    out = tmp_path / name
    args = [sys.executable, "-m", "whisker_opt.cli", "run", str(REPO / "configs" / "demo.yaml"), "--out", str(out),
            "--no-progress", "--set", "optimiser.ga.population=2", "--set", "optimiser.ga.n_elite=0",
            "--set", "optimiser.stopping.max_generations=1", "--set", "optimiser.law_spread_top=0",
            "--set", "optimiser.executor.kind=serial", *(x for s in sets for x in ("--set", s))]
    proc = subprocess.run(args, cwd=REPO, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
def test_a_ga_with_an_added_gene_runs_end_to_end(tmp_path):
    out = _run(tmp_path, "ga", "optimiser.genes.fibre_pitch=[2,4]")
    rows = _rows(out / "evaluations.csv")
    assert list(rows[0])[2:8] == ["alpha", "l", "t", "Q_i", "fibre_pitch", "f1"]
    assert all(2.0 <= float(r["fibre_pitch"]) <= 4.0 for r in rows) and len({r["fibre_pitch"] for r in rows}) > 1
    best = json.loads((out / "best.json").read_text())
    assert list(best["genes"]) == ["alpha", "l", "t", "Q_i", "fibre_pitch"]
    assert "best_fibre_pitch" in _rows(out / "generations.csv")[0]
    scenes = json.loads((out / "best" / "scenes.json").read_text())
    assert scenes["intact"]["genes"]["fibre_pitch"] == pytest.approx(best["genes"]["fibre_pitch"])


@pytest.mark.slow
def test_an_nsga2_over_f1_and_sensitivity_runs_end_to_end(tmp_path):
    out = _run(tmp_path, "mo", "optimiser.algorithm=nsga2", "optimiser.pareto.verify=false",
               "optimiser.objectives=[f1, {name: sensitivity, prefer: high}]")
    rows = _rows(out / "evaluations.csv")
    assert "sensitivity" in rows[0]
    ok = [r for r in rows if r["status"] == "ok"]
    assert ok and all(float(r["sensitivity"]) > 0 for r in ok)
    front = _rows(out / "pareto.csv")
    assert front and "sensitivity" in front[0]
    assert (out / "pareto.png").is_file()


#: A tiny GA of the genome and fibre_pitch (the config's pitch, 3 mm, outside its bounds), with the spread of its best.
ADDED_GENE_RUN = {"fidelity": {"preset": "coarse"}, "seed": 3, "optimiser": {
    "trim": 5.0, "genes": {"fibre_pitch": [2.0, 2.5]}, "law_spread_top": 1, "executor": {"kind": "serial"},
    "ga": {"population": 4, "n_elite": 1, "tournament": 2}, "stopping": {"max_generations": 1}}}


@pytest.fixture(scope="module")
def added_gene_run(tmp_path_factory):
    """A tiny GA over the four genes and ``fibre_pitch`` in [2, 2.5] (the config's pitch is 3), verified at its
    own preset and with the wall-law spread of its best design."""
    from whisker_opt.cli import main as cli

    d = tmp_path_factory.mktemp("added_gene")
    (d / "run.yaml").write_text(yaml.safe_dump(ADDED_GENE_RUN))
    out = d / "run"
    assert cli.main(["run", str(d / "run.yaml"), "--out", str(out), "--no-progress", "--verify", "coarse",
                     "--verify-top", "1"]) == 0
    return out


@pytest.mark.slow
def test_verify_and_the_law_spread_re_evaluate_the_optimum_in_every_gene(added_gene_run):
    out = added_gene_run
    best = json.loads((out / "best.json").read_text())
    genome = ["alpha", "l", "t", "Q_i", "fibre_pitch"]
    assert list(best["genes"]) == genome and 2.0 <= best["genes"]["fibre_pitch"] <= 2.5
    verified = _rows(out / "verify_coarse.csv")
    assert list(verified[0])[2:7] == genome
    assert {g: float(verified[0][g]) for g in genome} == best["genes"]
    assert float(verified[0]["f1_verify"]) == pytest.approx(best["f1"], rel=1e-9)  # the run's preset
    spread = _rows(out / "law_spread.csv")
    assert [r["law"] for r in spread] == ["embedded", "sliding"] and all(r["status"] == "ok" for r in spread)
    assert list(spread[0])[2:7] == genome
    for r in spread:
        assert {g: float(r[g]) for g in genome} == best["genes"]
    assert float(spread[0]["f1"]) == pytest.approx(best["f1"], rel=1e-9)  # its own law: the run's evaluation


@pytest.mark.slow
def test_api_evaluate_takes_an_added_gene_as_the_ga_did(added_gene_run):
    import whisker_opt as wo

    best = json.loads((added_gene_run / "best.json").read_text())
    cfg = wo.load_config(added_gene_run / "config.yaml")
    out = wo.evaluate(cfg, best["genes"])
    assert out.ok and out.f1 == pytest.approx(best["f1"], rel=1e-9)
    in_order = wo.evaluate(cfg, list(best["genes"].values()))  # the values in the genome's order
    assert in_order.f1 == pytest.approx(out.f1, rel=1e-9)
    with pytest.raises(ValueError, match=r"missing \['fibre_pitch'\]"):
        wo.evaluate(cfg, {g: best["genes"][g] for g in GENE_NAMES})
    with pytest.raises(ValueError, match="expected 5 genes"):
        wo.evaluate(cfg, [best["genes"][g] for g in GENE_NAMES])
