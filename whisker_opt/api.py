"""The public Python API: what a researcher calls from a script or a notebook.

Each function is a thin, documented front of :mod:`whisker_opt.workflows` (simulate,
evaluate, run, resume), :mod:`whisker_opt.optimise.runner` (reading a run) and
:mod:`whisker_opt.analysis.verify` (re-evaluation at a finer preset). They take a validated
config (:func:`load_config`) and return plain objects; logging goes through :mod:`logging`.

Every name here is also reachable as ``whisker_opt.<name>`` (imported on first use, so
``import whisker_opt`` stays fast). Units: mm, MPa, degrees.

Examples
--------
>>> import whisker_opt as wo
>>> cfg = wo.load_config({"fidelity": {"preset": "coarse"}, "scene": {"Q_i": 0.2, "trim": 5.0}})
>>> cfg.scene.trim
5.0
>>> sim = wo.simulate(cfg, "out/scene")                                 # doctest: +SKIP
>>> round(sim.f1, 5)                                                    # doctest: +SKIP
0.00301
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

if TYPE_CHECKING:  # pragma: no cover - annotations only; the imports are heavy
    from whisker_opt.analysis.compensation_map import CompensationMap
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt.experiment.outcome import EvalOutcome
    from whisker_opt.optimise.runner import RunSummary
    from whisker_opt.workflows import Simulation

logger = logging.getLogger(__name__)

__all__ = ["load_config", "simulate", "evaluate", "run", "resume", "load_run", "verify", "RunResults",
           "vent_pressure", "CompensationMap"]

#: Stem of a run directory created for a config that came from Python, not from a file
#: (``<output.name or this>-<kind>-<UTC time>``).
DEFAULT_RUN_NAME = "whisker"


def load_config(path_or_mapping: str | Path | Mapping[str, Any] | WhiskerConfig) -> WhiskerConfig:
    """Read and validate a run configuration from a YAML file or a mapping.

    Parameters
    ----------
    path_or_mapping : str, Path, mapping or WhiskerConfig
        A YAML run file, or the same content as a (nested) mapping: sections ``design``,
        ``material``, ``scene``, ``fidelity``, ``optimiser``, ``output`` and ``seed``, all
        optional. A :class:`~whisker_opt.config.model.WhiskerConfig` is returned as is.

    Returns
    -------
    whisker_opt.config.model.WhiskerConfig
        Frozen; every default filled in. A mapping and the YAML file holding the same
        content give equal configs.

    Raises
    ------
    whisker_opt.config.model.ConfigError
        Missing file, YAML syntax error or a validation problem; the message names the key.

    Examples
    --------
    >>> from whisker_opt import load_config
    >>> cfg = load_config({"design": {"alpha": 4.0}, "fidelity": {"preset": "coarse"}})
    >>> cfg.design.alpha, cfg.design.l, cfg.fidelity.preset
    (4.0, 15.0, 'coarse')
    >>> load_config({"design": {"alpah": 4.0}})
    Traceback (most recent call last):
    ...
    whisker_opt.config.base.ConfigError: <mapping>: design.alpah: unknown key 'alpah'; did you mean 'alpha'?
    """
    from pydantic import ValidationError

    from whisker_opt.config import model

    if isinstance(path_or_mapping, model.WhiskerConfig):
        return path_or_mapping
    if isinstance(path_or_mapping, (str, Path)):
        return model.load_config(path_or_mapping)
    if not isinstance(path_or_mapping, Mapping):
        raise model.ConfigError(f"load_config: expected a YAML path or a mapping of sections, "
                                f"got {type(path_or_mapping).__name__}")
    try:
        return model.WhiskerConfig.model_validate(dict(path_or_mapping))
    except ValidationError as exc:
        raise model.ConfigError(model.format_validation_error(exc, "<mapping>")) from None


def _checked_config(cfg: Any, where: str) -> WhiskerConfig:
    """``cfg`` if it is a loaded config, else :class:`~whisker_opt.config.model.ConfigError` in one line."""
    from whisker_opt.config.model import ConfigError, WhiskerConfig

    if not isinstance(cfg, WhiskerConfig):
        raise ConfigError(f"{where}: cfg is a {type(cfg).__name__}, not a loaded config: pass it through "
                          "load_config() first (a path, a mapping or a WhiskerConfig)")
    return cfg


def _checked_path(path: Any, name: str, where: str) -> Path:
    """``path`` as a Path if it is a str or an ``os.PathLike``, else a ValueError in one line naming it."""
    import os

    if isinstance(path, bool) or not isinstance(path, (str, os.PathLike)) or str(path) == "":
        raise ValueError(f"{where}: {name} is {path!r} ({type(path).__name__}); expected the path of a folder (a str "
                         "or a pathlib.Path, not empty)")
    return Path(path)


def _out_dir(cfg: WhiskerConfig, out: str | Path | None, kind: str) -> Path:
    """``out``, or a new run directory under ``cfg.output.results_dir``."""
    if out is not None:
        return Path(out)
    from whisker_opt.workflows import new_run_dir

    run_dir = new_run_dir(cfg, DEFAULT_RUN_NAME, kind)
    logger.info("writing into %s", run_dir)
    return run_dir


def simulate(cfg: WhiskerConfig, out: str | Path | None = None) -> Simulation:
    """Solve the config's scenes: the intact/trimmed pair of ``cfg.design`` (or one scene).

    With ``scene.pair`` (the default) three scenes are solved: ``intact`` at ``scene.Q_i``,
    ``trimmed_uncompensated`` (trimmed by ``scene.trim``, still at Q_i; only when Q_i > 0)
    and ``trimmed`` (trimmed and vented), each pressurised, then pushed sideways to
    ``scene.deflection``. With ``pair: false`` one scene at Q_i and ``scene.trim``.

    Parameters
    ----------
    cfg : WhiskerConfig
        From :func:`load_config`.
    out : str or Path, optional
        Output directory (created). Default: a new directory
        ``<output.results_dir>/<output.name or "whisker">-simulate-<UTC time>`` holding the
        resolved ``config.yaml``.

    Returns
    -------
    whisker_opt.workflows.Simulation
        ``results[name]`` (a :class:`~whisker_opt.experiment.scene.SceneResult`: ``delta_l``
        [mm], ``delta``, ``eps`` (the readings by name), ``contact_force`` [N] and ``base_reaction`` [N] at each
        solved δ, ``contact_stiffness`` = F(δ₁)/δ₁ [N/mm] over the first solved step ...),
        ``columns`` (the ``curve.csv`` columns ``delta_mm``, ``eps_<scene>``,
        ``force_<scene>_N`` and ``base_reaction_y_<scene>_N``), ``f1`` and ``f1_uncompensated``
        for a pair, and ``out``. Written: one VTU per solved state, ``scenes.pvd``, ``curve.csv``,
        ``scenes.json``, ``force.png``.

    Raises
    ------
    whisker_opt.config.model.ConfigError
        A pair with ``scene.trim`` = 0 (before anything is written).
    geometry.design.InvalidDesignError
        ``cfg.design`` does not describe a whisker.

    Examples
    --------
    >>> cfg = load_config({"fidelity": {"preset": "coarse"}, "scene": {"Q_i": 0.2, "trim": 5.0}})
    >>> sim = simulate(cfg, "out/scene")                                 # doctest: +SKIP
    >>> sim.results["intact"].delta_l, sim.columns["eps_intact"][-1], sim.f1  # doctest: +SKIP
    (4.397..., 0.0678..., 0.00300...)
    >>> sim.results["intact"].contact_force[-1], sim.results["intact"].contact_stiffness  # doctest: +SKIP
    (0.0892..., 0.0174...)
    """
    from whisker_opt.workflows import simulate as _simulate, simulation_specs

    cfg = _checked_config(cfg, "simulate")
    simulation_specs(cfg, "simulate")  # refuse a bad pair before creating a directory
    return _simulate(cfg, _out_dir(cfg, out, "simulate"), source="simulate")


def evaluate(cfg: WhiskerConfig, genes: Mapping[str, float] | Sequence[float]) -> EvalOutcome:
    """One GA evaluation of a genome: f1 and timings, or the classified failure.

    The genome's whisker is solved intact at Q_i and trimmed by ``optimiser.trim`` and
    vented; f1 = mean |ε_i(δ) − ε_c(δ)| over δ = Δδ … ``scene.deflection`` (Δδ =
    ``scene.delta_step``). Nothing is written to disk. ``scene.trim`` and ``scene.Q_i`` (the keys
    of :func:`simulate`) have no effect here: when set, each is warned about in one line
    (:func:`whisker_opt.wiring.unread_keys`).

    Parameters
    ----------
    cfg : WhiskerConfig
        From :func:`load_config`; its ``design`` supplies every parameter that is not a gene.
    genes : mapping or sequence of float
        The config's genome (:func:`whisker_opt.genes.run_genome`): ``{"alpha": deg, "l": mm, "t": mm,
        "Q_i": MPa}`` and each gene ``optimiser.genes`` adds, by its key (e.g. ``"fibre_pitch": mm``), or
        the values in that order.

    Returns
    -------
    whisker_opt.experiment.outcome.EvalOutcome
        ``ok``, ``f1``, ``status`` and ``reason`` (why it failed), ``timings`` [s] per
        scene and stage (``total`` for the whole evaluation).

    Raises
    ------
    whisker_opt.config.model.ConfigError
        ``cfg`` is not a loaded config (pass a mapping or path through :func:`load_config`).
    ValueError
        ``genes`` is not a mapping or sequence, lacks a gene of the config's genome or holds another one.

    Examples
    --------
    >>> cfg = load_config({"fidelity": {"preset": "coarse"}, "optimiser": {"trim": 5.0}})
    >>> res = evaluate(cfg, {"alpha": 4.0, "l": 12.0, "t": 3.0, "Q_i": 0.1})  # doctest: +SKIP
    >>> res.ok, res.f1, res.timings["total"]                               # doctest: +SKIP
    (True, 0.00255..., 1.8...)
    """
    from whisker_opt.genes import genes_dict, run_genome
    from whisker_opt.workflows import evaluate as _evaluate

    cfg = _checked_config(cfg, "evaluate")
    names = run_genome(cfg)
    if isinstance(genes, (str, bytes)) or not hasattr(genes, "__iter__"):
        raise ValueError(f"evaluate: genes={genes!r}: expected a mapping {names} -> value or "
                         f"{len(names)} values in that order")
    if not isinstance(genes, Mapping):
        values = list(genes)
        if len(values) != len(names):
            raise ValueError(f"evaluate: expected {len(names)} genes {names}, got {len(values)}")
        _check_gene_values(dict(zip(names, values)))
        genes = genes_dict(values, names)
    missing = [g for g in names if g not in genes]
    unknown = [g for g in genes if g not in names]
    if missing or unknown:
        raise ValueError(f"evaluate: genes must be exactly {names}, the genome of optimiser.genes (missing {missing}, "
                         f"unknown {unknown})")
    _check_gene_values(genes)
    return _evaluate(cfg, genes)


def _check_gene_values(genes: Mapping[str, Any]) -> None:
    """Refuse a gene that is not a real number (``float('3')`` would take a string, or ``True``, silently) or
    that leaves the range of the key it sets (a negative Q_i, a NaN)."""
    import numpy as np

    from whisker_opt.genes import gene_key

    for name, v in genes.items():
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise ValueError(f"evaluate: genes[{name!r}] is {v!r} ({type(v).__name__}); a gene is a real number "
                             f"within its bounds (optimiser.genes.{name})")
        key = gene_key(name)
        if not key.admits(v):
            where = "scene.Q_i" if key.section == "load" else f"{key.section}.{name}"
            raise ValueError(f"evaluate: genes[{name!r}] = {float(v)!r} is outside the allowed range "
                             f"{key.range_text()} {key.unit} of {where}")


def run(cfg: WhiskerConfig, out: str | Path | None = None, progress: bool = False) -> RunSummary:
    """Run the genetic algorithm of a config, then re-run its best design with its meshes.

    Parameters
    ----------
    cfg : WhiskerConfig
        From :func:`load_config`; ``optimiser`` (defaults when absent) sets the gene bounds,
        ``trim``, penalties, population, stopping rules and executor.
    out : str or Path, optional
        Run directory. Default: a new directory
        ``<output.results_dir>/<output.name or "whisker">-run-<UTC time>``.
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    whisker_opt.optimise.runner.RunSummary
        ``run_dir``, ``stop_reason``, ``best`` (genes, f1, F_p, ...) and the counters. Read
        the files back with :func:`load_run`.

    Raises
    ------
    FileExistsError
        ``out`` already holds a run (continue it with :func:`resume`).
    geometry.design.InvalidDesignError
        ``cfg.design`` does not describe a whisker.
    whisker_opt.optimise.executors.MachineFailure
        The executor cannot start, or its workers were lost (resume the run later).

    Examples
    --------
    >>> cfg = load_config({"fidelity": {"preset": "coarse"}, "output": {"results_dir": "out"},
    ...                    "optimiser": {"ga": {"population": 4, "n_elite": 1},
    ...                                  "stopping": {"max_generations": 1}}, "seed": 1})
    >>> summary = run(cfg)                                                 # doctest: +SKIP
    >>> summary.stop_reason, summary.best["genes"]                         # doctest: +SKIP
    ('max_generations', {'alpha': 3.9..., 'l': 12.2..., 't': 2.1..., 'Q_i': 0.12...})
    """
    import whisker_opt.workflows as workflows

    cfg = _checked_config(cfg, "run")
    if out is None:  # refuse an impossible design or executor before creating the directory
        workflows.check_runnable(cfg)
    return workflows.run(cfg, _out_dir(cfg, out, "run"), progress=progress)


def resume(run_dir: str | Path, progress: bool = False, allow_config_change: bool = False) -> RunSummary:
    """Continue a killed run from its last checkpoint; the result equals an uninterrupted run.

    A finished run is not run again: its summary is returned.

    Parameters
    ----------
    run_dir : str or Path
        A directory written by :func:`run` (or ``whisker-opt run``).
    progress : bool
        Show a progress bar on stderr.
    allow_config_change : bool
        Continue although the run's ``config.yaml`` was edited since it started (the change is
        recorded); otherwise such a run is refused.

    Returns
    -------
    whisker_opt.optimise.runner.RunSummary

    Raises
    ------
    FileNotFoundError
        ``run_dir`` is not a run directory.
    whisker_opt.optimise.checkpoint.RunDirectoryError
        A damaged checkpoint, one of an earlier version
        (:class:`~whisker_opt.optimise.checkpoint.OlderFormatError`), or an edited ``config.yaml``
        (:class:`~whisker_opt.optimise.rundir.ConfigChanged`).
    whisker_opt.output.lock.RunDirectoryBusy
        Another process writes into ``run_dir``.

    Examples
    --------
    >>> summary = resume("out/whisker-run-20250101-120000")                # doctest: +SKIP
    >>> summary.stop_reason                                                # doctest: +SKIP
    'max_generations'
    """
    import whisker_opt.workflows as workflows

    run_dir = _checked_path(run_dir, "run_dir", "resume")
    return workflows.resume(run_dir, progress=progress, allow_config_change=allow_config_change)


@dataclass(frozen=True)
class RunResults:
    """The files of a run directory, read back.

    Attributes
    ----------
    run_dir : Path
    config : WhiskerConfig
        The resolved run file (``config.yaml``).
    best : dict
        ``best.json``: ``genes``, ``f1``, ``F_p``, ``kappas``, ``feasible``, ``status``,
        ``generation_found``, ``stop_reason`` and ``stop_detail``, ``best_designs`` (the run's best
        designs pairwise ``distinct_distance`` apart) and the run's counters.
    evaluations : list of dict
        ``evaluations.csv``, one row per evaluated individual.
    generations : list of dict
        ``generations.csv``, one row per generation.
    stop_reason : str or None
        The stopping rule that fired (``target_fp``, ``resolution``, ``stall`` or
        ``max_generations``); None while the run is unfinished (``best["stop_detail"]`` says why).

    Notes
    -----
    CSV cells are converted: integers to int, other numbers (``nan`` included) to float,
    ``True``/``False`` to bool and empty cells to None; text stays str.
    """

    run_dir: Path
    config: WhiskerConfig
    best: dict
    evaluations: list
    generations: list
    stop_reason: str | None

    @property
    def best_genes(self) -> dict[str, float]:
        """The best design's genes, ``{"alpha": deg, "l": mm, "t": mm, "Q_i": MPa}``."""
        return dict(self.best.get("genes") or {})


