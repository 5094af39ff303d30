"""What a robustness study writes: its tables, its JSON and its plot (all atomically).

``robustness.csv``
    One row per design and method: the genes, the run's f1 when the design comes from a run,
    and the nominal value, mean, standard deviation and worst case of f1 and of the recovery
    rate [%], the deviated designs solved and the wall time.
``robustness_sensitivities.csv``
    One row per design, method and toleranced parameter: its half-width h and σ, the slope of
    each output (``df1``, ``drecovery_rate``: central difference, or the sample's linear fit) and
    its share σ·slope of the standard deviation; for the expansion also the outputs at −h and +h.
``robustness.json``
    The settings, and per design and method every number above plus the sample's points and values.
``robustness.png``
    One row per design: a tornado of each tolerance's effect on f1 (f1 at the low and the
    high end of the tolerance, about the nominal f1) and, when a sample was drawn, the
    histogram of the sample's f1 with its mean, mean + std and worst value.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from whisker_opt.output import storage
from whisker_opt.output.plots import STRAIN_UNIT, _save

SUMMARY_CSV = "robustness.csv"
SENSITIVITIES_CSV = "robustness_sensitivities.csv"
JSON = "robustness.json"
PNG = "robustness.png"


def _columns(rows: Sequence[dict]) -> list[str]:
    cols: list[str] = []
    for row in rows:
        cols += [k for k in row if k not in cols]
    return cols


def robustness_figure(items: Sequence[dict[str, Any]], title: str = "") -> Figure:
    """The tornado (and histogram) of each design (:mod:`whisker_opt.robustness` ``_plot_data`` items).

    Parameters
    ----------
    items : sequence of dict
        ``label``, ``nominal``, ``parameters`` and ``minus``/``plus`` (f1 at −h and +h per
        parameter, optional), ``sample`` (the sample's f1, optional) with ``sample_mean``,
        ``sample_std``, ``sample_worst``.
    title : str
        Above the figure (e.g. the fidelity preset).
    """
    n = max(len(items), 1)
    fig = Figure(figsize=(12, 3.4 * n))
    axes = fig.subplots(n, 2, squeeze=False)
    for row, item in zip(axes, items):
        ax, hx = row
        f0 = float(item["nominal"])
        if "minus" in item:
            names = list(item["parameters"])
            lo = np.asarray(item["minus"], dtype=float) - f0
            hi = np.asarray(item["plus"], dtype=float) - f0
            order = np.argsort(np.nan_to_num(np.maximum(np.abs(lo), np.abs(hi))))  # largest effect on top
            y = np.arange(len(order))
            ax.barh(y - 0.2, lo[order], height=0.4, color="tab:blue", label="parameter at −h")
            ax.barh(y + 0.2, hi[order], height=0.4, color="tab:orange", label="parameter at +h")
            ax.set_yticks(y, [names[i] for i in order])
            ax.axvline(0.0, color="k", lw=0.8)
            ax.xaxis.set_major_locator(MaxNLocator(5))
            ax.set_xlabel(f"f1 − nominal f1 ({f0:.3g}) {STRAIN_UNIT}")
            ax.set_title(f"{item['label']}\ntornado ({item.get('tornado', '')})", fontsize=9)
            ax.legend(fontsize=8, loc="lower right")
        else:
            ax.set_axis_off()
        sample = item.get("sample")
        if sample is not None:
            vals = np.asarray(sample, dtype=float)
            vals = vals[np.isfinite(vals)]
            hx.hist(vals, bins=max(5, min(30, vals.size // 2)), color="0.6", edgecolor="k")
            m, s = float(item["sample_mean"]), float(item["sample_std"])
            hx.axvline(f0, color="k", ls=":", label=f"nominal {f0:.3g}")
            hx.axvline(m, color="tab:green", label=f"mean {m:.3g}")
            hx.axvline(m + s, color="tab:green", ls="--", label=f"mean + std {m + s:.3g}")
            hx.axvline(float(item["sample_worst"]), color="tab:red", label=f"worst {float(item['sample_worst']):.3g}")
            hx.set_xlabel(f"f1 {STRAIN_UNIT}")
            hx.xaxis.set_major_locator(MaxNLocator(5))
            hx.set_ylabel("designs of the sample")
            hx.set_title(f"sample of {vals.size} deviated designs", fontsize=9)
            hx.legend(fontsize=8)
        elif "minus" in item:
            m, s = float(item["mean"]), float(item["std"])
            hx.bar(["nominal", "mean + std", "worst corner"], [f0, m + s, float(item["worst"])],
                   color=["0.6", "tab:green", "tab:red"])
            hx.set_ylabel(f"f1 {STRAIN_UNIT}")
            hx.set_title("first-order expansion (no sample drawn)", fontsize=9)
        else:
            hx.set_axis_off()
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def write_outputs(out: Path, summary: Sequence[dict], sensitivities: Sequence[dict], data: dict,
                  plot_items: Sequence[dict], fidelity: str = "") -> dict[str, Path]:
    """Write the four files of a study into ``out`` (created).

    Returns
    -------
    dict of str -> Path
        ``csv``, ``sensitivities``, ``json``, ``png``.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"csv": out / SUMMARY_CSV, "sensitivities": out / SENSITIVITIES_CSV, "json": out / JSON, "png": out / PNG}
    storage.write_csv(paths["csv"], _columns(summary), summary)
    storage.write_csv(paths["sensitivities"], _columns(sensitivities), sensitivities)
    storage.write_json(paths["json"], data)
    title = "robustness of f1 to the fabrication tolerances" + (f" ({fidelity})" if fidelity else "")
    _save(robustness_figure(plot_items, title), paths["png"])
    return paths
