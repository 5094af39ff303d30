"""A design and its scenes for other tools: CalculiX/Abaqus decks, STEP and STL (``whisker-opt export``).

For every scene ``simulate`` would solve (:func:`whisker_opt.workflows.simulation_specs`: the
``intact``/``trimmed_uncompensated``/``trimmed`` pair, or the one scene ``scene``):

``<scene>.inp``
    The scene on the preset's mesh as a CalculiX/Abaqus deck
    (:func:`whisker_opt.output.scene_deck.write_scene_deck`): C3D10 rubber, fibres as springs tied
    into the rubber, base supports, pressurise then deflect.
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


def export(cfg: WhiskerConfig, out: Path, source: str = "config", n_increments: int = 10) -> Export:
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

    Returns
    -------
    Export

    Raises
    ------
    whisker_opt.config.model.ConfigError
        A pair with ``scene.trim`` = 0, or a rubber the deck cannot write.
    """
    from geometry.mesh import build_mesh
    from whisker_opt.config.model import ConfigError
    from whisker_opt.output import storage
    from whisker_opt.output.scene_deck import DeckOptions, write_scene_deck
    from whisker_opt.workflows import record_config, simulation_specs

    if cfg.material.rubber != "neo_hookean" or cfg.material.cap_rubber not in ("same", "neo_hookean"):
        raise ConfigError(f"{source}: material.rubber: {cfg.material.rubber!r} (cap_rubber "
                          f"{cfg.material.cap_rubber!r}); the CalculiX deck writes the neo-Hookean law only "
                          "(rubber: neo_hookean, cap_rubber: same)")
    specs = simulation_specs(cfg, source)
    from whisker_opt.wiring import warn_unread_keys

    warn_unread_keys(cfg, "export")
    out = Path(out)
    record_config(out, cfg)
    decks, solids, entries = {}, {}, {}
    for name, spec in specs.items():
        wm = build_mesh(spec.design, spec.sizing, method=spec.mesh_method)
        decks[name] = write_scene_deck(out / f"{name}.inp", spec, wm, DeckOptions(n_increments=n_increments))
        entries[name] = {"deck": decks[name].name, "Q_MPa": spec.Q, "deflection_mm": spec.deflection,
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
