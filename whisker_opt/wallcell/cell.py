"""A periodic cell of the fibre-wound chamber wall: axisymmetric pressurisation and the n = 1 bending about it.

The chamber wall is a tube of inner radius r_i and thickness t wound with fibres; the double helix rises a
few degrees from the hoop, so the cell models its turns as rings of the fibre's section at radius r_f,
``s`` apart (pitch / number of fibres). A ring-periodic tube has mirror planes half-way between rings, so
the cell Z ∈ [0, s] (ring at Z = s/2) with those planes kept plane is the infinite wall exactly, under
inflation and under pure bending alike:

1. **Pressurisation** (axisymmetric, :class:`fem.axisym.harmonic.HarmonicSolid`): follower pressure Q on the
   cavity, u_z = 0 on Z = 0, a uniform axial displacement U of Z = s carrying the closed-end thrust
   N = Q π a², a the cavity radius at that plane (current: the wall's force across any section of a
   closed chamber; ``thrust='reference'`` uses r_i, as the 3-D reference cell :mod:`peers.wall_cell3d` does).
2. **Bending** (harmonic n = 1 about the pressurised state): the plane Z = s rotated by θ about an axis
   through the tube's centre (δu_z = θ x, x its current or reference distance from the axis), Z = 0 held,
   one hoop pin against the rigid translation. EI = s M/θ with M the moment work-conjugate to θ: the
   bending stiffness per reference length s of the whole tube [N mm²].
3. **Readings**: ε_z = U/s; the outer surface's radial growth at the ring and at mid-gap; the gauge
   transfer g = ε_g/(κ r_o), ε_g the change of length of a 2 mm outer-surface line along the axis (the
   gauge) per its length, κ = θ/s, over every position of the gauge relative to the rings (1 for a beam
   whose plane sections stay plane).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, replace

import numpy as np

from fem.axisym.harmonic import HarmonicSolid, HoopFibre, Region
from fem.axisym.harmonic_solve import AxisymmetricPath, EndThrust, Reduction, harmonic_response
from fem.axisym.meshgen2d import QuadMesh, grid_mesh, inclusion_mesh
from fem.axisym.quad9 import line_shape
from fem.material import NeoHookean
from fem.newton import SolveFailed
from geometry.materials import FIBRE_DIAMETER
from whisker_opt.experiment.rubber_laws import rubber_law
from whisker_opt.wall.law import mid_chamber_x
from whisker_opt.wallcell.mechanisms import WallMechanism

log = logging.getLogger(__name__)

#: Pressures of the study [MPa].
PRESSURES = (0.0, 0.05, 0.1, 0.15, 0.2)
GAUGE_LENGTH = 2.0  # mm


@dataclass(frozen=True)
class WallGeometry:
    """The wall of one chamber station [mm]: cavity radius, thickness, ring spacing, fibre section, fibre radius."""

    r_i: float
    t: float
    s: float = 1.5
    fibre_diameter: float = FIBRE_DIAMETER
    r_f: float | None = None  # None: mid-wall

    def __post_init__(self) -> None:
        a = self.fibre_diameter / 2
        if not (self.r_i > 0 and self.t > 0 and self.s > 2.2 * a and a > 0):
            raise ValueError(f"WallGeometry: r_i={self.r_i}, t={self.t}, s={self.s}, fibre_diameter="
                             f"{self.fibre_diameter}: need r_i, t > 0 and s > 1.1 fibre diameters")
        if not (self.r_i + 1.05 * a <= self.fibre_r <= self.r_o - 1.05 * a):
            raise ValueError(f"WallGeometry.r_f={self.fibre_r:.4g} leaves no rubber around the fibre in "
                             f"[{self.r_i}, {self.r_o}]")

    @property
    def r_o(self) -> float:
        return self.r_i + self.t

    @property
    def fibre_r(self) -> float:
        return self.r_i + self.t / 2 if self.r_f is None else self.r_f

    @property
    def fibre_area(self) -> float:
        return math.pi * self.fibre_diameter**2 / 4

    @classmethod
    def of_design(cls, design, x: float | None = None) -> "WallGeometry":
        """The wall of ``design`` (geometry.design.WhiskerDesign) at axial station x (mid-chamber by default)."""
        x = mid_chamber_x(design) if x is None else x
        return cls(r_i=float(design.r_inner(x)), t=float(design.t), s=design.fibre_pitch / design.n_fibres,
                   fibre_diameter=design.fibre_diameter, r_f=float(design.r_fibre(x)))


@dataclass(frozen=True)
class Resolution:
    """Mesh of the cell at refinement ``level`` (every count below times level).

    ``grid``: the 3-D reference cell's grid (:mod:`peers.wall_cell3d`, square section only): 5, 2, 5 cells across the wall
    and 3, 2, 3 along it at level 1.
    """

    level: int = 2
    n_quarter: int = 4
    n_core: int = 2
    n_gap: int = 4
    n_side: int = 3
    n_layer: int = 1
    grid: bool = False


def cell_mesh(geo: WallGeometry, mech: WallMechanism, res: Resolution) -> QuadMesh:
    """The cell's Q9 mesh: regions 'fibre', 'layer' (if any), 'inner' and 'outer' rubber (split at r_f)."""
    a, rf, zc = geo.fibre_diameter / 2, geo.fibre_r, geo.s / 2
    names = ("fibre", "layer", "inner", "outer")
    if mech.section in ("square", "band"):
        h = math.sqrt(geo.fibre_area) / 2
        if res.grid:
            counts_r, counts_z, br, bz = [5, 2, 5], [3, 2, 3], [0.0] * 3, [0.0] * 3
        else:
            counts_r, counts_z = [res.n_side + 2, res.n_core, res.n_side + 2], [res.n_gap, res.n_core, res.n_gap]
            br, bz = [-1.5, 0.0, 1.5], [-1.5, 0.0, 1.5]
        if mech.bond == "layer" and not res.grid:
            raise ValueError("cell_mesh: a layer around a square section is one cell of the 3-D cell's grid "
                             "(Resolution(grid=True))")
        dr = (rf - h - geo.r_i) / (counts_r[0] * res.level)  # the grid cells next to the fibre
        dz = (zc - h) / (counts_z[0] * res.level)

        def inside(r, z):
            if abs(r - rf) < h and (mech.section == "band" or abs(z - zc) < h):
                return "fibre"
            if mech.bond == "layer" and abs(r - rf) < h + dr and abs(z - zc) < h + dz:
                return "layer"
            return "inner" if r < rf else "outer"

        return grid_mesh([geo.r_i, rf - h, rf + h, geo.r_o], [0.0, zc - h, zc + h, geo.s], counts_r, counts_z,
                         level=res.level, r_betas=br, z_betas=bz, inside=inside, region_names=names)
    rings = (a + mech.layer_thickness,) if mech.bond == "layer" else ()
    region_names = ("fibre", "layer", "matrix") if rings else ("fibre", "matrix")
    m = inclusion_mesh(geo.r_i, geo.r_o, geo.s, rf, a, rings=rings, level=res.level, n_quarter=res.n_quarter,
                       n_core=res.n_core, n_ring=res.n_layer, n_gap=res.n_gap, n_side=res.n_side,
                       region_names=region_names)
    centre_r = m.points[m.cells[:, 8], 0]
    labels = np.array(m.region_names)[m.region]
    matrix = labels == "matrix"
    region = np.array([names.index(n) if n in names else -1 for n in labels])
    region[matrix] = np.where(centre_r[matrix] < rf, names.index("inner"), names.index("outer"))
    return QuadMesh(m.points, m.cells, region, names)