def _cell(text: str) -> Any:
    """A CSV cell as int, float, bool, None or str."""
    if text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _table(path: Path) -> list[dict[str, Any]]:
    from whisker_opt.output import storage

    if not path.is_file():
        return []
    return [{k: _cell(v) for k, v in row.items()} for row in storage.read_csv(path)]


def _read_best(path: Path) -> dict:
    """``best.json`` as a dict, or a RunDirectoryError in one line naming the file and the damage."""
    import json

    from whisker_opt.optimise.checkpoint import RunDirectoryError

    try:
        best = json.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise RunDirectoryError(f"{path}: damaged (not UTF-8 text at byte {exc.start})") from None
    except ValueError as exc:
        raise RunDirectoryError(f"{path}: damaged (not valid JSON: {' '.join(str(exc).split())})") from None
    except RecursionError:
        raise RunDirectoryError(f"{path}: damaged (JSON nested too deeply to read)") from None
    if not isinstance(best, dict):
        raise RunDirectoryError(f"{path}: damaged (top level is a {type(best).__name__}, expected an object)")
    return best


def load_run(run_dir: str | Path) -> RunResults:
    """Read a run directory: its config, best design, evaluations and generations.

    Parameters
    ----------
    run_dir : str or Path
        A directory written by :func:`run` (or ``whisker-opt run``).

    Returns
    -------
    RunResults
        Tables are empty lists (and ``best`` an empty dict) before the first generation
        has finished.

    Raises
    ------
    FileNotFoundError
        ``run_dir`` holds no ``config.yaml``: it is not a run directory.
    whisker_opt.optimise.checkpoint.RunDirectoryError
        A ``best.json`` that is not a JSON object (damaged, not UTF-8, nested too deeply).
    ValueError
        ``run_dir`` is not a path.

    Examples
    --------
    >>> res = load_run("out/whisker-run-20250101-120000")                  # doctest: +SKIP
    >>> res.stop_reason, res.best["f1"], res.best_genes["t"]               # doctest: +SKIP
    ('max_generations', 0.00137..., 2.10...)
    >>> [(g["generation"], g["best_fp"]) for g in res.generations]        # doctest: +SKIP
    [(0, 0.00216...), (1, 0.00216...)]
    """
    from whisker_opt.output import storage
    from whisker_opt.workflows import run_config

    run_dir = _checked_path(run_dir, "run_dir", "load_run")
    cfg = run_config(run_dir)
    best_path = run_dir / storage.BEST_JSON
    best = _read_best(best_path) if best_path.is_file() else {}
    return RunResults(
        run_dir=run_dir,
        config=cfg,
        best=best,
        evaluations=_table(run_dir / storage.EVALUATIONS_CSV),
        generations=_table(run_dir / storage.GENERATIONS_CSV),
        stop_reason=best.get("stop_reason"),
    )


