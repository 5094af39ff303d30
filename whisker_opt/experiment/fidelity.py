"""Fidelity presets: how fine the mesh and how many solved load levels a scene uses.

A preset is one object, :class:`Preset`: a name, the mesh sizing
(:class:`geometry.sizing.MeshSizing`) and the solved increments of the pressurise and deflect
steps. Chosen by measurement (default design, intact at Q = 0.2 MPa, gauge line reading at
δ = 5 mm against a 21 600-element swept mesh of 4 layers, 16 sectors, dz = pitch/8; one
evaluation = intact + trimmed scene on one core)::

    preset    layers, sectors, dz/pitch  elements  eval [s]   gauge err
    coarse    1, 8, 0.75                 ~1 000    ~2.5       −2.0 %
    default   1, 8, 0.5                  ~1 100    2.7        −0.8 %
    fine      3, 12, 0.17                ~8 900    ~100       −0.3 %

The gauge reading scatters by ±0.5 % between mesh families without a trend in the wall layers
(one P2 layer through the wall reads within 0.7 % of three), so ``default``, the GA's, is the
cheapest mesh within 1 % of the gauge reference; ``fine`` keeps three wall layers. f1, a
difference of two close curves, carries larger errors at every preset (``README.md``, "Fidelity
and how far to trust f1"). Figures: ``benchmarks/bench_scene.py``, ``benchmarks/time_vs_error.py``
and ``benchmarks/README.md``.

Three solved deflection increments suffice for the cubic-spline curve: against 20 increments
its error over δ ∈ [0.01, 5] mm is 6.5e-6 (intact, Q = 0.2) and 1.0e-5 (trimmed, Q = 0) of
ε(5 mm), against 1.1e-3 with two increments (coarse mesh, default design).

The shipped template meshes (:mod:`geometry.template`) are made for these presets' sizings:
regenerate them with ``python3 -m whisker_opt.experiment.fidelity`` after changing a sizing.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

from geometry.sizing import MeshSizing


@dataclass(frozen=True)
class Preset:
    """One fidelity preset: mesh sizing and solved load levels.

    Attributes
    ----------
    name : str
    sizing : geometry.sizing.MeshSizing
        Element sizes (its template meshes are shipped for the named presets).
    n_pressure_steps, n_deflection_steps : int
        Solved (reported) load levels of the pressurise and deflect steps.
    """

    name: str
    sizing: MeshSizing
    n_pressure_steps: int
    n_deflection_steps: int


#: The named presets, cheapest first.
PRESETS: dict[str, Preset] = {
    "coarse": Preset("coarse", MeshSizing(wall_layers=1.0, n_theta=8, axial_pitch_fraction=0.75, h_body=12.0,
                                          name="coarse"), n_pressure_steps=1, n_deflection_steps=3),
    "default": Preset("default", MeshSizing(), n_pressure_steps=1, n_deflection_steps=3),
    "fine": Preset("fine", MeshSizing(wall_layers=3.0, n_theta=12, axial_pitch_fraction=0.17, h_body=10.0,
                                      name="fine"), n_pressure_steps=2, n_deflection_steps=10),
}

#: Names of :data:`PRESETS` (the allowed values of ``fidelity.preset``).
PRESET_NAMES: tuple[str, ...] = tuple(PRESETS)


def preset(name: str) -> Preset:
    """The named preset; ``ValueError`` naming the allowed names otherwise."""
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"fidelity preset {name!r} is not one of {', '.join(PRESET_NAMES)}") from None


def resolve(cfg) -> Preset:
    """The preset named in a ``fidelity`` config section with its overrides applied.

    Parameters
    ----------
    cfg : whisker_opt.config.model.FidelityConfig
        ``preset`` plus optional ``n_pressure_steps``, ``n_deflection_steps``, ``h_wall`` and
        ``h_body`` overrides (an absolute ``h_wall`` disables templates: the mesh is made afresh).
    """
    p = preset(cfg.preset)
    steps = {k: getattr(cfg, k) for k in ("n_pressure_steps", "n_deflection_steps") if getattr(cfg, k) is not None}
    sizes = {k: getattr(cfg, k) for k in ("h_wall", "h_body") if getattr(cfg, k) is not None}
    if sizes:
        p = replace(p, sizing=replace(p.sizing, **sizes))
    return replace(p, **steps) if steps else p


def regenerate_templates(num_threads: int = 0):
    """Rebuild the shipped template meshes of every preset (:func:`geometry.template.generate_templates`)."""
    from geometry.template import generate_templates

    return generate_templates(tuple(p.sizing for p in PRESETS.values()), num_threads=num_threads)


if __name__ == "__main__":  # pragma: no cover
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    regenerate_templates()