def _laws(mech: WallMechanism):
    """Law of each region name."""
    inner = rubber_law(mech.rubber, mech.c10, 0.0)
    outer = inner if mech.rubber_outer == "same" else rubber_law(mech.rubber_outer, mech.c10, 0.0)
    E, nu = mech.fibre_modulus, mech.fibre_poisson
    fibre = NeoHookean(E / (4 * (1 + nu)), 6 * (1 - 2 * nu) / E) if mech.fibre_law == "solid" else inner
    return {"fibre": fibre, "layer": NeoHookean(mech.layer_shear_modulus / 2, 0.0), "inner": inner, "outer": outer}


def cell_solid(geo: WallGeometry, mech: WallMechanism, mesh: QuadMesh) -> HarmonicSolid:
    """The cell's :class:`fem.axisym.harmonic.HarmonicSolid`: regions, hoop fibre, cavity pressure, sliding interface."""
    laws = _laws(mech)
    regions = [Region(mesh.elements_of(n), laws[n]) for n in mesh.region_names if len(mesh.elements_of(n))]
    fib = mesh.elements_of("fibre")
    k = mech.fibre_modulus
    if mech.section == "band":  # E_f A_f per ring spread over the band's section 2h × s
        k *= geo.fibre_area / (math.sqrt(geo.fibre_area) * geo.s)
    hoop = (HoopFibre(fib, k),) if mech.fibre_law == "hoop" else ()
    cavity = mesh.edges_where(lambda P: np.abs(P[:, 0] - geo.r_i) < 1e-9 * geo.r_o)
    slide = None
    if mech.bond == "sliding":
        others = np.setdiff1d(np.arange(mesh.n_elements), fib)
        iface = np.intersect1d(np.unique(mesh.cells[fib]), np.unique(mesh.cells[others]))
        slide = (fib, iface)
    return HarmonicSolid(mesh.points, mesh.cells, regions, hoop_fibres=hoop, pressure_edges=cavity, slide=slide)


