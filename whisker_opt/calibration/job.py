"""The calibration job: a run file with a ``calibration`` section -> a fitted, named model on disk.

:func:`prepare` reads and checks everything a calibration needs (the section, the parameters against the
keys they name, every measurement file, the held-out names, the designs at the parameters' bounds)
without solving anything, so bad input is refused before a results folder is made; :func:`calibrate`
fits (:mod:`~whisker_opt.calibration.fit`) and writes the outputs (:mod:`~whisker_opt.calibration.report`).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from geometry.design import InvalidDesignError
import whisker_opt.wiring as wiring
from whisker_opt.calibration.fit import FitOutcome, Problem, Weighted, fit
from whisker_opt.calibration.forward import BeamSimulator, RestoreSearch, SceneSimulator
from whisker_opt.calibration.measurements import check_names, cut_column, read_measurements
from whisker_opt.calibration.parameters import ModelParameter, configure, resolve_parameters
from whisker_opt.calibration.report import format_summary, write_outputs
from whisker_opt.config.model import ConfigError, WhiskerConfig


#: The model evaluations of a stopped calibration, in its output folder.
JOURNAL = "calibration.partial.json"
#: The kind of study of :data:`JOURNAL`.
STUDY = "calibration"
#: Largest deflection a measurement may ask for [mm] (the range of ``scene.deflection``).
MAX_DELTA = 30.0


@dataclass(frozen=True)
class Prepared:
    """A checked calibration, ready to fit."""

    cfg: WhiskerConfig
    data: dict
    source_file: str
    parameters: tuple[ModelParameter, ...]
    fitted: tuple[Weighted, ...]
    held_out: tuple[Weighted, ...]

    @property
    def section(self):
        return self.cfg.calibration


@dataclass(frozen=True)
class CalibrationRun:
    """What :func:`calibrate` computed and wrote."""

    outcome: FitOutcome
    cfg: WhiskerConfig
    paths: dict
    summary: str


def prepare(cfg: WhiskerConfig, config_path: str | Path) -> Prepared:
    """Check a calibration run file and read its measurement files (nothing is solved).

    Parameters
    ----------
    cfg : WhiskerConfig
        The validated run file (with its ``--set`` settings).
    config_path : str or Path
        Its path: measurement files are read relative to its folder.

    Raises
    ------
    ConfigError
        No ``calibration`` section, a parameter that names no real-valued key or whose bounds leave its
        range, a held-out name that no observation has, nothing left to fit.
    whisker_opt.calibration.measurements.MeasurementError
        A malformed measurement file (one line naming the file, row and column).
    geometry.design.InvalidDesignError
        A parameter bound, or a measurement's trim, that makes the whisker impossible.
    """
    source = str(config_path)
    section = cfg.calibration
    if section is None:
        raise ConfigError(f"{source}: no calibration section: add `calibration:` with source, parameters and "
                          "measurements (docs/calibration.md)")
    for key, value in (("source", section.source.strip()), ("parameters", section.parameters),
                       ("measurements", section.measurements)):
        if not value:
            raise ConfigError(f"{source}: calibration.{key}: empty; a calibration needs a data source, at least one "
                              "parameter and at least one measurement file (docs/calibration.md)")
    data = cfg.model_dump(mode="json")
    data.pop("calibration")
    params = resolve_parameters(section, data, source)
    base = Path(config_path).parent
    weighted: list[Weighted] = []
    for i, m in enumerate(section.measurements):
        path = m.file if m.file.is_absolute() else base / m.file
        obs = read_measurements(path, m.kind, length_L=cfg.design.L, max_delta=MAX_DELTA, shown=str(path))
        weighted += [Weighted(ob, m.weight) for ob in obs]
    check_names(w.observation for w in weighted)
    names = [w.observation.name for w in weighted]
    for i, name in enumerate(section.holdout):
        if name not in names:
            close = difflib.get_close_matches(name, names, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f" (the names: {', '.join(names[:12])})"
            raise ConfigError(f"{source}: calibration.holdout[{i}]: no observation is named {name!r}{hint}")
    fitted = tuple(w for w in weighted if w.observation.name not in section.holdout)
    held = tuple(w for w in weighted if w.observation.name in section.holdout)
    if not fitted:
        raise ConfigError(f"{source}: calibration.holdout: every observation is held out; nothing is left to fit")
    _check_designs(data, params, weighted, source)
    wiring.warn_unread_keys(cfg, "calibrate")
    return Prepared(cfg, data, source, params, fitted, held)


def _check_designs(data: dict, params, weighted, source: str) -> None:
    """Every trim of the data must leave a whisker: at the parameters' starts, where a row that cuts too much is
    named with the range its column allows, then at each parameter's bounds (the others at their start)."""
    cuts = {}  # trim -> the first row and column that asks for it
    for w in weighted:
        for k in ("trim", "trim_ref"):
            if hasattr(w.observation, k):
                cuts.setdefault(float(getattr(w.observation, k)), (w.observation, k))
    start = np.array([p.start for p in params])
    cfg = configure(data, params, start, source)
    for trim, (ob, k) in sorted(cuts.items()):
        try:
            wiring.design_from_config(cfg, trim, trim_key="the trim of a measurement")
        except InvalidDesignError:
            if _is_whisker(cfg):  # else the design itself is wrong: named at a parameter's bound below
                raise ConfigError(_cut_message(ob, k, trim, cfg)) from None
    for k, p in enumerate(params):
        for end in (p.lower, p.upper):
            theta = start.copy()
            theta[k] = end
            cfg = configure(data, params, theta, source)
            for trim, (ob, col) in sorted(cuts.items()):
                try:
                    wiring.design_from_config(cfg, trim, trim_key="the trim of a measurement")
                except InvalidDesignError as exc:
                    bound = "lower" if end == p.lower else "upper"
                    raise ConfigError(f"{source}: calibration.parameters[{k}].{bound}: {p.path} = {end:g} leaves "
                                      f"no whisker at the trim {trim:g} mm of {ob.where}, column "
                                      f"{cut_column(ob, col)}: {exc}") from None


