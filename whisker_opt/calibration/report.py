"""What a calibration writes and prints: ``calibration.json``, ``calibrated.yaml``, ``calibration.png``, a summary.

``calibrated.yaml`` is the resolved run file (every key at its value) with the fitted values set and
without the ``calibration`` section, so ``whisker-opt run`` and ``whisker-opt compensate`` take it as it
is. Its header says that it is a calibrated model, from which run file and data source, on which date,
and the fitted values with their uncertainties: a calibrated model is used by name, never silently.
The header calls calibrated only the parameters the observations determine
(:func:`~whisker_opt.calibration.fit.determined`) and names those they do not; a fit that did not
converge, or that determines no parameter (:attr:`~whisker_opt.calibration.fit.FitOutcome.state`), is
headed ``NOT CALIBRATED`` instead, with the reason. The header, the summary and ``calibration.json``
state the fit's status, χ²/ν against its limit (flagged above it), each parameter's uncertainty and
whether it is determined, the local fits and where they started, and every warning
(:meth:`~whisker_opt.calibration.fit.FitOutcome.warnings`).

The figure has one panel per kind of observation: each observation's measured value with its stated
uncertainty (±σ), the model's value at the start and at the fitted parameters, held-out observations
marked apart, and unmatched restore predictions drawn hollow.
"""

from __future__ import annotations

import io
import math
import textwrap
import time
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from whisker_opt.calibration.fit import (CHI2_QUANTILE, DETERMINED_FRACTION, NOT_DETERMINED, FitOutcome,
                                         ObservationResult, chi2_limit)
from whisker_opt.config.model import WhiskerConfig
from whisker_opt.output.storage import atomic_write_bytes, atomic_write_text, write_json

CALIBRATION_JSON = "calibration.json"
CALIBRATED_YAML = "calibrated.yaml"
CALIBRATION_PNG = "calibration.png"

_KIND_TITLES = {"restore": "restore: matching pressure [MPa]", "response": "response: reading or ratio",
                "extension": "extension Δl [mm]"}


