"""What determines one scene: :class:`SceneSpec`, a hashable value that keys the scene memo.

Its user settings (contact, deflection, rubber constants, gauge factor) are declared here once
with :func:`geometry.design.parameter`: their defaults, units, ranges and meanings; the
``scene`` and ``material`` sections of a run file are generated from them
(:mod:`whisker_opt.config.model`). The rubbers a scene may name are those of
:mod:`whisker_opt.experiment.rubber_laws` (:data:`whisker_opt.experiment.rubber_laws.RUBBERS`), which also makes
them into law objects. This module imports no solver code at import time (:mod:`fem` only inside functions),
so the configuration can read it cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from geometry.design import WhiskerDesign, parameter, parameter_violations
from geometry.materials import RUBBER_C10
from geometry.sizing import MeshSizing
from whisker_opt.experiment.base_supports import BASE_SUPPORTS
from whisker_opt.experiment.bases import compliant, grip
from whisker_opt.experiment.cap_joints import CAP_JOINTS
from whisker_opt.experiment.caps import compliant as compliant_cap
from whisker_opt.experiment.gauge_patches import GAUGE_PATCHES
from whisker_opt.experiment.patches import bonded
from whisker_opt.experiment.rubber_laws import RUBBERS
from whisker_opt.wall.law import SLOPE_RANGE, WALL_LAW_NAMES, WallLaw

if TYPE_CHECKING:  # pragma: no cover
    from fem.newton import SolveOptions

#: Where the contact is placed (:attr:`SceneSpec.contact_at`).
CONTACT_AT: tuple[str, ...] = ("pressurised", "reference")
#: What the reference says of the allowed rubbers instead of listing them (they are a registry that grows).
_LISTED_RUBBERS = "registered rubber law, listed by `python3 -m whisker_opt.experiment.rubber_laws`"


def cap_elements(mesh, c: float) -> np.ndarray:
    """Mask (n_el,) of the cap's elements of ``mesh`` (``points``, ``cells``): those whose centroid
    (mean of the four corner nodes) lies at x < c."""
    corners = mesh.points[mesh.cells[:, :4]]  # (n_el, 4, 3)
    return corners[:, :, 0].mean(axis=1) < c


#: The chamber pressures a scene may take [MPa]: ``scene.Q_i`` and the gene Q_i read this range.
Q_RANGE: tuple[float, float] = (0.0, 1.0)

FIBRE_MODELS: tuple[str, ...] = ("embedded", "smeared")


def default_solve_options():
    """The scenes' Newton controls: :class:`fem.newton.SolveOptions` with modified Newton (reuse 0.3)."""
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
        The two differ in the pressure trend of off-tip readings, which rise monotonically with Q
        with 'reference' and peak and fall again with 'pressurised' (benchmarks/results/compensation.md,
        the default design at a = 0.5 and 0.75).
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
        CalculiX; it locks on coarse meshes such as the default preset's at K/μ = 1000:
        benchmarks/results/time_vs_error.md, "CalculiX point").
    rubber : str
        Rubber law of the body (every element, or every element outside the cap when
        ``cap_rubber`` differs): one of :data:`whisker_opt.experiment.rubber_laws.RUBBERS`, 'neo_hookean'
        (C10 = ``c10``, the default) or a law of its own constants (a two-term Yeoh fit of a named silicone,
        ...). D1 = ``d1`` for all.
    cap_rubber : str
        'same' (default: the cap is of the body's rubber) or one of the rubbers for the
        elements of the cap, those whose centroid lies at x < c, bonded to the body.
    cap_joint : str
        How the cap is joined to the body: one of :data:`whisker_opt.experiment.cap_joints.CAP_JOINTS`
        ('tied', the default; 'compliant', a bond layer smeared over the cap,
        :mod:`whisker_opt.experiment.caps.compliant`, which documents its range).
    cap_joint_k : float
        The 'compliant' joint's stiffness per area [N/mm³].
    base_support : str
        How the holder holds the base: one of the mechanisms of
        :data:`whisker_opt.experiment.base_supports.BASE_SUPPORTS` ('clamped', the default: every node of
        the base face fixed; 'sliding', 'axial', 'grip', 'compliant'; each module of
        :mod:`whisker_opt.experiment.bases` documents its mechanism and its parameters' ranges).
    base_grip_depth : float
        Depth d [mm] over which 'grip' holds the outer surface (0 ≤ d < the whisker's length).
    base_k_n, base_k_t : float
        Normal and tangential stiffness per area [N/mm³] of the 'compliant' base's springs.
    gauge_patch : str
        What the gauge adds to the surface, one of :data:`whisker_opt.experiment.gauge_patches.GAUGE_PATCHES`:
        'none' (the default, the bare rubber) or 'bonded' (a stiff sheet over the gauge's footprint,
        :mod:`whisker_opt.experiment.patches.bonded`, which documents the defaults' sources).
    patch_length, patch_width, patch_thickness : float
        The 'bonded' sheet's axial length (centred on the grid), arc width (centred on the +y generator) and
        thickness [mm].
    patch_modulus, patch_poisson : float
        The 'bonded' sheet's Young's modulus [MPa] and Poisson ratio [-].
    fibre_model : {'embedded', 'smeared'}
        'embedded' (default): each helix a line of trusses in its host elements
        (:mod:`geometry.fibres`). 'smeared': the winding as an anisotropic term of the wall
        with the same axial stiffness per length (:mod:`geometry.fibre_field`), which
        converges under mesh refinement (benchmarks/results/fibre_models.md).
    wall_law : str
        The chamber wall's law under pressure (:mod:`whisker_opt.wall.law`): 'embedded' (default),
        'sliding' or 'calibrated'.
    wall_slope : float
        Slope s [1/MPa] of the 'calibrated' law c(Q) = 1 + s·Q; 0 for the others.
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
    c10: float = parameter(RUBBER_C10, "MPa", "neo-Hookean C10 = μ/2", gt=0, le=100, key="C10")
    d1: float = parameter(0.0, "1/MPa", "compressibility D1 = 2/K; 0 = incompressible", ge=0, le=100, key="D1")
    calibration: float = parameter(3.9, "-", "gauge calibration factor ξ: every reading (hence f1 and F_p) is the "
                                   "simulated strain times ξ", gt=0, le=100)
    band_width: float = parameter(1.0, "mm", "axial width of the contact band of nodes (off-tip contact)",
                                  gt=0, le=10)
    n_pressure_steps: int = 2
    n_deflection_steps: int = 5
    sizing: MeshSizing = field(default_factory=MeshSizing)
    mesh_method: str = "auto"
    solve_options: SolveOptions = field(default_factory=default_solve_options)
    formulation: str = "mixed"
    rubber: str = parameter(
        "neo_hookean", "", "rubber law of the body, by name: 'neo_hookean' (C10, D1 of the material section) or "
        "a registered law of its own constants, e.g. a two-term Yeoh fit of a named silicone's published uniaxial "
        "data (docs/physics.md §1)", choices=RUBBERS, listed=f"a {_LISTED_RUBBERS}")
    cap_rubber: str = parameter(
        "same", "", "rubber of the cap (elements at x < c), bonded to the body: 'same' as the body, or one of "
        "the rubber laws", choices=("same",) + RUBBERS, listed=f"`same` or a {_LISTED_RUBBERS}")
    cap_joint: str = parameter(
        "tied", "", "how the cap is joined to the body: 'tied' (shared nodes) or 'compliant' (a bond layer of "
        "stiffness cap_joint_k per area, smeared over the cap's thickness); docs/physics.md §2",
        choices=CAP_JOINTS, listed="a registered cap joint, listed by `python3 -m whisker_opt.experiment.cap_joints`")
    cap_joint_k: float = parameter(
        compliant_cap.K_DEFAULT, "N/mm^3", "stiffness per area of cap_joint 'compliant', μ/h of the bond layer "
        "(estimated 0.4-10 for a silicone glue layer)", gt=compliant_cap.K_RANGE[0], le=compliant_cap.K_RANGE[1])
    base_support: str = parameter(
        "clamped", "", "how the holder holds the base, by name: 'clamped' (every base node fixed), 'sliding' (the "
        "base held axially, only its inner half r ≤ D/4 also radially), 'axial' (held axially only, plus two nodes "
        "against rigid motion), 'grip' (the outer surface fixed over base_grip_depth, the base face free) or "
        "'compliant' (the base face on springs base_k_n, base_k_t); docs/physics.md §2",
        choices=BASE_SUPPORTS, listed="a registered base mechanism, listed by "
        "`python3 -m whisker_opt.experiment.base_supports`")
    base_grip_depth: float = parameter(
        grip.DEPTH_DEFAULT, "mm", "depth d from x = 0 over which base_support 'grip' holds the outer surface "
        "(estimated 1-6 mm for the default design); below the whisker's length", ge=0, le=100)
    base_k_n: float = parameter(
        compliant.K_N_DEFAULT, "N/mm^3", "normal stiffness per area of base_support 'compliant' (estimated 0.08-35 "
        "for a rubber layer of 1-10 mm in the holder)", gt=compliant.K_RANGE[0], le=compliant.K_RANGE[1])
    base_k_t: float = parameter(
        compliant.K_T_DEFAULT, "N/mm^3", "tangential stiffness per area of base_support 'compliant' (estimated "
        "0.03-0.3, μ/h)", gt=compliant.K_RANGE[0], le=compliant.K_RANGE[1])
    gauge_patch: str = parameter(
        "none", "", "what the gauge adds to the surface it is bonded to: 'none' (the bare rubber) or 'bonded' (a "
        "stiff sheet, its backing and adhesive, over patch_length × patch_width); docs/physics.md §3",
        choices=GAUGE_PATCHES, listed="a registered gauge patch, listed by "
        "`python3 -m whisker_opt.experiment.gauge_patches`")
    patch_length: float = parameter(
        bonded.LENGTH_DEFAULT, "mm", "axial length of gauge_patch 'bonded', centred on the grid (the gauge's base; "
        "estimated 6-7 mm)", gt=0, le=50)
    patch_width: float = parameter(
        bonded.WIDTH_DEFAULT, "mm", "arc width of gauge_patch 'bonded' around the +y generator (the gauge's base; "
        "estimated 2.5-3 mm)", gt=0, le=50)
    patch_thickness: float = parameter(
        bonded.THICKNESS_DEFAULT, "mm", "thickness of gauge_patch 'bonded' (polyimide base about 0.015 plus "
        "adhesive, estimated 0.02-0.035)", gt=0, le=1)
    patch_modulus: float = parameter(
        bonded.MODULUS_DEFAULT, "MPa", "Young's modulus of gauge_patch 'bonded' (polyimide 2500, cyanoacrylate "
        "1000-2000: estimated 1500-4000)", gt=0, le=1e6)
    patch_poisson: float = parameter(
        bonded.POISSON_DEFAULT, "-", "Poisson ratio of gauge_patch 'bonded' (polyimide 0.34)", ge=0, lt=0.5)
    fibre_model: str = parameter(
        "embedded", "", "'embedded': each helix a line of trusses in the elements that hold it; 'smeared': the "
        "winding spread over the wall as an anisotropic fibre term of the same stiffness per length "
        "(docs/physics.md)", choices=FIBRE_MODELS)
    wall_law: str = parameter(
        "embedded", "", "what pressure does to the chamber wall's stiffness in bending: 'embedded' (the fibres "
        "as meshed, a perfectly bonded wall), 'sliding' (the stored wall-law table's sliding fibres) or "
        "'calibrated' (c(Q) = 1 + wall_slope·Q); docs/physics.md §14", choices=WALL_LAW_NAMES)
    wall_slope: float = parameter(
        0.0, "1/MPa", "slope s of the 'calibrated' wall law c(Q) = 1 + s·Q (the wall's incremental stiffness "
        "under pressure relative to the bonded wall's); read only by wall_law 'calibrated'",
        ge=SLOPE_RANGE[0], le=SLOPE_RANGE[1])

    def __post_init__(self) -> None:
        bad = parameter_violations(self)  # the ranges and choices declared with each parameter
        checks = [
            ("Q", self.Q, Q_RANGE[0] <= self.Q <= Q_RANGE[1],
             f"in the allowed range [{Q_RANGE[0]:g}, {Q_RANGE[1]:g}] MPa (the chamber pressure)"),
            ("formulation", self.formulation, self.formulation in ("mixed", "displacement"),
             "'mixed' or 'displacement'"),
            ("n_pressure_steps", self.n_pressure_steps, self.n_pressure_steps >= 1, ">= 1"),
            ("n_deflection_steps", self.n_deflection_steps, self.n_deflection_steps >= 1, ">= 1"),
            ("base_grip_depth", self.base_grip_depth, self.base_grip_depth < self.design.length,
             f"< the whisker's length {self.design.length:g} mm"),
        ]
        bad = [f"SceneSpec.{name}={value!r}: must be {allowed}" for name, value, ok, allowed in checks if not ok] + bad
        if self.wall_law in WALL_LAW_NAMES:
            self.law  # noqa: B018  (validates wall_slope with wall_law, in the law's own words)
        if bad:
            raise ValueError(bad[0])

    @property
    def law(self) -> WallLaw:
        """The wall law of the scene (:class:`whisker_opt.wall.law.WallLaw`)."""
        return WallLaw(self.wall_law, self.wall_slope)
