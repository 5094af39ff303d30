"""Re-evaluate a finished run's best designs at another fidelity: is the optimum real?

A run ranks designs at its own fidelity preset (usually ``default``). That preset's mesh
error in f1 depends on the design, in size and in sign, and is largest at thick walls
(``benchmarks/results/time_vs_error.md``). So
the absolute f1 of a GA optimum, and its rank against designs of a different wall
thickness, should be confirmed at a finer preset before they are reported. This module
re-runs the run's ``top`` best feasible designs, pairwise distinct by ``optimiser.distinct_distance``
(:func:`whisker_opt.optimise.best.run_best_designs`, the designs of the report and ``best.json``),
through the same evaluator at the verification preset, recomputes F_p with the run's own penalty terms
(:func:`whisker_opt.optimise.penalty.dynamic_penalty`: F_p = f1 + Σ_j C_j κ_j, κ_j = f1 · distance_j)
and writes ``verify_<preset>.csv`` into the run directory (atomically).

Each design takes one evaluation at the verification preset (its time per preset:
``benchmarks/results/bench_scene.md``), two scenes: a bar over the scenes shows on a terminal (``progress=False`` hides it) and a progress
line per scene, with elapsed time and ETA, is logged either way
(:class:`whisker_opt.output.progress.Progress`). Verifying at the run's own preset reproduces the run's f1 and verifies
nothing: that is logged as a warning and said in the printed table.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Sequence

from whisker_opt.genes import GENE_NAMES, genome_of, run_genome
from whisker_opt.output import storage
from whisker_opt.numfmt import short_float

logger = logging.getLogger(__name__)

class VerifyError(ValueError):
    """Unusable arguments for :func:`verify_run` (a user error: the message names the field)."""


def columns(gene_names: Sequence[str] = GENE_NAMES) -> tuple[str, ...]:
    """The columns of ``verify_<preset>.csv``: the ranks, the genome ``gene_names`` (each gene by its key,
    :func:`whisker_opt.genes.run_genome` of the run), then f1 and F_p of the run and of the verification."""
    return ("rank_run", "rank_verify", *gene_names, "f1_run", "f1_verify", "f1_change",
            "F_p_run", "F_p_verify", "status", "reason", "time_s")


#: The columns of a run of the default genome.
COLUMNS = columns()


def check_args(preset: str, top: int) -> None:
    """Raise :class:`VerifyError` naming the argument unless preset is a named preset and 1 <= top <= 1000."""
    from whisker_opt.experiment.fidelity import PRESET_NAMES

    if preset not in PRESET_NAMES:
        raise VerifyError(f"verify: preset={preset!r} is not one of {', '.join(map(repr, PRESET_NAMES))}")
    if not 1 <= int(top) <= 1000:
        raise VerifyError(f"verify: top={top!r} outside the allowed range 1..1000")


def verify_run(run_dir: Path, preset: str = "fine", top: int = 3, progress: bool = True) -> list[dict[str, Any]]:
    """Re-evaluate the best ``top`` distinct feasible designs of ``run_dir`` at fidelity ``preset``.

    Parameters
    ----------
    run_dir : Path
        Run directory with ``config.yaml`` and a checkpoint (written by ``whisker-opt run``).
    preset : str
        Verification preset (:data:`whisker_opt.experiment.fidelity.PRESET_NAMES`) (the run's other fidelity overrides are dropped).
    top : int
        Number of designs, 1 … 1000 (fewer when the run has fewer distinct feasible designs).
    progress : bool
        Show a tqdm bar over the scenes (stderr, on a terminal only).

    Returns
    -------
    list of dict
        One row per design (:func:`columns` of the run's genome), in the run's order; also written to
        ``run_dir / f"verify_{preset}.csv"``. Each row also holds ``run_preset`` (the run's
        own preset), ``f1_resolution`` / ``run_f1_resolution`` (of the verification and
        the run's preset, in the run's calibrated strain) and ``gene_names`` (the genome), which
        :func:`format_rows` reports.

    Raises
    ------
    FileNotFoundError
        ``run_dir`` has no ``config.yaml`` or no checkpoint.
    VerifyError
        ``preset`` or ``top`` out of range, or the run has no feasible design.
    """
    import whisker_opt.wiring as wiring
    from whisker_opt.experiment.fidelity import f1_resolution
    from whisker_opt.optimise.aggregate import objective_column
    from whisker_opt.optimise.best import describe_distance
    from whisker_opt.optimise.penalty import penalise, penalty_terms
    from whisker_opt.optimise.evaluator import SceneEvaluator
    from whisker_opt.output.progress import Progress, format_duration

    run_dir = Path(run_dir)
    check_args(preset, top)
    cfg, opt, chosen = _best_of_run(run_dir, top)
    wiring.warn_unread_keys(cfg, "verify")
    if len(chosen) < int(top):
        logger.warning("verify: %s has %d feasible design(s) %s, fewer than --top %d: verifying those",
                       run_dir, len(chosen), describe_distance(opt.distinct_distance), int(top))
    run_preset = cfg.fidelity.preset
    if preset == run_preset:
        logger.warning("verify: preset %s is the run's own preset: the re-evaluation reproduces the run's f1 and "
                       "verifies nothing; choose a finer preset", preset)
    names = run_genome(cfg)
    resolution = {"run_preset": run_preset, "f1_resolution": f1_resolution(preset, cfg.scene.calibration),
                  "run_f1_resolution": f1_resolution(run_preset, cfg.scene.calibration), "gene_names": names}
    evaluate = wiring.evaluator(wiring.with_preset(cfg, preset))
    terms = penalty_terms(opt)
    rows = []
    per_scene = isinstance(evaluate, SceneEvaluator)  # a robust objective's evaluation is counted as a whole
    steps = Progress(len(chosen) * (len(SceneEvaluator.SCENES) if per_scene else 1), f"verify at {preset}",
                     "scene" if per_scene else "design", progress)
    with steps:
        for rank, best in enumerate(chosen, start=1):
            genes = genome_of(best["genes"], names, f"verify: design {rank}")
            f1_run = float(best["f1"])
            logger.info("verify: design %d/%d %s at preset %s", rank, len(chosen), genes, preset)
            if per_scene:
                out = evaluate(genes, on_scene=lambda name, s: steps.step(
                    f"(design {rank}/{len(chosen)}: {name} scene solved in {format_duration(s)})"))
            else:
                out = evaluate(genes)
            left = rank * steps.total // len(chosen) - steps.done  # the scenes a failed design did not reach
            if left > 0:
                steps.step(f"(design {rank}/{len(chosen)}: {out.status})", n=left)
            row = {"rank_run": rank, **genes, "f1_run": f1_run, "F_p_run": float(best["F_p"]),
                   "status": out.status, "reason": out.reason,
                   "time_s": float(out.timings.get("total", float("nan"))), **resolution}
            if out.ok:
                fp = penalise(out, genes, terms, opt.failure_penalty, objective_column(opt)).fp  # F_p as the run's
                row.update(f1_verify=out.f1, F_p_verify=fp,
                           f1_change=out.f1 / f1_run - 1.0 if f1_run else float("nan"))
            else:
                row.update(f1_verify=float("nan"), F_p_verify=float("nan"), f1_change=float("nan"))
            rows.append(row)
            logger.info("verify: design %d/%d done: %s, f1 %.6g at %s against %.6g at %s (%.0f s)", rank, len(chosen),
                        out.status, row["f1_verify"], preset, f1_run, run_preset, row["time_s"])
    ok = sorted((r for r in rows if r["status"] == "ok"), key=lambda r: r["F_p_verify"])
    for i, r in enumerate(ok, start=1):
        r["rank_verify"] = i
    for r in rows:
        r.setdefault("rank_verify", "")
    storage.write_csv(run_dir / f"verify_{preset}.csv", columns(names), rows)
    return rows


def format_rows(rows: list[dict[str, Any]], preset: str) -> str:
    """Text table of :func:`verify_run`'s rows and whether the run's order survived."""
    first = rows[0] if rows else {}
    added = [g for g in first.get("gene_names", GENE_NAMES) if g not in GENE_NAMES]
    lines = [f"{'rank':>4} {'alpha':>7} {'l':>7} {'t':>6} {'Q_i':>7}" + "".join(f" {g:>{max(7, len(g))}}" for g in added)
             + f" {'f1 run':>11} {f'f1 {preset}':>11} {'change':>8} {f'F_p {preset}':>11} {'rank':>5}"]
    for r in rows:
        lines.append(f"{r['rank_run']:>4} {r['alpha']:>7.3f} {r['l']:>7.3f} {r['t']:>6.3f} {r['Q_i']:>7.4f}"
                     + "".join(f" {r[g]:>{max(7, len(g))}.4g}" for g in added)
                     + f" {r['f1_run']:>11.5g} {r['f1_verify']:>11.5g} {r['f1_change']:>+8.1%} "
                     f"{r['F_p_verify']:>11.5g} {str(r['rank_verify']):>5}"
                     + ("" if r["status"] == "ok" else f"  {r['status']}: {r['reason']}"))
    order = [r["rank_verify"] for r in rows if r["status"] == "ok"]
    same = order == sorted(order)
    lines.append(f"the run's order {'holds' if same else 'changes'} at preset {preset}")
    if first.get("f1_resolution") is not None:
        lines.append(f"f1 resolution ~{short_float(first['f1_resolution'])} at preset {preset}"
                     + (f", ~{short_float(first['run_f1_resolution'])} at the run's preset {first['run_preset']}"
                        if first.get("run_preset") != preset else "") + ": smaller f1 values are not resolved")
    if first.get("run_preset") == preset:
        import math

        from whisker_opt.experiment.fidelity import PRESET_NAMES, PRESETS

        after = PRESET_NAMES[PRESET_NAMES.index(preset) + 1:] if preset in PRESET_NAMES else ()
        finer = [p for p in after if math.isfinite(PRESETS[p].f1_resolution)]  # a measured resolution
        lines.append(f"WARNING: preset {preset} is the run's own preset: these f1 values reproduce the run's and "
                     + (f"verify nothing; re-run with a finer preset (--preset {finer[-1]})" if finer
                        else "verify nothing; no finer preset exists"))
    return "\n".join(lines)


def _best_of_run(run_dir: Path, top: int) -> tuple:
    """(config, optimiser config, the best ``top`` distinct feasible designs) of a run directory.

    Raises FileNotFoundError without a config or checkpoint and VerifyError without a feasible design."""
    from whisker_opt.config.model import load_config
    from whisker_opt.optimise.best import run_best_designs
    from whisker_opt.optimise.runner import load_run, run_config_path

    cfg = load_config(run_config_path(run_dir))
    state, opt, _, _ = load_run(run_dir)
    if state is None:
        raise FileNotFoundError(f"{run_dir}: no checkpoint yet (the run has not finished a generation)")
    chosen = run_best_designs(state, opt, int(top))
    if not chosen:
        raise VerifyError(f"verify: {run_dir} has no feasible design")
    return cfg, opt, chosen


def law_spread_run(run_dir: Path, top: int = 3, progress: bool = True) -> tuple[list[dict[str, Any]], str]:
    """The model-form spread of a run's best ``top`` distinct feasible designs at the run's own preset.

    Each design's three scenes are solved again under every available wall law
    (:func:`whisker_opt.analysis.law_spread.law_spread`); the rows are written to ``run_dir / "law_spread.csv"``
    (atomically). Returns the rows and the preset they were computed at.

    Raises
    ------
    FileNotFoundError
        ``run_dir`` has no ``config.yaml`` or no checkpoint.
    VerifyError
        ``top`` out of range or no feasible design.
    """
    from whisker_opt.analysis.law_spread import available_laws, law_spread, write_spread
    from whisker_opt.output.progress import Progress
    from whisker_opt.wiring import SCENE_NAMES

    run_dir = Path(run_dir)
    if not 1 <= int(top) <= 1000:
        raise VerifyError(f"verify: top={top!r} outside the allowed range 1..1000")
    cfg, _, chosen = _best_of_run(run_dir, top)
    laws = available_laws(cfg)
    steps = Progress(len(chosen) * len(laws) * len(SCENE_NAMES), "wall-law spread", "scene", progress)
    with steps:
        rows = law_spread(cfg, [dict(b["genes"]) for b in chosen], laws, on_scene=steps.step)
    write_spread(rows, run_dir / "law_spread.csv", run_genome(cfg))
    return rows, cfg.fidelity.preset
