"""Fidelity presets: how fine the mesh and how many solved load levels a scene uses.

A preset is one object, :class:`Preset`: a name, the mesh sizing
(:class:`geometry.sizing.MeshSizing`) and the solved increments of the pressurise and deflect
steps. Chosen by measurement (default design, intact at Q = 0.2 MPa, gauge line reading at
δ = 5 mm against a 21 600-element swept mesh of 4 layers, 16 sectors, dz = pitch/8; one
evaluation = intact + trimmed scene on one core)::

    preset    layers, sectors, dz/pitch
    coarse    1, 8, 0.75
    default   1, 8, 0.5
    fine      3, 12, 0.17

The mesh ladder refines every direction together (:func:`ladder_sizing`; level 1 = ``default``)::

    preset    layers, sectors, dz/pitch, body
    level2    2, 10, 0.25, 5 mm
    level3    3, 12, 0.17, 3.3 mm
    level4    4, 16, 0.125, 2.5 mm
    reference 5, 20, 0.1, 2 mm      (the finest level of the reference table; swept meshes, no template)

The gauge reading scatters between mesh families without a trend in the wall layers, so
``default``, the GA's, is the cheapest mesh within 1 % of the gauge reference; ``fine`` keeps three
wall layers. f1, a difference of two close curves, carries larger errors at every preset
(``README.md``, "Fidelity and how far to trust f1"). Three solved deflection increments suffice
for the cubic-spline curve. Figures (elements, time per evaluation, gauge and curve errors):
``benchmarks/performance/bench_scene.py``, ``benchmarks/accuracy/time_vs_error.py`` and
``benchmarks/results/bench_scene.md`` (with the figures this docstring used to state: "The presets'
cost and gauge error as the preset module stated them"), ``benchmarks/results/time_vs_error.md``.

The shipped template meshes (:mod:`geometry.template`) are made for these presets' sizings:
regenerate them with ``python3 -m whisker_opt.experiment.fidelity`` after changing a sizing.

f1 resolution
    Each preset carries ``f1_resolution``: the absolute f1 (mean |ε_i − ε_c|, in calibrated
    strain at the default ξ = 3.9, docs/physics.md §4) below which a preset's f1 is mesh error
    rather than a difference between the two responses: its largest distance from the finest level
    measured (level 4 at twelve designs, ``reference`` at three) plus that level's own uncertainty at
    the same design, rounded up to one significant digit (``python3 -m benchmarks.accuracy.f1_reference``;
    no level is a converged reference, docs/physics.md §13). ``reference`` has no finer mesh and
    claims none (NaN). The figures and the derivation of each value:
    ``benchmarks/results/f1_convergence.md``, "The presets' f1 resolution: how each value was derived".

    f1 scales with the calibration ξ (``scene.calibration``): :func:`f1_resolution` converts.
    Overrides of a preset's sizing or increments (``fidelity.h_wall`` …) leave the figure of
    the named preset, which then only approximates the run's.
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
    f1_resolution : float
        Measured absolute f1 [calibrated strain, ξ = :data:`RESOLUTION_CALIBRATION`] below
        which f1 is not resolved at this preset (see the module docstring; the figures:
        ``benchmarks/results/f1_convergence.md``).
    template : bool
        Whether shipped template meshes serve it (the GA's mapped meshes); otherwise the
        ``auto`` mesh method sweeps a mesh for each design (:func:`geometry.mesh.build_mesh`).
    """

    name: str
    sizing: MeshSizing
    n_pressure_steps: int
    n_deflection_steps: int
    f1_resolution: float = float("nan")
    template: bool = True


#: Calibration factor ξ of the readings in which :attr:`Preset.f1_resolution` was measured.
RESOLUTION_CALIBRATION = 3.9

#: Sectors around the whisker at each level of the mesh ladder.
LADDER_SECTORS = {1: 8, 2: 10, 3: 12, 4: 16, 5: 20}

#: The preset (and mesh sizing) name of each level of the mesh ladder; level 5 is ``reference``.
LADDER_NAMES = {1: "default", 2: "level2", 3: "level3", 4: "level4", 5: "reference"}


