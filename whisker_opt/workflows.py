"""The jobs a user runs, as library functions: mesh a design, simulate scenes, evaluate a genome,
run and resume the GA, verify (compensation: :mod:`whisker_opt.compensation`).

The command line (:mod:`whisker_opt.cli`) and the public API (:mod:`whisker_opt`) call these; each
takes a validated config (:func:`whisker_opt.config.model.load_config`) and writes into a results
directory it is given or creates (:func:`new_run_dir`).
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Mapping

import numpy as np

import whisker_opt.wiring as wiring
from whisker_opt.config.model import ConfigError, WhiskerConfig, dump_config
from whisker_opt.output import storage

logger = logging.getLogger(__name__)

#: The run file of a run directory, defaults filled in.
CONFIG_YAML = "config.yaml"
#: Folder of the best design's meshes in a run directory, and the hidden folder it is built in.
BEST_DIR = "best"
BEST_PARTIAL = ".best.partial"
#: Written last into a folder of solved scenes: the folder is complete when it holds this file.
SCENES_JSON = "scenes.json"
#: The log file of a run directory (:func:`run_log`).
RUN_LOG = "run.log"
#: Logger whose records :func:`run_log` writes.
PACKAGE_LOGGER = "whisker_opt"


def new_run_dir(cfg: WhiskerConfig, config_path: Path | str, kind: str) -> Path:
    """Create ``<results_dir>/<name or stem>-<kind>-<UTC time>`` holding the resolved ``config.yaml``."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    name = cfg.output.name or Path(config_path).stem
    run_dir = Path(cfg.output.results_dir) / f"{name}-{kind}-{stamp}"
    k = 1
    while run_dir.exists():
        k += 1
        run_dir = Path(cfg.output.results_dir) / f"{name}-{kind}-{stamp}-{k}"
    run_dir.mkdir(parents=True)
    record_config(run_dir, cfg, kind)
    return run_dir


def record_config(folder: Path | str, cfg: WhiskerConfig, command: str | None = None) -> Path:
    """Write ``folder/config.yaml``: the resolved config a command ran (defaults filled in), the one record of
    the model that made the folder's files, headed by the ``command`` that wrote them (``dump_config``); a
    FileExistsError when ``folder`` holds a GA run of another config, or, with ``command``, a GA run or another
    command's results (:func:`whisker_opt.optimise.rundir.check_output_folder`)."""
    from whisker_opt.optimise.rundir import check_output_folder

    folder, path = Path(folder), Path(folder) / CONFIG_YAML
    if command is not None:
        check_output_folder(folder, command)
    if (folder / storage.OPTIMISER_JSON).exists() and path.exists() and not _same_config(path, cfg):
        raise FileExistsError(f"{folder} holds a GA run of another config ({path}): choose another --out")
    folder.mkdir(parents=True, exist_ok=True)
    storage.atomic_write_text(path, dump_config(cfg, command))
    return path


