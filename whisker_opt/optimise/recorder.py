"""What a run keeps on disk: the run directory's recorder and the algorithms' result files and plots.

The algorithms (:mod:`whisker_opt.optimise.ga`, :mod:`whisker_opt.optimise.nsga2`) write nothing:
the runner passes a :class:`RunRecorder` to :meth:`GeneticAlgorithm.run`, which hands it every
completed generation. It writes, in this order, the checkpoint, then ``evaluations.csv``,
``generations.csv`` and ``best.json`` (all atomic, see :mod:`whisker_opt.output.storage`); at the
end (:meth:`RunRecorder.finish`) the convergence plot, the best design's curves when its outcome
carries them, and what the algorithm's :class:`Outputs` add (the multi-objective mode's front:
``pareto.csv``, ``pareto.png``, ``hypervolume.png``, also after its verification at a finer preset).

Each value of ``optimiser.algorithm`` has one entry in :data:`OUTPUTS`.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from whisker_opt.config.optimiser import ExecutorConfig, OptimiserConfig
from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.optimise.best import run_best_designs
from whisker_opt.optimise.checkpoint import save_checkpoint
from whisker_opt.optimise.ga import GAState, GeneticAlgorithm, Recorder, best_design
from whisker_opt.optimise.nsga2 import NSGA2, finer_preset, hypervolume_basis, objective_terms
from whisker_opt.optimise.resolution import run_fidelity
from whisker_opt.optimise.aggregate import aggregate_columns, objective_column
from whisker_opt.output import pareto_plots, storage
from whisker_opt.output.plots import design_label, plot_convergence, plot_curves, write_best_curves

logger = logging.getLogger(__name__)


class Outputs:
    """The result files of a single-objective GA run beyond the tables: its convergence plot of F_p."""

    def convergence(self, path: Path, state: GAState, cfg: OptimiserConfig, stop: str,
                    fidelity: Mapping[str, Any] | None) -> Path:
        """Write the run's ``convergence.png`` to ``path`` (best and mean F_p per generation)."""
        lb = state.logbook
        return plot_convergence(
            path,
            [r["generation"] for r in lb],
            [r["best_fp"] for r in lb],
            [r["mean_fp"] for r in lb],
            [r["best_feasible"] for r in lb],
            cfg.stopping.target_fp,
            title=f"GA convergence ({stop}, generation {state.generation}, {state.n_evaluations} evaluations)",
            fidelity=fidelity,
            target_strain=cfg.stopping.target_strain,
            best_f1=[r.get(f"best_{objective_column(cfg)}") for r in lb],
            f1_label=objective_column(cfg),
        )

    def write(self, run_dir: Path, algo: GeneticAlgorithm, state: GAState) -> list[Path]:
        """The algorithm's own files at the end of a run (none for the GA)."""
        return []

    def report_lines(self, run_dir: Path, algo: GeneticAlgorithm, state: GAState) -> list[str]:
        """The algorithm's own lines of ``whisker-opt report`` (none for the GA)."""
        return []


class FrontOutputs(Outputs):
    """The multi-objective mode's files: the convergence of what it optimises, and the front."""

    def convergence(self, path: Path, state: GAState, cfg: OptimiserConfig, stop: str,
                    fidelity: Mapping[str, Any] | None) -> Path:
        """``convergence.png`` of the front's hypervolume and its smallest f1."""
        lb = state.logbook
        return pareto_plots.plot_mo_convergence(
            path, lb, smallest_f1(state.records, [r["generation"] for r in lb]),
            [o.label for o in objective_terms(cfg)],
            f"NSGA-II convergence ({stop}, generation {state.generation}, {state.n_evaluations} evaluations)",
            fidelity, hypervolume_basis(objective_terms(cfg), state))

    def write(self, run_dir: Path, algo: NSGA2, state: GAState) -> list[Path]:
        """``pareto.csv`` (keeping verified values already in it), ``pareto.png`` and ``hypervolume.png``."""
        if state.generation < 0:
            return []
        rows = kept_front(run_dir, algo, state)
        algo.mark_verified_front(rows)
        return write_front(run_dir, algo, state, rows)

    def report_lines(self, run_dir: Path, algo: NSGA2, state: GAState) -> list[str]:
        """The front as ``whisker-opt report`` shows it (from ``pareto.csv`` when verified)."""
        rows = kept_front(run_dir, algo, state)
        algo.mark_verified_front(rows)
        hv = state.logbook[-1]["hypervolume"] if state.logbook else 0.0
        return pareto_plots.front_table(rows, [o.label for o in algo.objectives], algo.names, hv,
                                        algo.measure_columns, hypervolume_basis(algo.objectives, state))