def _f(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _observation(o: ObservationResult) -> dict[str, Any]:
    return {
        "name": o.name, "kind": o.kind, "where": o.where, "unit": o.unit, "held_out": o.held_out,
        "measured": o.measured, "sigma": o.sigma, "weight": o.weight,
        "start": _f(o.start.value), "start_matched": o.start.matched, "start_miss": _f(o.start_miss),
        "fitted": _f(o.fitted.value), "matched": o.fitted.matched, "miss": _f(o.miss),
        "residual": _f(o.residual), "note": o.fitted.note, "start_note": o.start.note,
        "specimens": o.specimens, "predicted_std": _f(o.predicted_std), "z": _f(o.z),
    }


def summary_dict(outcome: FitOutcome, *, source: str, config: str, model: str,
                 fidelity: Mapping[str, Any] | None, date: str) -> dict[str, Any]:
    """The content of ``calibration.json``."""
    params = []
    for k, p in enumerate(outcome.parameters):
        params.append({"path": p.path, "unit": p.unit, "lower": p.lower, "upper": p.upper, "start": p.start,
                       "value": float(outcome.values[k]), "std": _f(outcome.std[k]),
                       "std_scaled": _f(outcome.std_scaled[k]), "uncertainty": _f(outcome.uncertainty[k]),
                       "at_bound": outcome.at_bound[k], "determined": outcome.determined[k]})
    names = [p.path for p in outcome.parameters]
    return {
        "calibrated_model": outcome.calibrated, "fit_status": outcome.state, "warnings": outcome.warnings(),
        "calibrated_parameters": [n for n, ok in zip(names, outcome.determined) if ok and outcome.calibrated],
        "undetermined_parameters": [n for n, ok in zip(names, outcome.determined) if not ok],
        "determined_fraction": DETERMINED_FRACTION, "chi2_high": outcome.chi2_high,
        "start_dependent": outcome.start_dependent,
        "starts": [{"origin": f.origin, "start": dict(zip(names, map(float, f.start))),
                    "end": dict(zip(names, map(float, f.values))), "cost_start": f.cost_start, "cost": f.cost,
                    "status": f.status, "message": f.message, "evaluations": f.evaluations} for f in outcome.starts],
        "scan": [{"values": dict(zip(names, map(float, theta))), "cost": _f(c)} for theta, c in outcome.scan],
        "total_evaluations": outcome.total_evaluations,
        "source": source, "config": config, "date": date, "model": model,
        "fidelity": dict(fidelity) if fidelity else None,
        "parameters": params,
        "correlation": [[_f(v) for v in row] for row in outcome.correlation],
        "singular_values": [float(v) for v in outcome.singular_values],
        "cost_start": outcome.cost_start, "cost": outcome.cost, "chi2": outcome.chi2, "dof": outcome.dof,
        "chi2_per_dof": _f(outcome.chi2_per_dof), "chi2_per_dof_limit": _f(chi2_limit(outcome.dof)),
        "chi2_quantile": CHI2_QUANTILE, "at_bound_tolerance": outcome.tolerance,
        "observations": [_observation(o) for o in outcome.observations],
        "held_out": {o.name: {"measured": o.measured, "sigma": o.sigma, "predicted": _f(o.fitted.value),
                              "predicted_std": _f(o.predicted_std), "miss": _f(o.miss), "z": _f(o.z),
                              "matched": o.fitted.matched, "unit": o.unit, "specimens": o.specimens}
                     for o in outcome.held_out},
        "evaluations": outcome.evaluations, "max_evaluations": outcome.max_evaluations,
        "scenes_solved": outcome.scenes, "seconds": outcome.seconds,
        "status": outcome.status, "message": outcome.message,
    }


def _pm(value: float, std: float, unit: str) -> str:
    u = "" if unit in ("", "-") else f" {unit}"
    if not math.isfinite(std):
        return f"{value:.6g}{u} (not determined by these observations)"
    return f"{value:.6g} ± {std:.2g}{u}"


def _headline(outcome: FitOutcome, config: str, date: str) -> list[str]:
    """The first lines of ``calibrated.yaml``: what is calibrated, what is not, and a misfit flag."""
    made = f"Written by `whisker-opt calibrate` from {Path(config).name} on {date}."
    undetermined = [p.path for p, ok in zip(outcome.parameters, outcome.determined) if not ok]
    if outcome.calibrated and not undetermined:
        head = [f"# CALIBRATED MODEL, not the default one: written by `whisker-opt calibrate` from {Path(config).name} "
                f"on {date}."]
    elif outcome.calibrated:
        good = [p.path for p, ok in zip(outcome.parameters, outcome.determined) if ok]
        head = [f"# CALIBRATED MODEL in {', '.join(good)} only, not the default one. NOT DETERMINED by the data, "
                f"left where the fit stopped: {', '.join(undetermined)}.", f"# {made}"]
    else:
        why = ("the observations determine none of the parameters" if outcome.state == NOT_DETERMINED else
               "the fit stopped before it converged")
        head = [f"# NOT CALIBRATED ({outcome.state}): {why}; the values below are where it stopped,",
                f"# not a calibrated model. {made}"]
    if outcome.chi2_high:
        limit = chi2_limit(outcome.dof)
        head.append(f"# MISFIT: chi2/dof = {outcome.chi2_per_dof:.4g} is above its limit {limit:.3g}: "
                    "the model does not reach the data within their stated uncertainties.")
    return head


def calibrated_yaml(cfg: WhiskerConfig, outcome: FitOutcome, *, source: str, config: str, date: str) -> str:
    """The text of ``calibrated.yaml``: a header of comments, then the resolved run file."""
    data = cfg.model_dump(mode="json")
    data.pop("calibration", None)
    lines = [
        *_headline(outcome, config, date),
        f"# Fit: {_status_line(outcome)}",
        *(f"# WARNING: {w}" for w in outcome.warnings()),
        f"# Data source: {' '.join(source.split())}",
        "# Fitted values (± standard uncertainty from the fit's Jacobian, scaled by sqrt(chi2/dof) when that is",
        "# above 1; calibration.json beside this file holds the residual of every observation and the held-out",
        "# predictions):",
    ]
    for k, p in enumerate(outcome.parameters):
        bound = f" (at its {outcome.at_bound[k]} bound)" if outcome.at_bound[k] else ""
        what = "determined" if outcome.determined[k] else "NOT DETERMINED"
        lines.append(f"#   {p.path} = {_pm(outcome.values[k], outcome.uncertainty[k], p.unit)}{bound}  "
                     f"({what}; range [{p.lower:g}, {p.upper:g}], start {p.start:.6g})")
    for o in outcome.held_out:
        state = "" if o.fitted.matched else " (no match found)"
        u = "" if o.unit in ("", "-") else f" {o.unit}"
        pred = (f"{o.fitted.value:.6g}{u}" if math.isnan(o.predicted_std)
                else _pm(o.fitted.value, o.predicted_std, o.unit))
        z = "" if math.isnan(o.z) else f", z {o.z:+.2g}"
        lines.append(f"# Held out: {o.name}: measured {_pm(o.measured, o.sigma, o.unit)}, predicted {pred}{state}{z}")
    lines += ["# Use it by name (e.g. `whisker-opt run THIS_FILE`); the project's defaults are unchanged.", ""]
    return "\n".join(lines) + yaml.safe_dump(data, sort_keys=False)


def _status_line(outcome: FitOutcome) -> str:
    """The fit's state, its evaluations against the budget and χ²/ν against its limit."""
    limit = chi2_limit(outcome.dof)
    chi = (f"chi2/dof {outcome.chi2_per_dof:.4g} (limit {limit:.3g})" if outcome.dof > 0
           else "chi2/dof undefined (no more observations than parameters)")
    return (f"{outcome.state.upper()} after {outcome.evaluations} of at most {outcome.max_evaluations} model "
            f"evaluations; {chi}")


def format_summary(outcome: FitOutcome, *, source: str) -> str:
    """The printed summary: the fit's status and warnings, the parameters, then every observation
    measured / start / fitted / miss."""
    out = [f"calibration against {source}", f"status: {_status_line(outcome)}",
           f"{outcome.message.rstrip('.')}; {outcome.total_evaluations} model evaluations in all (a scan of "
           f"{len(outcome.scan)}, {len(outcome.starts)} local fit(s)), {outcome.scenes} scenes, "
           f"{outcome.seconds:.0f} s; cost {outcome.cost_start:.5g} -> {outcome.cost:.5g} (chi2 {outcome.chi2:.4g}, dof {outcome.dof})"]
    out += [f"WARNING: {w}" for w in outcome.warnings()]
    out += ["", f"{'parameter':<28} {'start':>10} {'fitted':>12} {'std':>10} {'scaled':>10}  determined  unit"]
    for k, p in enumerate(outcome.parameters):
        std, scaled = (f"{v:.3g}" if math.isfinite(v) else "inf" for v in (outcome.std[k], outcome.std_scaled[k]))
        bound = f"  (at {outcome.at_bound[k]} bound)" if outcome.at_bound[k] else ""
        ok = "yes" if outcome.determined[k] else "NO"
        out.append(f"{p.path:<28} {p.start:>10.5g} {outcome.values[k]:>12.6g} {std:>10} {scaled:>10}  {ok:<10}  "
                   f"{p.unit}{bound}")
    out += ["", "local fits:"] + [f"  from {f.origin}: {f.cost_start:.5g} -> {f.cost:.5g} in {f.evaluations} "
                                  f"evaluations, ending at {', '.join(f'{v:.6g}' for v in f.values)}"
                                  for f in outcome.starts]
    out += ["", f"{'observation':<26} {'kind':<9} {'measured':>10} {'±σ':>8} {'start':>10} {'fitted':>10} "
                f"{'miss':>10}  unit"]
    for o in outcome.observations:
        tag = (" [held out]" + ("" if math.isnan(o.predicted_std) else f" (prediction ±{o.predicted_std:.3g}, "
                                f"z {o.z:+.2g})") if o.held_out else "") + \
            (" [two specimens]" if o.specimens == 2 else "")
        flag = "" if o.fitted.matched else " (no match)"
        out.append(f"{o.name:<26} {o.kind:<9} {o.measured:>10.5g} {o.sigma:>8.3g} {o.start.value:>10.5g} "
                   f"{o.fitted.value:>10.5g} {o.miss:>+10.4g}  {o.unit}{tag}{flag}")
    notes = [f"  {o.name}: {o.fitted.note}" for o in outcome.observations if not o.fitted.matched]
    if notes:
        out += ["", "not matched by the fitted model:"] + notes
    return "\n".join(out)


def calibration_figure(outcome: FitOutcome, *, title: str = ""):
    """Measured (±σ) against the start and fitted model, one panel per kind of observation."""
    from matplotlib.figure import Figure

    kinds = [k for k in ("restore", "response", "extension") if any(o.kind == k for o in outcome.observations)]
    fig = Figure(figsize=(max(6.0, 0.55 * len(outcome.observations) + 3.0), 3.2 * len(kinds)))
    axes = fig.subplots(len(kinds), 1, squeeze=False)[:, 0]
    for ax, kind in zip(axes, kinds):
        obs = [o for o in outcome.observations if o.kind == kind]
        x = np.arange(len(obs))
        ax.errorbar(x, [o.measured for o in obs], yerr=[o.sigma for o in obs], fmt="s", color="black", mfc="none",
                    markersize=9, capsize=4, zorder=2, label="measured ± σ")
        ax.plot(x, [o.start.value for o in obs], "o", mfc="none", color="tab:grey", label="model at start")
        for xi, o in zip(x, obs):
            colour = "tab:red" if o.held_out else "tab:blue"
            ax.plot([xi], [o.fitted.value], "o", color=colour, mfc=colour if o.fitted.matched else "none",
                    markersize=6, zorder=4)
        ax.plot([], [], "o", color="tab:blue",
                label="calibrated model" if outcome.calibrated else f"fitted, NOT calibrated ({outcome.state})")
        if any(o.held_out for o in obs):
            ax.plot([], [], "o", color="tab:red", label="calibrated, held out")
        if any(not o.fitted.matched for o in obs):
            ax.plot([], [], "o", color="tab:blue", mfc="none", label="no match (Q extrapolated)")
        ax.set_xticks(x)
        ax.set_xticklabels([o.name for o in obs], rotation=30, ha="right", fontsize=8)
        ax.set_title(_KIND_TITLES[kind], fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def write_outputs(out: Path, cfg: WhiskerConfig, outcome: FitOutcome, *, source: str, config: str, model: str,
                  fidelity: Mapping[str, Any] | None) -> dict[str, Path]:
    """Write ``calibration.json``, ``calibrated.yaml`` and ``calibration.png`` into ``out`` (atomically).

    Parameters
    ----------
    out : Path
        An existing folder.
    cfg : WhiskerConfig
        The run file at the fitted values.
    outcome : FitOutcome
    source, config, model : str
        The data source, the calibration's run file, 'fe' or 'beam'.
    fidelity : mapping, optional
        ``{"preset", ...}`` of the FE model.

    Returns
    -------
    dict of str -> Path
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    out = Path(out)
    date = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    paths = {"json": out / CALIBRATION_JSON, "yaml": out / CALIBRATED_YAML, "png": out / CALIBRATION_PNG}
    write_json(paths["json"], summary_dict(outcome, source=source, config=config, model=model, fidelity=fidelity,
                                           date=date))
    atomic_write_text(paths["yaml"], calibrated_yaml(cfg, outcome, source=source, config=config, date=date))
    preset = f", preset {fidelity['preset']}" if fidelity and fidelity.get("preset") else ""
    what = textwrap.shorten(" ".join(source.split()), 240, placeholder=" …")
    fig = calibration_figure(outcome, title=f"calibration ({model} model{preset}), data: " + "\n".join(
        textwrap.wrap(what, 110)))
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    atomic_write_bytes(paths["png"], buf.getvalue())
    return paths
