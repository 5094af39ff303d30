"""A 3-D periodic cell of the chamber wall: an independent formulation the 2-D wall cell is checked against.

The project's model of the chamber wall is the axisymmetric cell of :mod:`whisker_opt.wallcell.cell` (the
pressurised ring-periodic wall and its n = 1 bending on :mod:`fem.axisym`). This module builds the same wall
as a 3-D solid of 10-node tets on :mod:`fem` (the solver of the whisker scene), so that the 2-D cell can be
compared with a different discretisation and a different way of bending it, as the CalculiX peer
(:mod:`peers.calculix`) checks the 3-D solver. It takes the wall's geometry from
:class:`whisker_opt.wallcell.cell.WallGeometry` and the materials' constants from :mod:`geometry.materials`.
Users: ``tests/test_fibre_cell.py``, ``tests/test_fem_harmonic.py``, ``benchmarks/studies/fibre_cell.py`` and
``benchmarks/studies/wall_law.py`` (``cross3d``, ``scenecheck``).

The chamber wall of the default design (cavity radius 5.6 mm, wall 3 mm, fibres of 0.38 mm at mid-wall,
1.5 mm apart) is modelled as a straight tube of fibre *rings* (the double helix of pitch 3 mm rises 4° from
the hoop; its rings keep the fibres' spacing, radius and cross-section). A ring-periodic tube has mirror
planes half-way between two rings, so one cell from mid-gap to mid-gap (z = 0 … s, s = 1.5 mm, ring at
z = s/2) with those planes kept plane is the infinite wall exactly, under extension and pure bending alike.
Half the tube is modelled (y ≥ 0, mirror plane y = 0).

Loads, as the chamber of a whisker carries them away from its ends: a follower pressure Q on the cavity
and the closed-end thrust N = Q π r_i² (half of it on the half tube), applied by finding the uniform
axial displacement U of the plane z = s that carries it (secant iterations); then a small rotation ±θ of
that plane about the y axis gives the bending stiffness EI = s·dM/dθ about the pressurised state. In the
2-D cell's terms these are ``thrust='reference'`` and ``plane='reference'`` of
:class:`whisker_opt.wallcell.mechanisms.WallMechanism`.

Fibre models on the same cell:

* ``resolved``: the fibre's cross-section is meshed (a square of the fibre's area, 0.337 mm); its elements
  carry the fibre's modulus along the ring on top of the rubber (``SmearedFibres`` with k = E_f). The
  fibre is axially stiff and bends as a beam but its section deforms as rubber does;
* ``resolved-rigid``: the same elements stiff in nine directions (hoop, radial, axial and the diagonals
  of each pair), a section that does not deform, as a nylon fibre does not against the rubber;
* ``weak-ring``: ``resolved`` with the ring of grid cells around the fibre's square of rubber ten times
  softer (a weak interphase one element thick);
* ``band``: the ring's E_f A_f spread along the hoop over a thin band |r − r_f| < side/2 the whole length of
  the cell (a continuous sleeve in place of the discrete ring);
* ``embedded``: a truss ring whose points move with their host tets, as ``material.fibre_model:
  embedded`` (segments of min(h/2, 0.5) mm, E_f A_f);
* ``smeared``: the ring's stiffness spread uniformly over the wall, k = E_f A_f r_f /(s · t · r), one
  fibre strain per element, as ``material.fibre_model: smeared``;
* ``none``: the rubber tube alone.
"""


from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np

from fem.assembly import Assembler
from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.mesh import TetMesh, boundary_faces, mapped_points
from fem.meshgen import box_mesh
from fem.newton import SolveFailed
from fem.problem import Dirichlet, EmbeddedTrusses, FollowerPressure, Problem, SmearedFibres
from fem.quadrature import tet_rule
from fem.state import State
from geometry.design import WhiskerDesign
from geometry.locate import PointLocator
from geometry.materials import FIBRE_MODULUS, RUBBER_C10
from whisker_opt.wallcell.cell import WallGeometry
from whisker_opt.wallcell.mechanisms import WallMechanism

