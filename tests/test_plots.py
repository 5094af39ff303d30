"""Plots and the fidelity in every output: integer ticks, the residual panel, the uncompensated
curve, the compensation figures' labels, the preset and its f1 resolution in titles, report and
best.json, and the warning when a run's best F_p lies below that resolution."""

from __future__ import annotations

import json
import logging
import math

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.ticker import MultipleLocator

from geometry.design import WhiskerDesign
from whisker_opt.analysis import compensation as comp
from whisker_opt.analysis.beam import BeamModel, BeamResponse, BeamSensitivity
from whisker_opt.config.model import FidelityConfig
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.experiment import fidelity, objective
from whisker_opt.optimise.runner import run_optimisation
from whisker_opt.report import report
from whisker_opt.output import compensation as comp_io
from whisker_opt.output.plots import (convergence_figure, curves_figure, fidelity_label, short_float,
                                      write_best_curves)
from whisker_opt.output.storage import read_csv
from tests.analytic_fitness import AnalyticFitness

COARSE = {"preset": "coarse", "f1_resolution": 2e-3, "calibration": 3.9}


def _tick_labels(ax, axis="x"):
    FigureCanvasAgg(ax.figure).draw()
    labels = ax.get_xticklabels() if axis == "x" else ax.get_yticklabels()
    return [t.get_text().replace("\u2212", "-") for t in labels if t.get_text()]


def _all_text(fig) -> str:
    FigureCanvasAgg(fig).draw()
    parts = [t.get_text() for t in fig.findobj(lambda o: hasattr(o, "get_text"))]
    return "\n".join(p for p in parts if p)


# ----------------------------------------------------------------------------- fidelity presets
def test_presets_carry_a_measured_f1_resolution():
    res = {n: p.f1_resolution for n, p in fidelity.PRESETS.items()}
    assert math.isnan(res.pop("reference"))  # the finest level: no finer mesh, no resolution claimed
    assert res == {"coarse": 2e-3, "default": 2e-3, "level2": 9e-4, "fine": 7e-4, "level3": 7e-4,
                   "level4": 4e-4}  # the figures of benchmarks/results/f1_convergence.md
    assert fidelity.f1_resolution("default", calibration=1.0) == pytest.approx(2e-3 / 3.9)
    assert fidelity.describe(FidelityConfig(preset="coarse")) == COARSE
    over = fidelity.describe(FidelityConfig(preset="fine", n_deflection_steps=20), calibration=3.9)
    assert over["overrides"] == {"n_deflection_steps": 20} and over["f1_resolution"] == 7e-4
    assert "(overridden)" in fidelity_label(over) and "~7e-4" in fidelity_label(over)
    assert fidelity_label(None) == "fidelity preset not recorded"


# ----------------------------------------------------------------------------- convergence
@pytest.mark.parametrize("n_gen", [1, 3, 8, 51])
def test_convergence_ticks_are_whole_generations(n_gen):
    g = list(range(n_gen))
    best = [1e-2 / (k + 1) for k in g]
    fig = convergence_figure(g, best, [2 * b for b in best], [True] * n_gen, 1e-3, "GA convergence", COARSE)
    ax = fig.axes[0]
    labels = _tick_labels(ax)
    assert labels and all(lab.lstrip("-").isdigit() for lab in labels), labels
    shown = [float(x) for x in ax.get_xticks() if ax.get_xlim()[0] <= x <= ax.get_xlim()[1]]
    assert all(x == int(x) for x in shown)
    title = ax.get_title()
    assert "preset coarse" in title and "~2e-3" in title
    assert "calibrated strain" in ax.get_ylabel() and "generation" in ax.get_xlabel()


# ----------------------------------------------------------------------------- best curves
def _curves(n=101):
    d = np.linspace(0.0, 5.0, n)
    eps_i = 0.015 * d
    eps_c = eps_i - 4e-4 * d
    eps_u = 1.2 * eps_i
    return d, eps_i, eps_c, eps_u