class WallCell:
    """Pressurise the cell and measure its bending stiffness and gauge transfer along the way."""

    def __init__(self, geo: WallGeometry, mech: WallMechanism, res: Resolution = Resolution()) -> None:
        if mech.fibre_offset is not None:
            geo = replace(geo, r_f=geo.r_i + mech.fibre_offset)
        self.geo, self.mech, self.res = geo, mech, res
        self.mesh = cell_mesh(geo, mech, res)
        self.solid = cell_solid(geo, mech, self.mesh)
        P, tol = self.mesh.points, 1e-9 * geo.r_o
        self.bottom = np.nonzero(np.abs(P[:, 1]) < tol)[0]
        self.top = np.nonzero(np.abs(P[:, 1] - geo.s) < tol)[0]
        corner = np.nonzero((np.abs(P[:, 1] - geo.s) < tol) & (np.abs(P[:, 0] - geo.r_i) < tol))[0][0]
        self.pin = np.nonzero((np.abs(P[:, 1]) < tol) & (np.abs(P[:, 0] - geo.r_i) < tol))[0][0]
        size = self.solid.n_u0 + 3 * self.solid.n_el
        red = Reduction(size, 2 * self.bottom + 1, ties=(2 * self.top + 1,))
        thrust = EndThrust(0, geo.r_i, 2 * corner, current=mech.thrust == "current")
        self.path = AxisymmetricPath(self.solid, red, thrust)
        self.outer_edges = self.mesh.edges_where(lambda Pt: np.abs(Pt[:, 0] - geo.r_o) < tol)
        self.ring = int(np.argmin(np.hypot(P[:, 0] - geo.r_o, P[:, 1] - geo.s / 2)))  # outer node at the ring
        self.gap = int(np.argmin(np.hypot(P[:, 0] - geo.r_o, P[:, 1])))  # outer node at mid-gap
        self.y = np.zeros(self.path.n_red)
        self.Q = 0.0
        self._previous = None  # the equilibrium before (y, Q), for the next increment's predictor

    @property
    def x(self) -> np.ndarray:
        return self.path.full(self.y)

    def pressurise(self, Q: float, steps: int | None = None) -> None:
        """Follow the path to pressure Q (MPa), in steps of at most 0.025 MPa."""
        steps = steps or max(1, math.ceil(abs(Q - self.Q) / 0.025))
        self.y, self.Q, self._previous = self.path.follow(self.y, self.Q, Q, steps, previous=self._previous)

    def readings(self) -> dict:
        """EI, ε_z, radial growth and the gauge transfer at the current pressure."""
        geo, x = self.geo, self.x
        u = x[: self.solid.n_u0].reshape(-1, 2)
        r_plane = self.mesh.points[self.top, 0] + (u[self.top, 0] if self.mech.plane == "current" else 0.0)
        fixed = np.concatenate([3 * self.bottom + 1, 3 * self.top + 1, [3 * self.pin + 2]])
        vals = np.concatenate([np.zeros(len(self.bottom)), r_plane, [0.0]])
        yh, f, _ = harmonic_response(self.solid, 1, x, self.Q, fixed, vals)
        M = float(f[3 * self.top + 1] @ r_plane)
        amp = yh[: 3 * self.mesh.n_nodes].reshape(-1, 3)
        g = gauge_transfer(self.mesh, self.outer_edges, u, amp[:, :2], geo.s, geo.r_o)
        return {"Q": self.Q, "EI": geo.s * M, "ez": float(x[2 * self.top[0] + 1]) / geo.s,
                "ur_ring": float(u[self.ring, 0]), "ur_gap": float(u[self.gap, 0]), "g": float(np.mean(g)),
                "g_min": float(np.min(g)), "g_max": float(np.max(g))}

    def sweep(self, pressures=PRESSURES, stop_on_failure: bool = False) -> list[dict]:
        """Readings at each pressure (increasing), with the time since the start in 't_s'.

        With ``stop_on_failure`` a pressure the path cannot reach (the wall balloons past its limit point)
        ends the sweep with the readings so far, the failure logged; otherwise it raises.
        """
        t0 = time.perf_counter()
        rows = []
        for Q in pressures:
            try:
                self.pressurise(Q)
            except SolveFailed as exc:
                if not stop_on_failure:
                    raise
                log.warning("wall cell %s: Q = %.3g MPa not reached (%s)", self.mech.name, Q, exc)
                break
            row = self.readings()
            row["t_s"] = time.perf_counter() - t0
            rows.append(row)
            log.info("wall cell %s level %d: Q = %.3g MPa, EI = %.6g N mm², eps_z = %.5g (%.1f s)", self.mech.name,
                     self.res.level, Q, row["EI"], row["ez"], row["t_s"])
        return rows


