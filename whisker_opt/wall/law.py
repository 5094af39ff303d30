"""The chamber wall's law in the whisker scene: how pressure changes the wall's stiffness in bending.

The 3-D scene carries the fibre winding as embedded trusses (:mod:`geometry.fibres`). On the GA's mesh
these give the chamber wall the bending stiffness of a perfectly bonded wall under pressure: the
periodic wall cell with embedded lines (``benchmarks/studies/fibre_cell.py``) reproduces the converged bonded
cell (:mod:`whisker_opt.wallcell.cell`, the ``bonded`` entries of the stored table) within the tolerances
measured in ``benchmarks/results/wall_law.md`` ("The wall law in the whisker scene"). A *wall law* is a named
statement of what the wall does instead, applied as a correction of the wall's incremental stiffness
about the pressurised state (the pressurisation itself, and so the extension Δl(Q), stays the
embedded model's)::

    W_wall = c(Q) W̄(C) − ½ (c(Q) − 1) S̄_p : (C − I)          on the chamber's elements

with W̄ the rubber's isochoric energy and S̄_p its stress in the pressurised state p
(:class:`fem.material.ScaledMaterial`, :mod:`fem.frozen_stress`). At the pressurised state the stress is
unchanged (equilibrium is kept exactly) and the wall's incremental material stiffness is c(Q) times the
rubber's: the wall's bending stiffness EI(Q) scales by c(Q) where the rubber carries it, which the same
cell checks. The laws (:data:`WALL_LAWS`):

``embedded`` (default)
    c ≡ 1: the embedded trusses as meshed, i.e. the perfectly bonded wall.
``sliding``
    c(Q) = EI_sliding(Q) / EI_bonded(Q) of the stored table (:mod:`whisker_opt.wall.table`), interpolated
    over the wall's (r_i, t) at mid-chamber and linearly in Q: fibres free to slide along their
    channels in the rubber. Its extension equals the bonded wall's, so Δl is unchanged by construction.
``calibrated``
    c(Q) = 1 + s Q with the slope s = ``material.wall_slope`` [1/MPa], a parameter that
    ``whisker-opt calibrate`` fits to a prototype's readings (docs/calibration.md); s = 0 is
    ``embedded``. A fitted s is a property of that prototype, with its data source in
    ``calibrated.yaml``.

A law other than ``embedded`` is opt-in: ``material.wall_law``. The stress of a state it solved (the result
files, ``von_mises_max``) is this law's, frozen stress included (:func:`apply_law`,
:func:`fem.post.problem_strain_stress`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from geometry.design import WhiskerDesign


@dataclass(frozen=True)
class LawInfo:
    """One registered wall law: its meaning and its data source (shown by ``whisker-opt explain``)."""

    name: str
    meaning: str
    source: str
    table_variant: str | None = None


#: The registered wall laws (``material.wall_law``).
WALL_LAWS: dict[str, LawInfo] = {
    "embedded": LawInfo(
        "embedded", "the embedded fibre trusses as meshed (a perfectly bonded wall)",
        "the periodic wall cell with embedded lines against the converged bonded cell "
        "(benchmarks/results/wall_law.md)"),
    "sliding": LawInfo(
        "sliding", "fibres that slide along their channels: the stored table's EI_sliding/EI_bonded at the "
        "wall's (r_i, t)", "whisker_opt/wall/data/wall_law.json, variant 'sliding' (benchmarks/studies/wall_law.py)",
        table_variant="sliding"),
    "calibrated": LawInfo(
        "calibrated", "c(Q) = 1 + s·Q with s = material.wall_slope",
        "a fit of material.wall_slope to a prototype's readings (whisker-opt calibrate), or the user's value"),
}
WALL_LAW_NAMES: tuple[str, ...] = tuple(WALL_LAWS)

#: Allowed slopes s [1/MPa] of the calibrated law: c(0.2 MPa) ≥ 0.1 at the lower end. A scene whose
#: c(Q) = 1 + s Q falls below :data:`MIN_FACTOR` is refused (:meth:`WallLaw.factor`).
SLOPE_RANGE = (-4.5, 10.0)
MIN_FACTOR = 0.05


def mid_chamber_x(design: WhiskerDesign) -> float:
    """The axial station of mid-chamber, x = (c + l)/2 [mm]: where a table law reads the wall, the wall cell
    stands by default and the scene measures the chamber's radial growth.

    Parameters
    ----------
    design : geometry.design.WhiskerDesign

    Returns
    -------
    float
    """
    return 0.5 * (design.c + design.l)


def mid_chamber_wall(design: WhiskerDesign) -> tuple[float, float]:
    """(r_i, t) of the wall at mid-chamber x = (c + l)/2 [mm] (:func:`mid_chamber_x`): the point at which a
    table law is read."""
    return float(design.r_inner(mid_chamber_x(design))), float(design.t)


@lru_cache(maxsize=1)
def _table():
    from whisker_opt.wall.table import WallTable

    return WallTable.load()


@dataclass(frozen=True)
class WallLaw:
    """A wall law with its parameters (see the module docstring).

    Parameters
    ----------
    name : str
        One of :data:`WALL_LAW_NAMES`.
    slope : float
        s [1/MPa] of ``calibrated``; must be 0 for the other laws.
    """

    name: str = "embedded"
    slope: float = 0.0

    def __post_init__(self) -> None:
        if self.name not in WALL_LAWS:
            raise ValueError(f"material.wall_law={self.name!r}: must be one of {', '.join(map(repr, WALL_LAW_NAMES))}")
        if not (math.isfinite(self.slope) and SLOPE_RANGE[0] <= self.slope <= SLOPE_RANGE[1]):
            raise ValueError(f"material.wall_slope={self.slope!r}: must lie in [{SLOPE_RANGE[0]}, {SLOPE_RANGE[1]}] 1/MPa")
        if self.slope != 0.0 and self.name != "calibrated":
            raise ValueError(f"material.wall_slope={self.slope!r} is read only by material.wall_law 'calibrated' "
                             f"(the law is {self.name!r}); set it to 0 or choose 'calibrated'")

    def describe(self) -> str:
        """The law in words: ``embedded (the embedded fibre trusses as meshed, ...)``, or for
        ``calibrated`` its c(Q) with the slope, e.g. ``calibrated: c(Q) = 1 + 0.5·Q (material.wall_slope
        = 0.5 1/MPa)``."""
        if self.name == "calibrated":
            same = ", the same as 'embedded'" if self.slope == 0.0 else ""
            return f"calibrated: c(Q) = 1 + {self.slope:g}·Q (material.wall_slope = {self.slope:g} 1/MPa{same})"
        return f"{self.name} ({WALL_LAWS[self.name].meaning})"

    @property
    def identity(self) -> bool:
        """True when the law changes nothing (c ≡ 1)."""
        return self.name == "embedded" or (self.name == "calibrated" and self.slope == 0.0)

    def gauge_transfer(self, Q: float, design: WhiskerDesign) -> float:
        """G(Q) = g(Q) (1 + ε_z(Q)) of the stored wall cell: the outer surface's strain per unit section
        curvature (curvature per current length) of ``design``'s wall at mid-chamber under pressure Q.

        g is the cell's gauge transfer per reference length, the mean over the gauge's positions relative to
        the fibre rings, and ε_z its axial strain (docs/physics.md §14), of the law's own table variant
        (``bonded`` for ``embedded`` and ``calibrated``, whose scaling changes the wall's stiffness and not the
        kinematics of its surface), interpolated over (r_i, t) and by a not-a-knot cubic in Q. G(0) = 1.

        Raises
        ------
        ValueError
            A wall or a pressure outside the table, naming the range.
        """
        from scipy.interpolate import CubicSpline

        table = _table()
        qs = np.asarray(table.pressures, float)
        if not (qs[0] - 1e-12 <= Q <= qs[-1] + 1e-12):
            raise ValueError(f"the gauge's wall transfer: Q = {Q:g} MPa outside the wall table's "
                             f"[{qs[0]:g}, {qs[-1]:g}] MPa")
        variant = WALL_LAWS[self.name].table_variant or "bonded"
        r_i, t = mid_chamber_wall(design)
        G = table.lookup(variant, "g", r_i, t) * (1.0 + table.lookup(variant, "ez", r_i, t))
        return float(CubicSpline(qs, G)(min(max(Q, qs[0]), qs[-1])))

    def factor(self, Q: float, design: WhiskerDesign) -> float:
        """c(Q) for ``design``'s wall (see the module docstring).

        Raises
        ------
        ValueError
            A table law at a wall or a pressure outside the table, naming the range.
        """
        if self.identity:
            return 1.0
        if self.name == "calibrated":
            c = 1.0 + self.slope * float(Q)
            if c < MIN_FACTOR:
                raise ValueError(f"material.wall_slope={self.slope!r}: c(Q) = 1 + s·Q = {c:.3g} at Q = {Q:g} MPa, "
                                 f"below {MIN_FACTOR} (a wall without stiffness); use s > {(MIN_FACTOR - 1) / Q:.3g}")
            return c
        table = _table()
        r_i, t = mid_chamber_wall(design)
        qs = np.asarray(table.pressures, float)
        variant = WALL_LAWS[self.name].table_variant
        if not (qs[0] - 1e-12 <= Q <= qs[-1] + 1e-12):
            raise ValueError(f"Q = {Q:g} MPa: outside the {variant!r} table, {table.span(variant)}")
        ei = table.lookup(variant, "EI", r_i, t)
        ei_b = table.lookup("bonded", "EI", r_i, t)
        return float(np.interp(Q, qs, ei / ei_b))


def chamber_elements(points: np.ndarray, cells: np.ndarray, design: WhiskerDesign) -> np.ndarray:
    """Indices of the elements whose centroid (mean of the four corners) lies in the chamber's axial
    range c < x < l, i.e. the chamber wall's elements (the chamber is empty)."""
    x = points[cells[:, :4], 0].mean(axis=1)  # (n_el,)
    return np.nonzero((x > design.c) & (x < design.l))[0]


