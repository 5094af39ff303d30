"""The one place where a run file becomes objects: designs, scene specs and the GA's evaluator.

Everything that turns a validated :class:`whisker_opt.config.model.WhiskerConfig` into the
inputs of the experiment lives here, so the command line, the viewer, the verification and
the public API build the same scenes from the same config.

Scene names of a genome (:func:`design_scene_specs`):

``intact``
    The whisker of the genome, untrimmed, at its initial pressure Q_i.
``trimmed_uncompensated``
    Trimmed by ``optimiser.trim`` and still at Q_i: what trimming alone does to the reading.
``trimmed``
    Trimmed and vented (Q = 0): the compensated state the GA compares with ``intact``.
"""

from __future__ import annotations

import logging
import re
from dataclasses import replace
from typing import Any, Mapping

from whisker_opt.config.model import FidelityConfig, WhiskerConfig
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.config.readers import COMMAND_READS, TRIM_AND_Q_KEYS
from whisker_opt.genes import GEOMETRY_GENES

logger = logging.getLogger(__name__)

INTACT = "intact"
UNCOMPENSATED = "trimmed_uncompensated"
TRIMMED = "trimmed"
#: Scene names of a genome, in display order.
SCENE_NAMES: tuple[str, ...] = (INTACT, UNCOMPENSATED, TRIMMED)


def optimiser_of(cfg: WhiskerConfig) -> OptimiserConfig:
    """The config's ``optimiser`` section, or its defaults when the section is absent."""
    return cfg.optimiser or OptimiserConfig()


#: A violation as :meth:`geometry.design.WhiskerDesign.violations` words it: ``<relation> violated (p=v, ...)``.
_VIOLATION = re.compile(r"^(?P<relation>.*) violated \((?P<values>[^()]*)\)$")


def design_keys() -> dict[str, str]:
    """``{design field: run-file key}`` of every design parameter a run file sets, e.g.
    ``{"alpha": "design.alpha", ...}``."""
    from geometry.design import WhiskerDesign, user_parameters

    return {f.name: f"design.{f.metadata['key'] or f.name}" for f in user_parameters(WhiskerDesign)}


def keyed_design_error(exc, keys: Mapping[str, str]):
    """The same refusal, each violation led by the keys that set the parameters involved.

    A violation ``c < l (cavity from x=c to x=l) violated (c=2, l=1)`` becomes
    ``design.c=2, design.l=1: violates c < l (cavity from x=c to x=l)``; a parameter that no
    key sets (e.g. ``tip_clearance``) is marked ``(fixed)``.

    Parameters
    ----------
    exc : geometry.design.InvalidDesignError
    keys : mapping of str -> str
        Design field -> the key (or gene) that gave its value, e.g. ``{"trim": "scene.trim"}``.

    Returns
    -------
    geometry.design.InvalidDesignError
        Same ``parameters`` (design field names); the violations and the message name keys.
    """
    from geometry.design import InvalidDesignError

    out = []
    for text in exc.violations:
        m = _VIOLATION.match(text)
        if m is None:
            out.append(text)
            continue
        named = []
        for item in m["values"].split(", "):
            name, _, value = item.partition("=")
            named.append(f"{keys[name]}={value}" if name in keys else f"{name}={value} (fixed)")
        out.append(f"{', '.join(named)}: violates {m['relation']}")
    return InvalidDesignError(out, set(exc.parameters))


def _trim_key(cfg: WhiskerConfig, trim: float) -> str:
    """The key a trim most likely comes from: ``scene.trim``, ``optimiser.trim`` or the command's ``trim``."""
    if trim == cfg.scene.trim:
        return "scene.trim"
    if trim == optimiser_of(cfg).trim:
        return "optimiser.trim"
    return "trim"


