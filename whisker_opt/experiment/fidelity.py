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

The mesh ladder refines every direction together (:func:`ladder_sizing`; level 1 = ``default``)::

    preset    layers, sectors, dz/pitch, body  elements   eval [s], one core with 2 other jobs
    level2    2, 10, 0.25, 5 mm                 ~4 300     15–30
    level3    3, 12, 0.17, 3.3 mm               ~10 500    65–220
    level4    4, 16, 0.125, 2.5 mm              ~24 000    370–410

The gauge reading scatters by ±0.5 % between mesh families without a trend in the wall layers
(one P2 layer through the wall reads within 0.7 % of three), so ``default``, the GA's, is the
cheapest mesh within 1 % of the gauge reference; ``fine`` keeps three wall layers. f1, a
difference of two close curves, carries larger errors at every preset (``README.md``, "Fidelity
and how far to trust f1"). Figures: ``benchmarks/performance/bench_scene.py``, ``benchmarks/accuracy/time_vs_error.py``
and ``benchmarks/results/bench_scene.md``, ``benchmarks/results/time_vs_error.md``.

Three solved deflection increments suffice for the cubic-spline curve: against 20 increments
its error over δ ∈ [0.01, 5] mm is 6.5e-6 (intact, Q = 0.2) and 1.0e-5 (trimmed, Q = 0) of
ε(5 mm), against 1.1e-3 with two increments (coarse mesh, default design).

The shipped template meshes (:mod:`geometry.template`) are made for these presets' sizings:
regenerate them with ``python3 -m whisker_opt.experiment.fidelity`` after changing a sizing.

f1 resolution
    Each preset carries ``f1_resolution``: the absolute f1 (mean |ε_i − ε_c|, in calibrated
    strain at the default ξ = 3.9, docs/physics.md §4) below which a preset's f1 is mesh error
    rather than a difference between the two responses. Figures from ``benchmarks/results/time_vs_error.md``
    (2026-11-23) and the README's "Fidelity and how far to trust f1"::

        preset    f1_resolution  derived from
        coarse    2e-3           default's 1e-3 × 2 (below)
        default   1e-3           f1(fine) − f1(default) at a GA optimum: 9.3e-4
        fine      7e-4           default's 1e-3 × 0.69 (below)

    ``default``: the 50-generation case-1 run ended at f1 = 5.7e-6, which ``verify`` found to
    be 9.40e-4 at ``fine`` (a gap of 9.3e-4); a Q_i scan of the same geometry gave gaps of
    6.5e-4 to 9.3e-4. Against the mesh-converged references of ``time_vs_error.py`` the
    default preset's absolute f1 errors are 5.7e-4 (thesis design, −16 % of 3.54e-3),
    1.7e-5 (slim-thin, +0.8 % of 2.19e-3) and 1.7e-3 (stout-thick, −35 % of 4.84e-3).

    ``coarse``: its f1 errors against the same references are default's within 6 %
    (ratios coarse/default 0.94, 1.00, 1.03; 0.94 for the gap to ``fine`` at the case-1
    optimum: 8.7e-4 against 9.3e-4), but its gauge reading error is 2.7 times default's
    (−2.2 % against −0.81 % of ε(5 mm), ``bench_scene.py``), so its f1 error between the
    measured designs is less certain. The factor on default's 1e-3 is taken between those
    two ratios, 1 and 2.7, as their geometric mean 1.6, rounded up to 2; coarse's largest
    measured f1 error, 1.74e-3 (stout-thick, 36 % of 4.84e-3), lies just below.

    ``fine``: its absolute f1 errors against the same references are 3.9e-4 (thesis design,
    11 %), 1.2e-4 (slim-thin, 5.4 %) and 6.3e-4 (stout-thick, 13 %), i.e. 0.69 and 0.37 of
    default's at the two designs where default's error is material (at slim-thin both are
    below 2e-4). The larger ratio, 0.69, times default's 1e-3 gives 7e-4; fine's largest
    measured error, 6.3e-4, lies below. No finer reference exists at a GA optimum, so an
    optimised f1 below this is not resolved by any shipped preset.

    The mesh ladder (``default`` = level 1, ``level2`` … ``level4``, :func:`ladder_sizing`; the GA's
    increments at every level, so only the mesh differs) was measured on the template path at twelve
    designs (``python3 -m benchmarks.accuracy.f1_convergence ladder --method template``,
    ``benchmarks/results/f1_convergence.md``, "f1 over the mesh ladder"); the finest level is not converged
    either, so each figure is the largest distance to the next finer levels measured::

        preset    f1_resolution  derived from
        level2    6e-4           largest |f1(level2) − f1(level4)| over the four designs with a level 4:
                                 5.3e-4 at the case-1 optimum (1.9e-4, 7.5e-5, 2.5e-4 at the other three), rounded up
        level3    4e-4           largest |f1(level3) − f1(level4)|: 3.1e-4 at the stout thick-walled design
                                 (2.3e-4, 7.7e-5, 3.0e-4 at the others), rounded up
        level4    not measured   no finer reference (NaN: no resolution is claimed)

    Against level 4 the ``default`` preset's gap is 4.3e-4 at the default design and 1.24e-3 at the
    case-1 optimum (f1 5.7e-6 against 1.25e-3), above its 1e-3.

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
        which f1 is not resolved at this preset (see the module docstring for the figures).
    """

    name: str
    sizing: MeshSizing
    n_pressure_steps: int
    n_deflection_steps: int
    f1_resolution: float = float("nan")


#: Calibration factor ξ of the readings in which :attr:`Preset.f1_resolution` was measured.
RESOLUTION_CALIBRATION = 3.9

#: Sectors around the whisker at each level of the mesh ladder.
LADDER_SECTORS = {1: 8, 2: 10, 3: 12, 4: 16}


def ladder_sizing(k: int) -> MeshSizing:
    """Level k = 1 … 4 of the mesh ladder: k wall layers, :data:`LADDER_SECTORS` sectors, chamber layers of
    pitch/(2k) and body elements ≤ 10/k mm; level 1 is the ``default`` preset's sizing."""
    if k not in LADDER_SECTORS:
        raise ValueError(f"mesh ladder level {k!r}: allowed {', '.join(map(str, LADDER_SECTORS))}")
    if k == 1:
        return MeshSizing()
    return MeshSizing(wall_layers=float(k), n_theta=LADDER_SECTORS[k], axial_pitch_fraction=0.5 / k,
                      h_body=10.0 / k, name=f"level{k}")


#: The named presets, cheapest first.
PRESETS: dict[str, Preset] = {
    "coarse": Preset("coarse", MeshSizing(wall_layers=1.0, n_theta=8, axial_pitch_fraction=0.75, h_body=12.0,
                                          name="coarse"), n_pressure_steps=1, n_deflection_steps=3,
                     f1_resolution=2e-3),
    "default": Preset("default", MeshSizing(), n_pressure_steps=1, n_deflection_steps=3, f1_resolution=1e-3),
    "level2": Preset("level2", ladder_sizing(2), n_pressure_steps=1, n_deflection_steps=3, f1_resolution=6e-4),
    "fine": Preset("fine", MeshSizing(wall_layers=3.0, n_theta=12, axial_pitch_fraction=0.17, h_body=10.0,
                                      name="fine"), n_pressure_steps=2, n_deflection_steps=10, f1_resolution=7e-4),
    "level3": Preset("level3", ladder_sizing(3), n_pressure_steps=1, n_deflection_steps=3, f1_resolution=4e-4),
    "level4": Preset("level4", ladder_sizing(4), n_pressure_steps=1, n_deflection_steps=3),
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
    """Rebuild the shipped template meshes of every preset (:func:`geometry.template.generate_templates`)."""
    from geometry.template import generate_templates

    return generate_templates(tuple(p.sizing for p in PRESETS.values()), num_threads=num_threads)


if __name__ == "__main__":  # pragma: no cover
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    regenerate_templates()
