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
    """Mesh sizing and load stepping of one preset.

    Attributes
    ----------
    wall_layers : float
        Target element edge lengths through the chamber wall (h_wall = t / wall_layers).
    h_body : float
        Largest element edge in the solid body [mm].
    n_pressure_steps, n_deflection_steps : int
        Solved (reported) load levels of the pressurise and deflect steps.
    """

    wall_layers: float
    h_body: float
    n_pressure_steps: int
    n_deflection_steps: int


PRESETS: dict[str, Preset] = {
    "coarse": Preset(wall_layers=1.0, h_body=6.0, n_pressure_steps=2, n_deflection_steps=3),
    "default": Preset(wall_layers=2.0, h_body=4.0, n_pressure_steps=2, n_deflection_steps=4),
    "fine": Preset(wall_layers=3.0, h_body=3.0, n_pressure_steps=4, n_deflection_steps=8),
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
    """The :class:`geometry.sizing.MeshSizing` of a fidelity config (``design`` unused, kept for symmetry)."""
    p = PRESETS[cfg.preset]
    kw = dict(wall_layers=p.wall_layers, h_body=p.h_body, name=cfg.preset)
    if cfg.h_body is not None:
        kw["h_body"] = cfg.h_body
    if cfg.h_wall is not None:
        kw["h_wall"] = cfg.h_wall
    return MeshSizing(**kw)
