"""The chamber wall's law in the whisker scene: how pressure changes the wall's stiffness in bending.

The 3-D scene carries the fibre winding as embedded trusses (:mod:`geometry.fibres`). On the GA's mesh
these give the chamber wall the bending stiffness of a perfectly bonded wall under pressure: the
periodic wall cell with embedded lines (``benchmarks/studies/fibre_cell.py``) reproduces the converged bonded
cell (:mod:`whisker_opt.wall.cell`, the ``bonded`` entries of the stored table) within the tolerances
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

A law other than ``embedded`` is opt-in: ``material.wall_law``.
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


def mid_chamber_wall(design: WhiskerDesign) -> tuple[float, float]:
    """(r_i, t) of the wall at mid-chamber x = (c + l)/2 [mm]: the point at which a table law is read."""
    x = 0.5 * (design.c + design.l)
    return float(design.r_outer(x) - design.t), float(design.t)


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

    @property
    def identity(self) -> bool:
        """True when the law changes nothing (c ≡ 1)."""
        return self.name == "embedded" or (self.name == "calibrated" and self.slope == 0.0)

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
        isochoric second Piola–Kirchhoff stress at p; the same problem when c = 1.
    """
    from dataclasses import replace

    from fem.assembly import Assembler
    from fem.material import ScaledMaterial
    from fem.problem import FrozenStress

    if not (math.isfinite(c) and c > 0):
        raise ValueError(f"wall law: c = {c!r} must be finite and > 0")
    if c == 1.0 or len(elements) == 0:
        return problem
    mat = problem.material
    F, J, G = Assembler(problem).deformation(state.u)  # (n_el, n_qp, 3, 3), (n_el, n_qp), (n_el, n_qp, 3, 3)
    P_iso = mat.stress_coefficients(F, G, J)[0]  # (n_el, n_qp, 3, 3)
    S = np.matmul(G[elements], P_iso[elements])  # (n_sel, n_qp, 3, 3)  S̄ = F⁻¹ P̄
    S = 0.5 * (S + np.swapaxes(S, -1, -2))  # symmetric to round-off
    factor = np.ones(problem.mesh.n_elements)
    factor[elements] = c
    return replace(problem, material=ScaledMaterial(mat, factor),
                   frozen_stresses=(FrozenStress(elements, -(c - 1.0) * S, name="wall law"),))