# ----------------------------------------------------------------------------- mesh
def mesh(cfg: WhiskerConfig, out: Path, trim: float | None = None, method: str | None = None,
         step: bool = False, progress: bool = True) -> tuple[Any, dict]:
    """Build and mesh the config's design; write ``config.yaml`` (:func:`record_config`), ``mesh.npz``,
    ``mesh.vtu`` and ``mesh_report.json``.

    ``mesh.vtu`` carries, as field data, the element count, the wall layers (the sizing's and the
    median count of elements a radial line crosses through the wall), the mesh method, the trim,
    the gauge factor and the fidelity preset (when not overridden), which ``whisker-opt view`` names.

    Parameters
    ----------
    cfg : WhiskerConfig
    out : Path
        Output directory (created).
    trim : float, optional
        Trimmed length [mm]; default ``scene.trim``.
    method : {'auto', 'fresh', 'template', 'swept'}, optional
        Default ``fidelity.mesh_method``.
    step : bool
        Also export the CAD solid as STEP and STL.
    progress : bool
        A bar over the steps (meshing, then exporting STEP and STL) on a terminal; a progress
        line per step is logged either way (:class:`whisker_opt.output.progress.Progress`).

    Returns
    -------
    design : geometry.design.WhiskerDesign
    report : dict
        The mesh quality report with ``mesh_seconds`` and ``method``.
    """
    from fem.io import write_vtu
    from geometry.mesh import build_mesh
    from whisker_opt.experiment.fidelity import resolve
    from whisker_opt.output.progress import Progress

    wiring.warn_unread_keys(cfg, "mesh", trim=trim)
    trim = cfg.scene.trim if trim is None else trim
    design = wiring.design_from_config(cfg, trim=trim)
    method = method or cfg.fidelity.mesh_method
    out = Path(out)
    record_config(out, cfg, "mesh")
    steps = Progress(2 if step else 1, "mesh", "step", progress)
    with steps:
        t0 = time.perf_counter()
        wm = build_mesh(design, resolve(cfg.fidelity).sizing, method=method)
        elapsed = time.perf_counter() - t0
        wm.save(out / "mesh.npz")
        rep = wm.report
        meta = {"calibration_xi": float(cfg.scene.calibration), "n_elements": int(wm.mesh.n_elements),
                "wall_layers": float(rep.wall_layers), "elements_through_wall_median":
                float(rep.elements_through_wall_median), "mesh_method": str(rep.method), "trim_mm": float(trim)}
        if not fidelity_of(cfg).get("overrides"):  # a preset's own mesh (as the scene files say it)
            meta["fidelity_preset"] = cfg.fidelity.preset
        write_vtu(out / "mesh.vtu", wm.mesh, field_data=meta)  # what the mesh view names in its title
        steps.step(f"(meshed by {method}: {wm.mesh.cells.shape[0]} elements; mesh.npz and mesh.vtu written)")
        if step:
            from geometry.cad import build_solid, export_step, export_stl

            solid = build_solid(design)
            export_step(solid, out / "whisker.step")
            export_stl(solid, out / "whisker.stl")
            steps.step("(whisker.step and whisker.stl written)")
    # the method actually used (e.g. 'template:default_a3.3_t3.6') stays; the one asked for beside it
    report = dict(wm.report.as_dict(), mesh_seconds=round(elapsed, 3), method_requested=method, trim_mm=trim)
    storage.atomic_write_text(out / "mesh_report.json", json.dumps(report, indent=2))
    return design, report


# ----------------------------------------------------------------------------- simulate
@dataclass
class Simulation:
    """What :func:`simulate` solved and wrote.

    Attributes
    ----------
    specs : dict of str -> SceneSpec
    results : dict of str -> SceneResult
    summary : dict
        ``scenes.json``: one entry per scene, plus ``f1`` (and ``f1_uncompensated``) for a pair.
    columns : dict of str -> ndarray
        ``curve.csv`` columns: ``delta_mm``, ``eps_<scene>``, ``eps_<scene>_solved_line``, the
        contact force ``force_<scene>_N`` and the base reaction's y component
        ``base_reaction_y_<scene>_N`` [N] (splined through the solved deflections like ε).
    out : Path
    """

    specs: dict
    results: dict
    summary: dict
    columns: dict
    out: Path
    f1: float | None = None
    f1_uncompensated: float | None = None


def simulation_specs(cfg: WhiskerConfig, source: str = "config") -> dict:
    """The scenes ``simulate`` solves: the ``intact``/``trimmed_uncompensated``/``trimmed`` pair at
    ``scene.Q_i`` and ``scene.trim`` (``scene.pair``), or the single scene ``scene``.

    ``source`` (the config file) starts the message of a :class:`ConfigError`."""
    sc = cfg.scene
    if not sc.pair:
        return {"scene": wiring.scene_spec(cfg, wiring.design_from_config(cfg, sc.trim), sc.Q_i)}
    if sc.trim <= 0:
        raise ConfigError(f"{source}: scene.trim: must be > 0 for a pair (got {sc.trim})")
    trimmed = wiring.design_from_config(cfg, sc.trim)
    scenes = {wiring.INTACT: wiring.scene_spec(cfg, wiring.design_from_config(cfg, 0.0), sc.Q_i)}
    if sc.Q_i > 0:  # the trimmed whisker still at Q_i: what trimming alone does to the reading
        scenes[wiring.UNCOMPENSATED] = wiring.scene_spec(cfg, trimmed, sc.Q_i)
    scenes[wiring.TRIMMED] = wiring.scene_spec(cfg, trimmed, 0.0)
    return scenes