log = logging.getLogger(__name__)

#: This cell's model as a mechanism of the 2-D cell: the ``resolved`` fibre (a square of the fibre's area,
#: rubber carrying E_f along the hoop), the thrust on the reference cavity area, the end plane rotated about
#: reference positions. The 2-D cell of it is the one to set beside this cell.
MECHANISM = WallMechanism(name="cell3d", section="square", fibre_law="hoop", thrust="reference", plane="reference")

#: Pressures of the fibre-model study [MPa].
PRESSURES = (0.1, 0.2)
THETA = 1e-3  # rad, rotation of the plane z = s for the bending stiffness
TOL = 1e-9


@dataclass(frozen=True)
class Cell:
    """The 3-D cell of one wall: its geometry and the materials' constants.

    Parameters
    ----------
    geo : WallGeometry
        Cavity radius, thickness, ring spacing, fibre diameter and radius [mm] (the 2-D cell's own).
    E_f : float
        Young's modulus of the fibre [MPa].
    c10 : float
        Neo-Hookean C10 of the rubber [MPa].
    """

    geo: WallGeometry
    E_f: float = FIBRE_MODULUS
    c10: float = RUBBER_C10

    @classmethod
    def default(cls) -> "Cell":
        """The default design's wall at mid-chamber."""
        d = WhiskerDesign()
        return cls(WallGeometry.of_design(d), E_f=d.fibre_E)

    @classmethod
    def at(cls, r_i: float, t: float) -> "Cell":
        """The default cell's fibre, spacing and rubber on the wall (r_i, t), fibre at mid-wall."""
        g = cls.default().geo
        return cls(WallGeometry(r_i=r_i, t=t, s=g.s, fibre_diameter=g.fibre_diameter))

    @property
    def r_i(self) -> float:
        return self.geo.r_i

    @property
    def t(self) -> float:
        return self.geo.t

    @property
    def r_o(self) -> float:
        return self.geo.r_o

    @property
    def r_f(self) -> float:
        return self.geo.fibre_r

    @property
    def s(self) -> float:
        return self.geo.s

    @property
    def A_f(self) -> float:
        return self.geo.fibre_area

    @property
    def side(self) -> float:
        """Side of the square of the fibre's area, the section the resolved models mesh [mm]."""
        return math.sqrt(self.A_f)


def _segments(bounds: list[float], counts: list[int]) -> np.ndarray:
    """Grid coordinates: each interval [bounds[k], bounds[k+1]] split into counts[k] equal cells."""
    pts = [np.linspace(a, b, n + 1)[:-1] for a, b, n in zip(bounds, bounds[1:], counts)]
    return np.concatenate(pts + [np.array([bounds[-1]])])


def cell_mesh(cell: Cell, r_grid: np.ndarray, z_grid: np.ndarray, n_phi: int) -> TetMesh:
    """Half tube (0 ≤ φ ≤ π) on the given r and z grid lines, n_phi cells around, curved P2 edges."""
    base = box_mesh(1.0, 1.0, 1.0, len(r_grid) - 1, n_phi, len(z_grid) - 1)

    def fn(p):
        r = np.interp(p[:, 0], np.linspace(0, 1, len(r_grid)), r_grid)
        z = np.interp(p[:, 2], np.linspace(0, 1, len(z_grid)), z_grid)
        phi = math.pi * p[:, 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)

    return TetMesh(fn(base.points), base.cells)


