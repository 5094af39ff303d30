"""Run, resume and report an optimisation: the GA plus its results directory.

The CLI commands ``run``, ``resume`` and ``report`` are thin wrappers around
:func:`run_optimisation`, :func:`resume_optimisation` and :func:`report`. The evaluator is
any picklable callable ``evaluate(genes: dict[str, float]) -> EvalOutcome`` (genes
``alpha`` [deg], ``l`` [mm], ``t`` [mm], ``Q_i`` [MPa]); see :mod:`whisker_opt.experiment.outcome`.

The algorithm writes nothing: the runner passes it a :class:`whisker_opt.optimise.recorder.RunRecorder`,
which after every generation writes, in this order, the checkpoint, then ``evaluations.csv``,
``generations.csv`` and ``best.json`` (all atomic, see :mod:`whisker_opt.output.storage`); at the
end the convergence plot, when the best design's outcome carries its curves ``best_curves.csv/png``,
and the multi-objective mode's front.

Fidelity
    A run may be given its fidelity, ``{"preset": name, "f1_resolution": value}``
    (:func:`whisker_opt.experiment.fidelity.describe`); it is kept in the checkpointed state
    (``state.extra["fidelity"]``) and written to ``best.json``, the plots and the report. A
    finished run whose best f1 lies below the preset's f1 resolution logs a warning (the
    optimum is not resolved at that preset: verify it at a finer one), as does a run whose
    ``stopping.target_fp`` lies below it (:mod:`whisker_opt.optimise.resolution`).

Best designs
    ``best.json`` holds the best design and ``best_designs``, the run's best designs pairwise
    distinct by ``optimiser.distinct_distance`` (:mod:`whisker_opt.optimise.best`), which the
    report lists; ``stop_reason`` names the rule that ended the run and ``stop_detail`` says why.

Progress
    A tqdm bar on stderr (shown on a terminal only) counts evaluations as each one finishes
    (done / expected, best F_p, evaluations/s, failures, cache hits, ETA), and a log line
    per evaluation (INFO) goes to the log either way (the run and resume workflows write
    it to the run's ``run.log``, :func:`whisker_opt.workflows.run_log`).
"""

from __future__ import annotations

import logging
import math
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from whisker_opt.output import storage
from whisker_opt.optimise.checkpoint import (
    CHECKPOINT_NAME,
    OLDER_NAME,
    has_checkpoint,
    has_older_checkpoint,
    load_checkpoint,
    remove_stale_temporaries,
)
from whisker_opt.optimise.backend import make_executor
from whisker_opt.optimise.best import describe_distance, run_best_designs
from whisker_opt.optimise.ga import EvaluationProgress, GAState, GeneticAlgorithm, best_design
from whisker_opt.optimise.nsga2 import make_algorithm
from whisker_opt.optimise.recorder import RunRecorder, outputs_of, write_plots
from whisker_opt.optimise.resolution import resolution_warning, run_fidelity, target_warning  # noqa: F401
from whisker_opt.optimise.rundir import (  # noqa: F401 - write_run_metadata: also the workflows'
    ConfigChange,
    change_lines,
    complete_metadata,
    record_config,
    rewrite_optimiser_json,
    write_run_metadata,
)
from whisker_opt.output.lock import RunDirLock
from whisker_opt.config.optimiser import ExecutorConfig, OptimiserConfig
from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.numfmt import short_float
from whisker_opt.output.progress import progress_bar

logger = logging.getLogger(__name__)

Evaluator = Callable[[dict[str, float]], EvalOutcome]


@dataclass(frozen=True)
class RunSummary:
    """What a finished (or interrupted-and-resumed) run produced.

    Attributes
    ----------
    run_dir : Path
    seed : int
    stop_reason : str
        The stopping rule that fired (``target_fp``, ``resolution``, ``stall`` or ``max_generations``).
    generations : int
        Index of the last generation (0 = initial population).
    n_evaluations : int
        Evaluator calls (cache hits excluded).
    n_cache_hits : int
        Individuals whose outcome came from the cache.
    n_failures : int
        Individuals whose evaluation failed (any status but ``ok``).
    wall_time_s : float
        Wall time of the generations, summed over sessions [s].
    best : dict
        :func:`whisker_opt.optimise.ga.best_design`: genes, feasible, F_p, f1, kappas, status, ...
    population : tuple of tuple of float
        Final population's genes [α, l, t, Q_i].
    fitness : tuple of tuple of float
        Final population's fitness values (infeasible flag, F_p).
    """

    run_dir: Path
    seed: int
    stop_reason: str
    generations: int
    n_evaluations: int
    n_cache_hits: int
    n_failures: int
    wall_time_s: float
    best: dict[str, Any]
    population: tuple[tuple[float, ...], ...]
    fitness: tuple[tuple[float, ...], ...]