def simulate(cfg: WhiskerConfig, out: Path, source: str = "config") -> Simulation:
    """Solve the config's scenes (:func:`simulation_specs`); write ``config.yaml`` (:func:`record_config`),
    VTUs, ``curve.csv``, ``scenes.json``, ``force.png`` (contact force against δ) and, for a pair, ``curves.png``.

    For a pair, f1 (:func:`whisker_opt.experiment.objective.f1`) compares ``intact`` with ``trimmed``
    over δ = Δδ … δ_max, and ``f1_uncompensated`` ``intact`` with ``trimmed_uncompensated``.
    """
    from whisker_opt.experiment import objective
    from whisker_opt.output.scenes import solve_scenes

    sc = cfg.scene
    specs = simulation_specs(cfg, source)
    wiring.warn_unread_keys(cfg, "simulate")
    wiring.warn_smeared_on_one_layer(cfg)
    out = Path(out)
    record_config(out, cfg, "simulate")
    delta = np.round(np.arange(0.0, sc.deflection + 0.5 * sc.delta_step, sc.delta_step), 10)
    results, summary = solve_scenes(out, specs, sc.gauge_variant)
    cols: dict[str, np.ndarray] = {"delta_mm": delta}
    for name, res in results.items():
        cols[f"eps_{name}"] = res.curve(delta, sc.gauge_variant)
        cols[f"eps_{name}_solved_line"] = np.interp(delta, res.delta, res.eps["line"])
    for name, res in results.items():
        cols[f"force_{name}_N"] = res.force(delta)
        cols[f"base_reaction_y_{name}_N"] = res.force(delta, "base_y")
    sim = Simulation(specs, results, summary, cols, out)
    if sc.pair:
        sim.f1 = summary["f1"] = objective.f1(cols["eps_intact"][1:], cols["eps_trimmed"][1:])
        if wiring.UNCOMPENSATED in results:
            sim.f1_uncompensated = summary["f1_uncompensated"] = objective.f1(
                cols["eps_intact"][1:], cols[f"eps_{wiring.UNCOMPENSATED}"][1:])
    header = ",".join(cols)
    np.savetxt(out / "curve.csv", np.column_stack(list(cols.values())), delimiter=",", header=header, comments="")
    storage.atomic_write_text(out / SCENES_JSON, json.dumps(summary, indent=2, default=float))
    from whisker_opt.output.plots import design_label, plot_curves, plot_forces

    forces = {name: cols[f"force_{name}_N"] for name in results}
    d = next(iter(specs.values())).design
    title = design_label({'alpha': d.alpha, 'l': d.l, 't': d.t, 'Q_i': sc.Q_i}, sc.trim)
    plot_forces(out / "force.png", delta, forces, title, fidelity_of(cfg))
    if sc.pair:
        plot_curves(out / "curves.png", delta, cols["eps_intact"], cols["eps_trimmed"], title,
                    cols.get(f"eps_{wiring.UNCOMPENSATED}"), fidelity_of(cfg), forces)
    return sim


# ----------------------------------------------------------------------------- evaluate
def evaluate(cfg: WhiskerConfig, genes: Mapping[str, float], keep_curves: bool = False):
    """One GA evaluation of a genome: f1 and timings, or the classified failure.

    The genome's whisker is trimmed by ``optimiser.trim`` and its Q_i is the gene's: a
    ``scene.trim`` or ``scene.Q_i`` that is set is warned about (:func:`whisker_opt.wiring.unread_keys`).

    Returns
    -------
    whisker_opt.experiment.outcome.EvalOutcome
    """
    wiring.warn_unread_keys(cfg, "evaluate")
    return wiring.evaluator(cfg, keep_curves=keep_curves)({k: float(v) for k, v in genes.items()})


