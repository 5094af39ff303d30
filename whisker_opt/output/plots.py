"""Plots of a run: convergence of the GA and the response curves of a design.

Figures are drawn with matplotlib's object API on an Agg canvas (no pyplot, no global
backend switch, works without a display) and written atomically.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from whisker_opt.output import storage
from whisker_opt.output.storage import atomic_write_bytes
from whisker_opt.experiment import objective


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format=Path(path).suffix.lstrip(".") or "png", dpi=120, bbox_inches="tight")
    atomic_write_bytes(Path(path), buf.getvalue())
    return Path(path)


def plot_convergence(
    path: Path,
    generations: Sequence[int],
    best_fp: Sequence[float],
    mean_fp: Sequence[float],
    best_feasible: Sequence[bool] | None = None,
    target_fp: float | None = None,
    title: str = "GA convergence",
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
        Drawn as a horizontal line.
    title : str
    """
    g = np.asarray(generations, dtype=float)
    best = np.asarray(best_fp, dtype=float)
    mean = np.asarray(mean_fp, dtype=float)
    fig = Figure(figsize=(6.4, 4.0))
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(g, best, "o-", ms=3, label="best F_p")
    ax.plot(g, mean, "s--", ms=3, alpha=0.7, label="mean F_p (feasible)")
    if best_feasible is not None:
        bad = ~np.asarray(best_feasible, dtype=bool)
        if bad.any():
            ax.plot(g[bad], best[bad], "rx", label="best is a failure")
    if target_fp is not None and target_fp > 0:
        ax.axhline(target_fp, color="0.5", lw=0.8, ls=":", label=f"target {target_fp:g}")
    vals = np.concatenate([best, mean])
    if np.any(np.isfinite(vals) & (vals > 0)):
        ax.set_yscale("log", nonpositive="mask")
    ax.set_xlabel("generation")
    ax.set_ylabel("F_p [-]")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def plot_curves(
    path: Path,
    delta: Sequence[float],
    eps_i: Sequence[float],
    eps_c: Sequence[float],
    title: str = "",
) -> Path:
    """Gauge responses ε_i(δ) (intact, pressurised) and ε_c(δ) (trimmed, vented), and their gap.

    Parameters
    ----------
    path : Path
        Output image.
    delta : sequence
        Deflection δ [mm].
    eps_i, eps_c : sequences
        Calibrated gauge strain [-] of the intact and the compensated (trimmed) whisker.
    title : str
    """
    d = np.asarray(delta, dtype=float)
    a = np.asarray(eps_i, dtype=float)
    b = np.asarray(eps_c, dtype=float)
    f1 = objective.f1(a[1:], b[1:]) if len(d) > 1 else math.nan
    fig = Figure(figsize=(6.4, 4.0))
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(d, a, "-", label="ε_i intact, Q = Q_i")
    ax.plot(d, b, "--", label="ε_c trimmed, Q = 0")
    ax.fill_between(d, a, b, color="C3", alpha=0.15, label=f"|ε_i − ε_c|, mean {f1:.3g}")
    ax.set_xlabel("deflection δ [mm]")
    ax.set_ylabel("gauge strain ε [-]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def write_best_curves(run_dir: Path, delta: Sequence[float], eps_i: Sequence[float], eps_c: Sequence[float],
                      title: str = "best design") -> Path:
    """``best_curves.csv`` (delta_mm, eps_i, eps_c) and ``best_curves.png``; returns the CSV path."""
    run_dir = Path(run_dir)
    rows = [{"delta_mm": float(d), "eps_i": float(a), "eps_c": float(b)} for d, a, b in zip(delta, eps_i, eps_c)]
    path = run_dir / storage.BEST_CURVES_CSV
    storage.write_csv(path, ["delta_mm", "eps_i", "eps_c"], rows)
    plot_curves(run_dir / "best_curves.png", delta, eps_i, eps_c, title)
    return path