def _summary(run_dir: Path, state: GAState) -> RunSummary:
    return RunSummary(
        run_dir=Path(run_dir),
        seed=state.seed,
        stop_reason=str(state.stop_reason),
        generations=state.generation,
        n_evaluations=state.n_evaluations,
        n_cache_hits=state.n_cache_hits,
        n_failures=state.n_failures,
        wall_time_s=state.elapsed_s,
        best=best_design(state),
        population=tuple(tuple(float(x) for x in ind) for ind in state.population),
        fitness=tuple(tuple(ind.fitness.values) for ind in state.population),
    )


class _Progress(EvaluationProgress):
    """Per-evaluation progress of a run: a tqdm bar (evaluations done / expected, best F_p,
    evaluations/s, failures, ETA) and a log line per evaluation.

    The expected count is exact for the generation under way and ``population − n_elite`` per
    later generation up to ``max_generations`` (an upper bound: unvaried offspring and cache
    hits are not evaluated); the bar is closed at 100 % when a stopping rule ends the run.
    """

    def __init__(self, cfg: OptimiserConfig, state: GAState, enabled: bool) -> None:
        self.cfg = cfg
        self.per_generation = max(cfg.ga.population - (cfg.ga.n_elite if cfg.algorithm == "ga" else 0), 0)
        self.done = state.n_evaluations
        self.failures = state.n_failures
        self.hits = state.n_cache_hits
        self.best = state.hof[0].fitness.values[1] if state.hof and state.hof[0].fitness.values[0] == 0.0 else math.inf
        self.generation = state.generation
        self.batch = 0
        self.in_batch = 0
        self.initial = self.done
        self.t0 = time.perf_counter()
        self.bar = progress_bar(self._expected(state.generation + 1, None), "GA", "eval", enabled,
                                initial=self.done)
        self._postfix()

    def _expected(self, generation: int, batch: int | None) -> int:
        """Evaluations done + the rest of generation ``generation`` (its ``batch`` when known) +
        the bound of the later generations."""
        later = max(self.cfg.stopping.max_generations - generation, 0)
        if batch is None:
            batch = self.cfg.ga.population if generation == 0 else self.per_generation
        return self.done + max(batch - self.in_batch, 0) + later * self.per_generation

    def _postfix(self) -> None:
        best = "-" if not math.isfinite(self.best) else f"{self.best:.4g}"
        self.bar.set_postfix_str(f"gen {max(self.generation, 0)}/{self.cfg.stopping.max_generations} best F_p {best} "
                                 f"fail {self.failures} hits {self.hits}", refresh=False)

    def start_generation(self, state: GAState, generation: int, n_to_run: int, n_cached: int) -> None:
        self.generation, self.batch, self.in_batch = generation, n_to_run, 0
        self.hits += n_cached
        self.bar.total = self._expected(generation, n_to_run)
        self._postfix()
        self.bar.refresh()
        logger.info("generation %d: %d design(s) to evaluate, %d from the cache", generation, n_to_run, n_cached)

    def result(self, state: GAState, generation: int, genes: dict[str, float], outcome: EvalOutcome,
               fp: float | None) -> None:
        self.done += 1
        self.in_batch += 1
        if fp is None:
            self.failures += 1
        else:
            self.best = min(self.best, fp)
        self._postfix()
        self.bar.update(1)
        rate = (self.done - self.initial) / max(time.perf_counter() - self.t0, 1e-9)
        logger.info("generation %d, evaluation %d/%d: %s -> %s%s (%.1f s; %d done, %.3g evaluations/s, %d failed)",
                    generation, self.in_batch, self.batch, {k: round(v, 6) for k, v in genes.items()}, outcome.status,
                    f" f1={outcome.f1:.6g} F_p={fp:.6g}" if fp is not None else f" ({outcome.reason})",
                    float(outcome.timings.get("eval_s", math.nan)), self.done, rate, self.failures)

    def close(self, finished: bool) -> None:
        """Close the bar; at 100 % when the run finished (whatever rule stopped it)."""
        if finished:
            self.bar.total = self.done
            self._postfix()
            self.bar.refresh()
        self.bar.close()


