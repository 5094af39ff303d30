"""A design and its scenes for other tools: CalculiX/Abaqus decks, STEP and STL (``whisker-opt export``).

For every scene ``simulate`` would solve (:func:`whisker_opt.workflows.simulation_specs`: the
``intact``/``trimmed_uncompensated``/``trimmed`` pair, or the one scene ``scene``):

``<scene>.inp``
    The scene on the preset's mesh as a CalculiX or Abaqus deck (``flavour``,
    :func:`whisker_opt.output.scene_deck.write_scene_deck`): the rubber as C3D10 with a compressible
    K/μ = 20 (CalculiX) or as the hybrid C3D10H (Abaqus), fibres as springs tied into the rubber, base
    supports, pressurise then deflect. The CalculiX deck's expected agreement with the in-house solve on the
    same mesh: docs/physics.md, "The exported deck". A scene the deck cannot hold (another rubber, the
    smeared fibres, a wall law other than 'embedded') is refused before anything is written
    (:func:`check_deckable`).
``<design>.step``, ``<design>.stl``
    The CAD solid of each distinct design (``intact``, and ``trimmed`` for a pair's trimmed
    whisker; ``whisker`` for one scene) (:mod:`geometry.cad`; STL chordal tolerance 0.01 mm).
``config.yaml``
    The resolved config (:func:`whisker_opt.workflows.record_config`): the model the decks hold.
``export.json``
    What was written, with each scene's Q, δ, contact and mesh size; written last.

Every file is written atomically.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from whisker_opt.config.model import WhiskerConfig

logger = logging.getLogger(__name__)

#: Name of the summary written last.
EXPORT_JSON = "export.json"


@dataclass(frozen=True)
class Export:
    """What :func:`export` wrote.

    Attributes
    ----------
    decks : dict of scene name -> Path
    solids : dict of design name -> (STEP Path, STL Path)
    summary : Path
        ``export.json``.
    """

    decks: dict
    solids: dict
    summary: Path


def _write_cad(design, out: Path, name: str) -> tuple[Path, Path]:
    """STEP and STL of ``design`` as ``out/<name>.step`` and ``.stl``, each made in a hidden folder and
    renamed into place (the cadquery exporters choose nothing by suffix, but need the final name)."""
    from geometry.cad import build_solid, export_step, export_stl

    solid = build_solid(design)
    paths = []
    for suffix, writer in ((".step", export_step), (".stl", export_stl)):
        tmp = Path(tempfile.mkdtemp(prefix=".export-", dir=out))
        try:
            made = writer(solid, tmp / f"{name}{suffix}")
            os.replace(made, out / made.name)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        paths.append(out / f"{name}{suffix}")
    return paths[0], paths[1]


def check_deckable(cfg: WhiskerConfig, source: str = "config") -> dict:
    """The scenes of ``cfg`` that ``export`` writes, refused in one line when the deck cannot hold one of them.

    Returns
    -------
    dict of scene name -> SceneSpec
        :func:`whisker_opt.workflows.simulation_specs`.

    Raises
    ------
    whisker_opt.config.model.ConfigError
        A pair with ``scene.trim`` = 0, or a scene the deck cannot hold
        (:func:`whisker_opt.output.scene_deck.deck_refusal`: the key, its value and what the deck writes).
    """
    from whisker_opt.config.model import ConfigError
    from whisker_opt.output.scene_deck import deck_refusal
    from whisker_opt.workflows import simulation_specs

    specs = simulation_specs(cfg, source)
    refusal = next((r for r in map(deck_refusal, specs.values()) if r), None)
    if refusal:
        raise ConfigError(f"{source}: {refusal}")
    return specs


def export(cfg: WhiskerConfig, out: Path, source: str = "config", n_increments: int = 10,
           flavour: str = "calculix", bulk_ratio: float | None = None) -> Export:
    """Write the decks, STEP and STL of the config's scenes into ``out`` (see the module).

    Parameters
    ----------
    cfg : WhiskerConfig
    out : Path
        Created when missing.
    source : str
        The config file, for messages.
    n_increments : int
        Initial and largest increment of each phase of the deck, as a fraction 1/n of it.
    flavour : {'calculix', 'abaqus'}
        The deck's dialect and rubber element (:class:`whisker_opt.output.scene_deck.DeckOptions`).
    bulk_ratio : float or None
        K/μ written for the scene's D1 = 0; None: the flavour's own (20 for CalculiX, the hybrid element's
        incompressible rubber for Abaqus).

    Returns
    -------
    Export

    Raises
    ------
    whisker_opt.config.model.ConfigError
        A pair with ``scene.trim`` = 0, or a scene the deck cannot hold (:func:`check_deckable`).
    """
    from geometry.mesh import build_mesh
    from whisker_opt.output import storage
    from whisker_opt.output.scene_deck import DeckOptions, deck_d1, write_scene_deck
    from whisker_opt.workflows import record_config
    from whisker_opt.wiring import warn_unread_keys

    specs = check_deckable(cfg, source)
    options = DeckOptions(n_increments=n_increments, flavour=flavour, bulk_ratio=bulk_ratio)

    warn_unread_keys(cfg, "export")
    out = Path(out)
    record_config(out, cfg, "export")
    decks, solids, entries = {}, {}, {}
    for name, spec in specs.items():
        wm = build_mesh(spec.design, spec.sizing, method=spec.mesh_method)
        decks[name] = write_scene_deck(out / f"{name}.inp", spec, wm, options)
        entries[name] = {"deck": decks[name].name, "flavour": options.flavour, "element": options.element,
                         "C10_MPa": spec.c10, "D1_per_MPa": deck_d1(spec.c10, spec.d1, options.rubber_bulk_ratio),
                         "bulk_ratio": options.rubber_bulk_ratio, "Q_MPa": spec.Q, "deflection_mm": spec.deflection,
                         "contact_ratio": spec.contact_ratio, "trim_mm": spec.design.trim,
                         "base_support": spec.base_support, "n_nodes": wm.mesh.n_nodes,
                         "n_elements": wm.mesh.n_elements, "mesh_method": wm.report.method}
    designs = {}
    for name, spec in specs.items():
        key = "whisker" if len(specs) == 1 else ("intact" if spec.design.trim == 0 else "trimmed")
        designs.setdefault(key, spec.design)
    for key, design in designs.items():
        solids[key] = _write_cad(design, out, key)
    summary = {"scenes": entries, "solids": {k: [p.name for p in v] for k, v in solids.items()},
               "units": "mm, N, MPa", "fidelity_preset": cfg.fidelity.preset, "config": str(source)}
    storage.atomic_write_text(out / EXPORT_JSON, json.dumps(summary, indent=2, default=float))
    logger.info("exported %d scene deck(s) and %d solid(s) into %s", len(decks), len(solids), out)
    return Export(decks, solids, out / EXPORT_JSON)