def verify(run_dir: str | Path, preset: str = "fine", top: int = 3) -> list[dict[str, Any]]:
    """Re-evaluate a finished run's best designs at another fidelity preset: is the optimum real?

    Parameters
    ----------
    run_dir : str or Path
        A run directory with a checkpoint.
    preset : str
        Verification preset, a name of :data:`whisker_opt.experiment.fidelity.PRESETS`.
    top : int
        How many of the run's best feasible designs, 1 … 1000: pairwise at least
        ``optimiser.distinct_distance`` apart in normalised gene space, those of its report and
        ``best.json`` (:func:`whisker_opt.optimise.best.best_designs`).

    Returns
    -------
    list of dict
        One row per design, in the run's order: genes, ``f1_run``, ``f1_verify``,
        ``f1_change``, ``F_p_run``, ``F_p_verify``, ``rank_run``, ``rank_verify``, ``status``.
        Also written to ``run_dir/verify_<preset>.csv``.

    Raises
    ------
    whisker_opt.analysis.verify.VerifyError
        ``preset`` or ``top`` out of range, or no feasible design.
    FileNotFoundError
        ``run_dir`` has no ``config.yaml`` or no checkpoint.

    Examples
    --------
    >>> rows = verify("out/whisker-run-20250101-120000", preset="fine", top=1)  # doctest: +SKIP
    >>> rows[0]["f1_run"], rows[0]["f1_verify"]                          # doctest: +SKIP
    (0.00137..., 0.00142...)
    """
    from whisker_opt.analysis.verify import verify_run
    from whisker_opt.output.lock import RunDirLock

    run_dir = _checked_path(run_dir, "run_dir", "verify")
    with RunDirLock(run_dir, "verify"):
        return verify_run(run_dir, preset, top)