def ladder_sizing(k: int) -> MeshSizing:
    """Level k = 1 … 5 of the mesh ladder: k wall layers, :data:`LADDER_SECTORS` sectors, chamber layers of
    pitch/(2k) and body elements ≤ 10/k mm; level 1 is the ``default`` preset's sizing, level 5 the
    ``reference`` preset's (no template is shipped for it: its meshes are swept for each design)."""
    if k not in LADDER_SECTORS:
        raise ValueError(f"mesh ladder level {k!r}: allowed {', '.join(map(str, LADDER_SECTORS))}")
    if k == 1:
        return MeshSizing()
    return MeshSizing(wall_layers=float(k), n_theta=LADDER_SECTORS[k], axial_pitch_fraction=0.5 / k,
                      h_body=10.0 / k, name=LADDER_NAMES[k])


#: The named presets, cheapest first.
PRESETS: dict[str, Preset] = {
    "coarse": Preset("coarse", MeshSizing(wall_layers=1.0, n_theta=8, axial_pitch_fraction=0.75, h_body=12.0,
                                          name="coarse"), n_pressure_steps=1, n_deflection_steps=3,
                     f1_resolution=2e-3),
    "default": Preset("default", MeshSizing(), n_pressure_steps=1, n_deflection_steps=3, f1_resolution=2e-3),
    "level2": Preset("level2", ladder_sizing(2), n_pressure_steps=1, n_deflection_steps=3, f1_resolution=9e-4),
    "fine": Preset("fine", MeshSizing(wall_layers=3.0, n_theta=12, axial_pitch_fraction=0.17, h_body=10.0,
                                      name="fine"), n_pressure_steps=2, n_deflection_steps=10, f1_resolution=7e-4),
    "level3": Preset("level3", ladder_sizing(3), n_pressure_steps=1, n_deflection_steps=3, f1_resolution=7e-4),
    "level4": Preset("level4", ladder_sizing(4), n_pressure_steps=1, n_deflection_steps=3, f1_resolution=4e-4),
    "reference": Preset("reference", ladder_sizing(5), n_pressure_steps=1, n_deflection_steps=3, template=False),
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


def f1_resolution(name: str, calibration: float = RESOLUTION_CALIBRATION) -> float:
    """The named preset's f1 resolution in the readings of a run with calibration ξ = ``calibration``.

    Parameters
    ----------
    name : str
        A preset name (:data:`PRESET_NAMES`).
    calibration : float
        ``scene.calibration`` of the run; f1 scales with it (docs/physics.md §4).

    Returns
    -------
    float
        ``f1_resolution · calibration / RESOLUTION_CALIBRATION``.
    """
    return preset(name).f1_resolution * float(calibration) / RESOLUTION_CALIBRATION


def describe(cfg, calibration: float = RESOLUTION_CALIBRATION) -> dict:
    """The fidelity of a config as stored with its results: preset name and f1 resolution.

    Parameters
    ----------
    cfg : whisker_opt.config.model.FidelityConfig
        ``preset`` and its optional overrides.
    calibration : float
        ``scene.calibration`` (the unit of the resolution).

    Returns
    -------
    dict
        ``{"preset": name, "f1_resolution": float, "calibration": ξ}``, plus ``"overrides"``
        (the overridden keys and values) when the preset is overridden: the resolution is then
        the named preset's, an approximation. ``calibration`` is the gauge factor of the
        calibrated f1 and F_p; dividing by it gives them in simulated (uncalibrated) strain.
    """
    out: dict = {"preset": cfg.preset, "f1_resolution": f1_resolution(cfg.preset, calibration),
                 "calibration": float(calibration)}
    keys = ("h_wall", "h_body", "n_pressure_steps", "n_deflection_steps")
    overrides = {k: getattr(cfg, k) for k in keys if getattr(cfg, k, None) is not None}
    if overrides:
        out["overrides"] = overrides
    return out


def regenerate_templates(num_threads: int = 0):
    """Rebuild the shipped template meshes of every preset that has them (:func:`geometry.template.generate_templates`)."""
    from geometry.template import generate_templates

    return generate_templates(tuple(p.sizing for p in PRESETS.values() if p.template), num_threads=num_threads)


if __name__ == "__main__":  # pragma: no cover
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    regenerate_templates()