def _drive(
    ga: GeneticAlgorithm,
    state: GAState,
    run_dir: Path,
    evaluator: Evaluator,
    exec_cfg: ExecutorConfig,
    config: dict[str, Any],
    progress: bool,
    callbacks: Sequence[Callable[[GAState, dict], None]],
) -> RunSummary:
    recorder = RunRecorder(run_dir, ga, config)
    fidelity = run_fidelity(state, run_dir)
    if state.stop_reason is None:
        early = target_warning(ga.cfg.stopping, fidelity) if ga.cfg.algorithm == "ga" else None
        if early:
            logger.warning("%s", early)
        bar = _Progress(ga.cfg, state, progress)
        try:
            with make_executor(exec_cfg, evaluator) as ex:
                ga.run(state, ex, callbacks=callbacks, progress=bar, recorder=recorder)
        finally:
            bar.close(finished=state.stop_reason is not None)
    recorder.finish(state)
    logger.info(
        "run %s finished: %s after generation %d, %d evaluations, %d cache hits, %d failures, best F_p=%.6g (%s)",
        run_dir, state.stop_reason, state.generation, state.n_evaluations, state.n_cache_hits,
        state.n_failures, state.hof[0].fitness.values[1],
        f"preset {fidelity['preset']}, f1 resolution {fidelity['f1_resolution']:.3g}" if fidelity else "preset unknown",
    )
    detail = (state.extra or {}).get("stop_detail")
    if detail:
        (logger.warning if state.stop_reason == "resolution" else logger.info)("run stopped by %s", detail)
    warning = resolution_warning(state, fidelity, run_dir, ga.cfg.stopping.target_strain)
    if warning:
        logger.warning("%s", warning)
    return _summary(run_dir, state)