def vent_pressure(trim: float, a: float, table) -> float:
    """The vent pressure [MPa] after a trim Δ [mm] for a strike at contact ratio a, from a compensation map.

    Bilinear in (Δ, a) on the map ``whisker-opt compensate CONFIG --map`` writes (docs/physics.md §7):
    exact at the map's nodes; cells whose pressure sits at a bound (0: vent fully, or Q_i) enter
    with that clipped value.

    Parameters
    ----------
    trim : float
        Trim Δ [mm] within the map's trims.
    a : float
        Contact ratio within the map's contact ratios.
    table : CompensationMap, str or Path
        A loaded map (:meth:`CompensationMap.load`), a ``compensation_map.json`` or the results
        directory holding it.

    Returns
    -------
    float

    Raises
    ------
    whisker_opt.analysis.compensation_map.MapRangeError
        ``trim`` or ``a`` outside the map (one line: the argument, its value, the range).
    FileNotFoundError
        No map at the path.

    Examples
    --------
    >>> vent_pressure(3.7, 0.6, "out/compensate_default-compensate-20250101-120000")  # doctest: +SKIP
    0.0412...
    """
    from whisker_opt.compensation import vent_pressure as _vent_pressure

    return _vent_pressure(trim, a, table)


def __getattr__(name: str) -> Any:
    """``CompensationMap`` (:class:`whisker_opt.analysis.compensation_map.CompensationMap`), imported on first use."""
    if name == "CompensationMap":
        from whisker_opt.analysis.compensation_map import CompensationMap

        return CompensationMap
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
