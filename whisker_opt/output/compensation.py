"""Compensation results on disk: the Δ → Q table and the beam-vs-FE sensitivity comparison.

Writes what :mod:`whisker_opt.analysis.compensation` computes: CSV (one row per trim, or per
(a, Q) cell), JSON metadata with the curves, and a PNG figure each. The figures come from
:func:`table_figure` and :func:`comparison_figure`; their titles name the design and the FE
fidelity preset (``fidelity = {"preset": name, ...}``,
:func:`whisker_opt.experiment.fidelity.describe`).
"""

from __future__ import annotations

import csv
import io
import json
import logging
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator, MultipleLocator

from whisker_opt.output.storage import atomic_write_bytes, atomic_write_text

logger = logging.getLogger(__name__)

#: The recovery rate the compensation aims at [%] (drawn on the recovery panel).
RECOVERY_TARGET_PCT = 85.0

_TABLE_COLUMNS = ("trim_mm", "Q_MPa", "recovery_rate_pct", "compensation_error_pct", "gap_before", "gap_after",
                  "at_bound", "Q_analytic_MPa", "Q_minus_Q_analytic_MPa", "analytic_root_found",
                  "eps_o_mean", "eps_b_mean", "eps_c_mean", "delta_ref_mm", "eps_o_ref", "eps_b_ref", "eps_c_ref",
                  "recovery_rate_ref_pct", "compensation_error_ref_pct")


def _save_png(fig: Figure, path: Path) -> None:
    """``fig`` as a PNG written whole (:func:`whisker_opt.output.storage.atomic_write_bytes`)."""
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=120)
    atomic_write_bytes(path, png.getvalue())


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v)).lower()
    if isinstance(v, str):
        return v
    return f"{float(v):.10g}"


def _preset_text(fidelity: Mapping[str, Any] | None) -> str:
    if not fidelity or not fidelity.get("preset"):
        return "FE preset not recorded"
    return f"FE preset {fidelity['preset']}" + (" (overridden)" if fidelity.get("overrides") else "")


def _design_text(design) -> str:
    return f"α = {design.alpha:g}°, l = {design.l:g} mm, t = {design.t:g} mm, L = {design.L:g} mm"


def _trim_ticks(ax, trims: np.ndarray) -> None:
    """Integer ticks on the trim axis when every trim is a whole number of mm."""
    t = trims[np.isfinite(trims)]
    if t.size and np.allclose(t, np.round(t)):
        span = float(t.max() - t.min())
        ax.xaxis.set_major_locator(MultipleLocator(1.0) if span <= 12 else MaxNLocator(integer=True, min_n_ticks=1))


