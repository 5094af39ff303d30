"""Compensation results on disk: the Δ → Q table and the beam-vs-FE sensitivity comparison.

Writes what :mod:`whisker_opt.analysis.compensation` computes: CSV (one row per trim, or per
(a, Q) cell), JSON metadata with the curves, and a PNG figure each.
"""

from __future__ import annotations

import csv
import json
import logging
from pathlib import Path

import numpy as np

logger = logging.getLogger(__name__)

_TABLE_COLUMNS = ("trim_mm", "Q_MPa", "recovery_rate_pct", "compensation_error_pct", "gap_before", "gap_after",
                  "at_bound", "Q_analytic_MPa", "Q_minus_Q_analytic_MPa", "analytic_root_found",
                  "eps_o_mean", "eps_b_mean", "eps_c_mean", "delta_ref_mm", "eps_o_ref", "eps_b_ref", "eps_c_ref",
                  "recovery_rate_ref_pct", "compensation_error_ref_pct")


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v)).lower()
    if isinstance(v, str):
        return v
    return f"{float(v):.10g}"


def _reference_delta(table, delta_ref: float | None) -> float | None:
    """``delta_ref`` if it is a sample of the table, else None (with a log line)."""
    if delta_ref is None:
        return None
    if np.any(np.abs(table.deltas - float(delta_ref)) <= 1e-9):
        return float(delta_ref)
    logger.warning("write_table: δ_ref = %g mm is not a deflection sample; point measures left out", delta_ref)
    return None


def write_table(path_dir, table, delta_ref: float | None = 1.0) -> dict[str, Path]:
    """Write a compensation table: ``compensation_table.csv``, ``.json`` (metadata, curves) and ``.png``.

    ``table`` is a :class:`whisker_opt.analysis.compensation.CompensationTable`.

    CSV columns: trim_mm, Q_MPa, recovery_rate_pct, compensation_error_pct (on the table's
    scalar, default the curve mean), gap_before, gap_after, at_bound ('lower'/'upper'/''),
    Q_analytic_MPa, Q_minus_Q_analytic_MPa, analytic_root_found; the curve means
    eps_o_mean, eps_b_mean, eps_c_mean (intact at Q_i, trimmed at Q_i, trimmed at Q); and
    the readings and the recovery/compensation measures at the single deflection delta_ref_mm
    (eps_o_ref, eps_b_ref, eps_c_ref, recovery_rate_ref_pct, compensation_error_ref_pct; the
    beam model compares at δ = 1 mm). Empty/NaN where not applicable (Δ = 0 has nothing to recover;
    no point columns when ``delta_ref`` is None or not a sample of the table).

    Returns
    -------
    dict
        ``{'csv': Path, 'json': Path, 'png': Path}``.
    """
    out = Path(path_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"csv": out / "compensation_table.csv", "json": out / "compensation_table.json",
             "png": out / "compensation_table.png"}
    means = {w: np.nanmean(table.curves(w), axis=1) if table.deltas.size else np.full(len(table.rows), np.nan)
             for w in ("target", "broken", "compensated")}
    dref = _reference_delta(table, delta_ref)
    nan = np.full(len(table.rows), np.nan)
    pm = table.measures_at(dref) if dref is not None else {
        k: nan for k in ("eps_target", "eps_broken", "eps_compensated", "recovery_rate", "compensation_error")}
    with paths["csv"].open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(_TABLE_COLUMNS)
        for i, r in enumerate(table.rows):
            w.writerow([_fmt(v) for v in (
                r.trim, r.Q, r.recovery_rate, r.compensation_error, r.gap_before, r.gap_after, r.at_bound,
                r.Q_analytic, r.Q_difference, r.analytic_root_found, means["target"][i], means["broken"][i],
                means["compensated"][i], dref if dref is not None else float("nan"), pm["eps_target"][i],
                pm["eps_broken"][i], pm["eps_compensated"][i], pm["recovery_rate"][i], pm["compensation_error"][i])])
    meta = {
        "design": table.design.as_dict(), "Q_i_MPa": table.Q_i, "scalar": table.scalar,
        "deltas_mm": [float(d) for d in table.deltas], "monotone": table.is_monotone(), "delta_ref_mm": dref,
        "measures": "docs/physics.md; recovery = (1-|(e_c-e_o)/(e_b-e_o)|)*100, error = |(e_c-e_o)/(e_b-e_o)|*100",
        "curves": [{"trim_mm": r.trim, "Q_MPa": r.Q, "eps_o": list(r.eps_target), "eps_b": list(r.eps_broken),
                    "eps_c": list(r.eps_compensated)} for r in table.rows],
    }
    paths["json"].write_text(json.dumps(meta, indent=2))

    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.8), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    tr = table.trims
    ax1.plot(tr, table.pressures, "o-", label="response (FE) compensation")
    qa = table.column("Q_analytic")
    if np.any(np.isfinite(qa)):
        ax1.plot(tr, qa, "s--", label="analytic (beam)")
    ax1.axhline(table.Q_i, color="0.6", lw=0.8, ls=":")
    ax1.set_xlabel("trim Δ [mm]")
    ax1.set_ylabel("vent pressure Q [MPa]")
    ax1.set_ylim(bottom=0.0)
    ax1.legend(fontsize=8)
    ax1.set_title(f"Δ → Q  (Q_i = {table.Q_i:g} MPa)")
    ax2.plot(tr, table.column("recovery_rate"), "o-", label=f"curve {table.scalar}")
    if dref is not None:
        ax2.plot(tr, pm["recovery_rate"], "s--", label=f"at δ = {dref:g} mm")
    ax2.axhline(85.0, color="0.6", lw=0.8, ls=":")
    ax2.set_xlabel("trim Δ [mm]")
    ax2.set_ylabel("recovery rate [%]")
    ax2.set_ylim(0.0, 105.0)
    ax2.legend(fontsize=8)
    ax2.set_title("recovery rate")
    fig.savefig(paths["png"], dpi=120)
    logger.info("wrote compensation table to %s", out)
    return paths