def write_design_scenes(out: Path, cfg: WhiskerConfig, genes: Mapping[str, Any], specs: dict | None = None) -> dict:
    """Solve the scenes of a genome (:func:`whisker_opt.wiring.design_scene_specs`) and write them
    into ``out``: one VTU per state and, last, ``scenes.json`` with the gauge readings.

    Every file is written atomically and ``scenes.json`` after all VTU files, so a folder
    holding ``scenes.json`` is complete.

    Parameters
    ----------
    out : Path
        Created when missing.
    cfg : WhiskerConfig
    genes : mapping of str -> float
        The genome; its genes are stored in every ``scenes.json`` entry.
    specs : dict of str -> SceneSpec, optional
        The scenes, when already built.

    Returns
    -------
    dict of str -> whisker_opt.experiment.scene.SceneResult
    """
    from whisker_opt.output.scenes import solve_scenes

    specs = wiring.design_scene_specs(cfg, genes) if specs is None else specs
    results, entries = solve_scenes(Path(out), specs, cfg.scene.gauge_variant, genes=_clean_genes(genes))
    storage.atomic_write_text(Path(out) / SCENES_JSON, json.dumps(entries, indent=2, default=float))
    return results


def _clean_genes(genes: Mapping[str, Any]) -> dict[str, float]:
    from whisker_opt.genes import gene_keys

    keys = gene_keys()
    return {k: float(v) for k, v in genes.items() if k in keys}


# ----------------------------------------------------------------------------- run / resume
class _Forward(logging.Handler):
    """Passes on to the parent logger's handlers the records its logger passed on before
    :func:`run_log` lowered its level (so a console shows what it showed before)."""

    def __init__(self, parent: logging.Logger, threshold: int) -> None:
        super().__init__(logging.NOTSET)
        self.parent, self.threshold = parent, threshold

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= self._threshold_of(record.name):
            self.parent.handle(record)

    def _threshold_of(self, name: str) -> int:
        """The level set on ``name`` or an ancestor below the package's logger (e.g. the progress
        lines' logger), else the package's threshold before :func:`run_log` lowered it."""
        log = logging.getLogger(name)
        while log is not None and log.name not in (PACKAGE_LOGGER, "root"):
            if log.level != logging.NOTSET:
                return log.level
            log = log.parent
        return self.threshold


@contextlib.contextmanager
def run_log(run_dir: Path, level: int = logging.INFO) -> Iterator[Path]:
    """Write the ``whisker_opt`` logger's records at ``level`` and above to ``run_dir/run.log`` (appended).

    The logger's level is lowered to ``level`` for the duration if needed; what it passed on
    to its parent's handlers (e.g. the console) before stays the same. On exit the file's
    handler is removed and closed and the logger is restored.

    Parameters
    ----------
    run_dir : Path
        An existing run directory.
    level : int
        Lowest level written to the file.

    Yields
    ------
    Path
        The log file.

    Raises
    ------
    whisker_opt.output.storage.UnsafeLink
        ``run.log`` is a symbolic link (:func:`whisker_opt.output.storage.log_file_handler`).
    """
    path = Path(run_dir) / RUN_LOG
    log = logging.getLogger(PACKAGE_LOGGER)
    old_level, old_propagate = log.level, log.propagate
    threshold = log.getEffectiveLevel()
    handler = storage.log_file_handler(path)
    handler.setLevel(level)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    forward = _Forward(log.parent, threshold) if old_propagate and log.parent is not None else None
    log.addHandler(handler)
    if threshold > level:
        log.setLevel(level)
        if forward is not None:
            log.propagate = False
            log.addHandler(forward)
    log.info("---- log of %s", Path(run_dir))
    try:
        yield path
    finally:
        for h in (handler, forward):
            if h is not None:
                log.removeHandler(h)
        handler.close()
        log.setLevel(old_level)
        log.propagate = old_propagate


