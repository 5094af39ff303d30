"""The scenes of a genome, for meshes stored without a ``scenes.json``.

A run directory's ``best/`` folder (or an evaluation's folder) may hold only VTU files; what
the viewer then knows of its scenes comes from the run's ``config.yaml`` and the genome
(``best.json`` or a row of ``evaluations.csv``). The scenes are those that
:func:`whisker_opt.wiring.design_scene_specs` builds for the run: ``intact`` at Q_i,
``trimmed_uncompensated`` (trimmed, still at Q_i; only when Q_i > 0) and ``trimmed``
(vented, Q = 0).
"""

from __future__ import annotations

import dataclasses
import logging
from typing import Any, Mapping, Sequence

from pydantic import ValidationError

import whisker_opt.wiring as wiring
from whisker_opt.config.model import WhiskerConfig, format_validation_error
from whisker_opt.viewer.sceneinfo import SceneInfo, scene_info_from_dict

logger = logging.getLogger(__name__)

#: Which column of the curves ``(delta, eps_i, eps_c)`` is the response of a scene.
CURVE_COLUMN = {wiring.INTACT: 1, wiring.TRIMMED: 2}


def run_config(config: Mapping[str, Any]) -> WhiskerConfig | None:
    """The run's ``config.yaml`` (a plain mapping) as a validated config; None when it is not one.

    A partial file is complete with the defaults; empty sections (``design:`` without keys)
    count as absent; renamed keys are read with a deprecation warning.
    """
    data = {k: v for k, v in dict(config).items() if v is not None}
    try:
        return WhiskerConfig.model_validate(data)
    except ValidationError as exc:
        logger.warning("the run's config.yaml does not validate; scenes shown without design facts:\n%s",
                       format_validation_error(exc, "config.yaml"))
        return None


def genome_scenes(config: Mapping[str, Any], genes: Mapping[str, Any],
                  curves: tuple[Sequence[float], Sequence[float], Sequence[float]] | None = None,
                  notes: Mapping[str, Any] | None = None) -> dict[str, SceneInfo]:
    """The scenes of a genome as :class:`SceneInfo`, named as :mod:`whisker_opt.wiring` names them.

    Parameters
    ----------
    config : mapping
        The run's ``config.yaml`` as read (may be partial or empty).
    genes : mapping
        ``alpha`` [deg], ``l``, ``t`` [mm], ``Q_i`` [MPa] (numbers or numeric strings; other
        keys, e.g. of an ``evaluations.csv`` row, are ignored).
    curves : (delta, eps_i, eps_c), optional
        Gauge responses of the intact and the vented scene (e.g. ``best_curves.csv``).
    notes : mapping, optional
        Shown as text (f1, F_p, ...).

    Returns
    -------
    dict of str -> SceneInfo
        Empty when the config does not validate or a gene is missing or not a number.
    """
    from geometry.design import InvalidDesignError

    cfg = run_config(config)
    if cfg is None:
        return {}
    try:
        try:
            specs = wiring.design_scene_specs(cfg, genes)
        except InvalidDesignError as exc:
            logger.info("design of genes %s does not validate (%s); its scenes are described as stored",
                        dict(genes), exc)
            specs = wiring.design_scene_specs(cfg, genes, validate=False)
    except (KeyError, TypeError, ValueError) as exc:
        logger.info("genes %s: no scenes (%s: %s)", dict(genes), type(exc).__name__, exc)
        return {}
    out = {}
    for name, spec in specs.items():
        entry: dict[str, Any] = {"design": spec.design.as_dict(), "Q": spec.Q, "trim": spec.design.trim,
                                 "contact_ratio": spec.contact_ratio}
        k = CURVE_COLUMN.get(name)
        if curves is not None and k is not None:
            entry.update(delta=list(curves[0]), eps=list(curves[k]))
        out[name] = dataclasses.replace(scene_info_from_dict(name, entry), notes=dict(notes or {}))
    return out