#: The result files of each ``optimiser.algorithm``.
OUTPUTS: dict[str, Outputs] = {"ga": Outputs(), "nsga2": FrontOutputs()}


def outputs_of(cfg: OptimiserConfig) -> Outputs:
    """The :class:`Outputs` of the algorithm ``cfg.algorithm`` names."""
    return OUTPUTS[cfg.algorithm]


class RunRecorder(Recorder):
    """The recorder that keeps a run directory in step with the algorithm's state (module docstring).

    Parameters
    ----------
    run_dir : Path
        The run directory.
    algo : GeneticAlgorithm
        The run's algorithm (its genes, penalty terms and config name the columns).
    config : dict
        The optimiser section stored with the checkpoint.
    """

    def __init__(self, run_dir: Path, algo: GeneticAlgorithm, config: dict[str, Any]) -> None:
        self.run_dir = Path(run_dir)
        self.algo = algo
        self.config = config
        self.eval_cols = storage.evaluation_columns(algo.names, [t.column for t in algo.terms],
                                                    aggregate_columns(algo.cfg),
                                                    algo.measure_columns)
        self.gen_cols = (storage.generation_columns(algo.names) + list(algo.EXTRA_GENERATION_COLUMNS)
                         + ([f"best_{algo.objective}"] if algo.objective != "f1" else []))

    def generation(self, state: GAState, row: dict) -> None:
        """The checkpoint, then the tables."""
        save_checkpoint(self.run_dir, state, self.config)
        self.write_tables(state)

    def write_tables(self, state: GAState) -> None:
        """``evaluations.csv``, ``generations.csv`` and ``best.json``."""
        storage.write_evaluations(self.run_dir, state.records, self.eval_cols)
        storage.write_generations(self.run_dir, state.logbook, self.gen_cols)
        storage.write_best(self.run_dir, best_json(state, self.algo.cfg))

    def finish(self, state: GAState) -> None:
        """The tables, the plots and the algorithm's own files of a run that ends (or is reported)."""
        self.write_tables(state)
        write_plots(self.run_dir, state, self.algo.cfg)
        outputs_of(self.algo.cfg).write(self.run_dir, self.algo, state)


def best_json(state: GAState, cfg: OptimiserConfig) -> dict[str, Any]:
    """The contents of ``best.json``: the best design, the run's facts and its best distinct designs."""
    return {
        **best_design(state),
        "fidelity": run_fidelity(state),
        "seed": state.seed,
        "stop_reason": state.stop_reason,
        "stop_detail": (state.extra or {}).get("stop_detail") if state.stop_reason else None,
        "distinct_distance": cfg.distinct_distance,
        "best_designs": run_best_designs(state, cfg),
        "generations": state.generation,
        "n_evaluations": state.n_evaluations,
        "n_cache_hits": state.n_cache_hits,
        "n_failures": state.n_failures,
        "wall_time_s": state.elapsed_s,
        "config_changes": list(state.extra.get("config_changes", [])),
    }


def best_outcome(state: GAState) -> EvalOutcome | None:
    """The cached outcome of the hall of fame's best design (None before any)."""
    if not state.hof:
        return None
    return state.cache.get(state.cache.key(state.hof[0]))


def write_plots(run_dir: Path, state: GAState, cfg: OptimiserConfig) -> list[Path]:
    """Convergence plot (:meth:`Outputs.convergence`), and the best design's curves when its outcome holds them.

    Titles name the run's fidelity (:func:`run_fidelity`) and, for the curves, the trim.
    """
    out: list[Path] = []
    if not state.logbook:
        return out
    fidelity = run_fidelity(state, run_dir)
    stop = f"stopped by {state.stop_reason}" if state.stop_reason else "running"
    out.append(outputs_of(cfg).convergence(Path(run_dir) / "convergence.png", state, cfg, stop, fidelity))
    best_out = best_outcome(state)
    curves_csv = Path(run_dir) / storage.BEST_CURVES_CSV
    if (best_out is None or "eps_i" not in best_out.extra) and curves_csv.is_file():
        rows = storage.read_csv(curves_csv)  # the best design's curves as re-solved after the run
        try:
            col = {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}
        except (KeyError, ValueError):
            col = {}
        if {"delta_mm", "eps_i", "eps_c"} <= set(col):
            title = f"best design: {design_label(best_design(state)['genes'], cfg.trim)}"
            out.append(plot_curves(Path(run_dir) / "best_curves.png", col["delta_mm"], col["eps_i"], col["eps_c"],
                                   title, col.get("eps_u"), fidelity))
    if best_out is not None and all(k in best_out.extra for k in ("delta", "eps_i", "eps_c")):
        title = f"best design: {design_label(best_design(state)['genes'], cfg.trim)}"
        out.append(
            write_best_curves(
                run_dir, best_out.extra["delta"], best_out.extra["eps_i"], best_out.extra["eps_c"], title,
                best_out.extra.get("eps_u"), fidelity,
            )
        )
    return out