def validate_design(design, keys: Mapping[str, str]):
    """``design.validate()``, its refusal naming the keys that set each parameter involved.

    Parameters
    ----------
    design : geometry.design.WhiskerDesign
    keys : mapping of str -> str
        As :func:`keyed_design_error`.

    Returns
    -------
    geometry.design.WhiskerDesign
        ``design``.

    Raises
    ------
    geometry.design.InvalidDesignError
        See :func:`keyed_design_error`.
    """
    from geometry.design import InvalidDesignError

    try:
        return design.validate()
    except InvalidDesignError as exc:
        raise keyed_design_error(exc, keys) from None


def design_from_config(cfg: WhiskerConfig, trim: float = 0.0, validate: bool = True, trim_key: str | None = None):
    """The :class:`geometry.design.WhiskerDesign` described by ``cfg.design``, validated unless
    ``validate`` is False.

    Parameters
    ----------
    cfg : WhiskerConfig
    trim : float
        Length cut off the tip [mm].
    validate : bool
        Check the design.
    trim_key : str, optional
        The key that gave ``trim``, for the message; by default ``scene.trim`` or
        ``optimiser.trim`` when ``trim`` equals it, else ``trim``.

    Returns
    -------
    geometry.design.WhiskerDesign

    Raises
    ------
    geometry.design.InvalidDesignError
        The design section does not describe a whisker; the message names ``design.<key>=value``
        for each parameter involved, e.g. ``design.D=18, design.alpha=9, design.L=70,
        scene.trim=0: violates tip radius ... > 0``.
    """
    from geometry.design import WhiskerDesign

    d = WhiskerDesign(**cfg.design.model_dump(), trim=trim)
    if validate:
        validate_design(d, {**design_keys(), "trim": trim_key or _trim_key(cfg, trim)})
    return d


def scene_spec(cfg: WhiskerConfig, design, Q: float):
    """The :class:`whisker_opt.experiment.spec.SceneSpec` of a config for one design and pressure."""
    from whisker_opt.experiment.fidelity import resolve
    from whisker_opt.experiment.spec import SceneSpec, default_solve_options

    preset = resolve(cfg.fidelity)
    return SceneSpec(
        design=design,
        Q=Q,
        **_spec_parameters(cfg),
        n_pressure_steps=preset.n_pressure_steps,
        n_deflection_steps=preset.n_deflection_steps,
        sizing=preset.sizing,
        mesh_method=cfg.fidelity.mesh_method,
        solve_options=replace(default_solve_options(), linear_solver=cfg.fidelity.linear_solver),
    )


def _spec_parameters(cfg: WhiskerConfig) -> dict[str, Any]:
    """The user parameters of a :class:`whisker_opt.experiment.spec.SceneSpec` from the run file: each
    declared field (:func:`geometry.design.user_parameters`) from the ``scene`` or ``material`` section that
    holds its key (the sections are generated from the same declarations)."""
    from geometry.design import user_parameters
    from whisker_opt.experiment.spec import SceneSpec

    out = {}
    for f in user_parameters(SceneSpec):
        key = f.metadata["key"] or f.name
        section = next(sec for sec in (cfg.scene, cfg.material) if key in type(sec).model_fields)
        out[f.name] = getattr(section, key)
    return out


def warn_smeared_on_one_layer(cfg: WhiskerConfig) -> bool:
    """Log a warning (and return True) when the smeared fibre winding is asked for on a mesh with one
    element layer through the wall: there its f1 is an order of magnitude too small (docs/physics.md §13)."""
    from whisker_opt.experiment.fidelity import resolve

    sizing = resolve(cfg.fidelity).sizing
    if cfg.material.fibre_model != "smeared" or sizing.h_wall is not None or sizing.wall_layers >= 2:
        return False
    logger.warning("material.fibre_model 'smeared' on %g wall layer(s) (fidelity.preset %s): f1 is an order of "
                   "magnitude too small on one layer; use fidelity.preset fine or fidelity.h_wall <= t/2 "
                   "(docs/physics.md section 13)", sizing.wall_layers, cfg.fidelity.preset)
    return True