def test_curves_figure_has_a_residual_panel_whose_mean_is_f1():
    d, a, c, u = _curves()
    fig = curves_figure(d, a, c, "best design: α = 3°, trim Δ = 5 mm", u, COARSE)
    top, res = fig.axes
    assert "ε_i − ε_c" in res.get_ylabel() and "δ" in res.get_xlabel() and "[mm]" in res.get_xlabel()
    line = next(ln for ln in res.get_lines() if ln.get_label() == "ε_i − ε_c")
    np.testing.assert_allclose(line.get_ydata(), a - c)
    f1 = objective.f1(a[1:], c[1:])
    assert f"= {short_float(f1, 2)} (calibrated strain)" in res.get_title()
    f1_lines = [ln for ln in res.get_lines() if ln.get_label().startswith("f1 = mean")]
    assert len(f1_lines) == 1 and f1_lines[0].get_ydata()[0] == pytest.approx(f1)  # residual one-signed
    labels = [ln.get_label() for ln in top.get_lines()]
    assert any(lab.startswith("ε_u trimmed") for lab in labels) and len(top.get_lines()) == 3
    assert "trim Δ = 5 mm" in top.get_title() and "preset coarse" in top.get_title()
    assert "calibrated strain" in top.get_ylabel()


def test_curves_figure_without_the_uncompensated_curve():
    d, a, c, _ = _curves()
    top, _ = curves_figure(d, a, c, "t").axes
    assert len(top.get_lines()) == 2 and "fidelity preset not recorded" in top.get_title()


def test_best_curves_csv_adds_eps_u_only_when_given(tmp_path):
    d, a, c, u = _curves(11)
    (tmp_path / "a").mkdir()
    write_best_curves(tmp_path / "a", d, a, c)
    assert list(read_csv(tmp_path / "a" / "best_curves.csv")[0]) == ["delta_mm", "eps_i", "eps_c"]
    (tmp_path / "b").mkdir()
    write_best_curves(tmp_path / "b", d, a, c, "t", u, COARSE)
    rows = read_csv(tmp_path / "b" / "best_curves.csv")
    assert list(rows[0]) == ["delta_mm", "eps_i", "eps_c", "eps_u"]
    assert float(rows[-1]["eps_u"]) == pytest.approx(u[-1])
    assert (tmp_path / "b" / "best_curves.png").read_bytes()[:4] == b"\x89PNG"


# ----------------------------------------------------------------------------- compensation figures
@pytest.fixture(scope="module")
def table():
    return comp.compensation_table(WhiskerDesign(), 0.2, 7.0, BeamResponse(), step=1.0, method="root", xatol=1e-6,
                                   analytic_model=BeamModel())


def test_compensation_figure_labels_bounds_target_and_preset(table):
    lower = [r.trim for r in table.rows if r.at_bound == "lower"]
    assert lower  # the beam stand-in vents fully at the largest trims
    fig = comp_io.table_figure(table, fidelity=COARSE)
    ax1, ax2 = fig.axes
    assert isinstance(ax1.xaxis.get_major_locator(), MultipleLocator)
    labels = _tick_labels(ax1)
    assert labels and all(lab.lstrip("-").isdigit() for lab in labels), labels
    marks = [ln for ln in ax1.get_lines() if "at its bound 0" in ln.get_label()]
    assert len(marks) == 1 and list(marks[0].get_xdata()) == lower
    assert any("at its bound" in ln.get_label() for ln in ax2.get_lines())
    text = _all_text(fig)
    assert "85 % recovery" in text and "preset coarse" in text and "Q_i = 0.2 MPa" in text
    assert f"Q = 0 for Δ = {', '.join(f'{x:g}' for x in lower)} mm" in text
    assert "[MPa]" in ax1.get_ylabel() and "[%]" in ax2.get_ylabel() and "[mm]" in ax1.get_xlabel()


