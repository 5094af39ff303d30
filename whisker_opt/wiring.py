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

from dataclasses import replace
from typing import Mapping

from whisker_opt.config.model import FidelityConfig, WhiskerConfig
from whisker_opt.config.optimiser import OptimiserConfig

INTACT = "intact"
UNCOMPENSATED = "trimmed_uncompensated"
TRIMMED = "trimmed"
#: Scene names of a genome, in display order.
SCENE_NAMES: tuple[str, ...] = (INTACT, UNCOMPENSATED, TRIMMED)


def optimiser_of(cfg: WhiskerConfig) -> OptimiserConfig:
    """The config's ``optimiser`` section, or its defaults when the section is absent."""
    return cfg.optimiser or OptimiserConfig()


def design_from_config(cfg: WhiskerConfig, trim: float = 0.0, validate: bool = True):
    """The :class:`geometry.design.WhiskerDesign` described by ``cfg.design``, validated unless
    ``validate`` is False.

    Raises
    ------
    geometry.design.InvalidDesignError
        The design section does not describe a whisker.
    """
    from geometry.design import WhiskerDesign

    d = WhiskerDesign(**cfg.design.model_dump(), trim=trim)
    if validate:
        d.validate()
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
        The genome's intact or trimmed geometry is impossible (only when ``validate``).
    """
    intact, trimmed = evaluator(cfg, validate=validate).specs(genes, validate=validate)
    specs = {INTACT: intact}
    if intact.Q > 0:
        specs[UNCOMPENSATED] = replace(trimmed, Q=intact.Q)
    specs[TRIMMED] = trimmed
    return specs
