"""Every job leaves the outputs a user looks for: the mesh method used, a plot of a simulated pair,
and a report that rebuilds the best design's curves plot."""

from __future__ import annotations

import json
from pathlib import Path

from tests.subprocess_run import run_cli

ROOT = Path(__file__).resolve().parents[1]


def _cli(*args, cwd):
    return run_cli(*args, cwd=cwd, timeout=600)


def test_mesh_reports_the_method_used_and_the_trim(tmp_path):
    cfg = tmp_path / "m.yaml"
    cfg.write_text("fidelity: {preset: coarse}\nscene: {trim: 5.0}\n")
    proc = _cli("mesh", cfg, "--out", tmp_path / "m", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    report = json.loads((tmp_path / "m" / "mesh_report.json").read_text())
    assert report["method_requested"] == "auto" and report["method"] != "auto"  # e.g. template:coarse_a3.3_t3.6
    assert report["trim_mm"] == 5.0 and "trimmed by 5 mm (scene.trim)" in proc.stdout


def test_simulate_writes_a_curves_plot_and_report_rebuilds_best_curves(tmp_path):
    cfg = tmp_path / "s.yaml"
    cfg.write_text("fidelity: {preset: coarse}\nscene: {Q_i: 0.1, trim: 2.0, deflection: 1.0}\n")
    proc = _cli("simulate", cfg, "--out", tmp_path / "s", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "s" / "curves.png").stat().st_size > 10_000
    run = tmp_path / "r"
    cfg_run = tmp_path / "r.yaml"
    cfg_run.write_text("fidelity: {preset: coarse}\nscene: {deflection: 1.0}\noptimiser:\n  trim: 2.0\n"
                       "  ga: {population: 2, n_elite: 1, tournament: 1}\n  stopping: {max_generations: 0}\n")
    assert _cli("run", cfg_run, "--out", run, "--no-progress", cwd=tmp_path).returncode == 0
    png = run / "best_curves.png"
    png.unlink()
    proc = _cli("report", run, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert png.stat().st_size > 10_000
