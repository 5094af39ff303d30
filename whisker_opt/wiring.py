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

import re
from dataclasses import replace
from typing import Mapping

from whisker_opt.config.model import FidelityConfig, WhiskerConfig
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GEOMETRY_GENES

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
    from whisker_opt.experiment.spec import SceneSpec

    preset = resolve(cfg.fidelity)
    return SceneSpec(
        design=design,
        Q=Q,
        contact_ratio=cfg.scene.contact_ratio,
        contact_at=cfg.scene.contact_at,
        deflection=cfg.scene.deflection,
        c10=cfg.material.C10,
        d1=cfg.material.D1,
        calibration=cfg.scene.calibration,
        band_width=cfg.scene.band_width,
        n_pressure_steps=preset.n_pressure_steps,
        n_deflection_steps=preset.n_deflection_steps,
        sizing=preset.sizing,
        mesh_method=cfg.fidelity.mesh_method,
    )


def evaluator(cfg: WhiskerConfig, keep_curves: bool = False, validate: bool = True):
    """The GA's :class:`whisker_opt.experiment.evaluator.SceneEvaluator` for a config (its base
    design validated unless ``validate`` is False)."""
    from whisker_opt.experiment.evaluator import SceneEvaluator

    base = scene_spec(cfg, design_from_config(cfg, 0.0, validate), 0.0)
    return SceneEvaluator(base, optimiser_of(cfg).trim, cfg.scene.delta_step, cfg.scene.gauge_variant,
                          keep_curves)


def with_preset(cfg: WhiskerConfig, preset: str) -> WhiskerConfig:
    """``cfg`` with its fidelity replaced by the named preset (other fidelity overrides dropped,
    the mesh method kept)."""
    fid = FidelityConfig(preset=preset, mesh_method=cfg.fidelity.mesh_method)
    return cfg.model_copy(update={"fidelity": fid})


def design_scene_specs(cfg: WhiskerConfig, genes: Mapping[str, float], validate: bool = True) -> dict:
    """The scenes of a genome: ``intact``, ``trimmed_uncompensated`` (only when Q_i > 0, else it
    would equal the vented one) and ``trimmed`` (see the module docstring).

    Parameters
    ----------
    cfg : WhiskerConfig
    genes : mapping
        ``alpha`` [deg], ``l``, ``t`` [mm], ``Q_i`` [MPa] (numbers or numeric strings).
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
    intact, trimmed = evaluator(cfg, validate=validate).specs(genes, validate=False)
    if validate:
        keys = {**design_keys(), **{g: f"gene {g}" for g in GEOMETRY_GENES}}
        validate_design(intact.design, {**keys, "trim": "trim"})
        validate_design(trimmed.design, {**keys, "trim": "optimiser.trim"})
    specs = {INTACT: intact}
    if intact.Q > 0:
        specs[UNCOMPENSATED] = replace(trimmed, Q=intact.Q)
    specs[TRIMMED] = trimmed
    return specs