def nominal_evaluator(cfg: WhiskerConfig, keep_curves: bool = False, validate: bool = True):
    """The :class:`whisker_opt.optimise.evaluator.SceneEvaluator` of a config's nominal design (its base design
    validated unless ``validate`` is False), whatever ``optimiser.robust`` and ``optimiser.wall_laws`` say: what
    the studies that vary the design or the law themselves evaluate (the wall-law spread, robustness)."""
    from whisker_opt.optimise.evaluator import SceneEvaluator

    warn_smeared_on_one_layer(cfg)
    base = scene_spec(cfg, design_from_config(cfg, 0.0, validate), 0.0)
    return SceneEvaluator(base, optimiser_of(cfg).trim, cfg.scene.delta_step, cfg.scene.gauge_variant, keep_curves)


def evaluator(cfg: WhiskerConfig, keep_curves: bool = False, validate: bool = True, robust: bool = True):
    """The GA's evaluator of a genome for a config: :func:`nominal_evaluator`, over variants where the config asks.

    With ``optimiser.robust`` set (and ``robust`` True) it is evaluated over the tolerances of the
    ``robustness`` section (:func:`robust_evaluator`, the GA minimising ``f1_robust`` = mean + k·std of f1);
    with ``optimiser.wall_laws`` over the wall laws (:func:`law_set_evaluator`, ``f1_mean_over_laws`` or
    ``f1_worst_over_laws``); either outcome's ``f1`` is the nominal design's. ``robust=False`` gives the
    nominal evaluator whatever the config says.
    """
    ev = nominal_evaluator(cfg, keep_curves, validate)
    if robust and optimiser_of(cfg).robust is not None:
        return robust_evaluator(cfg, ev)
    if robust and optimiser_of(cfg).wall_laws is not None:
        return law_set_evaluator(cfg, ev)
    return ev


# ----------------------------------------------------------------------------- keys a command does not read
def _set_value(cfg: WhiskerConfig, key: str) -> Any:
    """The value of ``key`` when it is set to something other than its default, else None."""
    section, name = key.split(".")
    sec = getattr(cfg, section)
    if sec is None:
        return None
    value = getattr(sec, name)
    default = type(sec).model_fields[name].default
    return None if value == default else value


def _used_value(cfg: WhiskerConfig, key: str, command: str, trim: float | None) -> float | None:
    """The one value ``command`` uses in place of ``key`` (as :func:`_instead` says), None when it uses no
    single value (Q_i from the gene Q_i, calibrate's measurement files)."""
    if command == "calibrate" or (key == "scene.Q_i" and command != "mesh"):
        return None
    if key == "scene.Q_i":
        return 0.0
    if trim is not None:
        return float(trim)
    if command in ("mesh", "simulate", "export"):
        return float(cfg.scene.trim)
    return float(optimiser_of(cfg).trim)  # compensate: its largest trim


def _instead(cfg: WhiskerConfig, key: str, command: str, trim: float | None) -> str:
    """What ``command`` uses in place of ``key``, as the end of the sentence of :func:`unread_keys`."""
    if command == "calibrate":
        return "which takes the trims and pressures of its measurement files (calibrated.yaml keeps the key)"
    if key == "scene.Q_i":
        return "which meshes the unpressurised whisker" if command == "mesh" else "which takes Q_i from the gene Q_i"
    if trim is not None:
        return f"which is given the trim {trim:g} mm (--trim)"
    if command in ("mesh", "simulate", "export"):
        return f"which trims by scene.trim = {cfg.scene.trim:g} mm"
    if command == "compensate":
        return f"whose trims run from 0 to optimiser.trim = {optimiser_of(cfg).trim:g} mm"
    return f"which trims by optimiser.trim = {optimiser_of(cfg).trim:g} mm"