def fidelity_of(cfg: WhiskerConfig) -> dict:
    """``{"preset", "f1_resolution"}`` of a config (:func:`whisker_opt.experiment.fidelity.describe`),
    the resolution in the config's calibrated strain."""
    from whisker_opt.experiment.fidelity import describe

    return describe(cfg.fidelity, cfg.scene.calibration)


def _best_genes(summary) -> dict | None:
    genes = summary.best.get("genes") if isinstance(summary.best, dict) else None
    return genes or None


def finish_best(run_dir: Path, cfg: WhiskerConfig, summary) -> None:
    """Re-run the best design of a run summary with curves and deformed meshes (VTU) into ``run_dir/best``.

    The meshes and ``scenes.json`` are written into the hidden ``run_dir/.best.partial``, then
    ``best_curves.csv/png``, and last the folder is renamed to ``best`` (replacing an older one):
    ``best/`` exists only complete, and after ``best_curves.*``. A kill on the way leaves no
    ``best/``, which :func:`resume` rebuilds (:func:`missing_best_outputs`).

    ``best_curves.*`` hold the intact and the trimmed, vented curves and, when the design has
    it (Q_i > 0), the trimmed whisker still at Q_i (``eps_u``); the plot's title names the
    genes, the trim and the fidelity preset with its f1 resolution.
    """
    from whisker_opt.output.plots import design_label, write_best_curves

    run_dir = Path(run_dir)
    best_genes = _best_genes(summary)
    if not best_genes:
        return
    try:
        specs = wiring.design_scene_specs(cfg, best_genes)
    except Exception as exc:  # the best of a run where every design failed
        logger.warning("best design cannot be re-run: %s", exc)
        return
    partial = run_dir / BEST_PARTIAL
    shutil.rmtree(partial, ignore_errors=True)
    results = write_design_scenes(partial, cfg, best_genes, specs)
    delta = wiring.evaluator(cfg).samples()
    names = [n for n in (wiring.INTACT, wiring.TRIMMED, wiring.UNCOMPENSATED) if n in results]
    curves = {n: np.concatenate([[0.0], results[n].curve(delta, cfg.scene.gauge_variant)]) for n in names}
    title = f"best design: {design_label(_clean_genes(best_genes), wiring.optimiser_of(cfg).trim)}"
    write_best_curves(run_dir, np.concatenate([[0.0], delta]), curves[wiring.INTACT], curves[wiring.TRIMMED], title,
                      curves.get(wiring.UNCOMPENSATED), fidelity_of(cfg))
    _move_into_place(partial, run_dir / BEST_DIR)


