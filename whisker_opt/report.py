"""The text report of a run directory (``whisker-opt report``, and the end of ``run`` and ``resume``).

It reads what :mod:`whisker_opt.optimise.runner` keeps in a run directory (the checkpoint, the run's config),
rebuilds the plots and appends the lines of the run's outputs and of the wall-law spread of its best designs
(:mod:`whisker_opt.analysis.law_spread`): it stands above the optimiser and the analyses, which import nothing of it.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import Any

from whisker_opt.analysis.law_spread import report_lines as spread_lines
from whisker_opt.numfmt import short_float
from whisker_opt.optimise.best import describe_distance, run_best_designs
from whisker_opt.optimise.ga import best_design
from whisker_opt.optimise.nsga2 import make_algorithm
from whisker_opt.optimise.recorder import outputs_of, write_plots
from whisker_opt.optimise.resolution import resolution_warning, run_fidelity, target_warning
from whisker_opt.optimise.rundir import change_lines, check_state_config
from whisker_opt.optimise.runner import load_run


def _fmt(x: Any, spec: str = ".6g") -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return format(x, spec)
    return str(x)


def _fp_line(b: dict, stopping, xi: float | None) -> str:
    """The best design's F_p and ``stopping.target_fp``, each with the strain it is written in: F_p calibrated
    (and uncalibrated), the target in its ``target_strain`` (and the other, when ξ is known)."""
    uncal = f" ({_fmt(b['F_p_uncalibrated'])} uncalibrated)" if b.get("F_p_uncalibrated") is not None else ""
    target = f"{stopping.target_fp:g} {stopping.target_strain}"
    if xi:
        other, kind = ((stopping.target_fp * xi, "calibrated") if stopping.target_strain == "uncalibrated"
                       else (stopping.target_fp / xi, "uncalibrated"))
        target += f" ({other:.6g} {kind})"
    return (f"  F_p    {_fmt(b['F_p'])} calibrated{uncal}; {b['status']}, generation {b['generation_found']}, "
            f"eval {b['eval_id']}; target_fp {target}")


def best_design_lines(designs: list[dict], cfg, names: tuple[str, ...], objective: str | None = None) -> list[str]:
    """The report's table of the best designs (:func:`whisker_opt.optimise.best.run_best_designs`), with the
    column of the aggregate over variants the run minimises (``objective``, e.g. ``f1_robust``) after f1."""
    width = max(13, len(objective) + 1) if objective else 0
    lines = ["", f"best designs   {len(designs)} of at most {cfg.ga.hall_of_fame}, "
             f"{describe_distance(cfg.distinct_distance)}",
             "  rank " + "".join(f"{n:>{max(11, len(n) + 1)}}" for n in names) + f"{'f1':>13}"
             + (f"{objective:>{width}}" if objective else "") + f"{'F_p':>13}{'eval':>7}{'gen':>5}{'apart':>7}"
             + f"   ({', '.join(['f1', *([objective] if objective else []), 'F_p'])} calibrated)"]
    for d in designs:
        gap = d["distance_to_better"]
        lines.append(f"  {d['rank']:>4} " + "".join(f"{d['genes'][n]:>{max(11, len(n) + 1)}.5g}" for n in names)
                     + f"{d['f1']:>13.5g}" + (f"{_fmt(d.get(objective), '.5g'):>{width}}" if objective else "")
                     + f"{d['F_p']:>13.5g}{_fmt(d['eval_id']):>7}{_fmt(d['generation']):>5}"
                     + f"{'-' if gap is None else format(gap, '.3f'):>7}")
    if not designs:
        lines.append("  (no feasible design)")
    return lines


def report(run_dir: Path, max_rows: int = 60) -> str:
    """Summary table of a run (text), rebuilding its plots.

    Parameters
    ----------
    run_dir : Path
        A run directory with a checkpoint.
    max_rows : int
        Generations shown in full up to this many; beyond, the first and last halves.

    Returns
    -------
    str
        Multi-line text: run facts (the stopping rule that fired and why, the fidelity preset and
        its f1 resolution), best design, the best designs pairwise distinct by
        ``optimiser.distinct_distance`` (:func:`whisker_opt.optimise.best.run_best_designs`, with
        D to the nearest better one in column ``apart``) and the per-generation table; ``WARNING``
        lines when the best f1 or ``stopping.target_fp`` lies below the f1 resolution
        (:mod:`whisker_opt.optimise.resolution`).

    Raises
    ------
    whisker_opt.optimise.rundir.ConfigChanged
        The checkpoint was written under another config than the run's ``config.yaml``
        (:func:`whisker_opt.optimise.rundir.check_state_config`): nothing is shown or written.
    """
    run_dir = Path(run_dir)
    state, cfg, _, seed = load_run(run_dir)
    if state is None or state.generation < 0:
        return f"{run_dir}: no generation completed yet"
    check_state_config(run_dir, state.extra)  # not another run's checkpoint
    write_plots(run_dir, state, cfg)
    ga = make_algorithm(cfg, seed)
    outputs = outputs_of(cfg)
    outputs.write(run_dir, ga, state)
    b = best_design(state)
    statuses = Counter(r["status"] for r in state.records if r["status"] != "ok")
    rate = state.n_evaluations / state.elapsed_s if state.elapsed_s > 0 else math.nan
    fidelity = run_fidelity(state, run_dir)
    if fidelity:
        over = f" (overridden: {', '.join(f'{k}={v}' for k, v in fidelity['overrides'].items())})" \
            if fidelity.get("overrides") else ""
        fid_line = (f"preset {fidelity['preset']}{over}, f1 resolution ~{short_float(fidelity['f1_resolution'])} "
                    f"(calibrated strain): f1 below it is not resolved")
    else:
        fid_line = "not recorded"
    strain = cfg.stopping.target_strain
    warning = resolution_warning(state, fidelity, run_dir, strain) if state.stop_reason else None
    early = target_warning(cfg.stopping, fidelity) if cfg.algorithm == "ga" else None
    detail = (state.extra or {}).get("stop_detail") if state.stop_reason else None
    lines = [
        f"run            {run_dir}",
        f"seed           {seed}",
        f"status         {'finished: ' + state.stop_reason if state.stop_reason else 'interrupted (resume it)'}",
        *([f"stopped by     {detail}"] if detail else []),
        f"fidelity       {fid_line}",
        *(f"config         {line}" for line in change_lines(state.extra)),
        f"generations    {state.generation} (+ initial population), population {cfg.ga.population}",
        f"evaluations    {state.n_evaluations} solved, {state.n_cache_hits} cache hits, "
        f"{state.n_failures} failed" + (f" ({', '.join(f'{k} {v}' for k, v in sorted(statuses.items()))})" if statuses else ""),
        f"GA time        {state.elapsed_s:.1f} s of breeding + evaluation ({rate:.3g} evaluations/s)",
        "",
        "best design",
    ]
    for name in ga.names:
        lines.append(f"  {name:<6} {b['genes'][name]:.6g}")
    xi = (fidelity or {}).get("calibration")
    uncal = f" ({_fmt(b['f1_uncalibrated'])} uncalibrated, / ξ = {xi:g})" if b.get("f1_uncalibrated") is not None \
        and xi else ""
    lines.append(f"  f1     {_fmt(b['f1'])} calibrated{uncal}")
    objective = b.get("objective")  # an aggregated run's: what it minimises, F_p built from it
    if objective:
        lines.append(f"  {objective}  {_fmt(b[objective])} calibrated  (minimised; f1 is the nominal design's)")
    for t in ga.terms:
        lines.append(f"  κ_{t.gene:<4} {_fmt(b['kappas'].get(t.gene))}  (C = {t.weight:g}, prefer {t.prefer})")
    lines += [_fp_line(b, cfg.stopping, xi)]
    lines += [f"  WARNING {w}" for w in (warning, early) if w]
    lines += best_design_lines(run_best_designs(state, cfg), cfg, ga.names, objective)
    lines += ["", "generations (F_p calibrated)", f"  {'gen':>4}{'evals':>7}{'hits':>6}{'fail':>6}{'best F_p':>13}{'mean F_p':>13}{'time s':>9}"]
    rows = state.logbook
    if len(rows) > max_rows:
        half = max_rows // 2
        shown: list[dict | None] = [*rows[:half], None, *rows[-half:]]
    else:
        shown = list(rows)
    for r in shown:
        if r is None:
            lines.append("   ...")
            continue
        lines.append(
            f"  {r['generation']:>4}{r['evals']:>7}{r['cache_hits']:>6}{r['n_failures']:>6}"
            f"{r['best_fp']:>13.5g}{_fmt(r['mean_fp'], '.5g'):>13}{r['time_s']:>9.2f}"
        )
    return "\n".join(lines + outputs.report_lines(run_dir, ga, state) + spread_lines(run_dir))
