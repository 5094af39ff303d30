"""Fidelity presets: how fine the mesh and how many solved load levels a scene uses.

Each preset trades run time against the error of the gauge reading; the measured error
of each preset against a mesh-converged reference is produced by
``benchmarks/bench_scene.py`` and quoted in ``benchmarks/README.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from geometry.mesh import MeshSizing
from whisker_opt.config import FidelityConfig


@dataclass(frozen=True)
class Preset:
    """Load stepping of one preset (its mesh sizing is ``MeshSizing.preset(name)``).

    Attributes
    ----------
    n_pressure_steps, n_deflection_steps : int
        Solved (reported) load levels of the pressurise and deflect steps.
    """

    n_pressure_steps: int
    n_deflection_steps: int


# Three solved deflection increments suffice for the cubic-spline curve: against 20
# increments its error over δ ∈ [0.01, 5] mm is 6.5e-6 (intact, Q = 0.2) and 1.0e-5
# (trimmed, Q = 0) of ε(5 mm), against 1.1e-3 with two increments (coarse mesh,
# default design, measured 2026-11-23 with benchmarks/bench_scene.py's method).
PRESETS: dict[str, Preset] = {
    "coarse": Preset(n_pressure_steps=1, n_deflection_steps=3),
    "default": Preset(n_pressure_steps=1, n_deflection_steps=3),
    "fine": Preset(n_pressure_steps=2, n_deflection_steps=10),
}


def resolve(cfg: FidelityConfig) -> Preset:
    """The preset named in ``cfg`` with its step-count overrides applied."""
    p = PRESETS[cfg.preset]
    if cfg.n_pressure_steps is not None:
        p = replace(p, n_pressure_steps=cfg.n_pressure_steps)
    if cfg.n_deflection_steps is not None:
        p = replace(p, n_deflection_steps=cfg.n_deflection_steps)
    return p


def mesh_sizing(cfg: FidelityConfig, design=None) -> MeshSizing:
    """The :class:`geometry.sizing.MeshSizing` of a fidelity config.

    The preset's own sizing (:meth:`MeshSizing.preset`, which the shipped template
    meshes reproduce) with the config's ``h_wall``/``h_body`` overrides applied
    (an absolute ``h_wall`` disables templates: the mesh is made afresh).
    """
    sizing = MeshSizing.preset(cfg.preset)
    kw = {}
    if cfg.h_body is not None:
        kw["h_body"] = cfg.h_body
    if cfg.h_wall is not None:
        kw["h_wall"] = cfg.h_wall
    return replace(sizing, **kw) if kw else sizing