def resolved_grids(cell: Cell, level: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid lines through the edges of the fibre's square; level 1 cuts it into 2 × 2 cells."""
    a = cell.side / 2
    zc = cell.s / 2
    m_f, m_g, m_w = 2 * level, 3 * level, 5 * level
    r_grid = _segments([cell.r_i, cell.r_f - a, cell.r_f + a, cell.r_o], [m_w, m_f, m_w])
    z_grid = _segments([0.0, zc - a, zc + a, cell.s], [m_g, m_f, m_g])
    return r_grid, z_grid


def uniform_grids(cell: Cell, n_r: int) -> tuple[np.ndarray, np.ndarray]:
    """n_r layers through the wall and about cubic cells along z (as the whisker's swept levels)."""
    n_z = max(1, round(n_r * cell.s / cell.t))
    return np.linspace(cell.r_i, cell.r_o, n_r + 1), np.linspace(0.0, cell.s, n_z + 1)


def _quadrature_points(mesh: TetMesh, degree: int) -> np.ndarray:
    return mapped_points(mesh.points, mesh.cells, tet_rule(degree).points)  # (n_el, n_qp, 3)


def _frame(Xq: np.ndarray) -> dict[str, np.ndarray]:
    """Unit hoop, radial and axial directions at the points Xq (..., 3)."""
    phi = np.arctan2(Xq[..., 1], Xq[..., 0])
    zero = np.zeros_like(phi)
    return {"h": np.stack([-np.sin(phi), np.cos(phi), zero], -1), "r": np.stack([np.cos(phi), np.sin(phi), zero], -1),
            "z": np.stack([zero, zero, zero + 1.0], -1)}


def resolved_fields(cell: Cell, mesh: TetMesh, degree: int, rigid: bool) -> tuple[SmearedFibres, ...]:
    """k = E_f along the ring (and, if ``rigid``, along eight more directions) in the fibre's elements."""
    X = mesh.points[mesh.cells[:, :4]].mean(axis=1)
    r, z = np.hypot(X[:, 0], X[:, 1]), X[:, 2]
    a = cell.side / 2
    el = np.nonzero((np.abs(r - cell.r_f) < a) & (np.abs(z - cell.s / 2) < a))[0]
    Xq = _quadrature_points(mesh, degree)[el]
    e = _frame(Xq)
    dirs = [e["h"]]
    if rigid:
        dirs += [e["r"], e["z"]]
        for u, v in (("h", "r"), ("h", "z"), ("r", "z")):
            dirs += [(e[u] + e[v]) / math.sqrt(2), (e[u] - e[v]) / math.sqrt(2)]
    k = np.full(Xq.shape[:2], cell.E_f)
    return tuple(SmearedFibres(el, k, d, name=f"fibre {i}") for i, d in enumerate(dirs))


def smeared_field(cell: Cell, mesh: TetMesh, degree: int, scale: float = 1.0) -> SmearedFibres:
    """The ring's axial stiffness E_f A_f · 2π r_f per length s spread uniformly over the wall (k ∝ 1/r),
    times ``scale`` (1 = the product's smeared model; other values test a softer homogenised wall)."""
    Xq = _quadrature_points(mesh, degree)
    r = np.hypot(Xq[..., 0], Xq[..., 1])
    k = scale * cell.E_f * cell.A_f * cell.r_f / (cell.s * cell.t * r)  # ∫ k 2πr dr dz = E_f A_f 2π r_f
    return SmearedFibres(np.arange(mesh.n_elements), k, _frame(Xq)["h"])


def embedded_ring(cell: Cell, mesh: TetMesh, h: float) -> EmbeddedTrusses:
    """The ring r = r_f, z = s/2, 0 ≤ φ ≤ π as trusses of about min(h/2, 0.5) mm in their host tets."""
    n = max(8, math.ceil(math.pi * cell.r_f / min(0.5 * h, 0.5)))
    phi = np.linspace(0.0, math.pi, n + 1)
    q = np.stack([cell.r_f * np.cos(phi), cell.r_f * np.sin(phi), np.full_like(phi, cell.s / 2)], axis=1)
    loc = PointLocator(mesh.points, mesh.cells).locate(q)
    if not np.all(loc.inside):  # curved P2 sectors of 45° (the GA's 8 sectors) on small radii need more iterations
        loc = PointLocator(mesh.points, mesh.cells).locate(q, n_newton=30)
    if not np.all(loc.inside):
        raise RuntimeError("embedded_ring: a ring point lies outside the mesh")
    seg = np.stack([np.arange(n), np.arange(1, n + 1)], axis=1)
    return EmbeddedTrusses(loc.host_elements, loc.local_coords, seg, cell.E_f, cell.A_f)


def band_field(cell: Cell, mesh: TetMesh, degree: int) -> SmearedFibres:
    """The ring's E_f A_f spread over a thin band |r − r_f| < side/2 along the whole cell, along the hoop."""
    X = mesh.points[mesh.cells[:, :4]].mean(axis=1)
    el = np.nonzero(np.abs(np.hypot(X[:, 0], X[:, 1]) - cell.r_f) < cell.side / 2)[0]
    Xq = _quadrature_points(mesh, degree)[el]
    k = np.full(Xq.shape[:2], cell.E_f * cell.A_f / (cell.side * cell.s))
    return SmearedFibres(el, k, _frame(Xq)["h"], name="band")


def weak_ring_material(cell: Cell, mesh: TetMesh, r_grid: np.ndarray, z_grid: np.ndarray, factor: float = 0.1):
    """Rubber C10 everywhere but in the ring of grid cells around the fibre's square, C10 × ``factor``."""
    from fem.material import ElementwiseMaterial

    a = cell.side / 2
    dr = np.diff(r_grid)[np.searchsorted(r_grid, cell.r_f - a) - 1]
    dz = np.diff(z_grid)[np.searchsorted(z_grid, cell.s / 2 - a) - 1]
    X = mesh.points[mesh.cells[:, :4]].mean(axis=1)
    r, z = np.hypot(X[:, 0], X[:, 1]), X[:, 2]
    near = (np.abs(r - cell.r_f) < a + dr) & (np.abs(z - cell.s / 2) < a + dz)
    fibre = (np.abs(r - cell.r_f) < a) & (np.abs(z - cell.s / 2) < a)
    return ElementwiseMaterial((NeoHookean(cell.c10, 0.0), NeoHookean(cell.c10 * factor, 0.0)),
                               (near & ~fibre).astype(np.int64))


def cell_problem(cell: Cell, mesh: TetMesh, trusses=(), fields=(), material=None) -> tuple[Problem, np.ndarray]:
    """Mirror planes y = 0 and z = 0, prescribed u_z on z = s, one u_x pin, pressure on the cavity."""
    X = mesh.points
    R = np.hypot(X[:, 0], X[:, 1])
    _, _, f6 = boundary_faces(mesh.cells)
    inner = f6[np.all(np.abs(R[f6] - cell.r_i) < 1e-6, axis=1)]
    top = np.nonzero(np.abs(X[:, 2] - cell.s) < TOL)[0]
    pin = np.nonzero((np.abs(X[:, 0]) < 1e-9) & (np.abs(X[:, 2]) < TOL) & (np.abs(R - cell.r_i) < 1e-6))[0][:1]
    prob = Problem(mesh, material or NeoHookean(cell.c10, 0.0),
                   dirichlet=(Dirichlet(np.nonzero(np.abs(X[:, 1]) < TOL)[0], (1,), "y=0"),
                              Dirichlet(np.nonzero(np.abs(X[:, 2]) < TOL)[0], (2,), "z=0"),
                              Dirichlet(top, (2,), "z=s"),
                              Dirichlet(pin, (0,), "pin")),
                   pressures=(FollowerPressure(inner, "cavity"),), trusses=tuple(trusses), fibre_fields=tuple(fields))
    return prob, top


class CellRun:
    """Load paths on one cell problem: pressure with the closed-end thrust, then a small bending."""

    def __init__(self, cell: Cell, prob: Problem, top: np.ndarray, law=None) -> None:
        self.cell, self.prob, self.top = cell, prob, top
        #: law(Q) -> c: the wall law of the whisker scene applied about each pressurised state for the
        #: bending (whisker_opt.wall.law.apply_law on every element of the cell); None = as meshed
        self.law = law
        self.asm = Assembler(prob)
        self.x_top = prob.mesh.points[top, 0]
        self.state = State.zero(prob)
        self.load = LoadState.zero(prob)

    def _load(self, Q: float, U: float, theta: float = 0.0) -> LoadState:
        uz = (U + theta * self.x_top)[:, None]
        return LoadState((Q,), (0.0, 0.0, uz, 0.0))

    def go(self, Q: float, U: float, theta: float = 0.0, steps: int = 1) -> State:
        """Solve from the current state to (Q, U, θ) and make it current (more steps for large moves of U)."""
        load1 = self._load(Q, U, theta)
        dU = np.abs(load1.dirichlet_values[2] - np.asarray(self.load.dirichlet_values[2])).max()
        steps = max(steps, math.ceil(dU / (0.05 * self.cell.s)))
        states, _ = solve_path(self.prob, self.state, self.load, load1,
                               fractions=tuple((k + 1) / steps for k in range(steps)))
        self.state, self.load = states[-1], load1
        return self.state

    def forces(self) -> tuple[float, float, float]:
        """Axial force N on the plane z = s, its moment M about the y axis through the origin (current
        positions) and the moment M_w = Σ F_z X work-conjugate to θ (reference positions, as θ is applied)."""
        st = self.state
        R, _, _ = self.asm.evaluate(st.u, st.p, self.load.pressures, need_tangent=False)
        Fz = R[3 * self.top + 2]
        x = self.prob.mesh.points[self.top, 0] + st.u[self.top, 0]
        return float(Fz.sum()), float((Fz * x).sum()), float(Fz @ self.prob.mesh.points[self.top, 0])

    def pressurise(self, Q: float, U: float, Q0: float = 0.0, n_levels: int = 4) -> float:
        """U that carries the half tube's thrust Q π r_i²/2 at pressure Q, from the current state at Q0.

        The pressure rises in ``n_levels`` equal steps; at each, secant iterations on U find the thrust, and
        the last two levels extrapolate the next U.
        """
        Us = [U]
        for q in np.linspace(Q0, Q, n_levels + 1)[1:]:
            guess = Us[-1] if len(Us) < 2 else 2 * Us[-1] - Us[-2]
            Us.append(self._thrust(float(q), guess))
        return Us[-1]

    def _thrust(self, Q: float, U_guess: float) -> float:
        """Secant iterations on U until the thrust is met to 0.1 % or the correction is below 1e-4 s
        (smaller moves start Newton increments whose energy norm is at round-off from the start)."""
        target = Q * math.pi * self.cell.r_i**2 / 2
        self.go(Q, U_guess)
        U0, N0 = U_guess, self.forces()[0]
        U1 = U0 + 0.02 * self.cell.s
        for _ in range(10):
            self.go(Q, U1)
            N1 = self.forces()[0]
            step = (target - N1) * (U1 - U0) / (N1 - N0)
            if abs(N1 - target) <= 1e-3 * target or abs(step) < 1e-4 * self.cell.s:
                return U1
            U0, N0, U1 = U1, N1, U1 + step
        raise RuntimeError(f"thrust at Q = {Q}: N = {N1:.6g} N after 10 secant steps, target {target:.6g} N")

    def bending_stiffness(self, Q: float, U: float) -> tuple[float, float]:
        """EI = s · (M(+θ) − M(−θ))/(2θ) about the current pressurised state [N mm²], with M about the
        origin and with the work-conjugate M_w (the two agree at Q = 0; under pressure M also holds the
        thrust times the end plane's lateral drift, which the closed chamber leaves unrestrained)."""
        base_state, base_load, base_prob, base_asm = self.state, self.load, self.prob, self.asm
        if self.law is not None:
            from whisker_opt.wall.law import apply_law

            self.prob = apply_law(base_prob, base_state, self.law(Q), np.arange(base_prob.mesh.n_elements))
            self.asm = Assembler(self.prob)
        m = []
        for th in (THETA, -THETA):
            self.state, self.load = base_state, base_load
            self.go(Q, U, th)
            m.append(self.forces()[1:])
        self.state, self.load, self.prob, self.asm = base_state, base_load, base_prob, base_asm
        return tuple(abs(a - b) / (2 * THETA) * self.cell.s for a, b in zip(m[0], m[1]))


def measure(cell: Cell, model: str, level: int, n_phi: int, smeared_scale: float = 1.0, pressures=PRESSURES,
            law=None) -> dict:
    """One model on one mesh: U/s at each pressure, EI(0) and EI(Q)/EI(0) (``law``: see :class:`CellRun`)."""
    t0 = time.perf_counter()
    if model.startswith("resolved") or model in ("weak-ring", "band"):
        r_grid, z_grid = resolved_grids(cell, level)
    else:
        r_grid, z_grid = uniform_grids(cell, level)
    mesh = cell_mesh(cell, r_grid, z_grid, n_phi)
    h = cell.t / (len(r_grid) - 1)
    deg = Problem.quadrature_degree  # the default rule, which cell_problem uses
    trusses, fields, material = (), (), None
    if model == "resolved":
        fields = resolved_fields(cell, mesh, deg, rigid=False)
    elif model == "weak-ring":
        fields = resolved_fields(cell, mesh, deg, rigid=False)
        material = weak_ring_material(cell, mesh, r_grid, z_grid)
    elif model == "band":
        fields = (band_field(cell, mesh, deg),)
    elif model == "resolved-rigid":
        fields = resolved_fields(cell, mesh, deg, rigid=True)
    elif model == "embedded":
        trusses = (embedded_ring(cell, mesh, h),)
    elif model == "smeared":
        fields = (smeared_field(cell, mesh, deg, smeared_scale),)
    elif model != "none":
        raise ValueError(f"--models: unknown model {model!r}; allowed resolved, resolved-rigid, weak-ring, band, "
                         "embedded, smeared, none")
    prob, top = cell_problem(cell, mesh, trusses, fields, material)
    run = CellRun(cell, prob, top, law)
    row = {"model": model, "level": level, "n_el": mesh.n_elements, "n_r": len(r_grid) - 1, "n_z": len(z_grid) - 1}
    ei0 = run.bending_stiffness(0.0, 0.0)[1]
    row["EI0"] = ei0
    log.info("%s level %d: %d tets, EI(0) = %.6g N mm² (%.0f s)", model, level, mesh.n_elements, ei0,
             time.perf_counter() - t0)
    U, Q0 = 0.0, 0.0
    for Q in pressures:
        try:
            U, Q0 = run.pressurise(Q, U, Q0), Q
        except SolveFailed as exc:  # the bare tube balloons (limit pressure ≈ μ ln(r_o/r_i) = 0.12 MPa)
            log.warning("%s level %d: Q = %s MPa not reached (%s)", model, level, Q, exc)
            break
        row[f"ez_{Q}"] = U / cell.s
        ei, ei_w = run.bending_stiffness(Q, U)
        row[f"EIr_{Q}"], row[f"EIw_{Q}"] = ei / ei0, ei_w / ei0
        log.info("%s level %d: Q = %s MPa, U/s = %.6g, EI(Q)/EI(0) = %.6g (%.0f s)", model, level, Q, U / cell.s,
                 row[f"EIr_{Q}"], time.perf_counter() - t0)
    row["t_s"] = time.perf_counter() - t0
    return row