def unread_keys(cfg: WhiskerConfig, command: str, reads: tuple[str, ...] | None = None,
                trim: float | None = None) -> list[str]:
    """One line per key of :data:`~whisker_opt.config.readers.TRIM_AND_Q_KEYS` that is set (to a value
    other than its default) and that ``command`` does not read, saying what it uses instead
    (:mod:`whisker_opt.config.readers`). A key set to the value the command uses in its place (``scene.trim``
    equal to ``optimiser.trim`` in ``run``) is not named: it changes nothing either way.

    Parameters
    ----------
    cfg : WhiskerConfig
    command : str
        A key of :data:`~whisker_opt.config.readers.COMMAND_READS`.
    reads : tuple of str, optional
        The keys the job reads this time, when not ``COMMAND_READS``'s (``robustness`` of a
        config's own design also reads ``scene.Q_i``).
    trim : float, optional
        The trim [mm] the job was given by an argument (``mesh --trim``): then no trim key is read.

    Returns
    -------
    list of str
        E.g. ``scene.trim = 5 has no effect in run, which trims by optimiser.trim = 10 mm
        (docs/config.md, "Keys read by each command")``.

    Raises
    ------
    ValueError
        An unknown ``command`` (naming the allowed ones).
    """
    if command not in COMMAND_READS:
        raise ValueError(f"unread_keys: command={command!r} is not one of {', '.join(COMMAND_READS)}")
    reads = COMMAND_READS[command] if reads is None else reads
    if trim is not None:
        reads = tuple(k for k in reads if not k.endswith(".trim"))
    out = []
    for key in TRIM_AND_Q_KEYS:
        value = _set_value(cfg, key)
        if value is None or key in reads or value == _used_value(cfg, key, command, trim):
            continue
        out.append(f"{key} = {value:g} has no effect in {command}, {_instead(cfg, key, command, trim)} "
                   "(docs/config.md, \"Keys read by each command\")")
    return out


#: Commands that solve nothing under the config's wall law: mesh and export solve no scene, calibrate fits
#: ``material.wall_slope`` (a start at 0 is no mistake there).
WALL_LAW_UNSOLVED = ("mesh", "export", "calibrate")


def idle_wall_law(cfg: WhiskerConfig) -> str | None:
    """The line saying that ``material.wall_law: calibrated`` with ``material.wall_slope`` 0 is the
    'embedded' law (c(Q) = 1, :mod:`whisker_opt.wall.law`); None for any other law or slope."""
    m = cfg.material
    if m.wall_law != "calibrated" or m.wall_slope != 0.0:
        return None
    return ("material.wall_law = calibrated with material.wall_slope = 0 is the 'embedded' law (c(Q) = 1 + 0·Q = 1): "
            "set material.wall_slope (e.g. fitted by whisker-opt calibrate) or choose wall_law embedded")


def warn_unread_keys(cfg: WhiskerConfig, command: str, reads: tuple[str, ...] | None = None,
                     trim: float | None = None) -> list[str]:
    """Log :func:`unread_keys` as warnings, one line each, and for a command that solves scenes the
    wall law that changes nothing (:func:`idle_wall_law`); returns the lines of :func:`unread_keys`."""
    lines = unread_keys(cfg, command, reads, trim)
    idle = idle_wall_law(cfg) if command not in WALL_LAW_UNSOLVED else None
    if idle is not None:
        logger.warning("%s", idle)
    for line in lines:
        logger.warning("%s", line)
    return lines


# ----------------------------------------------------------------------------- tolerances
def tolerance_half_widths(cfg: WhiskerConfig) -> tuple[float, ...]:
    """The ``robustness.tolerances`` of a config in :data:`whisker_opt.config.robustness.TOLERANCE_KEYS`
    order, checked against the scene they deviate.

    Raises
    ------
    ConfigError
        The calibration tolerance is not below ``scene.calibration`` (a gauge factor must stay > 0).
    """
    from whisker_opt.config.model import ConfigError

    tol = cfg.robustness.tolerances
    if tol.calibration >= cfg.scene.calibration:
        raise ConfigError(f"robustness.tolerances.calibration: {tol.calibration:g} must be < scene.calibration = "
                          f"{cfg.scene.calibration:g} (the deviated gauge factor must stay > 0)")
    return tol.half_widths()