def _move_into_place(partial: Path, final: Path) -> None:
    """Rename the complete folder ``partial`` to ``final``; an existing ``final`` is removed.

    An old ``final`` is first renamed to a hidden ``*.partial`` name, so that at any instant
    ``final`` is either absent or a complete folder."""
    old = None
    if final.exists():
        old = final.with_name(f".{final.name}.old.partial")
        shutil.rmtree(old, ignore_errors=True)
        final.rename(old)
    partial.rename(final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def missing_best_outputs(run_dir: Path, summary) -> list[str]:
    """What of the best design's outputs is missing or incomplete in a run directory.

    ``best/`` is complete when its ``scenes.json`` (written last) reads, describes the run's
    best genes and each of its scenes has a VTU file; ``best_curves.csv`` and ``.png`` must exist.

    Parameters
    ----------
    run_dir : Path
    summary : whisker_opt.optimise.runner.RunSummary
        The run's summary (its ``best`` genes).

    Returns
    -------
    list of str
        Names of the missing outputs (empty when complete, or when the run has no best design).
    """
    run_dir = Path(run_dir)
    genes = _best_genes(summary)
    if not genes:
        return []
    best = run_dir / BEST_DIR
    want = _clean_genes(genes)
    missing = []
    try:
        entries = json.loads((best / SCENES_JSON).read_text())
    except (OSError, ValueError):
        entries = None
    if not isinstance(entries, dict) or not entries:
        missing.append(f"{BEST_DIR}/")
    elif not all(isinstance(e, dict) and _same_genes(e.get("genes"), want) for e in entries.values()):
        missing.append(f"{BEST_DIR}/ (of another design)")
    elif not all(any(best.glob(f"{name}_*.vtu")) for name in entries):
        missing.append(f"{BEST_DIR}/*.vtu")
    for name in (storage.BEST_CURVES_CSV, "best_curves.png"):
        if not (run_dir / name).is_file():
            missing.append(name)
    return missing


def _same_genes(got: Any, want: dict[str, float]) -> bool:
    if not isinstance(got, dict) or set(got) != set(want):
        return False
    try:
        return all(math.isclose(float(got[k]), v, rel_tol=1e-12, abs_tol=0.0) for k, v in want.items())
    except (TypeError, ValueError):
        return False


def _same_config(path: Path, cfg: WhiskerConfig) -> bool:
    """True when the run file ``path`` holds ``cfg`` (the same text, or the same validated values)."""
    from whisker_opt.config.model import load_config

    try:
        if path.read_text() == dump_config(cfg):
            return True
        return load_config(path).model_dump(mode="json") == cfg.model_dump(mode="json")
    except (OSError, ConfigError, UnicodeDecodeError):
        return False


def check_run_config(run_dir: Path, cfg: WhiskerConfig) -> None:
    """Refuse a run directory whose ``config.yaml`` is another config than ``cfg``.

    Raises
    ------
    FileExistsError
        One line naming ``whisker-opt resume``.
    """
    path = Path(run_dir) / CONFIG_YAML
    if path.exists() and not _same_config(path, cfg):
        raise FileExistsError(f"{run_dir} already holds a run of another config ({path} differs): continue it "
                              f"with `whisker-opt resume {run_dir}` or choose another --out")


class GenerationLines:
    """``callbacks`` entry of a run: a progress line per generation with elapsed time and ETA
    (:class:`whisker_opt.output.progress.Progress`; the run's bar counts the evaluations).

    Parameters
    ----------
    max_generations : int
        The last generation (generations 0 … this); a stopping rule may end the run sooner, so the
        ETA is an upper bound.
    done : int
        Generations finished before (a resumed run).
    """

    def __init__(self, max_generations: int, done: int = 0) -> None:
        from whisker_opt.output.progress import Progress

        self.steps = Progress(max_generations + 1, "run", "generations done", bar=False, initial=done, at_most=True)

    def __call__(self, state, row: dict) -> None:
        feasible = "" if row.get("best_feasible", True) else " (infeasible)"
        stop = f"; stop: {state.stop_reason}" if state.stop_reason else ""
        self.steps.step(f"(generation {row['generation']}: best F_p {row['best_fp']:.4g}{feasible}, "
                        f"{row.get('evals', 0)} evaluations, {state.n_evaluations} in all{stop})")


def check_runnable(cfg: WhiskerConfig):
    """The GA's evaluator of ``cfg``, once its design section and executor are known to work.

    Called before a run directory is made, so an impossible ``design`` section or an executor that
    cannot start (an unreachable dask scheduler) leaves nothing behind.

    Returns
    -------
    whisker_opt.optimise.evaluator.SceneEvaluator

    Raises
    ------
    geometry.design.InvalidDesignError
        ``cfg.design`` does not describe a whisker.
    whisker_opt.optimise.executors.MachineFailure
        The executor cannot start.
    """
    from whisker_opt.optimise.backend import preflight

    ev = wiring.evaluator(cfg)
    preflight(wiring.optimiser_of(cfg).executor)
    return ev


def run(cfg: WhiskerConfig, run_dir: Path, progress: bool = True, overwrite: bool = False):
    """Run the GA of a config into ``run_dir`` and re-run its best design into ``run_dir/best``.

    ``run_dir`` may be new, empty, or a run killed before its first checkpoint with the same
    config (it starts again); with ``overwrite``, a folder holding a run is emptied first
    (:func:`whisker_opt.optimise.rundir.check_run_target`). The run holds the folder's writer
    lock throughout (:class:`whisker_opt.output.lock.RunDirLock`). The run's log (INFO and above)
    is appended to ``run_dir/run.log`` (:func:`run_log`); the run records its fidelity preset and
    f1 resolution (:func:`fidelity_of`) and its resolved config with its digest.

    Returns
    -------
    whisker_opt.optimise.runner.RunSummary

    Raises
    ------
    FileExistsError
        ``run_dir`` already holds a run (resume it instead, or pass ``overwrite``), a ``config.yaml``
        of another config, or files of no run.
    whisker_opt.output.lock.RunDirectoryBusy
        Another process writes into ``run_dir``.
    whisker_opt.optimise.executors.MachineFailure
        The executor cannot start (an unreachable dask scheduler), or workers were lost during
        the run (it resumes from its last checkpoint).
    """
    from whisker_opt.optimise.rundir import check_run_target, clear_run_dir
    from whisker_opt.optimise.runner import remove_run_temporaries, run_optimisation
    from whisker_opt.output.lock import RunDirLock

    opt = wiring.optimiser_of(cfg)
    ev = check_runnable(cfg)
    run_dir = Path(run_dir)
    check_run_target(run_dir, lambda path: _same_config(path, cfg), overwrite)  # before anything is written
    run_dir.mkdir(parents=True, exist_ok=True)
    with RunDirLock(run_dir, "run"):
        if check_run_target(run_dir, lambda path: _same_config(path, cfg), overwrite):  # again, under the lock
            clear_run_dir(run_dir)
        if (run_dir / CONFIG_YAML).exists():  # a run of this config killed before its first checkpoint
            remove_run_temporaries(run_dir)
        else:
            record_config(run_dir, cfg, "run")
        fidelity = fidelity_of(cfg)
        with run_log(run_dir):
            logger.info("run of %s at preset %s (f1 resolution %.3g)", run_dir, fidelity["preset"],
                        fidelity["f1_resolution"])
            wiring.warn_unread_keys(cfg, "run")
            summary = run_optimisation(opt, run_dir, ev, opt.resolve_seed(cfg.seed), progress=progress,
                                       fidelity=fidelity, callbacks=[GenerationLines(opt.stopping.max_generations)],
                                       run_config=run_config(run_dir).model_dump(mode="json"))  # as resume reads it
            finish_best(run_dir, cfg, summary)
            _verify_front(run_dir, cfg)
            finish_law_spread(run_dir, cfg, progress)
    return summary


def finish_law_spread(run_dir: Path, cfg: WhiskerConfig, progress: bool = False) -> None:
    """The model-form spread of the run's best ``optimiser.law_spread_top`` designs (``law_spread.csv``, logged).

    Skipped when the key is 0 or the run's evaluator is not the scene evaluator (a stand-in fitness); a failure
    is logged as a warning and does not fail the finished run.
    """
    from whisker_opt.analysis.law_spread import format_spread
    from whisker_opt.analysis.verify import law_spread_run
    from whisker_opt.optimise.evaluator import SceneEvaluator

    top = wiring.optimiser_of(cfg).law_spread_top
    if not top or not isinstance(wiring.nominal_evaluator(cfg), SceneEvaluator):
        return
    try:
        rows, preset = law_spread_run(run_dir, top, progress)
    except Exception as exc:  # noqa: BLE001 - the run itself is complete and saved
        logger.warning("wall-law spread of the best design(s) not computed: %s", exc)
        return
    for line in format_spread(rows, preset).splitlines():
        logger.info("%s", line)


def _verify_front(run_dir: Path, cfg: WhiskerConfig) -> None:
    """A multi-objective run's front re-evaluated at the next finer preset (``pareto.csv``, ``pareto.png``)."""
    from whisker_opt.optimise.recorder import verify_run_front

    verify_run_front(run_dir, lambda preset: wiring.evaluator(wiring.with_preset(cfg, preset)), cfg.fidelity.preset)


def run_config(run_dir: Path) -> WhiskerConfig:
    """The ``config.yaml`` of a run directory.

    Raises
    ------
    FileNotFoundError
        ``run_dir`` holds no ``config.yaml``.
    """
    from whisker_opt.config.model import load_config
    from whisker_opt.optimise.runner import run_config_path

    return load_config(run_config_path(run_dir))


def resume(run_dir: Path, progress: bool = True, max_generations: int | None = None,
           allow_config_change: bool = False):
    """Continue a killed run from its last checkpoint (same result as an uninterrupted run), or
    extend a finished one to ``max_generations`` (:func:`~whisker_opt.optimise.runner.resume_optimisation`).

    The resume holds the folder's writer lock (:class:`whisker_opt.output.lock.RunDirLock`). A
    ``config.yaml`` edited since the run started is refused
    (:class:`whisker_opt.optimise.rundir.ConfigChanged`) unless ``allow_config_change``: the run
    then continues with it and records the change (:func:`whisker_opt.optimise.rundir.check_config`).

    Whatever a kill left unwritten is written: ``optimiser.json`` and ``environment.json``,
    the tables and the convergence plot, and ``best/`` with ``best_curves.csv/png`` when any
    of them is missing or incomplete (:func:`missing_best_outputs`). Temporaries left by the
    kill are deleted. A complete run is left as it is (its tables and plots rewritten). The
    log is appended to ``run_dir/run.log`` (:func:`run_log`).

    Returns
    -------
    whisker_opt.optimise.runner.RunSummary
    """
    from whisker_opt.optimise.checkpoint import has_checkpoint
    from whisker_opt.optimise.rundir import check_config
    from whisker_opt.optimise.runner import load_run, remove_run_temporaries, resume_optimisation, write_run_metadata
    from whisker_opt.output.lock import RunDirLock

    run_dir = Path(run_dir)
    cfg = run_config(run_dir)
    resolved = cfg.model_dump(mode="json")
    with RunDirLock(run_dir, "resume"):
        remove_run_temporaries(run_dir)
        if not has_checkpoint(run_dir) and not (run_dir / storage.OPTIMISER_JSON).is_file():
            opt = wiring.optimiser_of(cfg)  # killed before the run wrote anything but its config
            write_run_metadata(run_dir, opt, opt.resolve_seed(cfg.seed), resolved)
        state, opt_cfg, _, _ = load_run(run_dir)  # a damaged run directory is refused before run.log is written
        done = -1 if state is None else state.generation
        change = check_config(run_dir, None if state is None else state.extra, done, resolved, wiring.optimiser_of(cfg),
                              allow_config_change)
        opt_cfg = opt_cfg if change is None else change.optimiser
        lines = GenerationLines(max_generations if max_generations is not None else opt_cfg.stopping.max_generations,
                                0 if state is None else state.generation + 1)
        with run_log(run_dir):
            logger.info("resume of %s", run_dir)
            wiring.warn_unread_keys(cfg, "resume")
            summary = resume_optimisation(run_dir, wiring.evaluator(cfg), progress=progress,
                                          fidelity=fidelity_of(cfg), max_generations=max_generations,
                                          callbacks=[lines], run_config=resolved, config_change=change)
            missing = missing_best_outputs(run_dir, summary)
            if missing:
                logger.info("rebuilding the best design's outputs (missing: %s)", ", ".join(missing))
                finish_best(run_dir, cfg, summary)
            _verify_front(run_dir, cfg)
            if missing or not (run_dir / "law_spread.csv").exists():
                finish_law_spread(run_dir, cfg, progress)
    return summary

