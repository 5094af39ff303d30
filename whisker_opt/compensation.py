"""Morphological compensation as a job: the FE compensation table Δ → Q at one contact ratio, the
beam-vs-FE sensitivity comparison, the full map Q(Δ, a) over trims and contact ratios, and the
lookup a controller calls on a stored map.

The measures and the searches live in :mod:`whisker_opt.analysis.compensation` (one trim) and
:mod:`whisker_opt.analysis.compensation_map` (the grid Δ × a and its bilinear lookup,
:class:`CompensationMap`); :mod:`whisker_opt.output.compensation` writes them. Here: the FE
responses of those searches, the progress of the long jobs, the map's warm starts of the FE
pressurise step (:class:`WarmPressurise`) and :func:`vent_pressure`. The formulas are in
docs/physics.md §7.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import whisker_opt.wiring as wiring
from whisker_opt.analysis.compensation_map import CompensationMap, MapRangeError
from whisker_opt.config.model import ConfigError, WhiskerConfig
from whisker_opt.workflows import fidelity_of, record_config

logger = logging.getLogger(__name__)

__all__ = ["CompensationMap", "MapRangeError", "WarmPressurise", "compensate", "compensate_map", "format_table",
           "vent_pressure"]


def scene_response(cfg: WhiskerConfig, runner):
    """``response(design, Q, deltas) -> ε(δ)``: the config's scene at ``cfg.scene.contact_ratio``.

    ``runner`` is a :class:`whisker_opt.experiment.scene.SceneRunner` (its memo shares scenes between calls).
    """
    def response(d, Q, deltas):
        res = runner.run(wiring.scene_spec(cfg, d, float(Q)))
        return res.curve(np.asarray(deltas, dtype=float), cfg.scene.gauge_variant)

    return response


def scene_sensitivity(cfg: WhiskerConfig, runner, delta_ref: float = 1.0):
    """``sensitivity(design, a, Q) -> ε(δ_ref)/δ_ref`` [1/mm] from the config's scene at contact ratio a.

    The scene pushes at x = a·L_Q of the pressurised whisker; for a < 1 it places the
    contact node ring there itself (:func:`whisker_opt.experiment.scene.run_scene`, swept meshes).
    """
    import dataclasses

    def sensitivity(d, a, Q):
        spec = dataclasses.replace(wiring.scene_spec(cfg, d, float(Q)), contact_ratio=float(a))
        eps = runner.run(spec).curve(np.array([delta_ref]), cfg.scene.gauge_variant)
        return float(eps[0]) / delta_ref

    return sensitivity


@dataclass
class Compensation:
    """What :func:`compensate` computed and wrote."""

    design: Any
    table: Any
    paths: dict
    table_seconds: float
    comparison: Any = None
    comparison_seconds: float = float("nan")
    extra: dict = field(default_factory=dict)


def format_table(table, resolution: float = float("nan")) -> str:
    """The compensation table as the terminal shows it: per trim the vent pressure Q and the beam model's, the
    recovery rate and the two gaps it is the ratio of, and a note (a Q at its bound, a trim effect below the
    preset's f1 ``resolution`` [calibrated strain]: :func:`whisker_opt.analysis.compensation.recovery`, the
    same rule as the wall-law spread). The file ``compensation_table.csv`` keeps every column.

    Parameters
    ----------
    table : whisker_opt.analysis.compensation.CompensationTable
    resolution : float
        The preset's f1 resolution in the table's (calibrated) strain; NaN shows every rate.
    """
    from whisker_opt.analysis.compensation import recovery

    head = (f"{'trim [mm]':>9} {'Q [MPa]':>9} {'Q beam [MPa]':>12} {'recovery [%]':>12} "
            f"{'trim effect':>11} {'vent gap':>9}  note")
    lines = [head, f"{'':>45}{'(calibrated strain)':>21}"]
    for r in table.rows:
        rec = recovery(r.eps_target, r.eps_broken, r.eps_compensated, table.scalar, resolution)
        notes = []
        if r.trim == 0.0:
            notes.append("intact: nothing to recover")
        elif not rec.resolved:
            notes.append(f"trim effect below resolution {rec.resolution:.2g}")
        if r.at_bound and r.trim > 0:
            notes.append(f"Q at its bound ({'0, vented fully' if r.at_bound == 'lower' else 'Q_i, not vented'})")
        rate = f"{rec.rate:.1f}" if rec.resolved and math.isfinite(rec.rate) and r.trim > 0 else "-"
        lines.append(f"{r.trim:>9g} {r.Q:>9.4f} {r.Q_analytic:>12.4f} {rate:>12} {rec.trim_effect:>11.3g} "
                     f"{rec.vent_gap:>9.3g}  {'; '.join(notes)}")
    return "\n".join(lines)


class _TableProgress:
    """Progress of a compensation table, seen through its response function: a row per trim.

    The table solves the intact response first, then each trim's responses in increasing
    trim order (the Δ = 0 row needs none); a call at a new trim means the rows before it are done.
    """

    def __init__(self, response, trims: list[float], enabled: bool) -> None:
        from whisker_opt.output.progress import Progress

        self.response, self.trims = response, trims
        self.current: float | None = None
        self.done = 0
        self.bar = Progress(len(trims), "compensate: table", "row", enabled)

    def _advance(self, done: int) -> None:
        if done > self.done:
            self.bar.step(f"(trim Δ up to {self.trims[done - 1]:g} mm)", n=done - self.done)
        self.done = max(done, self.done)

    def __call__(self, d, Q, deltas):
        tr = float(d.trim)
        if tr > 0.0 and tr != self.current:
            self.current = tr
            self._advance(sum(1 for t in self.trims if t < tr - 1e-9))
            logger.info("compensate: row %d/%d, trim Δ = %g mm", self.done + 1, len(self.trims), tr)
        return self.response(d, Q, deltas)

    def close(self, finished: bool) -> None:
        if finished:
            self._advance(len(self.trims))
        self.bar.close()


def _table_trims(trim_max: float, step: float) -> list[float]:
    """The trims of :func:`whisker_opt.analysis.compensation.compensation_table`: 0, step, …, trim_max."""
    n = int(math.floor(trim_max / step + 1e-9))
    trims = [i * step for i in range(n + 1)]
    return trims + [trim_max] if trim_max - trims[-1] > 1e-9 else trims


def compensate(cfg: WhiskerConfig, out: Path, step: float = 1.0, delta_ref: float = 1.0,
               compare_a=(0.5, 0.75, 1.0), compare_Q=(0.0, 0.1, 0.2), compare: bool = True,
               source: str = "config", progress: bool = True) -> Compensation:
    """FE compensation table Δ → vent pressure Q (with the beam model's Q beside it) and the
    beam-vs-FE sensitivity comparison.

    Writes ``compensation_table.{csv,json,png}`` and, when ``compare``,
    ``sensitivity_comparison.{csv,png}``. The FE deflection samples are δ_max/10 … δ_max
    (10 points), with ``delta_ref`` added if missing. Plot titles name the fidelity preset.
    A tqdm bar per phase (rows of the table, cells of the comparison) shows on a terminal
    unless ``progress`` is False; a log line per row and per cell is written either way.

    Raises
    ------
    ConfigError
        ``scene.Q_i`` is not positive, or an argument is out of range; the
        message starts with ``source``.
    """
    from whisker_opt.analysis.beam import BeamModel
    from whisker_opt.analysis.compensation import compare_sensitivity, compensation_table
    from whisker_opt.output.compensation import write_comparison, write_table
    from whisker_opt.experiment.scene import SceneRunner

    opt = wiring.optimiser_of(cfg)
    if cfg.scene.Q_i <= 0:
        raise ConfigError(f"{source}: scene.Q_i: the intact pressure Q_i must be > 0 for compensation (got {cfg.scene.Q_i})")
    wiring.warn_unread_keys(cfg, "compensate")
    dref = float(delta_ref)
    if not 0.0 < dref <= cfg.scene.deflection:
        raise ConfigError(f"--delta-ref {dref:g}: must lie in (0, scene.deflection = {cfg.scene.deflection:g}] mm")
    bad_a = [a for a in compare_a if not 0.0 < a <= 1.0]
    bad_q = [q for q in compare_Q if q < 0.0]
    if bad_a or bad_q:
        raise ConfigError(f"--compare-a must lie in (0, 1] (got {bad_a}), --compare-Q must be >= 0 (got {bad_q})")
    runner = SceneRunner()
    design = wiring.design_from_config(cfg, 0.0)
    model = BeamModel(calibration=cfg.scene.calibration)
    deltas = np.linspace(cfg.scene.deflection / 10, cfg.scene.deflection, 10)
    if not np.any(np.abs(deltas - dref) <= 1e-9):
        deltas = np.sort(np.append(deltas, dref))
    out = Path(out)
    fidelity = fidelity_of(cfg)
    t0 = time.perf_counter()
    rows = _TableProgress(scene_response(cfg, runner), _table_trims(float(opt.trim), float(step)), progress)
    finished = False
    try:
        table = compensation_table(design, cfg.scene.Q_i, opt.trim, rows, step=step, deltas=deltas, method="root",
                                   analytic_model=model)
        finished = True
    finally:
        rows.close(finished)
    for r in table.rows:
        logger.info("compensate: trim Δ = %g mm: Q = %.6g MPa%s, recovery %.4g %%, analytic Q = %.6g MPa", r.trim,
                    r.Q, f" (at its bound, {'0' if r.at_bound == 'lower' else 'Q_i'})" if r.at_bound and r.trim > 0
                    else "", r.recovery_rate, r.Q_analytic)
    forces = table_forces(cfg, runner, design, table)
    record_config(out, cfg, "compensate")  # only once the table is solved: a failed solve leaves no folder
    paths = write_table(out, table, delta_ref=dref, fidelity=fidelity, forces=forces)
    result = Compensation(design, table, paths, time.perf_counter() - t0)
    if compare:
        t0 = time.perf_counter()
        cells = _CellProgress(scene_sensitivity(cfg, runner, dref), len(compare_a) * len(compare_Q), progress)
        try:
            result.comparison = compare_sensitivity(design, cells, a_values=compare_a, Q_values=compare_Q, model=model)
        finally:
            cells.bar.close()
        cpaths = write_comparison(out, result.comparison, fidelity=fidelity, delta_ref=dref)
        paths.update({f"comparison_{k}": v for k, v in cpaths.items()})
        result.comparison_seconds = time.perf_counter() - t0
    return result


def table_forces(cfg: WhiskerConfig, runner, design, table) -> list[dict]:
    """Contact forces of each row of a compensation table at its deflections [N], and the secant
    stiffness over the first solved step, k = F(δ₁)/δ₁ [N/mm] (:attr:`SceneResult.contact_stiffness`).

    Per row: ``o`` the intact whisker at Q_i, ``b`` the trimmed one at Q_i, ``c`` the trimmed one at the
    row's Q; from the runner's memo (the table solved them) or solved now.

    Returns
    -------
    list of dict
        ``{"force_<w>_N": list, "stiffness_<w>_N_per_mm": float}`` for w in o, b, c.
    """
    deltas = np.asarray(table.deltas, dtype=float)
    out = []
    for r in table.rows:
        row = {}
        for w, d, Q in (("o", design.trimmed(0.0), table.Q_i), ("b", design.trimmed(r.trim), table.Q_i),
                        ("c", design.trimmed(r.trim), r.Q)):
            res = runner.run(wiring.scene_spec(cfg, d, float(Q)))
            row[f"force_{w}_N"] = [float(v) for v in res.force(deltas)]
            row[f"stiffness_{w}_N_per_mm"] = res.contact_stiffness
        out.append(row)
    return out


class _CellProgress:
    """``sensitivity`` with a tqdm bar over the ``n_cells`` cells (a × Q) and a log line per cell."""

    def __init__(self, sensitivity, n_cells: int, enabled: bool) -> None:
        from whisker_opt.output.progress import Progress

        self.sensitivity, self.n_cells, self.done = sensitivity, n_cells, 0
        self.bar = Progress(n_cells, "compensate: beam vs FE", "cell", enabled)

    def __call__(self, d, a, Q):
        value = self.sensitivity(d, a, Q)
        self.done += 1
        self.bar.step(f"(a = {a:g}, Q = {Q:g} MPa)")
        logger.info("compensate: sensitivity cell %d/%d, a = %g, Q = %g MPa: FE ε/δ = %.6g 1/mm", self.done,
                    self.n_cells, a, Q, value)
        return value


# ----------------------------------------------------------------------------- the map Q(Δ, a)
class WarmPressurise:
    """A :class:`~whisker_opt.experiment.scene.SceneRunner` ``pressurise_with`` hook for grids of scenes.

    Two savings, both on the pressurise step (:func:`whisker_opt.experiment.scene.pressurise`),
    which the contact ratio does not enter:

    - *shared*: a scene on the same mesh object with the same spec but another contact ratio
      takes the stored pressurised state as it is (bit-identical to solving it again);
    - *Newton start* (``newton_start``): a new pressure on a mesh with the same nodes and
      elements starts from the stored state of the nearest pressure, in one step from that
      pressure (``pressurise(..., start=(Q0, state))``): of the same design if one is stored,
      else of the nearest trim of the same design (the map's next row); it falls back to the
      cold path when that solve fails. The answer equals the cold one within the Newton
      tolerances (rtol 1e-8), not bit for bit.

    Attributes
    ----------
    counts : dict
        'shared', 'newton_start', 'cold', 'fallback' calls so far.
    """

    def __init__(self, newton_start: bool = True, keep: int = 64) -> None:
        self.newton_start = newton_start
        self.keep = keep
        self._done: dict[tuple, tuple] = {}
        self._states: dict[tuple, list] = {}
        self._topologies: dict[int, tuple] = {}
        self.counts = {"shared": 0, "newton_start": 0, "cold": 0, "fallback": 0}

    def _topology(self, wm) -> tuple:
        """(nodes, elements, hash of the connectivity, base and cavity) of ``wm`` (kept per mesh object)."""
        hit = self._topologies.get(id(wm))
        if hit is None or hit[0] is not wm:
            m = wm.mesh
            sig = hash((np.asarray(m.cells).tobytes(), np.asarray(wm.node_sets["base"]).tobytes(),
                        np.asarray(wm.face_sets["cavity"]).tobytes()))
            hit = (wm, (m.n_nodes, m.n_elements, sig))
            if len(self._topologies) >= self.keep:
                self._topologies.pop(next(iter(self._topologies)))
            self._topologies[id(wm)] = hit
        return hit[1]

    def __call__(self, spec, wm):
        import dataclasses

        from fem.newton import SolveFailed
        from whisker_opt.experiment.scene import pressurise

        if spec.Q <= 0:
            return pressurise(spec, wm)
        key = (id(wm), dataclasses.replace(spec, contact_ratio=1.0))
        hit = self._done.get(key)
        if hit is not None and hit[0] is wm:
            self.counts["shared"] += 1
            return hit[1]
        # states of meshes with the same nodes and elements and the same spec but Q, a and the trim
        family = (self._topology(wm), dataclasses.replace(spec, Q=0.0, contact_ratio=1.0,
                                                          design=spec.design.trimmed(0.0)))
        trim = spec.design.trim
        near = min(self._states.get(family, ()), key=lambda s: (abs(s[0] - trim), abs(s[1] - spec.Q)), default=None)
        near = None if near is None else near[1:]
        pre = None
        if self.newton_start and near is not None:
            try:
                pre = pressurise(spec, wm, start=near)
                self.counts["newton_start"] += 1
            except SolveFailed as exc:
                logger.debug("warm pressurise from Q = %g to %g failed (%s); solving from 0", near[0], spec.Q, exc)
                self.counts["fallback"] += 1
        if pre is None:
            pre = pressurise(spec, wm)
            self.counts["cold"] += 1
        if len(self._done) >= self.keep:
            self._done.pop(next(iter(self._done)))
        self._done[key] = (wm, pre)
        states = self._states.setdefault(family, [])
        states.append((float(trim), float(spec.Q), pre.state))
        del states[:-16]
        return pre


def scene_map_response(cfg: WhiskerConfig, runner):
    """``response(design, Q, a, deltas) -> ε(δ)``: the config's scene at contact ratio a (the map's response)."""
    import dataclasses

    def response(d, Q, a, deltas):
        spec = dataclasses.replace(wiring.scene_spec(cfg, d, float(Q)), contact_ratio=float(a))
        response.calls += 1
        return runner.run(spec).curve(np.asarray(deltas, dtype=float), cfg.scene.gauge_variant)

    response.calls = 0
    return response


#: Contact ratios of ``whisker-opt compensate --map`` unless ``--a`` is given.
MAP_CONTACT_RATIOS = (0.45, 0.55, 0.7, 0.85, 1.0)


@dataclass
class MapRun:
    """What :func:`compensate_map` computed and wrote."""

    map: Any
    paths: dict
    seconds: float
    pressurise_counts: dict = field(default_factory=dict)
    #: Scenes solved (responses asked less the runner's memo hits).
    scenes: int = 0


class _MapProgress:
    """``on_cell`` of :func:`whisker_opt.analysis.compensation_map.solve_map`: a tqdm bar over the cells, a log line each."""

    def __init__(self, n_cells: int, enabled: bool) -> None:
        from whisker_opt.output.progress import Progress

        self.n_cells, self.done = n_cells, 0
        self.bar = Progress(n_cells, "compensate: map", "cell", enabled)

    def __call__(self, trim: float, a: float, cell: dict) -> None:
        self.done += 1
        self.bar.step(f"(trim Δ = {trim:g} mm, a = {a:g})")
        logger.info("compensate: map cell %d/%d, trim Δ = %g mm, a = %g: Q = %.6g MPa%s, recovery %.4g %%",
                    self.done, self.n_cells, trim, a, cell["Q"],
                    f" (at its bound, {cell['at_bound']})" if cell["at_bound"] and trim > 0 else "",
                    cell["recovery_rate"])


#: The finished cells of a stopped map, in its output folder (:class:`whisker_opt.output.journal.StudyJournal`).
MAP_JOURNAL = "compensation_map.partial.json"
#: The kind of study of :data:`MAP_JOURNAL`.
MAP_STUDY = "compensation_map"


def map_inputs(cfg: WhiskerConfig, step: float = 1.0, a_values=MAP_CONTACT_RATIOS, warm: bool = True) -> dict:
    """Everything a map depends on, as its journal keeps it: the resolved config, the trims, the contact ratios,
    the deflections and ``warm``. A ConfigError names ``--a`` when a contact ratio is out of (0, 1]."""
    from whisker_opt.analysis.compensation_map import check_contact_ratios, map_trims

    try:
        a = check_contact_ratios(a_values)
    except ValueError as exc:
        raise ConfigError(f"--a: {exc}") from None
    deltas = np.linspace(cfg.scene.deflection / 10, cfg.scene.deflection, 10)
    return {"config": cfg.model_dump(mode="json"), "trims": map_trims(float(wiring.optimiser_of(cfg).trim),
                                                                       float(step)),
            "a": a.tolist(), "deltas": deltas.tolist(), "warm": bool(warm)}


def compensate_map(cfg: WhiskerConfig, out: Path | None, step: float = 1.0, a_values=MAP_CONTACT_RATIOS,
                   warm: bool = True, source: str = "config", progress: bool = True, runner=None) -> MapRun:
    """The compensation map Q(Δ, a), Δ = 0, step, …, ``optimiser.trim`` and a in ``a_values``.

    Each cell is the table's compensation (``method='root'`` on [0, Q_i], δ = δ_max/10 … δ_max)
    with the scene at contact ratio a (:func:`whisker_opt.analysis.compensation_map.solve_map`).
    ``warm``: trim by trim through one runner whose pressurise step is a :class:`WarmPressurise`;
    otherwise cold scenes contact ratio by contact ratio (the independent reference). Writes
    ``compensation_map.{csv,json,png}`` into ``out`` unless it is None. Each solved cell is kept in
    :data:`MAP_JOURNAL` in ``out`` until the map is written: the same command into the same folder
    after a kill reads those cells back and solves only the rest (with ``warm``, the cells solved
    after the stop start their Newton solves cold, so they equal the uninterrupted map's within the
    Newton tolerances; otherwise bit for bit).

    Raises
    ------
    ConfigError
        ``scene.Q_i`` not positive, or a contact ratio out of (0, 1] (the message starts with ``source``).
    """
    from whisker_opt.analysis.compensation_map import solve_map
    from whisker_opt.experiment.scene import SceneRunner
    from whisker_opt.output.compensation import write_map

    if cfg.scene.Q_i <= 0:
        raise ConfigError(f"{source}: scene.Q_i: the intact pressure Q_i must be > 0 for compensation (got {cfg.scene.Q_i})")
    inputs = map_inputs(cfg, step, a_values, warm)
    wiring.warn_unread_keys(cfg, "compensate")
    trims, a, deltas = inputs["trims"], np.asarray(inputs["a"], dtype=float), np.asarray(inputs["deltas"])
    hook = WarmPressurise() if warm else None
    runner = SceneRunner(memo_size=1024, pressurise_with=hook) if runner is None else runner
    design = wiring.design_from_config(cfg, 0.0)
    fidelity = fidelity_of(cfg)
    cells = _MapProgress(len(trims) * a.size, progress)
    response = scene_map_response(cfg, runner)
    hits0 = getattr(runner, "memo_hits", 0)
    journal = None
    if out is not None:
        from whisker_opt.output.journal import StudyJournal

        record_config(out, cfg, "compensate")
        journal = StudyJournal(Path(out), MAP_JOURNAL, MAP_STUDY, inputs)
    t0 = time.perf_counter()
    try:
        cmap = solve_map(design, cfg.scene.Q_i, trims, a, response, deltas=deltas,
                         by="trim" if warm else "a", fidelity=fidelity, on_cell=cells, journal=journal)
    finally:
        cells.bar.close()
        if journal is not None:
            journal.flush()
    seconds = time.perf_counter() - t0
    paths = write_map(out, cmap) if out is not None else {}
    if journal is not None:
        journal.finish()
    return MapRun(cmap, paths, seconds, dict(hook.counts) if hook is not None else {},
                  response.calls - (getattr(runner, "memo_hits", 0) - hits0))


def vent_pressure(trim: float, a: float, table) -> float:
    """The vent pressure [MPa] a controller sets after a trim Δ [mm], for a strike at contact ratio a.

    Bilinear in (Δ, a) on a compensation map (docs/physics.md §7): exact at the map's nodes,
    cells at a bound entering with their clipped Q (0 or Q_i).

    Parameters
    ----------
    trim : float
        Trim Δ [mm], within the map's trims.
    a : float
        Contact ratio [-], within the map's contact ratios.
    table : CompensationMap, str or Path
        A loaded map, a ``compensation_map.json`` or the results directory holding it.

    Raises
    ------
    whisker_opt.analysis.compensation_map.MapRangeError
        ``trim`` or ``a`` outside the map (one line: argument, value, range), or an unreadable file.
    FileNotFoundError
        No map at the path.

    Examples
    --------
    >>> vent_pressure(3.7, 0.6, "results/compensate_default-map")            # doctest: +SKIP
    0.0412...
    """
    cmap = table if isinstance(table, CompensationMap) else CompensationMap.load(table)
    return cmap.vent_pressure(trim, a)