def gauge_transfer(mesh: QuadMesh, edges: np.ndarray, u: np.ndarray, du: np.ndarray, s: float, r_o: float,
                   length: float = GAUGE_LENGTH, n_positions: int = 16, n_sub: int = 24) -> np.ndarray:
    """g = ε_g / (κ r_o) of a gauge of ``length`` on the outer surface, at ``n_positions`` starts in [0, s).

    ε_g = ∫ δ|x'| / ∫ |x'| over the gauge (its change of length per length), with x the current outer
    line (Θ = 0) and δx the n = 1 amplitudes ``du`` (n_nodes, 2) for a unit rotation θ of the plane Z = s,
    so κ = 1/s. The cell is periodic under pure bending, so the surface is extended by periodicity.
    """
    t = np.linspace(-1.0, 1.0, n_sub + 1)
    N, dN = line_shape(t)  # (n_sub+1, 3)
    x = (mesh.points + u)[edges]  # (n_e, 3, 2)
    dx = np.einsum("qa,eai->eqi", dN, x)  # (n_e, q, 2)
    ddx = np.einsum("qa,eai->eqi", dN, du[edges])  # (n_e, q, 2)
    speed = np.linalg.norm(dx, axis=-1)  # (n_e, q)
    dlen = np.einsum("eqi,eqi->eq", dx, ddx) / speed  # (n_e, q)
    Z = np.einsum("qa,ea->eq", N, mesh.points[edges][..., 1])  # (n_e, q)
    order = np.argsort(Z[:, 0])
    Z, speed, dlen = Z[order], speed[order], dlen[order]
    dZ = np.diff(Z, axis=1)
    seg_len = 0.5 * (speed[:, 1:] + speed[:, :-1]) * (t[1] - t[0])  # trapezoids in the edge's own coordinate
    seg_d = 0.5 * (dlen[:, 1:] + dlen[:, :-1]) * (t[1] - t[0])
    if np.any(dZ <= 0):
        raise ValueError("gauge_transfer: the outer edges are not monotone in Z")
    zs = np.concatenate([[Z[0, 0]], Z[:, 1:].ravel()])
    L = np.concatenate([[0.0], np.cumsum(seg_len.ravel())])
    D = np.concatenate([[0.0], np.cumsum(seg_d.ravel())])

    def cum(zq, arr):  # periodic cumulative integral
        k = np.floor(zq / s)
        return k * arr[-1] + np.interp(zq - k * s, zs, arr)

    z1 = np.linspace(0.0, s, n_positions, endpoint=False)
    z2 = z1 + length
    eps = (cum(z2, D) - cum(z1, D)) / (cum(z2, L) - cum(z1, L))
    return eps * s / r_o