def table_figure(table, delta_ref: float | None = None, point_recovery=None,
                 fidelity: Mapping[str, Any] | None = None) -> Figure:
    """The figure of :func:`write_table`: Δ → Q (FE and beam) and the recovery rates.

    Parameters
    ----------
    table : whisker_opt.analysis.compensation.CompensationTable
    delta_ref : float, optional
        Deflection [mm] of ``point_recovery``.
    point_recovery : array_like, optional
        Recovery rate [%] per row at ``delta_ref``.
    fidelity : mapping, optional
        The FE preset (``{"preset": name}``), named in the title.

    Returns
    -------
    matplotlib.figure.Figure
        Rows whose FE pressure sits at a bound of [0, Q_i] (``at_bound``, trims > 0) are
        marked and labelled on both panels; the 85 % recovery line is labelled.
    """
    fig = Figure(figsize=(9.6, 4.4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2, sharex=True)
    tr = table.trims
    q = table.pressures
    bound = np.array([bool(r.at_bound) and r.trim > 0 for r in table.rows], dtype=bool)
    lower = bound & np.array([r.at_bound == "lower" for r in table.rows], dtype=bool)
    ax1.plot(tr, q, "o-", color="C0", label="FE (response) compensation")
    qa = table.column("Q_analytic")
    if np.any(np.isfinite(qa)):
        ax1.plot(tr, qa, "s--", color="C1", label="analytic (beam model)")
    ax1.axhline(table.Q_i, color="0.5", lw=0.8, ls=":", label=f"Q_i = {table.Q_i:g} MPa (upper bound)")
    rec = table.column("recovery_rate")
    ax2.plot(tr, rec, "o-", color="C0", label=f"FE, on the curve {table.scalar}")
    if delta_ref is not None and point_recovery is not None:
        ax2.plot(tr, point_recovery, "s--", color="C2", label=f"FE, at δ = {delta_ref:g} mm")
    for mask, text in ((lower, "FE Q at its bound 0 (fully vented)"), (bound & ~lower, "FE Q at its bound Q_i")):
        if mask.any():
            ax1.plot(tr[mask], q[mask], "v" if mask is lower else "^", ms=10, mfc="none", mec="C3", mew=1.5,
                     ls="none", label=text)
            ax2.plot(tr[mask], rec[mask], "v" if mask is lower else "^", ms=10, mfc="none", mec="C3", mew=1.5,
                     ls="none", label=f"{text}: recovery capped")
    if lower.any():
        ax1.annotate(f"Q = 0 for Δ = {', '.join(f'{x:g}' for x in tr[lower])} mm",
                     (tr[lower][0], 0.0), xytext=(0, 18), textcoords="offset points", ha="center", fontsize=8,
                     color="C3", arrowprops={"arrowstyle": "->", "color": "C3", "lw": 0.8})
    ax1.set_xlabel("trim Δ [mm]")
    ax1.set_ylabel("vent pressure Q [MPa]")
    ax1.set_ylim(bottom=-0.04 * table.Q_i, top=1.12 * table.Q_i)
    ax1.legend(fontsize=7, loc="upper right")
    ax1.set_title("vent pressure per trim", fontsize=9)
    ax2.axhline(RECOVERY_TARGET_PCT, color="0.3", lw=0.9, ls=":")
    ax2.annotate(f"{RECOVERY_TARGET_PCT:g} % recovery (target)", (0.02, RECOVERY_TARGET_PCT), xycoords=("axes fraction", "data"),
                 xytext=(0, 3), textcoords="offset points", fontsize=8, color="0.3")
    ax2.set_xlabel("trim Δ [mm]")
    ax2.set_ylabel("recovery rate [%]")
    finite = rec[np.isfinite(rec)]
    ax2.set_ylim(min(0.0, float(finite.min()) - 5.0) if finite.size else 0.0, 105.0)
    ax2.legend(fontsize=7, loc="lower left")
    ax2.set_title("recovery rate (100 % = intact response restored)", fontsize=9)
    _trim_ticks(ax1, tr)
    fig.suptitle(f"Compensation: {_design_text(table.design)}, intact at Q_i = {table.Q_i:g} MPa\n"
                 f"{_preset_text(fidelity)}; beam model for the analytic Q", fontsize=10)
    return fig


def _reference_delta(table, delta_ref: float | None) -> float | None:
    """``delta_ref`` if it is a sample of the table, else None (with a log line)."""
    if delta_ref is None:
        return None
    if np.any(np.abs(table.deltas - float(delta_ref)) <= 1e-9):
        return float(delta_ref)
    logger.warning("write_table: δ_ref = %g mm is not a deflection sample; point measures left out", delta_ref)
    return None


def write_table(path_dir, table, delta_ref: float | None = 1.0,
                fidelity: Mapping[str, Any] | None = None, forces: list | None = None) -> dict[str, Path]:
    """Write a compensation table: ``compensation_table.csv``, ``.json`` (metadata, curves) and ``.png``.

    ``table`` is a :class:`whisker_opt.analysis.compensation.CompensationTable`.

    CSV columns: trim_mm, Q_MPa, recovery_rate_pct, compensation_error_pct (on the table's
    scalar, default the curve mean), gap_before, gap_after, at_bound ('lower'/'upper'/''),
    Q_analytic_MPa, Q_minus_Q_analytic_MPa, analytic_root_found; the curve means
    eps_o_mean, eps_b_mean, eps_c_mean (intact at Q_i, trimmed at Q_i, trimmed at Q); and
    the readings and the recovery/compensation measures at the single deflection delta_ref_mm
    (eps_o_ref, eps_b_ref, eps_c_ref, recovery_rate_ref_pct, compensation_error_ref_pct; the
    beam model compares at δ = 1 mm). Empty/NaN where not applicable (Δ = 0 has nothing to recover;
    no point columns when ``delta_ref`` is None or not a sample of the table). ``fidelity``
    (the FE preset) is named in the figure's title (:func:`table_figure`). With ``forces`` (one
    dict per row, :func:`whisker_opt.compensation.table_forces`) the CSV ends with the secant
    stiffnesses stiffness_o/b/c_N_per_mm and each JSON curve holds the contact forces
    force_o/b/c_N [N] at the table's deflections.

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
    stiff = tuple(f"stiffness_{w}_N_per_mm" for w in "obc") if forces else ()
    buf = io.StringIO(newline="")  # made in memory and written whole: a full disk leaves no half-written file
    w = csv.writer(buf)
    w.writerow(_TABLE_COLUMNS + stiff)
    for i, r in enumerate(table.rows):
        w.writerow([_fmt(v) for v in (
            r.trim, r.Q, r.recovery_rate, r.compensation_error, r.gap_before, r.gap_after, r.at_bound,
            r.Q_analytic, r.Q_difference, r.analytic_root_found, means["target"][i], means["broken"][i],
            means["compensated"][i], dref if dref is not None else float("nan"), pm["eps_target"][i],
            pm["eps_broken"][i], pm["eps_compensated"][i], pm["recovery_rate"][i], pm["compensation_error"][i],
            *(forces[i][k] for k in stiff))])
    meta = {
        "design": table.design.as_dict(), "Q_i_MPa": table.Q_i, "scalar": table.scalar,
        "deltas_mm": [float(d) for d in table.deltas], "monotone": table.is_monotone(), "delta_ref_mm": dref,
        "measures": "docs/physics.md; recovery = (1-|(e_c-e_o)/(e_b-e_o)|)*100, error = |(e_c-e_o)/(e_b-e_o)|*100",
        "curves": [{"trim_mm": r.trim, "Q_MPa": r.Q, "eps_o": list(r.eps_target), "eps_b": list(r.eps_broken),
                    "eps_c": list(r.eps_compensated),
                    **({k: v for k, v in forces[i].items() if k.startswith("force_")} if forces else {})}
                   for i, r in enumerate(table.rows)],
    }
    if fidelity:
        meta["fidelity"] = dict(fidelity)
    atomic_write_text(paths["csv"], buf.getvalue())
    atomic_write_text(paths["json"], json.dumps(meta, indent=2))
    fig = table_figure(table, dref, pm["recovery_rate"] if dref is not None else None, fidelity)
    _save_png(fig, paths["png"])
    logger.info("wrote compensation table to %s", out)
    return paths




def comparison_figure(comparison, fidelity: Mapping[str, Any] | None = None,
                      delta_ref: float | None = None) -> Figure:
    """The figure of :func:`write_comparison`: ε/δ against a per Q (FE solid, beam dashed) and
    their relative difference.

    Parameters
    ----------
    comparison : whisker_opt.analysis.compensation.SensitivityComparison
    fidelity : mapping, optional
        The FE preset, named in the title and the legend.
    delta_ref : float, optional
        Deflection δ [mm] of the sensitivity ε(δ)/δ, named in the title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    rel = comparison.relative_difference
    fig = Figure(figsize=(9.6, 4.4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    colors = [f"C{j % 10}" for j in range(comparison.Q.size)]
    for j, qj in enumerate(comparison.Q):
        ax1.plot(comparison.a, comparison.fe[:, j], "o-", ms=3, color=colors[j], label=f"Q = {qj:g} MPa")
        ax1.plot(comparison.a, comparison.beam[:, j], "--", color=colors[j])
        ax2.plot(comparison.a, 100.0 * rel[:, j], "o-", color=colors[j], ms=3, label=f"Q = {qj:g} MPa")
    style = [Line2D([], [], color="0.2", ls="-", label=_preset_text(fidelity).replace("FE preset", "FE, preset")),
             Line2D([], [], color="0.2", ls="--", label="beam model")]
    ax1.set_yscale("log")
    ax1.set_xlabel("contact ratio a [-]")
    ax1.set_ylabel("sensitivity ε/δ [1/mm]")
    ax1.legend(handles=ax1.get_legend_handles_labels()[0] + style, fontsize=7)
    ax1.set_title("gauge sensitivity", fontsize=9)
    ax2.axhline(0.0, color="0.6", lw=0.8)
    ax2.set_xlabel("contact ratio a [-]")
    ax2.set_ylabel("(beam − FE)/FE [%]")
    ax2.legend(fontsize=7)
    ax2.set_title("beam model relative to FE", fontsize=9)
    at = f"ε(δ = {delta_ref:g} mm)/δ" if delta_ref is not None else "ε/δ"
    fig.suptitle(f"Gauge sensitivity {at} [1/mm]: beam model vs FE ({_preset_text(fidelity)})\n"
                 f"{_design_text(comparison.design)}", fontsize=10)
    return fig


def write_comparison(path_dir, comparison, fidelity: Mapping[str, Any] | None = None,
                     delta_ref: float | None = None) -> dict[str, Path]:
    """Write ``sensitivity_comparison.csv`` (long format: a, Q_MPa, beam, fe, rel_diff) and ``.png``.

    ``comparison`` is a :class:`whisker_opt.analysis.compensation.SensitivityComparison`;
    ``fidelity`` and ``delta_ref`` label the figure (:func:`comparison_figure`).

    Returns
    -------
    dict
        ``{'csv': Path, 'png': Path}``.
    """
    out = Path(path_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"csv": out / "sensitivity_comparison.csv", "png": out / "sensitivity_comparison.png"}
    rel = comparison.relative_difference
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(("a", "Q_MPa", "beam_per_mm", "fe_per_mm", "rel_diff"))
    for i, ai in enumerate(comparison.a):
        for j, qj in enumerate(comparison.Q):
            w.writerow([_fmt(v) for v in (ai, qj, comparison.beam[i, j], comparison.fe[i, j], rel[i, j])])
    atomic_write_text(paths["csv"], buf.getvalue())
    _save_png(comparison_figure(comparison, fidelity, delta_ref), paths["png"])
    logger.info("wrote sensitivity comparison to %s", out)
    return paths


# ----------------------------------------------------------------------------- the map Q(Δ, a)
_MAP_COLUMNS = ("trim_mm", "a", "Q_MPa", "recovery_rate_pct", "compensation_error_pct", "gap_before", "gap_after",
                "at_bound", "n_responses")


#: Font size [pt] of the cell values, the ticks and the legend of the compensation map.
MAP_LABEL_PT = 9


def _edges(x: np.ndarray) -> np.ndarray:
    """Cell edges half-way between the grid values (the end cells as wide as their neighbours)."""
    mid = 0.5 * (x[1:] + x[:-1])
    return np.concatenate([[x[0] - (mid[0] - x[0])], mid, [x[-1] + (x[-1] - mid[-1])]])


def map_figure(cmap) -> Figure:
    """The figure of :func:`write_map`: heatmaps of Q [MPa] and of the recovery rate [%] over Δ × a.

    Cells at a bound (trims > 0) are marked: ▼ Q = 0 (vent fully), ▲ Q = Q_i; each cell carries
    its value in :data:`MAP_LABEL_PT` points (the figure grows with the number of cells so that the
    labels fit). ``cmap`` is a :class:`whisker_opt.analysis.compensation_map.CompensationMap`.
    """
    tr, a = cmap.trims, cmap.a
    # ~0.75 in a cell across (a 9 pt "0.123" is 0.4 in), 0.45 in down; at least the former 11 x 4.8 in
    fig = Figure(figsize=(max(11.0, 2 * (1.6 + 0.75 * len(tr))), max(4.8, 2.2 + 0.45 * len(a))), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    bound = (cmap.at_bound != "") & (tr[:, None] > 0)  # (n_t, n_a)
    panels = ((cmap.Q, "viridis", "vent pressure Q [MPa]", (0.0, cmap.Q_i), "{:.3f}"),
              (cmap.recovery_rate, "magma", "recovery rate [%]", (min(0.0, float(np.nanmin(cmap.recovery_rate)))
                                                                 if np.isfinite(cmap.recovery_rate).any() else 0.0,
                                                                 100.0), "{:.0f}"))
    for ax, (z, cm, label, (lo, hi), fmt) in zip(axes, panels):
        mesh = ax.pcolormesh(_edges(tr), _edges(a), np.ma.masked_invalid(z).T, cmap=cm, vmin=lo, vmax=hi,
                             shading="flat")
        fig.colorbar(mesh, ax=ax, label=label)
        for i, ti in enumerate(tr):
            for j, aj in enumerate(a):
                if np.isfinite(z[i, j]):
                    frac = (z[i, j] - lo) / (hi - lo) if hi > lo else 0.5
                    ax.text(ti, aj, fmt.format(z[i, j]), ha="center", va="center", fontsize=MAP_LABEL_PT,
                            color="white" if frac < 0.55 else "black")
        for kind, marker, text in (("lower", "v", "at its bound: Q = 0 (vent fully)"),
                                   ("upper", "^", f"at its bound: Q = Q_i = {cmap.Q_i:g} MPa")):
            m = bound & (cmap.at_bound == kind)
            if m.any():
                ii, jj = np.nonzero(m)
                ax.plot(tr[ii], a[jj] + 0.33 * np.min(np.diff(a)), marker, ms=6, mfc="none", mec="C3", mew=1.2,
                        ls="none", label=text)
        ax.set_xlabel("trim Δ [mm]")
        ax.set_xticks(tr)
        ax.tick_params(axis="both", labelsize=MAP_LABEL_PT)
        ax.set_yticks(a)
    if tr[0] == 0.0 and np.isnan(cmap.recovery_rate[0]).all():
        axes[1].text(0.0, float(np.mean(a)), "Δ = 0: intact, nothing to recover", rotation=90, ha="center",
                     va="center", fontsize=MAP_LABEL_PT, color="0.3")
    axes[0].set_ylabel("contact ratio a [-]")
    axes[0].set_title("vent pressure Q(Δ, a)", fontsize=10)
    axes[1].set_title("recovery rate on the curve mean (100 % = intact restored)", fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=MAP_LABEL_PT)
    fig.suptitle(f"Compensation map: {cmap.design_text}, intact at Q_i = {cmap.Q_i:g} MPa at the same a\n"
                 f"{_preset_text(cmap.fidelity)}; Brent on [0, Q_i], xatol = {cmap.xatol:g} MPa", fontsize=10)
    return fig


def write_map(path_dir, cmap) -> dict[str, Path]:
    """Write a compensation map: ``compensation_map.csv`` (a row per cell), ``.json`` (the whole map,
    read back by :meth:`~whisker_opt.analysis.compensation_map.CompensationMap.load`) and ``.png``
    (:func:`map_figure`), each atomically.

    CSV columns: trim_mm, a, Q_MPa, recovery_rate_pct, compensation_error_pct, gap_before,
    gap_after, at_bound ('lower'/'upper'/''; 'upper' on the row Δ = 0, trivially), n_responses.

    Returns
    -------
    dict
        ``{'csv': Path, 'json': Path, 'png': Path}``.
    """
    import io

    from whisker_opt.output.storage import atomic_write_bytes, atomic_write_text, write_json

    out = Path(path_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {kind: out / name for kind, name in cmap.FILES.items()}
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(_MAP_COLUMNS)
    for i, ti in enumerate(cmap.trims):
        for j, aj in enumerate(cmap.a):
            w.writerow([_fmt(v) for v in (ti, aj, cmap.Q[i, j], cmap.recovery_rate[i, j],
                                          cmap.compensation_error[i, j], cmap.gap_before[i, j],
                                          cmap.gap_after[i, j], str(cmap.at_bound[i, j]), cmap.n_responses[i, j])])
    atomic_write_text(paths["csv"], buf.getvalue())
    write_json(paths["json"], cmap.as_dict())
    png = io.BytesIO()
    map_figure(cmap).savefig(png, format="png", dpi=120)
    atomic_write_bytes(paths["png"], png.getvalue())
    logger.info("wrote compensation map to %s", out)
    return paths