def test_compensation_figure_keeps_fractional_trims():
    t = comp.compensation_table(WhiskerDesign(), 0.2, 3.0, BeamResponse(), step=1.5, method="root", xatol=1e-6)
    ax1 = comp_io.table_figure(t).axes[0]
    assert not isinstance(ax1.xaxis.get_major_locator(), MultipleLocator)


def test_sensitivity_comparison_figure_has_title_and_units(tmp_path):
    cmp = comp.compare_sensitivity(WhiskerDesign(), BeamSensitivity(), a_values=[0.5, 1.0], Q_values=[0.0, 0.2])
    fig = comp_io.comparison_figure(cmp, COARSE, delta_ref=1.0)
    assert "beam model vs FE" in fig.get_suptitle() and "preset coarse" in fig.get_suptitle()
    assert "δ = 1 mm" in fig.get_suptitle()
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "Q = 0.2 MPa" in legend and "beam model" in legend and "FE, preset coarse" in legend
    assert "[1/mm]" in fig.axes[0].get_ylabel()
    paths = comp_io.write_comparison(tmp_path, cmp, fidelity=COARSE, delta_ref=1.0)
    assert paths["png"].stat().st_size > 1000


# ----------------------------------------------------------------------------- runs
def _cfg(target_fp: float, gens: int = 2) -> OptimiserConfig:
    return OptimiserConfig.model_validate({"ga": {"population": 6, "n_elite": 1},
                                           "stopping": {"max_generations": gens, "target_fp": target_fp},
                                           "executor": {"kind": "serial"}})


def test_report_and_best_json_name_the_preset_and_resolution(tmp_path):
    run = tmp_path / "run"
    run_optimisation(_cfg(0.0), run, AnalyticFitness(with_curves=True), seed=1, progress=False,
                     fidelity=fidelity.describe(FidelityConfig(preset="default")))
    best = json.loads((run / "best.json").read_text())
    assert best["fidelity"] == {"preset": "default", "f1_resolution": 2e-3, "calibration": 3.9}
    text = report(run)
    line = next(ln for ln in text.splitlines() if ln.startswith("fidelity"))
    assert "preset default" in line and "f1 resolution ~2e-3" in line


def test_a_run_without_a_recorded_fidelity_says_so(tmp_path):
    run = tmp_path / "run"
    run_optimisation(_cfg(0.0, gens=0), run, AnalyticFitness(), seed=1, progress=False)
    assert json.loads((run / "best.json").read_text())["fidelity"] is None
    assert "fidelity       not recorded" in report(run)


def test_target_stop_below_the_resolution_warns(tmp_path, caplog):
    # a coarse, demo-like tiny run whose analytic f1 falls below coarse's resolution at once
    run = tmp_path / "run"
    ev = AnalyticFitness(scale=1e-3)
    with caplog.at_level(logging.WARNING, logger="whisker_opt"):
        s = run_optimisation(_cfg(1e-3, gens=5), run, ev, seed=1, progress=False, fidelity=COARSE)
    assert s.stop_reason == "target_fp" and s.best["F_p"] < 2e-3
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    # f1 and the resolution in the strain of target_fp (uncalibrated) first, calibrated beside it
    f1 = s.best["f1"]
    said = (f"best f1 {short_float(f1 / 3.9, 2)} uncalibrated ({short_float(f1, 2)} calibrated) is below the f1 "
            f"resolution ~{short_float(2e-3 / 3.9, 2)} uncalibrated (2e-3 calibrated) of preset coarse")
    assert any(said in m and "verify at a finer preset" in m for m in warned), warned
    text = report(run)
    assert f"WARNING {said}" in text
    assert "stopped on target_fp" in text and "--preset level4" in text


