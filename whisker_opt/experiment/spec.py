"""What determines one scene: :class:`SceneSpec`, a hashable value that keys the scene memo.

Its user settings (contact, deflection, rubber constants, gauge factor) are declared here once
with :func:`geometry.design.parameter`: their defaults, units, ranges and meanings; the
``scene`` and ``material`` sections of a run file are generated from them
(:mod:`whisker_opt.config.model`). This module imports no solver code, so the configuration
can read it cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from geometry.design import WhiskerDesign, parameter
from geometry.sizing import MeshSizing

if TYPE_CHECKING:  # pragma: no cover
    from fem.newton import SolveOptions

#: Where the contact is placed (:attr:`SceneSpec.contact_at`).
CONTACT_AT: tuple[str, ...] = ("pressurised", "reference")


def _default_solve_options():
    from fem.newton import SolveOptions

    return SolveOptions(reuse_tangent=0.3)


@dataclass(frozen=True)
class SceneSpec:
    """Everything that determines one scene's result (hashable, so it keys the memo).

    Attributes
    ----------
    design : WhiskerDesign
        Geometry, including the trim (the whisker's length is ``design.length``).
    Q : float
        Chamber pressure [MPa], >= 0.
    contact_ratio : float
        a in (0, 1]; the contact is at x = a·L_Q.
    contact_at : {'pressurised', 'reference'}
        'pressurised': x = a·L_Q, the contact moves out with the extension
        (a = 1 is the tip face). 'reference': x = a·L, the pusher stays where it stood
        before pressurisation (for Q > 0 and a = 1 that is a section short of the tip).
        The two differ in the pressure trend of off-tip readings; see
        benchmarks/README.md (default design, a = 0.5: ε(1 mm) at 0.2 MPa +0.1 % of the
        vented value with 'pressurised', +10 % with 'reference').
    deflection : float
        Final deflection [mm].
    c10, d1 : float
        Neo-Hookean constants [MPa], [1/MPa].
    calibration : float
        Gauge factor ξ [-].
    band_width : float
        Axial width of the contact band [mm].
    n_pressure_steps, n_deflection_steps : int
        Solved (reported) load levels in each step; the solver may substep between them.
    sizing : MeshSizing
    mesh_method : str
        'auto' | 'fresh' | 'template'.
    solve_options : SolveOptions
    formulation : {'mixed', 'displacement'}
        :class:`fem.problem.Problem` formulation: 'mixed' (P2/P0 u–p, locking-free, the
        default) or 'displacement' (C3D10-like, needs D1 > 0; for cross-checks with
        CalculiX; it locks on coarse meshes: +12 % on ε(5 mm) of the default preset mesh
        at K/μ = 1000, benchmarks/README.md).
    """

    design: WhiskerDesign
    Q: float = 0.0
    contact_ratio: float = parameter(1.0, "-", "contact ratio a: the contact is at x = a·L_Q; 1 = the tip",
                                     gt=0, le=1)
    contact_at: str = parameter(
        "pressurised", "", "'pressurised': the contact at x = a·L_Q, of the pressurised length; 'reference': at "
        "x = a·(L − Δ), the pusher staying where it stood before the whisker extended",
        choices=CONTACT_AT)
    deflection: float = parameter(5.0, "mm", "largest deflection δ_max of the contact", gt=0, le=30)
    c10: float = parameter(0.14, "MPa", "neo-Hookean C10 = μ/2", gt=0, le=100, key="C10")
    d1: float = parameter(0.0, "1/MPa", "compressibility D1 = 2/K; 0 = incompressible", ge=0, le=100, key="D1")
    calibration: float = parameter(3.9, "-", "gauge calibration factor ξ: every reading (hence f1 and F_p) is the "
                                   "simulated strain times ξ", gt=0, le=100)
    band_width: float = parameter(1.0, "mm", "axial width of the contact band of nodes (off-tip contact)",
                                  gt=0, le=10)
    n_pressure_steps: int = 2
    n_deflection_steps: int = 5
    sizing: MeshSizing = field(default_factory=MeshSizing)
    mesh_method: str = "auto"
    solve_options: SolveOptions = field(default_factory=_default_solve_options)
    formulation: str = "mixed"

    def __post_init__(self) -> None:
        checks = [
            ("Q", self.Q, self.Q >= 0, ">= 0 MPa"),
            ("contact_ratio", self.contact_ratio, 0 < self.contact_ratio <= 1, "in (0, 1]"),
            ("contact_at", self.contact_at, self.contact_at in CONTACT_AT, " or ".join(map(repr, CONTACT_AT))),
            ("formulation", self.formulation, self.formulation in ("mixed", "displacement"),
             "'mixed' or 'displacement'"),
            ("deflection", self.deflection, self.deflection > 0, "> 0 mm"),
            ("band_width", self.band_width, self.band_width > 0, "> 0 mm"),
            ("n_pressure_steps", self.n_pressure_steps, self.n_pressure_steps >= 1, ">= 1"),
            ("n_deflection_steps", self.n_deflection_steps, self.n_deflection_steps >= 1, ">= 1"),
        ]
        for name, value, ok, allowed in checks:
            if not ok:
                raise ValueError(f"SceneSpec.{name}={value!r}: must be {allowed}")