def run_optimisation(
    cfg_opt: OptimiserConfig,
    run_dir: Path,
    evaluator: Evaluator,
    seed: int,
    progress: bool = True,
    callbacks: Sequence[Callable[[GAState, dict], None]] = (),
    fidelity: Mapping[str, Any] | None = None,
    run_config: Mapping[str, Any] | None = None,
) -> RunSummary:
    """Run the GA from scratch, writing results and a checkpoint per generation into ``run_dir``.

    The run holds ``run_dir``'s writer lock (:class:`whisker_opt.output.lock.RunDirLock`) throughout.

    Parameters
    ----------
    cfg_opt : OptimiserConfig
        The validated ``optimiser`` section.
    run_dir : Path
        Results directory (created if needed; may already hold the lead's ``config.yaml``)
        that must not hold a checkpoint yet.
    evaluator : callable
        Picklable ``evaluate(genes) -> EvalOutcome``.
    seed : int
        Master seed (e.g. ``cfg_opt.resolve_seed(cfg.seed)``).
    progress : bool
        Show the tqdm progress bar (stderr, on a terminal), ticking per evaluation.
    callbacks : sequence of callable
        Extra ``callback(state, row)`` after each generation (after the checkpoint).
    fidelity : mapping, optional
        ``{"preset", "f1_resolution"}`` of the evaluator
        (:func:`whisker_opt.experiment.fidelity.describe`): kept in the state, written to
        ``best.json``, the plots and the report.
    run_config : mapping, optional
        The resolved run file (``config.yaml`` with its defaults): kept with the state with its
        digest, against which ``resume`` checks ``config.yaml`` (:mod:`whisker_opt.optimise.rundir`).

    Returns
    -------
    RunSummary

    Raises
    ------
    FileExistsError
        ``run_dir`` already holds a checkpoint (use :func:`resume_optimisation`).
    whisker_opt.output.lock.RunDirectoryBusy
        Another process writes into ``run_dir``.
    """
    run_dir = Path(run_dir)
    check_new_run_dir(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    with RunDirLock(run_dir, "run"):
        check_new_run_dir(run_dir)  # again, now that no other writer can start one
        config = write_run_metadata(run_dir, cfg_opt, seed, run_config)
        ga = make_algorithm(cfg_opt, seed)
        state = ga.new_state()
        if fidelity:
            state.extra["fidelity"] = dict(fidelity)
        record_config(state, run_config, None)
        return _drive(ga, state, run_dir, evaluator, cfg_opt.executor, config, progress, callbacks)


def remove_run_temporaries(run_dir: Path) -> int:
    """Delete what a kill during a write left in a run directory; returns how many entries.

    Temporary files of atomic writes (the checkpoint's among them), hidden ``*.partial``
    folders and temporary VTU files (:func:`whisker_opt.output.storage.remove_temporaries`).
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return 0
    n = remove_stale_temporaries(run_dir) + len(storage.remove_temporaries(run_dir))
    if n:
        logger.info("removed %d temporary file(s) left by the interrupted run in %s", n, run_dir)
    return n


def check_new_run_dir(run_dir: Path) -> None:
    """Raise FileExistsError (naming ``whisker-opt resume``) if ``run_dir`` already holds a run."""
    if has_checkpoint(run_dir):
        name = OLDER_NAME if has_older_checkpoint(run_dir) else CHECKPOINT_NAME
        raise FileExistsError(f"{run_dir} already holds a run ({name}): continue it with `whisker-opt resume "
                              f"{run_dir}`, choose another --out, or pass --overwrite to delete it and start again")


def run_config_path(run_dir: Path) -> Path:
    """``run_dir/config.yaml`` (the run file the run was started with, defaults filled in).

    Raises
    ------
    FileNotFoundError
        The file is missing: ``run_dir`` is not a run directory.
    """
    path = Path(run_dir) / "config.yaml"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: not found; is {run_dir} a run directory?")
    return path


def load_run(run_dir: Path) -> tuple[GAState | None, OptimiserConfig, dict[str, Any], int]:
    """(state or None, config, config dict, seed) of a run directory."""
    run_dir = Path(run_dir)
    if has_checkpoint(run_dir):
        state, config = load_checkpoint(run_dir)
        return state, OptimiserConfig.model_validate(config), config, state.seed
    meta_path = run_dir / storage.OPTIMISER_JSON
    if not meta_path.is_file():
        raise FileNotFoundError(f"{run_dir}: not a run directory (no {CHECKPOINT_NAME} nor {storage.OPTIMISER_JSON})")
    import json

    meta = json.loads(meta_path.read_text())
    return None, OptimiserConfig.model_validate(meta["optimiser"]), meta["optimiser"], int(meta["seed"])


def resume_optimisation(
    run_dir: Path,
    evaluator: Evaluator,
    progress: bool = True,
    executor: ExecutorConfig | None = None,
    callbacks: Sequence[Callable[[GAState, dict], None]] = (),
    fidelity: Mapping[str, Any] | None = None,
    max_generations: int | None = None,
    run_config: Mapping[str, Any] | None = None,
    config_change: ConfigChange | None = None,
) -> RunSummary:
    """Continue a run from its last checkpoint; the result equals an uninterrupted run.

    The resume holds ``run_dir``'s writer lock (:class:`whisker_opt.output.lock.RunDirLock`)
    throughout. Temporaries left by a kill are deleted first, and ``optimiser.json`` or
    ``environment.json`` are written when a kill came before them.

    Parameters
    ----------
    run_dir : Path
        Directory written by :func:`run_optimisation`. A run killed before its first
        checkpoint restarts from generation 0 with the stored seed.
    evaluator : callable
        The same evaluator as the original run.
    progress : bool
        Show the progress bar.
    executor : ExecutorConfig, optional
        Evaluate on another back end than the stored one (results do not depend on it).
    callbacks : sequence of callable
        Extra per-generation callbacks.
    fidelity : mapping, optional
        As in :func:`run_optimisation`; fills in a state that does not hold it yet, and
        replaces it after an allowed ``config_change``.
    max_generations : int, optional
        Raise the run's ``stopping.max_generations`` to this (stored for later resumes): a run
        that stopped on that rule continues, and ends as an uninterrupted run with this limit
        would have (the GA's random state is in the checkpoint).
    run_config : mapping, optional
        The resolved run file the run continues with (recorded with its digest when the state
        holds none yet, or after ``config_change``).
    config_change : ConfigChange, optional
        An allowed change of ``config.yaml`` (:func:`whisker_opt.optimise.rundir.check_config`):
        the run continues with its optimiser section, and the change is recorded in the state.

    Returns
    -------
    RunSummary
        A finished run is not run again; its summary is returned (and its files rewritten).

    Raises
    ------
    ValueError
        ``max_generations`` is below the generations already run.
    whisker_opt.output.lock.RunDirectoryBusy
        Another process writes into ``run_dir``.
    """
    run_dir = Path(run_dir)
    load_run(run_dir)  # first: nothing is locked or deleted in a folder that is no run
    with RunDirLock(run_dir, "resume"):
        state, cfg, config, seed = load_run(run_dir)  # the last state, read under the lock
        remove_run_temporaries(run_dir)
        cfg = cfg if config_change is None else config_change.optimiser
        if max_generations is not None:
            done = state.generation if state is not None else -1
            if max_generations < max(done, 0):
                raise ValueError(f"--max-generations {max_generations}: the run has already bred {done} "
                                 f"generations; give at least {max(done, 0)}")
            cfg = cfg.model_copy(update={"stopping": cfg.stopping.model_copy(
                update={"max_generations": max_generations})})
        changed = config_change is not None or max_generations is not None
        if changed:
            config = cfg.model_dump(mode="json")
            rewrite_optimiser_json(run_dir, seed, config, run_config if config_change is not None else None)
        complete_metadata(run_dir, config, seed)
        ga = make_algorithm(cfg, seed)
        if state is None:
            state = ga.new_state()
        elif changed and state.logbook:
            ga.set_stop(state)
            logger.info("%s: the run %s", f"max_generations {cfg.stopping.max_generations}",
                        "continues" if state.stop_reason is None else f"stays stopped ({state.stop_reason})")
        if fidelity and (config_change is not None or not state.extra.get("fidelity")):
            state.extra["fidelity"] = dict(fidelity)
        if config_change is not None or not state.extra.get("run_config_sha256"):
            record_config(state, run_config, config_change)
        if state.generation >= 0:
            RunRecorder(run_dir, ga, config).write_tables(state)
            logger.info("resuming %s after generation %d", run_dir, state.generation)
        return _drive(ga, state, run_dir, evaluator, executor or cfg.executor, config, progress, callbacks)


def _fmt(x: Any, spec: str = ".6g") -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return format(x, spec)
    return str(x)


def best_design_lines(designs: list[dict], cfg: OptimiserConfig, names: tuple[str, ...],
                      objective: str | None = None) -> list[str]:
    """The report's table of the best designs (:func:`whisker_opt.optimise.best.run_best_designs`), with the
    column of the aggregate over variants the run minimises (``objective``, e.g. ``f1_robust``) after f1."""
    width = max(13, len(objective) + 1) if objective else 0
    lines = ["", f"best designs   {len(designs)} of at most {cfg.ga.hall_of_fame}, "
             f"{describe_distance(cfg.distinct_distance)}",
             "  rank " + "".join(f"{n:>{max(11, len(n) + 1)}}" for n in names) + f"{'f1':>13}"
             + (f"{objective:>{width}}" if objective else "") + f"{'F_p':>13}{'eval':>7}{'gen':>5}{'apart':>7}"]
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
    """
    run_dir = Path(run_dir)
    state, cfg, _, seed = load_run(run_dir)
    if state is None or state.generation < 0:
        return f"{run_dir}: no generation completed yet"
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
    uncal = f"  ({_fmt(b['f1_uncalibrated'])} uncalibrated, / ξ = {xi:g})" if b.get("f1_uncalibrated") is not None \
        and xi else ""
    lines.append(f"  f1     {_fmt(b['f1'])}{uncal}")
    objective = b.get("objective")  # an aggregated run's: what it minimises, F_p built from it
    if objective:
        lines.append(f"  {objective}  {_fmt(b[objective])}  (minimised; f1 is the nominal design's)")
    for t in ga.terms:
        lines.append(f"  κ_{t.gene:<4} {_fmt(b['kappas'].get(t.gene))}  (C = {t.weight:g}, prefer {t.prefer})")
    uncal = f", {_fmt(b['F_p_uncalibrated'])} uncalibrated" if b.get("F_p_uncalibrated") is not None else ""
    lines.append(f"  F_p    {_fmt(b['F_p'])}  ({b['status']}{uncal}, generation {b['generation_found']}, "
                 f"eval {b['eval_id']}; target_fp {cfg.stopping.target_fp:g} {cfg.stopping.target_strain})")
    lines += [f"  WARNING {w}" for w in (warning, early) if w]
    lines += best_design_lines(run_best_designs(state, cfg), cfg, ga.names, objective)
    lines += ["", "generations", f"  {'gen':>4}{'evals':>7}{'hits':>6}{'fail':>6}{'best F_p':>13}{'mean F_p':>13}{'time s':>9}"]
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
    from whisker_opt.analysis.law_spread import report_lines as spread_lines

    return "\n".join(lines + outputs.report_lines(run_dir, ga, state) + spread_lines(run_dir))
