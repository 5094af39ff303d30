"""The Pareto front of a multi-objective run on disk: ``pareto.csv``, ``pareto.png``, ``hypervolume.png``.

``pareto.csv`` holds one row per non-dominated design of the run (``on_front`` True), sorted
by f1, and the penalised optimum (the design the config's F_p = f1 + Σ_j C_j κ_j would pick,
docs/physics.md §5) as an extra row with ``on_front`` False when it is not on the front. The
columns are the genes, f1 and F_p at the run's fidelity, and — once the front has been
re-evaluated at a finer preset — ``verified_preset``, ``f1_verified``, ``F_p_verified``,
``status_verified`` and ``on_front_verified``: non-domination recomputed on the verified
values among the verified rows (objectives in :mod:`whisker_opt.optimise.nsga2`).

``pareto.png`` draws f1 against each other objective's gene (one panel per gene objective):
every feasible evaluation in grey, the front at the run's preset, the verified points, and
the penalised optimum at both presets. ``hypervolume.png`` is the archive's hypervolume per
generation; the run's ``convergence.png`` (:func:`plot_mo_convergence`) shows it with the smallest
f1 found against the f1 resolution. All writes are atomic.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from whisker_opt.output import storage
from whisker_opt.numfmt import short_float
from whisker_opt.output.plots import STRAIN_UNIT, _save, fidelity_label

#: File names in a run directory.
PARETO_CSV = "pareto.csv"
PARETO_PNG = "pareto.png"
HYPERVOLUME_PNG = "hypervolume.png"
#: Columns filled once the front is verified at a finer preset.
VERIFIED_COLUMNS = ("verified_preset", "f1_verified", "F_p_verified", "status_verified", "on_front_verified")
#: Units of the genes on the plot axes.
def _unit(name: str) -> str:
    """The unit of an objective's axis: a measure's (:mod:`whisker_opt.experiment.measures`) or a gene's
    (:func:`whisker_opt.genes.gene_keys`)."""
    from whisker_opt.experiment.measures import MEASURES
    from whisker_opt.genes import gene_keys

    if name in MEASURES:
        return MEASURES[name].unit
    key = gene_keys().get(name)
    return key.unit if key is not None else "-"


def front_columns(gene_names: Sequence[str], measure_columns: Sequence[str] = ()) -> list[str]:
    """Columns of ``pareto.csv`` (the measures an objective reads besides f1 after f1)."""
    return ["rank", "eval_id", "generation", *gene_names, "f1", *measure_columns, "F_p", "on_front",
            "penalised_optimum",
            *VERIFIED_COLUMNS]


def read_front(run_dir: Path) -> list[dict[str, str]]:
    """Rows of ``run_dir/pareto.csv`` as strings ([] when it does not exist or does not read)."""
    path = Path(run_dir) / PARETO_CSV
    if not path.is_file():
        return []
    try:
        return storage.read_csv(path)
    except (OSError, ValueError, UnicodeDecodeError):
        return []


def _num(v: Any) -> float | None:
    if v is None or v == "":
        return None
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def merge_verified(rows: list[dict[str, Any]], old: list[dict[str, str]], gene_names: Sequence[str]) -> list[dict]:
    """``rows`` with the verified values of ``old`` (an earlier ``pareto.csv``) for the same genome.

    Genomes match when every gene reads back equal (the CSV holds floats at full precision).
    """
    done: dict[tuple, dict[str, str]] = {}
    for r in old:
        key = tuple(_num(r.get(g)) for g in gene_names)
        if r.get("verified_preset") and None not in key:
            done[key] = r
    out = []
    for r in rows:
        r = dict(r)
        prev = done.get(tuple(float(r[g]) for g in gene_names))
        if prev is not None:
            r.update(verified_preset=prev["verified_preset"], status_verified=prev.get("status_verified") or None,
                     f1_verified=_num(prev.get("f1_verified")), F_p_verified=_num(prev.get("F_p_verified")))
        out.append(r)
    return out


def _value(row: Mapping[str, Any], name: str, verified: bool = False) -> float:
    if name == "f1":
        v = _num(row.get("f1_verified" if verified else "f1"))
        return math.nan if v is None else v
    return float(row[name])


def front_figure(rows: list[dict[str, Any]], objectives: Sequence[str], labels: Sequence[str],
                 all_points: Sequence[Mapping[str, float]], fidelity: Mapping[str, Any] | None,
                 title: str) -> Figure:
    """The figure of :func:`write_front_outputs`: f1 (log y when positive) against each gene objective."""
    genes = [o for o in objectives if o != "f1"]
    glabels = [lab for o, lab in zip(objectives, labels) if o != "f1"]
    fig = Figure(figsize=(6.4 * len(genes), 4.8))
    front = [r for r in rows if r.get("on_front")]
    best = [r for r in rows if r.get("penalised_optimum")]
    ver = [r for r in rows if r.get("status_verified") == "ok"]
    vpreset = next((r["verified_preset"] for r in ver), None)
    f1_all = [p["f1"] for p in all_points] + [_value(r, "f1") for r in rows] + [_value(r, "f1", True) for r in ver]
    positive = all(v > 0 for v in f1_all if math.isfinite(v)) and any(math.isfinite(v) for v in f1_all)
    for k, (g, glab) in enumerate(zip(genes, glabels)):
        ax = fig.add_subplot(1, len(genes), k + 1)
        if all_points:
            ax.plot([p[g] for p in all_points], [p["f1"] for p in all_points], ".", color="0.75", ms=3,
                    label=f"evaluated designs ({len(all_points)})", zorder=1)
        run_preset = (fidelity or {}).get("preset") or "the run's"
        fx = [float(r[g]) for r in front]
        fy = [_value(r, "f1") for r in front]
        style = "o-" if len(genes) == 1 else "o"
        order = np.argsort(fx, kind="stable") if fx else []
        ax.plot(np.asarray(fx)[order], np.asarray(fy)[order], style, color="C0", ms=4, lw=1,
                label=f"front at {run_preset} ({len(front)})", zorder=3)
        if ver:
            on = [r for r in ver if r.get("on_front_verified")]
            off = [r for r in ver if not r.get("on_front_verified")]
            for r in ver:
                ax.plot([float(r[g])] * 2, [_value(r, "f1"), _value(r, "f1", True)], "-", color="C1", lw=0.5,
                        alpha=0.6, zorder=2)
            ax.plot([float(r[g]) for r in on], [_value(r, "f1", True) for r in on], "D", color="C1", ms=4,
                    label=f"verified at {vpreset}, non-dominated there ({len(on)})", zorder=4)
            if off:
                ax.plot([float(r[g]) for r in off], [_value(r, "f1", True) for r in off], "D", mfc="none",
                        color="C1", ms=4, label=f"verified at {vpreset}, dominated there ({len(off)})", zorder=4)
        for r in best:
            ax.plot([float(r[g])], [_value(r, "f1")], "*", color="C3", ms=14, mec="k", mew=0.5, zorder=5,
                    label=f"penalised optimum (min F_p) at {run_preset}")
            if r.get("status_verified") == "ok":
                ax.plot([float(r[g])], [_value(r, "f1", True)], "*", mfc="none", color="C3", ms=14, mew=1.2,
                        zorder=5, label=f"penalised optimum at {vpreset}")
        if positive:
            ax.set_yscale("log")
        res = (fidelity or {}).get("f1_resolution")
        if res is not None and math.isfinite(float(res)) and res > 0:
            ax.axhline(res, color="C3", lw=0.8, ls="-.", label=f"f1 resolution of {run_preset} (~{short_float(res)})")
        ax.set_xlabel(f"{g} [{_unit(g)}] — objective {glab}")
        ax.set_ylabel(f"f1 {STRAIN_UNIT}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    fig.suptitle(f"{title}\n{fidelity_label(fidelity)}", fontsize=10)
    return fig


def _hypervolume_and_front_size(ax, g, logbook: Sequence[Mapping[str, Any]], label: str, ylabel: str) -> None:
    """The hypervolume per generation on ``ax`` and the front size on a twin axis, with one legend."""
    ax.plot(g, [r.get("hypervolume", math.nan) for r in logbook], "o-", ms=3, color="C0", label=label)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax2 = ax.twinx()
    ax2.plot(g, [r.get("front_size", 0) for r in logbook], "s--", ms=2, color="C2", alpha=0.7, label="front size")
    ax2.set_ylabel("designs on the front")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="lower right")


#: The hypervolume axis's label; what z and the reference point are goes in the figure (``basis``).
HV_LABEL = "hypervolume in z, up to the reference point"


def hypervolume_figure(logbook: Sequence[Mapping[str, Any]], title: str, basis: str = "") -> Figure:
    """Hypervolume and front size per generation; ``basis`` (:func:`whisker_opt.optimise.nsga2.hypervolume_basis`)
    says under the title what it is measured in."""
    g = [r["generation"] for r in logbook]
    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.add_subplot(1, 1, 1)
    _hypervolume_and_front_size(ax, g, logbook, "hypervolume of the archive", HV_LABEL)
    ax.set_xlabel("generation (0 = initial population)")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    ax.set_title(f"{title}\n{basis}" if basis else title, fontsize=9)
    fig.set_layout_engine("constrained")
    return fig


def mo_convergence_figure(logbook: Sequence[Mapping[str, Any]], smallest_f1: Sequence[float], labels: Sequence[str],
                          title: str, fidelity: Mapping[str, Any] | None = None, basis: str = "") -> Figure:
    """What a multi-objective run optimises, per generation: the hypervolume of its front (with the
    front's size) above, and the smallest f1 found so far below (log y), against the f1 resolution.

    Parameters
    ----------
    logbook : sequence of mapping
        Per-generation rows with ``generation``, ``hypervolume`` and ``front_size``.
    smallest_f1 : sequence of float
        The smallest f1 [calibrated strain] of the feasible designs evaluated up to each generation.
    labels : sequence of str
        The objectives (``f1``, ``Q_i (prefer low)``, ...), named in the title.
    title : str
        First title line.
    fidelity : mapping, optional
        ``{"preset", "f1_resolution"}``: named in the title, the resolution drawn on the f1 panel.
    basis : str, optional
        What the hypervolume is measured in (:func:`whisker_opt.optimise.nsga2.hypervolume_basis`), in the title.
    """
    g = np.asarray([r["generation"] for r in logbook], dtype=float)
    fig = Figure(figsize=(6.4, 6.4))
    ax, ax_f = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [1.3, 1]})
    _hypervolume_and_front_size(ax, g, logbook, "hypervolume of the front (archive)", HV_LABEL.replace(", ", ",\n"))
    f = np.asarray(smallest_f1, dtype=float)
    ax_f.plot(g, f, "o-", ms=3, color="C1", label="smallest f1 found (end of the front)")
    if np.any(np.isfinite(f) & (f > 0)):
        ax_f.set_yscale("log", nonpositive="mask")
    res = (fidelity or {}).get("f1_resolution")
    if res is not None and math.isfinite(float(res)) and res > 0:
        ax_f.axhline(res, color="C3", lw=0.9, ls="-.",
                     label=f"f1 resolution of preset {fidelity['preset']} (~{short_float(res)})")
        lo, hi = ax_f.get_ylim()
        ax_f.axhspan(min(lo, res), res, color="C3", alpha=0.07, lw=0)
        ax_f.set_ylim(min(lo, 0.8 * res), max(hi, 1.25 * res))
    ax_f.set_ylabel(f"f1 {STRAIN_UNIT}")
    ax_f.set_xlabel("generation (0 = initial population)")
    ax_f.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    if g.size:
        ax_f.set_xlim(float(g.min()) - 0.5, float(g.max()) + 0.5)
    ax_f.grid(True, which="both", alpha=0.3)
    ax_f.legend(fontsize=7, loc="best")
    ax.set_title(f"{title}\nobjectives: {', '.join(labels)}\n" + (f"hypervolume: {basis}\n" if basis else "")
                 + fidelity_label(fidelity), fontsize=9)
    fig.set_layout_engine("constrained")
    return fig


def plot_mo_convergence(path: Path, logbook: Sequence[Mapping[str, Any]], smallest_f1: Sequence[float],
                        labels: Sequence[str], title: str, fidelity: Mapping[str, Any] | None = None,
                        basis: str = "") -> Path:
    """Write :func:`mo_convergence_figure` (a multi-objective run's ``convergence.png``); returns ``path``."""
    return _save(mo_convergence_figure(logbook, smallest_f1, labels, title, fidelity, basis), Path(path))


def write_front_outputs(run_dir: Path, rows: list[dict[str, Any]], gene_names: Sequence[str], objectives: Sequence[str],
                        labels: Sequence[str], all_points: Sequence[Mapping[str, float]],
                        logbook: Sequence[Mapping[str, Any]], fidelity: Mapping[str, Any] | None,
                        stop_reason: str | None, basis: str = "") -> list[Path]:
    """Write ``pareto.csv``, ``pareto.png`` and ``hypervolume.png`` into ``run_dir``.

    Parameters
    ----------
    run_dir : Path
    rows : list of dict
        Front rows (module docstring); ``rank`` is set here (1 = smallest f1).
    gene_names : sequence of str
        The genes, in the genome's order.
    objectives, labels : sequences of str
        Objective names (``f1``, other measures and genes) and their labels.
    all_points : sequence of mapping
        f1 and genes of every feasible evaluation (grey background).
    logbook : sequence of mapping
        Per-generation rows with ``generation``, ``hypervolume`` and ``front_size``.
    fidelity : mapping or None
        ``{"preset", "f1_resolution"}`` of the run.
    stop_reason : str or None
    basis : str, optional
        What the hypervolume is measured in (:func:`whisker_opt.optimise.nsga2.hypervolume_basis`).

    Returns
    -------
    list of Path
    """
    run_dir = Path(run_dir)
    for k, r in enumerate(rows, start=1):
        r["rank"] = k
    measures = [o for o in objectives if o != "f1" and o not in gene_names]
    storage.write_csv(run_dir / PARETO_CSV, front_columns(gene_names, measures), rows)
    n_front = sum(1 for r in rows if r.get("on_front"))
    state = f"stopped by {stop_reason}" if stop_reason else "running"
    out = [run_dir / PARETO_CSV]
    out.append(_save(front_figure(rows, objectives, labels, all_points, fidelity,
                                  f"Pareto front: {n_front} designs ({state}, generation "
                                  f"{logbook[-1]['generation'] if logbook else '-'})"),
                     run_dir / PARETO_PNG))
    if logbook:
        title = f"NSGA-II convergence ({state}, generation {logbook[-1]['generation']})"
        out.append(_save(hypervolume_figure(logbook, title, basis), run_dir / HYPERVOLUME_PNG))
    return out


def front_table(rows: list[dict[str, Any]], labels: Sequence[str], gene_names: Sequence[str],
                hypervolume: float, measures: Sequence[str] = (), basis: str = "") -> list[str]:
    """Lines of ``whisker-opt report`` for the front: the genes, f1, every other measure an objective reads
    (``measures``, each with its unit) and F_p; ``basis`` says what the hypervolume is measured in."""
    front = [r for r in rows if r.get("on_front")]
    ver = [r for r in rows if r.get("status_verified") == "ok"]
    vpreset = next((r["verified_preset"] for r in ver), None)
    lines = ["", f"Pareto front   {len(front)} designs, objectives {', '.join(labels)}, "
             f"hypervolume {hypervolume:.6g}" + (f" ({basis})" if basis else ""),
             "  f1 and F_p in calibrated strain" + "".join(f"; {m} [{_unit(m)}]" for m in measures)]
    if vpreset:
        n_on = sum(1 for r in ver if r.get("on_front_verified"))
        lines.append(f"  verified at preset {vpreset}: {len(ver)} designs, {n_on} non-dominated there")
    else:
        lines.append("  not verified at a finer preset yet")
    head = "  rank " + "".join(f"{g:>10}" for g in gene_names) + f"{'f1':>12}" + \
        "".join(f"{m:>{max(12, len(m) + 2)}}" for m in measures) + f"{'F_p':>12}"
    if vpreset:
        head += f"{'f1 ' + vpreset:>14}{'front':>7}"
    lines.append(head + "  note")
    for k, r in enumerate(rows, start=1):
        line = f"  {k:>4} " + "".join(f"{float(r[g]):>10.4g}" for g in gene_names)
        line += f"{_value(r, 'f1'):>12.4g}" + "".join(
            f"{v:>{max(12, len(m) + 2)}.4g}" if (v := _num(r.get(m))) is not None else f"{'-':>{max(12, len(m) + 2)}}"
            for m in measures) + f"{float(r['F_p']):>12.4g}"
        if vpreset:
            fv = _num(r.get("f1_verified"))
            onv = r.get("on_front_verified")
            line += f"{fv:>14.4g}" if fv is not None else f"{'-':>14}"
            line += f"{'yes' if onv else ('no' if onv is not None else '-'):>7}"
        notes = []
        if r.get("penalised_optimum"):
            notes.append("penalised optimum" + ("" if r.get("on_front") else " (off the front)"))
        if r.get("status_verified") not in (None, "", "ok"):
            notes.append(f"verify {r['status_verified']}")
        lines.append(line + ("  " + "; ".join(notes) if notes else ""))
    return lines
