"""Plots of a run: convergence of the GA and the response curves of a design.

Figures are drawn with matplotlib's object API on an Agg canvas (no pyplot, no global
backend switch, works without a display) and written atomically. Each plot has a
``*_figure`` function that returns the :class:`matplotlib.figure.Figure` (for tests and
for callers that want to draw more) and a ``plot_*`` function that writes it.

Every title names the fidelity preset whose numbers the plot shows and its f1 resolution
(:attr:`whisker_opt.experiment.fidelity.Preset.f1_resolution`), passed as the mapping
``fidelity = {"preset": name, "f1_resolution": value}`` stored with a run
(:func:`whisker_opt.experiment.fidelity.describe`). Strains are gauge readings multiplied
by the calibration ξ (``scene.calibration``): "calibrated strain", dimensionless.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from whisker_opt.output import storage
from whisker_opt.output.storage import atomic_write_bytes
from whisker_opt.experiment import objective
from whisker_opt.numfmt import short_float

#: Unit of f1, F_p and the readings in labels.
STRAIN_UNIT = "[-] (calibrated strain)"


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format=Path(path).suffix.lstrip(".") or "png", dpi=120, bbox_inches="tight")
    atomic_write_bytes(Path(path), buf.getvalue())
    return Path(path)


def fidelity_label(fidelity: Mapping[str, Any] | None) -> str:
    """``"preset coarse, f1 resolution ~2e-3"`` (``"(overridden)"`` after the name when it is), or a
    statement that no preset was recorded."""
    if not fidelity or not fidelity.get("preset"):
        return "fidelity preset not recorded"
    name = str(fidelity["preset"]) + (" (overridden)" if fidelity.get("overrides") else "")
    res = fidelity.get("f1_resolution")
    if res is None or not math.isfinite(float(res)):
        return f"preset {name}"
    return f"preset {name}, f1 resolution ~{short_float(res)}"


def design_label(genes: Mapping[str, float], trim: float | None = None) -> str:
    """The genome with units, and the trim: ``α = 2.960°, l = 10.09 mm, …, fibre_pitch = 2.2 mm, trim Δ = 5 mm``
    (an added gene of :func:`whisker_opt.genes.gene_keys` by its key, after Q_i)."""
    from whisker_opt.genes import GENE_NAMES, gene_keys

    g = {k: float(v) for k, v in genes.items()}
    parts = []
    if "alpha" in g:
        parts.append(f"α = {g['alpha']:.3f}°")
    for name in ("l", "t"):
        if name in g:
            parts.append(f"{name} = {g[name]:.2f} mm")
    if "Q_i" in g:
        parts.append(f"Q_i = {g['Q_i']:.4f} MPa")
    keys = gene_keys()
    parts += [f"{k} = {v:.4g}" + (f" {keys[k].unit}" if keys[k].unit not in ("", "-") else "")
              for k, v in g.items() if k in keys and k not in GENE_NAMES]
    if trim is not None:
        parts.append(f"trim Δ = {float(trim):g} mm")
    return ", ".join(parts)


def convergence_figure(
    generations: Sequence[int],
    best_fp: Sequence[float],
    mean_fp: Sequence[float],
    best_feasible: Sequence[bool] | None = None,
    target_fp: float | None = None,
    title: str = "GA convergence",
    fidelity: Mapping[str, Any] | None = None,
    target_strain: str = "calibrated",
    best_f1: Sequence[float | None] | None = None,
    f1_label: str = "f1",
) -> Figure:
    """The convergence figure of :func:`plot_convergence` (integer generation ticks)."""
    g = np.asarray(generations, dtype=float)
    best = np.asarray(best_fp, dtype=float)
    mean = np.asarray(mean_fp, dtype=float)
    fig = Figure(figsize=(6.4, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(g, best, "o-", ms=3, label="best F_p (hall of fame)")
    ax.plot(g, mean, "s--", ms=3, alpha=0.7, label="mean F_p of the feasible designs")
    f1 = None
    if best_f1 is not None:  # the f1 of the best design: the number the f1 resolution applies to
        f1 = np.asarray([math.nan if v is None else float(v) for v in best_f1], dtype=float)
        if np.isfinite(f1).any():
            ax.plot(g, f1, "^:", ms=3, color="C4", label=f"{f1_label} of the best design")
    if best_feasible is not None:
        bad = ~np.asarray(best_feasible, dtype=bool)
        if bad.any():
            ax.plot(g[bad], best[bad], "rx", label="best is a failure")
    xi = float((fidelity or {}).get("calibration") or 0.0)
    if target_fp is not None and target_fp > 0:
        if target_strain == "uncalibrated" and xi > 0:
            ax.axhline(target_fp * xi, color="0.4", lw=0.8, ls=":",
                       label=f"target_fp {short_float(target_fp)} uncalibrated (× ξ = {short_float(target_fp * xi)})")
        else:
            ax.axhline(target_fp, color="0.4", lw=0.8, ls=":", label=f"target_fp {short_float(target_fp)}")
    vals = np.concatenate([best, mean] + ([f1] if f1 is not None else []))
    if np.any(np.isfinite(vals) & (vals > 0)):
        ax.set_yscale("log", nonpositive="mask")
    res = (fidelity or {}).get("f1_resolution")
    if res is not None and math.isfinite(float(res)) and res > 0:
        ax.axhline(res, color="C3", lw=0.9, ls="-.",
                   label=f"f1 resolution of preset {fidelity['preset']} (~{short_float(res)})")
        lo, hi = ax.get_ylim()
        ax.axhspan(min(lo, res), res, color="C3", alpha=0.07, lw=0)
        ax.set_ylim(lo, hi)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    if g.size:
        ax.set_xlim(float(np.nanmin(g)) - 0.5, float(np.nanmax(g)) + 0.5)
    ax.set_xlabel("generation (0 = initial population)")
    what = "F_p, f1" if f1 is not None and np.isfinite(f1).any() else "F_p"
    ax.set_ylabel(f"{what} {STRAIN_UNIT}")
    if xi > 0:  # the same numbers in simulated strain: F_p / ξ
        right = ax.secondary_yaxis("right", functions=(lambda y: y / xi, lambda y: y * xi))
        right.set_ylabel(f"{what} / ξ [-] (uncalibrated strain, ξ = {xi:g})")
    ax.set_title(f"{title}\n{fidelity_label(fidelity)}", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    return fig


def plot_convergence(
    path: Path,
    generations: Sequence[int],
    best_fp: Sequence[float],
    mean_fp: Sequence[float],
    best_feasible: Sequence[bool] | None = None,
    target_fp: float | None = None,
    title: str = "GA convergence",
    fidelity: Mapping[str, Any] | None = None,
    target_strain: str = "calibrated",
    best_f1: Sequence[float | None] | None = None,
    f1_label: str = "f1",
) -> Path:
    """Best and mean F_p per generation, log y (non-positive values are not drawn).

    Parameters
    ----------
    path : Path
        Output image (PNG, SVG or PDF by suffix).
    generations, best_fp, mean_fp : sequences
        One value per generation; ``mean_fp`` is the mean over feasible individuals (NaN
        when none).
    best_feasible : sequence of bool, optional
        Generations whose best is a failure are marked with crosses.
    target_fp : float, optional
        Drawn as a horizontal line (× ξ when ``target_strain`` is 'uncalibrated' and the
        fidelity holds the gauge factor ξ).
    title : str
        First title line; the second names the fidelity.
    fidelity : mapping, optional
        ``{"preset", "f1_resolution", "calibration"}`` of the run: named in the title, the
        resolution drawn as a line with the unresolved range below it shaded; with ξ a right
        axis gives F_p / ξ in uncalibrated strain.
    target_strain : {'calibrated', 'uncalibrated'}
        The strain ``target_fp`` is given in (``stopping.target_strain``).
    best_f1 : sequence of float or None, optional
        The f1 of each generation's best design, drawn beside its F_p: the f1 resolution (and
        the ``resolution`` stopping rule) applies to it.
    f1_label : str
        Its name: ``f1``, or the aggregate over variants a run minimises (``f1_robust``, ...).

    Returns
    -------
    Path
    """
    fig = convergence_figure(generations, best_fp, mean_fp, best_feasible, target_fp, title, fidelity,
                             target_strain, best_f1, f1_label)
    return _save(fig, path)


def curves_figure(
    delta: Sequence[float],
    eps_i: Sequence[float],
    eps_c: Sequence[float],
    title: str = "",
    eps_u: Sequence[float] | None = None,
    fidelity: Mapping[str, Any] | None = None,
    forces: Mapping[str, Sequence[float]] | None = None,
) -> Figure:
    """The figure of :func:`plot_curves`: responses above, residual ε_i − ε_c below and, with
    ``forces``, the contact force F(δ) of each scene at the bottom (:func:`force_panel`)."""
    d = np.asarray(delta, dtype=float)
    a = np.asarray(eps_i, dtype=float)
    b = np.asarray(eps_c, dtype=float)
    u = None if eps_u is None else np.asarray(eps_u, dtype=float)
    f1 = objective.f1(a[1:], b[1:]) if len(d) > 1 else math.nan
    if forces:
        fig = Figure(figsize=(6.4, 8.0))
        ax, ax_r, ax_f = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1, 1.3]})
        force_panel(ax_f, d, forces)
    else:
        fig = Figure(figsize=(6.4, 5.8))
        ax, ax_r = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(d, a, "-", color="C0", label="ε_i intact, Q = Q_i")
    ax.plot(d, b, "--", color="C1", label="ε_c trimmed, vented (Q = 0)")
    if u is not None:
        f1_u = objective.f1(a[1:], u[1:]) if len(d) > 1 else math.nan
        ax.plot(d, u, ":", color="C2",
                label=f"ε_u trimmed, still at Q_i (uncompensated): mean |ε_i − ε_u| = {short_float(f1_u, 2)}")
    ax.set_ylabel(f"gauge strain ε {STRAIN_UNIT}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    r = a - b
    ax_r.plot(d, r, "-", color="C3", lw=1.2, label="ε_i − ε_c")
    ax_r.fill_between(d, r, 0.0, color="C3", alpha=0.15, lw=0)
    ax_r.axhline(0.0, color="0.3", lw=0.6)
    if math.isfinite(f1) and f1 > 0:
        # f1 on the side(s) where the residual lies (both when it changes sign)
        big = float(np.nanmax(np.abs(r))) if r.size else 0.0
        signs = [sg for sg, has in ((1.0, np.any(r > 0.01 * big)), (-1.0, np.any(r < -0.01 * big))) if has]
        for k, sg in enumerate(signs):
            ax_r.axhline(sg * f1, color="0.2", lw=0.9, ls=":",
                         label=("± " if len(signs) > 1 else "") + f"f1 = mean |ε_i − ε_c| = {short_float(f1, 2)}"
                         if k == 0 else None)
    res = (fidelity or {}).get("f1_resolution")
    if res is not None and math.isfinite(float(res)) and res > 0:
        lo, hi = ax_r.get_ylim()
        ax_r.axhspan(-res, res, color="0.5", alpha=0.12, lw=0,
                     label=f"± f1 resolution ~{short_float(res)}: a smaller f1 is not resolved")
        ax_r.set_ylim(lo, hi)
    if not forces:
        ax_r.set_xlabel("deflection δ [mm]")
    ax_r.set_ylabel("ε_i − ε_c [-]")
    ax_r.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
    ax_r.grid(True, alpha=0.3)
    ax_r.legend(fontsize=7, loc="best")
    ax_r.set_title(f"residual ε_i − ε_c; f1 = mean |ε_i − ε_c| over δ > 0 = {short_float(f1, 2)} "
                   "(calibrated strain)", fontsize=9)
    head = f"{title}\n" if title else ""
    ax.set_title(f"{head}{fidelity_label(fidelity)}", fontsize=9)
    fig.set_layout_engine("constrained")
    return fig


#: Line style, colour and label of a scene, the same in the strain and force panels of :func:`curves_figure`.
_SCENE_STYLE = {"intact": ("-", "C0", "F_i intact, Q = Q_i"), "trimmed": ("--", "C1", "F_c trimmed, vented"),
                "trimmed_uncompensated": (":", "C2", "F_u trimmed, still at Q_i")}


def force_panel(ax, delta: Sequence[float], forces: Mapping[str, Sequence[float]]) -> None:
    """Contact force F(δ) [N] of each named scene on ``ax``, its secant stiffness at the first
    plotted deflection δ₁ > 0, k = F(δ₁)/δ₁ [N/mm], in the legend."""
    d = np.asarray(delta, dtype=float)
    for k, (name, f) in enumerate(forces.items()):
        f = np.asarray(f, dtype=float)
        stiff = f[1] / d[1] if len(d) > 1 and d[1] > 0 else math.nan
        ls, colour, label = _SCENE_STYLE.get(name, (("-", "--", ":")[k % 3], f"C{3 + k}", name))
        ax.plot(d, f, ls, color=colour, label=f"{label}: F/δ at δ = {d[1]:g} mm: {short_float(stiff, 3)} N/mm"
                if len(d) > 1 else label)
    ax.set_xlabel("deflection δ [mm]")
    ax.set_ylabel("contact force F [N]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")


def plot_forces(path: Path, delta: Sequence[float], forces: Mapping[str, Sequence[float]], title: str = "",
                fidelity: Mapping[str, Any] | None = None) -> Path:
    """Force–deflection curves F(δ) of named scenes (:func:`force_panel`) as an image.

    Parameters
    ----------
    path : Path
    delta : sequence
        Deflection δ [mm], starting at 0.
    forces : mapping of scene name -> sequence
        Contact force [N] at ``delta``.
    title : str
    fidelity : mapping, optional
        Named in the title (:func:`fidelity_label`).
    """
    fig = Figure(figsize=(6.4, 4.2))
    ax = fig.subplots()
    force_panel(ax, delta, forces)
    head = f"{title}\n" if title else ""
    ax.set_title(f"{head}{fidelity_label(fidelity)}", fontsize=9)
    fig.set_layout_engine("constrained")
    return _save(fig, path)


def plot_curves(
    path: Path,
    delta: Sequence[float],
    eps_i: Sequence[float],
    eps_c: Sequence[float],
    title: str = "",
    eps_u: Sequence[float] | None = None,
    fidelity: Mapping[str, Any] | None = None,
    forces: Mapping[str, Sequence[float]] | None = None,
) -> Path:
    """Gauge responses ε_i(δ) (intact, pressurised), ε_c(δ) (trimmed, vented) and, when given,
    ε_u(δ) (trimmed, still at Q_i); below them the residual ε_i − ε_c, whose mean absolute
    value is f1.

    Parameters
    ----------
    path : Path
        Output image.
    delta : sequence
        Deflection δ [mm], starting at 0 (δ = 0 is left out of f1).
    eps_i, eps_c : sequences
        Calibrated gauge strain [-] of the intact and the compensated (trimmed) whisker.
    title : str
        First title line (e.g. :func:`design_label`); the next names the fidelity.
    eps_u : sequence, optional
        Calibrated gauge strain [-] of the trimmed whisker left at Q_i.
    fidelity : mapping, optional
        ``{"preset", "f1_resolution"}``; the resolution is shaded on the residual panel.
    forces : mapping of scene name -> sequence, optional
        Contact force [N] at ``delta``: a third panel (:func:`force_panel`).

    Returns
    -------
    Path
    """
    return _save(curves_figure(delta, eps_i, eps_c, title, eps_u, fidelity, forces), path)


def write_best_curves(run_dir: Path, delta: Sequence[float], eps_i: Sequence[float], eps_c: Sequence[float],
                      title: str = "best design", eps_u: Sequence[float] | None = None,
                      fidelity: Mapping[str, Any] | None = None) -> Path:
    """``best_curves.csv`` and ``best_curves.png``; returns the CSV path.

    Parameters
    ----------
    run_dir : Path
    delta, eps_i, eps_c : sequences
        As in :func:`plot_curves`.
    title : str
    eps_u : sequence, optional
        The uncompensated curve (trimmed whisker at Q_i), plotted and written as column ``eps_u``.
    fidelity : mapping, optional
        As in :func:`plot_curves`.

    Returns
    -------
    Path
        The CSV (columns ``delta_mm, eps_i, eps_c`` and, with ``eps_u``, ``eps_u``).
    """
    run_dir = Path(run_dir)
    cols = ["delta_mm", "eps_i", "eps_c"]
    rows = [{"delta_mm": float(d), "eps_i": float(a), "eps_c": float(b)} for d, a, b in zip(delta, eps_i, eps_c)]
    if eps_u is not None:
        cols.append("eps_u")
        for row, v in zip(rows, eps_u):
            row["eps_u"] = float(v)
    path = run_dir / storage.BEST_CURVES_CSV
    storage.write_csv(path, cols, rows)
    plot_curves(run_dir / "best_curves.png", delta, eps_i, eps_c, title, eps_u, fidelity)
    return path
