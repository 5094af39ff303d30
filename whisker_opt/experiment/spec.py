"""What determines one scene: :class:`SceneSpec`, a hashable value that keys the scene memo.

Its user settings (contact, deflection, rubber constants, gauge factor) are declared here once
with :func:`geometry.design.parameter`: their defaults, units, ranges and meanings; the
``scene`` and ``material`` sections of a run file are generated from them
(:mod:`whisker_opt.config.model`). The rubbers are registered here by name, once, each a
factory of its law with the law's own constants (:class:`RubberLaw` in :data:`RUBBER_LAWS`, the
names :data:`RUBBERS`), and made into law objects by :func:`rubber_law` and :func:`rubber_material`
alone, for the solver, the result files and the viewer alike. This module imports no solver code at import time (:mod:`fem.material` only
inside those functions), so the configuration can read it cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Callable

import numpy as np

from geometry.design import WhiskerDesign, parameter, parameter_violations
from geometry.materials import RUBBER_C10
from geometry.sizing import MeshSizing
from whisker_opt.wall.law import SLOPE_RANGE, WALL_LAW_NAMES, WallLaw

if TYPE_CHECKING:  # pragma: no cover
    from fem.material import IsochoricI1Material
    from fem.newton import SolveOptions

#: Where the contact is placed (:attr:`SceneSpec.contact_at`).
CONTACT_AT: tuple[str, ...] = ("pressurised", "reference")

def neo_hookean(constants: tuple, c10: float, d1: float) -> IsochoricI1Material:
    """W = C10 (Ī1 − 3) with the material section's C10 = ``c10`` (:class:`fem.material.NeoHookean`);
    it has no constants of its own."""
    from fem.material import NeoHookean

    return NeoHookean(c10, d1)


def yeoh(constants: tuple, c10: float, d1: float) -> IsochoricI1Material:
    """W = Σ_k C_k0 (Ī1 − 3)^k with the law's own constants (C10, C20, ...) = ``constants``
    (:class:`fem.material.Yeoh`); ``c10`` is not read."""
    from fem.material import Yeoh

    return Yeoh(tuple(constants), d1)


@dataclass(frozen=True)
class RubberLaw:
    """A registered rubber law: a factory of the isochoric law with the law's own constants.

    Attributes
    ----------
    make : callable
        ``make(constants, c10, d1) -> fem.material.IsochoricI1Material``, importing :mod:`fem` when
        called (e.g. :func:`neo_hookean`, :func:`yeoh`); ``c10`` [MPa] is the material section's C10,
        ``d1`` [1/MPa] its D1, which every law takes.
    constants : tuple of float
        The law's own constants [MPa] (empty for a law of the material section's C10).
    source : str
        Where the constants come from.
    """

    make: Callable[[tuple, float, float], IsochoricI1Material]
    constants: tuple[float, ...] = ()
    source: str = ""

    def law(self, c10: float, d1: float) -> IsochoricI1Material:
        """The law with D1 = ``d1`` (and C10 = ``c10`` for a law that reads it)."""
        return self.make(self.constants, c10, d1)


#: The fits of the manufacturer's technical bulletin.
_TDS = "Smooth-On technical bulletin (ASTM D412), fit by benchmarks/studies/fit_rubber_tds.py"

#: The rubber laws of :attr:`SceneSpec.rubber` by name, read-only: the neo-Hookean law of the material
#: section's C10 and D1, and two-term Yeoh laws of named silicones, W = C10 (Ī1 − 3) + C20 (Ī1 − 3)²
#: (Yeoh 1993), their own ``constants`` (C10, C20) [MPa]. Each Yeoh pair passes exactly through the two
#: uniaxial points of the manufacturer's technical bulletin (Smooth-On, ASTM D412): the 100 % modulus at
#: λ = 2 and the tensile strength at the elongation at break; fitted by
#: ``benchmarks/studies/fit_rubber_tds.py`` (which prints these numbers), from Dragon Skin 30: σ100 = 86 psi,
#: 500 psi at 364 %; Dragon Skin 10 Medium: 22 psi, 475 psi at 1000 %; Ecoflex 00-30 (the Shore 00-30 grade):
#: 10 psi, 200 psi at 900 %. A new law is its class in :mod:`fem.material`, a factory as :func:`yeoh` and
#: one entry here.
RUBBER_LAWS = MappingProxyType({
    "neo_hookean": RubberLaw(neo_hookean, (), "material.C10 and material.D1"),
    "yeoh_dragon_skin_30": RubberLaw(yeoh, (0.14514, 6.0678e-3), _TDS),
    "yeoh_dragon_skin_10": RubberLaw(yeoh, (0.041520, 4.5462e-4), _TDS),
    "yeoh_ecoflex_00_30": RubberLaw(yeoh, (0.018663, 2.5902e-4), _TDS),
})

#: The names of the rubber laws (:data:`RUBBER_LAWS`).
RUBBERS: tuple[str, ...] = tuple(RUBBER_LAWS)


def rubber_law(name: str, c10: float, d1: float) -> IsochoricI1Material:
    """The isochoric law called ``name``, one of :data:`RUBBERS`: the one place a rubber's name
    becomes a law, by its registered factory (:meth:`RubberLaw.law`).

    'neo_hookean': W = C10 (Ī1 − 3) with C10 = ``c10`` (:class:`fem.material.NeoHookean`);
    a Yeoh entry: W = C10 (Ī1 − 3) + C20 (Ī1 − 3)² with that silicone's constants
    (:class:`fem.material.Yeoh`; ``c10`` is not used). D1 = ``d1`` for every law.

    Parameters
    ----------
    name : str
    c10 : float
        [MPa].
    d1 : float
        [1/MPa].

    Returns
    -------
    fem.material.IsochoricI1Material

    Raises
    ------
    ValueError
        An unknown name (the message lists :data:`RUBBERS`).
    """
    if name not in RUBBER_LAWS:
        raise ValueError(f"rubber {name!r}: must be " + " or ".join(map(repr, RUBBERS)))
    return RUBBER_LAWS[name].law(c10, d1)


def cap_elements(mesh, c: float) -> np.ndarray:
    """Mask (n_el,) of the cap's elements of ``mesh`` (``points``, ``cells``): those whose centroid
    (mean of the four corner nodes) lies at x < c."""
    corners = mesh.points[mesh.cells[:, :4]]  # (n_el, 4, 3)
    return corners[:, :, 0].mean(axis=1) < c


def rubber_material(rubber: str, cap_rubber: str, c10: float, d1: float, cap: np.ndarray) -> IsochoricI1Material:
    """The rubber of a whisker: one law, or the cap's law on the cap's elements and the body's elsewhere.

    Parameters
    ----------
    rubber, cap_rubber : str
        :attr:`SceneSpec.rubber`, :attr:`SceneSpec.cap_rubber` ('same', or one of :data:`RUBBERS`).
    c10, d1 : float
        [MPa], [1/MPa] (:func:`rubber_law`).
    cap : ndarray of bool, shape (n_el,)
        The cap's elements (:func:`cap_elements`); not read for one law.

    Returns
    -------
    fem.material.IsochoricI1Material
        :func:`rubber_law` of ``rubber``, or a :class:`fem.material.ElementwiseMaterial` of
        (body, cap) laws with group 1 on ``cap``.
    """
    from fem.material import ElementwiseMaterial

    body = rubber_law(rubber, c10, d1)
    if cap_rubber in ("same", rubber):
        return body
    return ElementwiseMaterial((body, rubber_law(cap_rubber, c10, d1)), np.asarray(cap, dtype=bool).astype(np.int64))

#: How the base face is held (:attr:`SceneSpec.base_support`).
BASE_SUPPORTS: tuple[str, ...] = ("clamped", "sliding")
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
        ``cap_rubber`` differs): one of :data:`RUBBERS`, 'neo_hookean' (C10 = ``c10``, the
        default) or a two-term Yeoh fit of a named silicone (:data:`RUBBER_LAWS`). D1 = ``d1`` for all.
    cap_rubber : str
        'same' (default: the cap is of the body's rubber) or one of :data:`RUBBERS` for the
        elements of the cap, those whose centroid lies at x < c, bonded to the body.
    base_support : {'clamped', 'sliding'}
        'clamped' (default): every node of the base face fixed in x, y and z. 'sliding':
        every base node held axially, only the nodes within r ≤ D/4 also held in y and z,
        so the outer half of the base may slide radially (a softer mount).
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
        "neo_hookean", "", "rubber law of the body: 'neo_hookean' (C10, D1 of the material section) or a "
        "two-term Yeoh fit of a named silicone's published uniaxial data (docs/physics.md §1)", choices=RUBBERS)
    cap_rubber: str = parameter(
        "same", "", "rubber of the cap (elements at x < c), bonded to the body: 'same' as the body, or one of "
        "the rubber laws", choices=("same",) + RUBBERS)
    base_support: str = parameter(
        "clamped", "", "'clamped': every base node fixed; 'sliding': the base held axially, only its inner "
        "half (r ≤ D/4) also held radially", choices=BASE_SUPPORTS)
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
            ("Q", self.Q, self.Q >= 0, ">= 0 MPa"),
            ("formulation", self.formulation, self.formulation in ("mixed", "displacement"),
             "'mixed' or 'displacement'"),
            ("n_pressure_steps", self.n_pressure_steps, self.n_pressure_steps >= 1, ">= 1"),
            ("n_deflection_steps", self.n_deflection_steps, self.n_deflection_steps >= 1, ">= 1"),
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