def deviated(ev, genes: Mapping[str, float], deviation) -> tuple:
    """The evaluator and genome of a design deviated by ``deviation`` from its nominal one.

    Parameters
    ----------
    ev : whisker_opt.optimise.evaluator.SceneEvaluator
        The nominal evaluator.
    genes : mapping
        The nominal genome.
    deviation : sequence of float
        In :data:`whisker_opt.config.robustness.TOLERANCE_KEYS` order: Δα [deg], Δl, Δt [mm] added
        to the genes; Δr_f [mm], the fibre radius, applied as ``fibre_radius_frac`` + Δr_f / t with the
        nominal t (r_f = r_i + frac·t, docs/physics.md §1) and clipped to [0, 1]; ΔC10 [%] of C10;
        Δξ added to the calibration factor ξ.

    Returns
    -------
    evaluator : SceneEvaluator
        With the deviated fibre radius and C10 (ξ unchanged).
    genes : dict
    scale : float
        (ξ + Δξ)/ξ: every reading, hence f1, is proportional to ξ (docs/physics.md §4), so the
        deviated ξ multiplies the nominal-ξ result instead of solving again.
    """
    from whisker_opt.config.robustness import TOLERANCE_KEYS

    dev = dict(zip(TOLERANCE_KEYS, (float(v) for v in deviation)))
    g = {k: float(v) for k, v in genes.items()}
    for name in GEOMETRY_GENES:
        g[name] += dev[name]
    base = ev.base_spec
    frac = min(max(g.get("fibre_radius_frac", base.design.fibre_radius_frac) + dev["fibre_radius"] / float(genes["t"]),
                   0.0), 1.0)
    c10 = g.get("C10", base.c10) * (1.0 + dev["C10"] / 100.0)
    for gene in {"fibre_radius_frac", "C10"} & set(g):  # a gene overrides the base spec: deviate the gene
        g[gene] = frac if gene == "fibre_radius_frac" else c10
    spec = replace(base, design=replace(base.design, fibre_radius_frac=frac), c10=c10)
    return replace(ev, base_spec=spec), g, (base.calibration + dev["calibration"]) / base.calibration


def robust_evaluator(cfg: WhiskerConfig, ev):
    """``ev`` evaluated over the fabrication tolerances of the ``robustness`` section, every measure reduced to
    mean + k·std (``optimiser.robust``; :class:`whisker_opt.optimise.aggregate.AggregateEvaluator`, ``f1_robust``).

    The variants are the deviations of :func:`deviated`: the first-order expansion (``expansion``: the nominal
    design and two per toleranced parameter; the calibration's cost nothing) or the seeded sample
    (``sample``: one per point, the same points for every genome).
    """
    from whisker_opt.optimise.aggregate import AggregateEvaluator, FabricationVariants, aggregate_label
    from whisker_opt.optimise.robust import draw  # a leaf module: numpy only

    rob, opt = cfg.robustness, optimiser_of(cfg)
    half = tolerance_half_widths(cfg)
    points: tuple = ()
    if opt.robust.method == "sample":
        pts = draw(rob.sample.n, half, rob.distribution, rob.sample.design, rob.sample_seed(cfg.seed), rob.normal_sigmas)
        points = tuple(tuple(float(v) for v in row) for row in pts)
    variants = FabricationVariants(deviated, half, opt.robust.method, rob.distribution, rob.normal_sigmas,
                                   rob.fd_step, points)
    return AggregateEvaluator(ev, variants, "mean_plus_k_std", aggregate_label(opt), float(opt.robust.k))


def with_wall_law(cfg: WhiskerConfig, law: str) -> WhiskerConfig:
    """``cfg`` with ``material.wall_law`` replaced (``material.wall_slope`` kept only for 'calibrated')."""
    slope = cfg.material.wall_slope if law == "calibrated" else 0.0
    return cfg.model_copy(update={"material": cfg.material.model_copy(update={"wall_law": law, "wall_slope": slope})})