def smallest_f1(records: Sequence[Mapping[str, Any]], generations: Sequence[int]) -> list[float]:
    """The smallest f1 of the feasible evaluations up to each of ``generations`` (NaN before the first)."""
    best, out, rows = math.inf, [], sorted((int(r["generation"]), float(r["f1"])) for r in records
                                           if r.get("f1") is not None and r.get("status", "ok") == "ok")
    k = 0
    for g in generations:
        while k < len(rows) and rows[k][0] <= g:
            best = min(best, rows[k][1])
            k += 1
        out.append(best if math.isfinite(best) else math.nan)
    return out


def kept_front(run_dir: Path, algo: NSGA2, state: GAState) -> list[dict[str, Any]]:
    """The front's rows (:meth:`NSGA2.front_rows`) with the verified values ``pareto.csv`` already holds."""
    return pareto_plots.merge_verified(algo.front_rows(state), pareto_plots.read_front(run_dir), algo.names)


def write_front(run_dir: Path, algo: NSGA2, state: GAState, rows: list[dict[str, Any]]) -> list[Path]:
    """``pareto.csv``, ``pareto.png`` and ``hypervolume.png`` of ``rows``."""
    fidelity = (state.extra or {}).get("fidelity") or {}
    return pareto_plots.write_front_outputs(
        run_dir, rows, algo.names, [o.name for o in algo.objectives], [o.label for o in algo.objectives],
        algo.all_points(state), state.logbook, fidelity, state.stop_reason, hypervolume_basis(algo.objectives, state))


def verify_front(run_dir: Path, algo: NSGA2, state: GAState, evaluator: Callable, preset: str,
                 executor_cfg: ExecutorConfig | None = None) -> list[dict[str, Any]]:
    """Re-evaluate the front (and the penalised optimum) at fidelity ``preset`` (:meth:`NSGA2.verify_rows`;
    rows ``pareto.csv`` holds verified at ``preset`` are kept) and rewrite the front's files.

    Returns
    -------
    list of dict
        The rows of ``pareto.csv``.
    """
    rows = algo.verify_rows(kept_front(run_dir, algo, state), state, evaluator, preset, executor_cfg)
    write_front(run_dir, algo, state, rows)
    return rows


def verify_run_front(run_dir: Path, evaluator_at: Callable[[str], Callable],
                     run_preset: str | None) -> list[dict[str, Any]] | None:
    """Verify a finished multi-objective run's front at the preset after ``run_preset`` (pareto.csv, pareto.png).

    Parameters
    ----------
    run_dir : Path
        A run directory with a checkpoint.
    evaluator_at : callable
        ``evaluator_at(preset)`` -> the run's evaluator at that fidelity preset.
    run_preset : str or None
        The run's own preset.

    Returns
    -------
    list of dict or None
        The rows of ``pareto.csv``; None for a GA run, a run without checkpoint, ``pareto.verify: false``
        or a run at the finest preset (logged).
    """
    from whisker_opt.optimise.checkpoint import has_checkpoint, load_checkpoint

    if not has_checkpoint(run_dir):
        return None
    state, config = load_checkpoint(run_dir)
    cfg = OptimiserConfig.model_validate(config)
    if cfg.algorithm != "nsga2" or not cfg.pareto.verify or state.generation < 0:
        return None
    preset = finer_preset(run_preset)
    if preset is None:
        logger.warning("the run's preset %s has no finer preset: the front is not verified", run_preset)
        return None
    return verify_front(run_dir, NSGA2(cfg, state.seed), state, evaluator_at(preset), preset)