def write_comparison(path_dir, comparison) -> dict[str, Path]:
    """Write ``sensitivity_comparison.csv`` (long format: a, Q_MPa, beam, fe, rel_diff) and ``.png``.

    ``comparison`` is a :class:`whisker_opt.analysis.compensation.SensitivityComparison`.

    Returns
    -------
    dict
        ``{'csv': Path, 'png': Path}``.
    """
    out = Path(path_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"csv": out / "sensitivity_comparison.csv", "png": out / "sensitivity_comparison.png"}
    rel = comparison.relative_difference
    with paths["csv"].open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(("a", "Q_MPa", "beam_per_mm", "fe_per_mm", "rel_diff"))
        for i, ai in enumerate(comparison.a):
            for j, qj in enumerate(comparison.Q):
                w.writerow([_fmt(v) for v in (ai, qj, comparison.beam[i, j], comparison.fe[i, j], rel[i, j])])

    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.8), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    colors = [f"C{j % 10}" for j in range(comparison.Q.size)]
    for j, qj in enumerate(comparison.Q):
        ax1.plot(comparison.a, comparison.fe[:, j], "-", color=colors[j], label=f"FE Q={qj:g}")
        ax1.plot(comparison.a, comparison.beam[:, j], "--", color=colors[j])
        ax2.plot(comparison.a, 100.0 * rel[:, j], "o-", color=colors[j], ms=3, label=f"Q={qj:g} MPa")
    ax1.set_yscale("log")
    ax1.set_xlabel("contact ratio a")
    ax1.set_ylabel("ε/δ [1/mm] (FE solid, beam dashed)")
    ax1.legend(fontsize=7)
    ax2.axhline(0.0, color="0.6", lw=0.8)
    ax2.set_xlabel("contact ratio a")
    ax2.set_ylabel("(beam − FE)/FE [%]")
    ax2.legend(fontsize=7)
    fig.savefig(paths["png"], dpi=120)
    logger.info("wrote sensitivity comparison to %s", out)
    return paths
