"""Robustness of designs to fabrication tolerances: from a run directory or a config to a table.

For each design (a run's best feasible designs, or the design of a config) the tolerances of
the config's ``robustness`` section are propagated to two figures (docs/physics.md §10):

- f1 = mean |ε_i − ε_c|, the intact whisker at Q_i against the trimmed, vented one (§4);
- the recovery rate (§7, :func:`whisker_opt.analysis.compensation.curve_measures`), which also
  needs the trimmed whisker left at Q_i (ε_u, the ``trimmed_uncompensated`` scene of
  :func:`whisker_opt.wiring.design_scene_specs`, the curve ``finish_best`` plots). It is therefore not
  a measure of :mod:`whisker_opt.experiment.measures`: those read the outcome of one evaluation, whose two
  scenes (intact at Q_i, trimmed and vented) hold no ε_u; this study solves the third scene itself.

One deviated design is three FE scenes (intact, trimmed vented, trimmed at Q_i), solved by a
:class:`whisker_opt.experiment.scene.SceneRunner` (the two trimmed scenes share their mesh). The
deviation of the calibration factor needs no solve: every reading is proportional to ξ, so f1
scales with it and the recovery rate does not change (:func:`whisker_opt.wiring.deviated`).
The estimators are those of :mod:`whisker_opt.optimise.robust`; the files and the plot are
written by :mod:`whisker_opt.output.robustness`.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

import whisker_opt.wiring as wiring
from whisker_opt.config.model import ConfigError, WhiskerConfig

logger = logging.getLogger(__name__)

#: The figures of a deviated design, in the order of the point function's outputs.
OUTPUTS: tuple[str, ...] = ("f1", "recovery_rate")
#: +1: a larger value is worse (f1); −1: a smaller one is (the recovery rate).
WORSE: tuple[float, ...] = (1.0, -1.0)
METHODS: tuple[str, ...] = ("expansion", "sample")
#: The deviated designs solved by a stopped study, in its output folder.
JOURNAL = "robustness.partial.json"
#: The kind of study of :data:`JOURNAL`.
STUDY = "robustness"


class RobustnessError(ValueError):
    """Unusable inputs of a robustness study (a user error: the message names the field)."""


@dataclass(frozen=True)
class StudyDesign:
    """A design to study: a label, its genome and, from a run, the f1 the run gave it."""

    label: str
    genes: dict
    f1_run: float | None = None


@dataclass
class DesignRobustness:
    """The result of one design: the estimates of each method, their times and FE solves.

    Attributes
    ----------
    design : StudyDesign
    nominal : dict of str -> float
        f1 and the recovery rate of the nominal design.
    estimates : dict of str -> ExpansionEstimate or SampleEstimate
        By method name.
    seconds : dict of str -> float
        Wall time per method (the nominal design's solve counted with the first method).
    solves : dict of str -> int
        Deviated designs solved per method (3 scenes each; points that differ only in ξ share one).
    failures : list of str
        Deviated designs that did not solve (their outputs are NaN).
    """

    design: StudyDesign
    nominal: dict
    estimates: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    solves: dict = field(default_factory=dict)
    failures: list = field(default_factory=list)


class DesignPoints:
    """``f(deviation) -> [f1, recovery rate]`` of one design, with a memo of the solved designs.

    Parameters
    ----------
    cfg : WhiskerConfig
    genes : mapping
        The nominal genome.
    runner : whisker_opt.experiment.scene.SceneRunner
    """

    def __init__(self, cfg: WhiskerConfig, genes: Mapping[str, float], runner, journal=None) -> None:
        self.cfg, self.genes, self.runner = cfg, {k: float(v) for k, v in genes.items()}, runner
        self.journal = journal
        self.ev = wiring.nominal_evaluator(cfg)
        self.delta = self.ev.samples()
        self.scalar = cfg.robustness.recovery_scalar
        self.curves: dict[tuple, Any] = {}
        self.failures: list[str] = []

    @property
    def solves(self) -> int:
        """Deviated designs solved (or attempted) so far, the nominal one included."""
        return len(self.curves)

    def curves_at(self, x, strict: bool = False):
        """(ε_i, ε_u, ε_c) of the design deviated by ``x`` at the nominal ξ, or None when it failed.

        ``strict``: a failure raises (the nominal design) instead of being recorded.
        """
        from whisker_opt.config.robustness import TOLERANCE_KEYS

        key = tuple(float(v) for v in x[:-1])
        if key in self.curves:
            return self.curves[key]
        stored_key = f"{sorted(self.genes.items())!r} {key!r}"
        stored = self.journal.get(stored_key) if self.journal is not None else None
        if stored is not None:  # solved before the study was stopped
            if "failure" in stored:
                self.failures.append(stored["failure"])
                logger.warning("robustness: %s", stored["failure"])
            value = None if "failure" in stored else tuple(np.asarray(c, dtype=float) for c in stored["curves"])
            self.curves[key] = value
            return value
        ev, genes, _ = wiring.deviated(self.ev, self.genes, x)
        variant = self.cfg.scene.gauge_variant
        try:
            intact, trimmed = ev.specs(genes)
            scenes = (intact, replace(trimmed, Q=intact.Q), trimmed)
            value = tuple(self.runner.run(spec).curve(self.delta, variant) for spec in scenes)
        except Exception as exc:  # noqa: BLE001 - a deviated design that cannot be solved is a finding, not a crash
            if strict:
                raise
            where = ", ".join(f"{n}{v:+.4g}" for n, v in zip(TOLERANCE_KEYS, x) if v != 0.0)
            text = f"deviated design ({where}): {type(exc).__name__}: {' '.join(str(exc).split())}"
            logger.warning("robustness: %s", text)
            self.failures.append(text)
            value = None
        self.curves[key] = value
        if self.journal is not None:
            self.journal.record(stored_key, {"failure": self.failures[-1]} if value is None else
                                {"curves": [np.asarray(c, dtype=float).tolist() for c in value]})
        return value

    def __call__(self, x) -> list[float]:
        from whisker_opt.analysis.compensation import curve_measures
        from whisker_opt.experiment import objective

        x = np.asarray(x, dtype=float)
        curves = self.curves_at(x)
        if curves is None:
            return [math.nan, math.nan]
        eps_i, eps_u, eps_c = curves
        scale = wiring.deviated(self.ev, self.genes, x)[2]
        return [objective.f1(eps_i, eps_c) * scale, curve_measures(eps_i, eps_u, eps_c, self.scalar)[0]]


# ----------------------------------------------------------------------------- which designs
def config_designs(cfg: WhiskerConfig, genomes: Sequence[Sequence[float]] = (), source: str = "config") -> list:
    """The design of a config, or the given genomes, each over the config's genome
    (:func:`whisker_opt.genes.run_genome`: α, l, t, Q_i and the genes ``optimiser.genes`` adds).

    The config's own design takes each gene's value from its key (α, l, t and an added design gene from
    ``design``, an added material gene from ``material``) and Q_i from ``scene.Q_i``; a given genome lists
    the genes' values in the genome's order.

    Raises
    ------
    ConfigError
        ``scene.Q_i`` is not positive (the recovery rate needs the trimmed whisker at Q_i) when the
        config's own design is studied.
    RobustnessError
        A given genome's length is not the genome's.
    """
    from whisker_opt.genes import config_genome, genes_dict, run_genome

    names = run_genome(cfg)
    for i, g in enumerate(genomes, start=1):
        if len(g) != len(names):
            raise RobustnessError(f"robustness: genome {i}: {len(g)} values given, the genome of {source} has "
                                  f"{len(names)} ({', '.join(names)}, in that order)")
    if genomes:
        return [StudyDesign(f"genes {i}", genes_dict(g, names)) for i, g in enumerate(genomes, start=1)]
    if cfg.scene.Q_i <= 0:
        raise ConfigError(f"{source}: scene.Q_i: must be > 0 for a robustness study (got {cfg.scene.Q_i:g}; the "
                          "recovery rate needs the trimmed whisker left at Q_i)")
    return [StudyDesign("config", config_genome(cfg))]


def run_designs(run_dir: Path, top: int) -> list:
    """The ``top`` best distinct feasible designs of a run (:func:`whisker_opt.optimise.best.run_best_designs`;
    a run without a checkpoint: its ``best.json``).

    Raises
    ------
    RobustnessError
        The run has no feasible design.
    """
    import json

    from whisker_opt.optimise.best import run_best_designs
    from whisker_opt.optimise.runner import load_run
    from whisker_opt.output.storage import BEST_JSON

    run_dir = Path(run_dir)
    state, opt, _, _ = load_run(run_dir)
    if state is not None:
        out = [StudyDesign(f"best {d['rank']}", dict(d["genes"]), float(d["f1"]))
               for d in run_best_designs(state, opt, int(top))]
    else:
        try:
            best = json.loads((run_dir / BEST_JSON).read_text())
        except (OSError, ValueError, RecursionError):
            best = {}
        ok = isinstance(best, dict) and best.get("feasible") and isinstance(best.get("genes"), dict)
        out = [StudyDesign("best", {k: float(v) for k, v in best["genes"].items()}, best.get("f1"))] if ok else []
    if not out:
        raise RobustnessError(f"robustness: {run_dir} has no feasible design in its evaluations or best.json")
    return out


# ----------------------------------------------------------------------------- the study
def check_methods(methods: Sequence[str]) -> tuple[str, ...]:
    """The methods to run (``both`` is both), each one of :data:`METHODS`."""
    out: list[str] = []
    for m in methods:
        names = METHODS if m == "both" else (m,)
        for n in names:
            if n not in METHODS:
                raise RobustnessError(f"robustness: method={m!r} is not one of 'expansion', 'sample', 'both'")
            if n not in out:
                out.append(n)
    return tuple(out)


def check_sample_size(cfg: WhiskerConfig, methods: Sequence[str]) -> None:
    """Refuse a sample too small for the sensitivities of the sample method.

    The sensitivities are the slopes of the least-squares fit y ≈ b0 + Σ_j b_j x_j over the
    sample (:func:`whisker_opt.optimise.robust.linear_fit_slopes`): d slopes of the d non-zero
    tolerances and an intercept need at least d + 1 points.

    Parameters
    ----------
    cfg : WhiskerConfig
    methods : sequence of str
        The methods to run (nothing is checked without 'sample').

    Raises
    ------
    RobustnessError
        ``robustness.sample.n`` below d + 1 (one line naming the field, the value and the minimum).
    """
    if "sample" not in check_methods(methods):
        return
    live = sum(1 for h in cfg.robustness.tolerances.half_widths() if h > 0)
    n = cfg.robustness.sample.n
    if n < live + 1:
        raise RobustnessError(f"robustness.sample.n (--samples): {n} is too few for the sensitivities to the {live} "
                              f"non-zero tolerances (a linear fit of {live} slopes and an intercept); the minimum is "
                              f"{live + 1}")


def _expected_points(method: str, cfg: WhiskerConfig, half) -> int:
    """Point evaluations of one design by ``method``: the sample's size, or at most 2d + 1 and two corners."""
    if method == "sample":
        return int(cfg.robustness.sample.n)
    return 2 * sum(1 for h in half if h > 0) + 1 + len(OUTPUTS)


def study_design(cfg: WhiskerConfig, design: StudyDesign, methods: Sequence[str] = ("expansion",),
                 runner=None, progress: bool = False, journal=None) -> DesignRobustness:
    """Propagate the tolerances of ``cfg.robustness`` to f1 and the recovery rate of one design.

    Parameters
    ----------
    cfg : WhiskerConfig
    design : StudyDesign
    methods : sequence of {'expansion', 'sample'}
    runner : SceneRunner, optional
    progress : bool
        Passed on to the progress lines, one per evaluated point (deviated design) of each method
        (:class:`whisker_opt.output.progress.Progress`, log lines only).
    journal : whisker_opt.output.journal.StudyJournal, optional
        The deviated designs solved before the study was stopped (read back, not solved again);
        each newly solved one is recorded there.

    Returns
    -------
    DesignRobustness

    Raises
    ------
    Exception
        The nominal design's scenes fail (a solve or a mesh): its own exception, as ``simulate``.
    """
    from whisker_opt.optimise.robust import draw, expansion_estimate, sample_estimate
    from whisker_opt.experiment.scene import SceneRunner
    from whisker_opt.output.progress import Progress

    rob = cfg.robustness
    half = wiring.tolerance_half_widths(cfg)
    points = DesignPoints(cfg, design.genes, runner or SceneRunner(), journal)
    t0 = time.perf_counter()
    zero = np.zeros(len(half))
    points.curves_at(zero, strict=True)
    nominal = dict(zip(OUTPUTS, points(zero)))
    res = DesignRobustness(design, nominal)
    for method in check_methods(methods):
        before = points.solves
        logger.info("robustness: %s %s by %s", design.label, design.genes, method)
        with Progress(_expected_points(method, cfg, half), f"robustness: {design.label} by {method}", "point",
                      progress, bar=False, at_most=method == "expansion") as steps:

            def counted(x, steps=steps):
                y = points(x)
                steps.step(f"(deviated designs solved: {points.solves})")
                return y

            if method == "expansion":
                est = expansion_estimate(counted, half, rob.distribution, rob.normal_sigmas, rob.fd_step, WORSE)
            else:
                pts = draw(rob.sample.n, half, rob.distribution, rob.sample.design, rob.sample_seed(cfg.seed),
                           rob.normal_sigmas)
                est = sample_estimate(counted, pts, WORSE)
        res.estimates[method] = est
        res.solves[method] = points.solves - before + (1 if not res.seconds else 0)
        res.seconds[method] = time.perf_counter() - t0
        t0 = time.perf_counter()
    res.failures = list(points.failures)
    return res


def study(cfg: WhiskerConfig, designs: Sequence[StudyDesign], methods: Sequence[str] = ("expansion",),
          progress: bool = True, journal=None) -> list[DesignRobustness]:
    """:func:`study_design` for every design, with a progress bar and a progress line per design
    (and a line per evaluated point, :func:`study_design`); ``journal`` as there."""
    from whisker_opt.experiment.scene import SceneRunner
    from whisker_opt.output.progress import Progress

    runner = SceneRunner(memo_size=16)
    out = []
    with Progress(len(designs), "robustness", "design", progress) as steps:
        for d in designs:
            out.append(study_design(cfg, d, methods, runner, progress, journal))
            steps.step(f"({d.label})")
    return out


# ----------------------------------------------------------------------------- tables
def summary_rows(results: Sequence[DesignRobustness]) -> list[dict]:
    """One row per design and method: genes, nominal, mean, std and worst of each output, cost."""
    rows = []
    for r in results:
        for method, est in r.estimates.items():
            row: dict[str, Any] = {"design": r.design.label, **r.design.genes, "method": method,
                                   "f1_run": r.design.f1_run, "solves": r.solves[method],
                                   "time_s": r.seconds[method], "failed": len(r.failures)}
            for i, name in enumerate(OUTPUTS):
                row.update({f"{name}_nominal": r.nominal[name], f"{name}_mean": float(est.mean[i]),
                            f"{name}_std": float(est.std[i]), f"{name}_worst": float(est.worst[i])})
            rows.append(row)
    return rows


def sensitivity_rows(results: Sequence[DesignRobustness], cfg: WhiskerConfig) -> list[dict]:
    """One row per design, method and toleranced parameter: its half-width, the slope of each
    output (central difference or the sample's linear fit) and its share σ_j·slope of the std."""
    from whisker_opt.optimise.robust import standard_deviations
    from whisker_opt.config.robustness import TOLERANCE_KEYS

    rob = cfg.robustness
    half = np.asarray(wiring.tolerance_half_widths(cfg))
    sigma = standard_deviations(half, rob.distribution, rob.normal_sigmas)
    rows = []
    for r in results:
        for method, est in r.estimates.items():
            slopes = est.gradient if method == "expansion" else est.slopes  # (m, d)
            for j, key in enumerate(TOLERANCE_KEYS):
                row: dict[str, Any] = {"design": r.design.label, "method": method, "parameter": key,
                                       "half_width": float(half[j]), "sigma": float(sigma[j])}
                for i, name in enumerate(OUTPUTS):
                    row[f"d{name}"] = float(slopes[i, j])
                    row[f"{name}_std_share"] = float(slopes[i, j] * sigma[j])
                    if method == "expansion":
                        row[f"{name}_minus"] = float(est.minus[j, i])
                        row[f"{name}_plus"] = float(est.plus[j, i])
                rows.append(row)
    return rows


def format_table(results: Sequence[DesignRobustness]) -> str:
    """The printed summary: per design and method, its genes (an added gene by its key, after Q_i), f1 and the
    recovery rate (nominal, mean, std, worst)."""
    from whisker_opt.genes import GENE_NAMES

    added = [g for g in (results[0].design.genes if results else {}) if g not in GENE_NAMES]
    head = (f"{'design':<8} {'alpha':>7} {'l':>7} {'t':>6} {'Q_i':>7}" + "".join(f" {g:>{max(7, len(g))}}" for g in added)
            + f" {'method':<9} {'f1 nom':>9} {'f1 mean':>9} "
            f"{'f1 std':>9} {'f1 worst':>9} {'rec nom':>8} {'rec mean':>8} {'rec std':>8} {'rec worst':>9} "
            f"{'solves':>6} {'time s':>7}")
    lines = [head]
    for row in summary_rows(results):
        lines.append(
            f"{row['design']:<8} {row['alpha']:>7.4f} {row['l']:>7.4f} {row['t']:>6.4f} {row['Q_i']:>7.5f}"
            + "".join(f" {row[g]:>{max(7, len(g))}.4g}" for g in added)
            + f" {row['method']:<9} {row['f1_nominal']:>9.3g} {row['f1_mean']:>9.3g} {row['f1_std']:>9.3g} "
            f"{row['f1_worst']:>9.3g} {row['recovery_rate_nominal']:>8.2f} {row['recovery_rate_mean']:>8.2f} "
            f"{row['recovery_rate_std']:>8.2f} {row['recovery_rate_worst']:>9.2f} {row['solves']:>6d} "
            f"{row['time_s']:>7.0f}")
    for r in results:
        for text in r.failures:
            lines.append(f"{r.design.label}: failed: {text}")
    return "\n".join(lines)


def journal_inputs(cfg: WhiskerConfig, designs: Sequence[StudyDesign], methods: Sequence[str] | None = None) -> dict:
    """Everything a study depends on, as its journal (:data:`JOURNAL`) keeps it: the resolved config, the
    methods (default ``robustness.method``) and the designs."""
    methods = check_methods([cfg.robustness.method] if methods is None else methods)
    return {"config": cfg.model_dump(mode="json"), "methods": list(methods),
            "designs": [[d.label, sorted(d.genes.items())] for d in designs]}


def robustness(cfg: WhiskerConfig, designs: Sequence[StudyDesign], out: Path, methods: Sequence[str] | None = None,
               progress: bool = True) -> tuple[list[DesignRobustness], dict]:
    """Study ``designs`` and write ``robustness.csv``, ``robustness_sensitivities.csv``,
    ``robustness.json`` and ``robustness.png`` into ``out``.

    Every deviated design solved is kept in :data:`JOURNAL` in ``out`` until the outputs are
    written (at most a second apart, and when the study stops): the same study into the same
    folder after a kill reads them back and ends with the same result
    (:class:`whisker_opt.output.journal.StudyJournal`).

    Parameters
    ----------
    methods : sequence of str, optional
        Default ``robustness.method`` of the config.

    Returns
    -------
    results : list of DesignRobustness
    paths : dict of str -> Path

    Raises
    ------
    RobustnessError
        A method that is none of :data:`METHODS`, or a sample too small for its sensitivities
        (:func:`check_sample_size`), before anything is solved.
    """
    from whisker_opt.output.robustness import write_outputs

    methods = check_methods([cfg.robustness.method] if methods is None else methods)
    check_sample_size(cfg, methods)
    wiring.tolerance_half_widths(cfg)
    own = any(d.label == "config" for d in designs)  # the config's own design takes its Q_i from scene.Q_i
    wiring.warn_unread_keys(cfg, "robustness", ("optimiser.trim", "scene.Q_i") if own else None)
    from whisker_opt.output.journal import StudyJournal

    journal = StudyJournal(Path(out), JOURNAL, STUDY, journal_inputs(cfg, designs, methods), min_interval=1.0)
    try:
        results = study(cfg, designs, methods, progress, journal)
    finally:
        journal.flush()
    paths = write_outputs(Path(out), summary_rows(results), sensitivity_rows(results, cfg), _json(results, cfg),
                          _plot_data(results, wiring.tolerance_half_widths(cfg)), _fidelity(cfg))
    journal.finish()
    return results, paths


def _fidelity(cfg: WhiskerConfig) -> str:
    from whisker_opt.experiment.fidelity import describe

    fid = describe(cfg.fidelity, cfg.scene.calibration)
    return f"preset {fid['preset']}, f1 resolution ~{fid['f1_resolution']:.2g}"


def _json(results: Sequence[DesignRobustness], cfg: WhiskerConfig) -> dict:
    """Everything of the study as plain JSON: settings, and per design the estimates and their points."""
    from whisker_opt.config.robustness import TOLERANCE_KEYS

    designs = []
    for r in results:
        entry: dict[str, Any] = {"design": r.design.label, "genes": r.design.genes, "f1_run": r.design.f1_run,
                                 "nominal": r.nominal, "failures": r.failures, "methods": {}}
        for method, est in r.estimates.items():
            m: dict[str, Any] = {"seconds": r.seconds[method], "solves": r.solves[method]}
            for i, name in enumerate(OUTPUTS):
                m[name] = {"mean": float(est.mean[i]), "std": float(est.std[i]), "worst": float(est.worst[i])}
            if method == "expansion":
                m["gradient"] = {name: dict(zip(TOLERANCE_KEYS, est.gradient[i].tolist()))
                                 for i, name in enumerate(OUTPUTS)}
                m["worst_corner"] = {name: dict(zip(TOLERANCE_KEYS, est.corners[i].tolist()))
                                     for i, name in enumerate(OUTPUTS)}
                m["minus"] = est.minus.tolist()
                m["plus"] = est.plus.tolist()
            else:
                m["slopes"] = {name: dict(zip(TOLERANCE_KEYS, est.slopes[i].tolist())) for i, name in enumerate(OUTPUTS)}
                m["points"] = est.points.tolist()
                m["values"] = est.values.tolist()
            entry["methods"][method] = m
        designs.append(entry)
    return {"tolerances": dict(zip(TOLERANCE_KEYS, cfg.robustness.tolerances.half_widths())),
            "tolerance_units": {"alpha": "deg", "l": "mm", "t": "mm", "fibre_radius": "mm", "C10": "%",
                                "calibration": "-"},
            "robustness": cfg.robustness.model_dump(mode="json"), "fidelity": _fidelity(cfg),
            "outputs": list(OUTPUTS), "designs": designs}


def _plot_data(results: Sequence[DesignRobustness], half_widths: Sequence[float]) -> list[dict]:
    """Per design: its label, nominal f1, the tornado (f1 at −h and +h per parameter) and the sample's f1."""
    from whisker_opt.config.robustness import TOLERANCE_KEYS

    out = []
    for r in results:
        item: dict[str, Any] = {"label": f"{r.design.label}: " + ", ".join(f"{k}={v:.4g}" for k, v in
                                                                             r.design.genes.items()),
                                "nominal": r.nominal["f1"], "parameters": list(TOLERANCE_KEYS)}
        exp = r.estimates.get("expansion")
        smp = r.estimates.get("sample")
        if exp is not None:
            item.update(minus=exp.minus[:, 0], plus=exp.plus[:, 0], mean=exp.mean[0], std=exp.std[0],
                        worst=exp.worst[0], tornado="central differences at ± step·h")
        elif smp is not None:  # the sample's linear fit at ± h
            half = np.asarray(half_widths, dtype=float)
            item.update(minus=r.nominal["f1"] - smp.slopes[0] * half, plus=r.nominal["f1"] + smp.slopes[0] * half,
                        tornado="linear fit of the sample at ± h")
        if smp is not None:
            item.update(sample=smp.values[:, 0], sample_mean=smp.mean[0], sample_std=smp.std[0],
                        sample_worst=smp.worst[0])
        out.append(item)
    return out