def warn_laws_that_cannot_differ(cfg: WhiskerConfig) -> tuple[str, ...]:
    """Log a warning (and return the laws) when two laws of ``optimiser.wall_laws`` are the same law here:
    ``embedded`` and ``calibrated`` at ``material.wall_slope`` = 0 (not a gene) both leave the wall as meshed,
    so the set's mean or worst is f1 under fewer laws than it names."""
    from whisker_opt.wall.law import WallLaw

    opt = optimiser_of(cfg)
    if opt.wall_laws is None or "wall_slope" in opt.genes.names():
        return ()
    slope = cfg.material.wall_slope
    same = tuple(n for n in opt.wall_laws.laws if WallLaw(n, slope if n == "calibrated" else 0.0).identity)
    if len(same) < 2:
        return ()
    logger.warning("optimiser.wall_laws: %s are the same law at material.wall_slope = %g (each leaves the wall as "
                   "meshed): the set cannot differ there; set a slope or drop one", " and ".join(map(repr, same)),
                   slope)
    return same


def law_set_evaluator(cfg: WhiskerConfig, ev):
    """``ev`` evaluated under each law of ``optimiser.wall_laws``, every measure reduced to the mean or the worst
    over the laws (:class:`whisker_opt.optimise.aggregate.AggregateEvaluator`, e.g. ``f1_mean_over_laws``).

    The nominal design is ``ev``, under the run's own ``material.wall_law``: its evaluation is shared with the
    law's variant when that law is in the set, else it costs one evaluation more.
    """
    from whisker_opt.optimise.aggregate import AggregateEvaluator, LawVariants, aggregate_label

    opt = optimiser_of(cfg)
    spec = opt.wall_laws
    warn_laws_that_cannot_differ(cfg)
    inners = tuple(replace(ev, base_spec=scene_spec(with_wall_law(cfg, law), ev.base_spec.design, 0.0))
                   for law in spec.laws)
    return AggregateEvaluator(ev, LawVariants(inners, tuple(spec.laws)), spec.objective, aggregate_label(opt))


def with_preset(cfg: WhiskerConfig, preset: str) -> WhiskerConfig:
    """``cfg`` with its fidelity replaced by the named preset (other fidelity overrides dropped,
    the mesh method and the linear solver kept)."""
    fid = FidelityConfig(preset=preset, mesh_method=cfg.fidelity.mesh_method, linear_solver=cfg.fidelity.linear_solver)
    return cfg.model_copy(update={"fidelity": fid})


def design_scene_specs(cfg: WhiskerConfig, genes: Mapping[str, float], validate: bool = True) -> dict:
    """The scenes of a genome: ``intact``, ``trimmed_uncompensated`` (only when Q_i > 0, else it
    would equal the vented one) and ``trimmed`` (see the module docstring).

    Parameters
    ----------
    cfg : WhiskerConfig
    genes : mapping
        ``alpha`` [deg], ``l``, ``t`` [mm], ``Q_i`` [MPa] and any added gene (numbers or numeric strings).
    validate : bool
        Check the designs (False describes stored results whose design may not pass today's checks).

    Returns
    -------
    dict of str -> whisker_opt.experiment.spec.SceneSpec

    Raises
    ------
    geometry.design.InvalidDesignError
        The genome's intact or trimmed geometry is impossible (only when ``validate``); the
        message names each parameter by its gene (``gene alpha``), its key (``design.D``,
        ``optimiser.trim``) or ``trim`` (0, the intact whisker).
    """
    intact, trimmed = nominal_evaluator(cfg, validate=validate).specs(genes, validate=False)
    if validate:
        keys = design_keys()
        keys.update({g: f"gene {g}" for g in (*GEOMETRY_GENES, *genes) if g in keys})
        validate_design(intact.design, {**keys, "trim": "trim"})
        validate_design(trimmed.design, {**keys, "trim": "optimiser.trim"})
    specs = {INTACT: intact}
    if intact.Q > 0:
        specs[UNCOMPENSATED] = replace(trimmed, Q=intact.Q)
    specs[TRIMMED] = trimmed
    return specs