def _is_whisker(cfg) -> bool:
    try:
        wiring.design_from_config(cfg, 0.0)
        return True
    except InvalidDesignError:
        return False


def _cut_message(ob, attribute: str, trim: float, cfg) -> str:
    """A row whose trim (or length) leaves no whisker of the run file's design: its place, value and the range."""
    d = wiring.design_from_config(cfg, 0.0, validate=False)
    max_trim = d.L - d.l - d.tip_clearance  # L - trim - l >= tip_clearance
    col = cut_column(ob, attribute)
    why = f"(design.l = {d.l:g} and {d.tip_clearance:g} mm of solid tip, of design.L = {d.L:g})"
    if col.startswith("length"):
        return (f"{ob.where}, column {col}: {d.L - trim:g} is outside the allowed range [{d.L - max_trim:g}, "
                f"{d.L:g}] mm {why}")
    return f"{ob.where}, column {col}: {trim:g} is outside the allowed range [0, {max(max_trim, 0.0):g}] mm {why}"


def simulator(prepared: Prepared):
    """The model the section names: the FE scenes (to the largest δ of the data) or the beam model."""
    if prepared.section.model == "beam":
        return BeamSimulator()
    deltas = [w.observation.delta for w in prepared.fitted + prepared.held_out if hasattr(w.observation, "delta")]
    return SceneSimulator(deflection=max(deltas) if deltas else 1.0)


def journal_inputs(prepared: Prepared, sim=None) -> dict:
    """Everything a calibration's model evaluations depend on, as its journal (:data:`JOURNAL`) keeps it: the
    resolved config, the model (``sim``, default :func:`simulator`) and the observations."""
    sim = simulator(prepared) if sim is None else sim
    return {"config": prepared.cfg.model_dump(mode="json"), "model": type(sim).__name__,
            "observations": [repr(w) for w in prepared.fitted + prepared.held_out]}


def calibrate(prepared: Prepared, out: str | Path, sim=None, progress: bool = False) -> CalibrationRun:
    """Fit the prepared calibration and write ``calibration.json``, ``calibrated.yaml``, ``calibration.png``.

    Parameters
    ----------
    prepared : Prepared
        From :func:`prepare`.
    out : str or Path
        An existing, writable folder.
    sim : Simulator, optional
        Default :func:`simulator`.
    progress : bool
        A bar over the model evaluations on a terminal (a progress line each is logged either way).

    Returns
    -------
    CalibrationRun

    Notes
    -----
    The predictions of every model evaluation are kept in :data:`JOURNAL` in ``out`` until the
    outputs are written: the same calibration into the same folder after a kill reads them back
    (the fit then takes the same path) and ends with the same result.
    """
    from whisker_opt.experiment.fidelity import describe
    from whisker_opt.output.journal import StudyJournal

    sec = prepared.section
    sim = simulator(prepared) if sim is None else sim
    search = RestoreSearch(Q_max=sec.restore_Q_max, scan=sec.restore_scan, xtol=sec.restore_xtol)
    problem = Problem(prepared.data, prepared.parameters, prepared.fitted, sim, search, prepared.source_file)
    problem.journal = StudyJournal(Path(out), JOURNAL, STUDY, journal_inputs(prepared, sim))
    try:
        outcome = fit(problem, prepared.held_out, max_evaluations=sec.max_evaluations, diff_step=sec.diff_step,
                      tolerance=sec.tolerance, progress=progress)
    finally:
        problem.journal.flush()
    cfg = problem.config(outcome.values)
    fidelity = describe(prepared.cfg.fidelity, prepared.cfg.scene.calibration) if sec.model == "fe" else None
    paths = write_outputs(Path(out), cfg, outcome, source=sec.source, config=prepared.source_file, model=sec.model,
                          fidelity=fidelity)
    problem.journal.finish()
    return CalibrationRun(outcome, cfg, paths, format_summary(outcome, source=sec.source))