def _isochoric_pk2(material, F: np.ndarray) -> np.ndarray:
    """The law's isochoric second Piola–Kirchhoff stress S̄ = F⁻¹ P̄(F), symmetric to round-off.

    Parameters
    ----------
    material : fem.material.IsochoricI1Material
        With one row per row of ``F`` when it differs by element or node.
    F : ndarray, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    G = np.linalg.inv(F)  # (..., 3, 3)
    P = material.stress_tangent(F, G, np.linalg.det(F), need_tangent=False)[0]  # (..., 3, 3)
    S = np.matmul(G, P)  # (..., 3, 3)  S̄ = F⁻¹ P̄
    return 0.5 * (S + np.swapaxes(S, -1, -2))


def apply_law(problem, state, c: float, elements: np.ndarray):
    """``problem`` with its wall's incremental material stiffness about ``state`` multiplied by ``c``.

    Parameters
    ----------
    problem : fem.problem.Problem
        The deflection problem (its material is the rubber of the pressurised state).
    state : fem.state.State
        The pressurised state p (the reference state when Q = 0).
    c : float
        c(Q) > 0 (:meth:`WallLaw.factor`).
    elements : ndarray of int
        The wall's elements (:func:`chamber_elements`).

    Returns
    -------
    fem.problem.Problem
        The rubber's moduli × c on ``elements`` (:class:`fem.material.ScaledMaterial`) and the frozen
        stress −(c − 1) S̄_p there (:class:`fem.problem.FrozenStress`), S̄_p = F⁻¹ P̄ the rubber's
        isochoric second Piola–Kirchhoff stress at p; the same problem when c = 1. The frozen stress
        at the nodes, for the stress of a solved state (:func:`fem.post.problem_strain_stress`), is
        the same law at the nodal deformation of p (:func:`fem.post.nodal_deformation_gradient`),
        −(c_n − 1) S̄(F_p,n) with c_n the nodal factor of the scaled law
        (:meth:`fem.material.ScaledMaterial.at_nodes`): at p the nodal stress is the rubber's, as
        it is at the quadrature points.
    """
    from dataclasses import replace

    from fem import post
    from fem.assembly import Assembler
    from fem.material import ScaledMaterial
    from fem.problem import FrozenStress

    if not (math.isfinite(c) and c > 0):
        raise ValueError(f"wall law: c = {c!r} must be finite and > 0")
    if c == 1.0 or len(elements) == 0:
        return problem
    mat, mesh = problem.material, problem.mesh
    F = Assembler(problem).deformation(state.u)[0]  # (n_el, n_qp, 3, 3)
    S = _isochoric_pk2(mat, F)[elements]  # (n_sel, n_qp, 3, 3)
    factor = np.ones(mesh.n_elements)
    factor[elements] = c
    scaled = ScaledMaterial(mat, factor)
    F_n, used = post.nodal_deformation_gradient(mesh.points, mesh.cells, state.u)  # (k, 3, 3)
    at_nodes = scaled.at_nodes(mesh.cells, used)
    T_n = -(at_nodes.factor - 1.0)[:, None, None] * _isochoric_pk2(at_nodes.base, F_n)  # (k, 3, 3)
    return replace(problem, material=scaled,
                   frozen_stresses=(FrozenStress(elements, -(c - 1.0) * S, name="wall law",
                                                 nodal=post.spread_to_nodes(T_n, used, fill=0.0)),))