def test_no_warning_above_the_resolution(tmp_path, caplog):
    run = tmp_path / "run"
    with caplog.at_level(logging.WARNING, logger="whisker_opt"):
        s = run_optimisation(_cfg(0.0, gens=1), run, AnalyticFitness(offset=5e-3), seed=1, progress=False,
                             fidelity=COARSE)
    assert s.best["F_p"] > 2e-3
    assert not [r for r in caplog.records if "f1 resolution" in r.getMessage()]
    assert "WARNING" not in report(run)
    assert math.isfinite(s.best["F_p"])


# ----------------------------------------------------------------------------- what a run optimises
def test_ga_convergence_shows_the_best_design_s_f1_against_the_resolution():
    fig = convergence_figure([0, 1, 2], [3e-3, 1e-3, 5e-4], [8e-3, 4e-3, 2e-3], [True] * 3, 1e-3, "t", COARSE,
                             "uncalibrated", best_f1=[2e-3, 8e-4, 3e-4])
    text = _all_text(fig)
    assert "f1 of the best design" in text and "f1 resolution of preset coarse" in text
    assert fig.axes[0].get_ylabel().startswith("F_p, f1 [-]")


def test_multi_objective_runs_plot_what_they_optimise(tmp_path, monkeypatch):
    import whisker_opt.optimise.recorder as recorder_mod
    import whisker_opt.output.pareto_plots as pp

    figures = []
    original = pp.mo_convergence_figure

    def keep(*args, **kw):
        figures.append(original(*args, **kw))
        return figures[-1]

    monkeypatch.setattr(pp, "mo_convergence_figure", keep)
    monkeypatch.setattr(recorder_mod, "plot_convergence", lambda *a, **k: pytest.fail("the GA's F_p plot drawn"))
    cfg = OptimiserConfig.model_validate({"algorithm": "nsga2", "ga": {"population": 8}, "pareto": {"verify": False},
                                          "stopping": {"max_generations": 3}, "executor": {"kind": "serial"}})
    run_optimisation(cfg, tmp_path / "run", AnalyticFitness(scale=0.2), seed=1, progress=False, fidelity=COARSE)
    assert figures and (tmp_path / "run" / "convergence.png").is_file()
    text = _all_text(figures[-1])
    assert "NSGA-II convergence (stopped by max_generations, generation 3" in text
    assert "objectives: f1, Q_i (prefer low)" in text and "preset coarse, f1 resolution ~2e-3" in text
    assert "hypervolume of the front" in text and "smallest f1 found" in text
    assert "F_p" not in text  # the penalised score is not what NSGA-II optimises
    hv, f1 = figures[-1].axes[0], figures[-1].axes[1]
    assert [round(x) for x in hv.lines[0].get_xdata()] == [0, 1, 2, 3]
    smallest = f1.lines[0].get_ydata()
    assert all(b <= a for a, b in zip(smallest, smallest[1:]))  # the smallest f1 so far never grows


def test_compensation_map_cell_labels_are_readable():
    from whisker_opt.analysis import compensation_map as cmod
    from whisker_opt.analysis.beam import BeamResponse

    m = cmod.solve_map(WhiskerDesign(), 0.2, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0], [0.55, 0.7, 0.85, 1.0],
                       lambda d, Q, a, x: BeamResponse(a=a)(d, Q, x), xatol=1e-6)
    fig = comp_io.map_figure(m)
    FigureCanvasAgg(fig).draw()
    cells = [t for ax in fig.axes[:2] for t in ax.texts]
    assert len(cells) >= 6 * 4 * 2 - 4  # a value in every cell (Δ = 0 has no recovery rate)
    assert min(t.get_fontsize() for t in cells) >= 9
    ticks = [t for ax in fig.axes[:2] for t in ax.get_xticklabels() + ax.get_yticklabels() if t.get_text()]
    assert min(t.get_fontsize() for t in ticks) >= 9
    # the labels fit their cells: no two values of one panel overlap
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes[:2]:
        boxes = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()[:1].isdigit()]
        assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
