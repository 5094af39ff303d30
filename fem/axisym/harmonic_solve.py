"""Equilibrium paths of the axisymmetric state and linear harmonic responses about it.

The axisymmetric unknowns x are restricted to ``x = T y + x_fixed`` (:class:`Reduction`): fixed dofs
take prescribed values, tied groups share one unknown (a mirror plane kept plane and free to move),
and a tied group may carry an axial force (the thrust of a closed end, :class:`EndThrust`). The cavity
pressure Q is an unknown too: :class:`AxisymmetricSystem` is the :class:`fem.system.NonlinearSystem` of
z = (y, Q), solved by the Newton driver (:class:`fem.newton.NewtonSolver`: its acceptance rules, line
search and linear solvers) and the load stepping (:func:`fem.loadpath.follow_path`: increments, secant
predictor, cut-backs, :class:`fem.newton.SolveFailed`) of the 3-D solid. A path prescribes either the
pressure Q (load control) or one displacement x_k (passing a limit point); the other is free, so each
iteration solves the bordered system::

    [ Tᵀ K T    Tᵀ ∂R/∂Q ] [Δy]     [ Tᵀ R ]
    [   c_y       c_Q    ] [ΔQ] = − [  c   ]

with the control row c = Q − Q* or c = x_k − x_k* (Crisfield, *Non-linear Finite Element Analysis of
Solids and Structures*, vol. 1, §9.2, displacement control), as a prescribed unknown of the Newton driver.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from fem.axisym.harmonic import HarmonicSolid
from fem.linsolve import LinearSolver, LinearSolverError, make_solver
from fem.loadpath import follow_path
from fem.newton import NewtonSolver, SolveOptions

log = logging.getLogger(__name__)

#: The Newton controls of the axisymmetric path: residuals to 1e-10 of the force scale, at most 25
#: iterations per increment and 8 cut-backs per path.
PATH_OPTIONS = SolveOptions(rtol=1e-10, max_iterations=25, max_cutbacks=8)


def with_diagonal(A: sp.spmatrix) -> sp.csr_matrix:
    """A in CSR with every diagonal entry stored (explicit zeros where A has none): the pressure rows of an
    incompressible mixed system have a zero diagonal, and a symmetric factorisation reads the upper triangle."""
    c = A.tocoo()
    n = A.shape[0]
    return sp.csr_matrix((np.r_[c.data, np.zeros(n)], (np.r_[c.row, np.arange(n)], np.r_[c.col, np.arange(n)])),
                         shape=A.shape)


@dataclass(frozen=True, eq=False)
class Reduction:
    """x = T y + x_fixed over ``size`` dofs: ``fixed`` dofs prescribed, each of ``ties`` one shared unknown."""

    size: int
    fixed: np.ndarray
    ties: tuple = ()

    def matrix(self) -> sp.csr_matrix:
        """T (size × n_red): identity on the free dofs, a column of ones per tied group."""
        free = np.ones(self.size, bool)
        free[np.asarray(self.fixed, np.int64)] = False
        for grp in self.ties:
            free[np.asarray(grp)] = False
        idx = np.nonzero(free)[0]
        rows, cols = [idx], [np.arange(len(idx))]
        for k, grp in enumerate(self.ties):
            rows.append(np.asarray(grp, np.int64))
            cols.append(np.full(len(grp), len(idx) + k))
        r, c = np.concatenate(rows), np.concatenate(cols)
        return sp.csr_matrix((np.ones(len(r)), (r, c)), shape=(self.size, len(idx) + len(self.ties)))


@dataclass(frozen=True)
class EndThrust:
    """An axial force N = Q π a² on a tied group (index into ``Reduction.ties``), pulling in +z.

    ``radius_dof`` is the axisymmetric dof of u_r at the cavity's edge of that plane: a = R₀ + u_r
    (the current cavity radius, ``current=True``: the closed end of a tube) or a = R₀ (the reference
    radius).
    """

    tie: int
    radius: float
    radius_dof: int
    current: bool = True

    def force(self, x: np.ndarray, Q: float) -> tuple[float, float, float]:
        """N, ∂N/∂Q and ∂N/∂u_r."""
        a = self.radius + (x[self.radius_dof] if self.current else 0.0)
        dN_du = 2.0 * Q * math.pi * a if self.current else 0.0
        return Q * math.pi * a * a, math.pi * a * a, dN_du


@dataclass(frozen=True)
class Control:
    """The prescribed value of an axisymmetric path's control: the pressure Q [MPa] or one displacement [mm]."""

    value: float

    def interpolate(self, other: "Control", s: float) -> "Control":
        """(1 − s)·self + s·other."""
        return Control((1 - s) * self.value + s * other.value)


class AxisymmetricSystem:
    """The axisymmetric state of a :class:`fem.axisym.harmonic.HarmonicSolid` as a :class:`fem.system.NonlinearSystem`.

    Unknowns z = [y, Q]: the reduced unknowns (x = T y, :class:`Reduction`) and the cavity pressure. Load
    control (``control=None``) prescribes Q; displacement control prescribes y_e (``control=e``, a reduced
    index) and frees Q, whose slot then holds the equation of y_e (its residual row and its row of the
    tangent), so the prescribed slot is a reaction as in the 3-D solid. R at the prescribed slot is the
    force scale of the pressure load, max(|Q|, 1e-3 MPa) ‖Tᵀ ∂R/∂Q‖ (with the increment's first residual it
    sets the acceptance rule's F_ref). Force rows and the element pressures' volume rows are measured apart
    (``SolveOptions.vtol`` against the solid's volume 2π ∫ R dA).

    Parameters
    ----------
    solid : HarmonicSolid
    reduction : Reduction
    thrust : EndThrust, optional
    control : int, optional
        The reduced index of the prescribed displacement (None: the pressure is prescribed).
    linear : LinearSolver, optional
        The linear solver of every solve (shared between the systems of one path); None: built by name.
    """

    symmetric = False  # the follower pressure and the end thrust make the tangent non-symmetric

    def __init__(self, solid: HarmonicSolid, reduction: Reduction, thrust: EndThrust | None = None,
                 control: int | None = None, linear: LinearSolver | None = None) -> None:
        self.solid, self.red, self.thrust, self.control, self._linear = solid, reduction, thrust, control, linear
        self.T = reduction.matrix()
        self.n_red = self.T.shape[1]
        self.x_fixed = np.zeros(reduction.size)
        n_free = self.n_red - len(reduction.ties)
        self.tie_col = [n_free + k for k in range(len(reduction.ties))]
        self._map = np.full(reduction.size, -1)  # full dof -> its reduced unknown (-1: fixed)
        Tc = self.T.tocoo()
        self._map[Tc.row] = Tc.col
        n = self.n_red + 1
        self.constrained = np.zeros(n, bool)
        self.constrained[self.n_red if control is None else control] = True
        self.constrained_dofs = np.nonzero(self.constrained)[0]
        self._volume_row = np.zeros(n, bool)
        self._volume_row[Tc.col[Tc.row >= solid.n_u0]] = True
        self._force_row = ~self.constrained & ~self._volume_row
        self.volume = 2.0 * math.pi * float(solid.wR.sum())
        rows = []  # the rows ∂R/∂Q may reach: the loaded edges' dofs and the thrust's tie
        if solid.pressure is not None:
            rows.append(self._map[(2 * solid.pressure.edges.ravel()[:, None] + np.arange(2)).ravel()])
        if thrust is not None:
            rows.append([self.tie_col[thrust.tie]])
        g_rows = np.unique(np.concatenate(rows)).astype(np.int64) if rows else np.zeros(0, np.int64)
        self._g_rows = g_rows[g_rows >= 0]

    def full(self, y: np.ndarray) -> np.ndarray:
        """The axisymmetric vector x = T y + x_fixed."""
        return self.T @ y + self.x_fixed

    def linear_solver(self, name: str) -> LinearSolver:
        """The path's solver when it gave one, else :func:`fem.linsolve.make_solver` of ``name`` (kept)."""
        if self._linear is None:
            self._linear = make_solver(name)
        return self._linear

    def prescribed(self, load: Control) -> tuple[np.ndarray, np.ndarray]:
        return self.constrained_dofs, np.array([float(load.value)])

    def _reduced(self, x: np.ndarray, Q: float, R: np.ndarray):
        """Tᵀ R, Tᵀ ∂R/∂Q with the end thrust, and the thrust's tangent entry (row, col, value) or None."""
        dRdQ = np.zeros_like(R)
        if self.solid.pressure is not None:
            dRdQ[: self.solid.n_u0] = self.solid.pressure.residual0(x[: self.solid.n_u0].reshape(-1, 2), 1.0)
        r, g = self.T.T @ R, self.T.T @ dRdQ
        extra = None
        if self.thrust is not None:
            N, dNdQ, dNdu = self.thrust.force(x, Q)
            col = self.tie_col[self.thrust.tie]
            r[col] -= N
            g[col] -= dNdQ
            extra = (self.red.ties[self.thrust.tie][0], self.thrust.radius_dof, -dNdu)
        return r, g, extra

    def evaluate(self, z: np.ndarray, load: Control, tangent: bool) -> tuple:
        """(R, the bordered tangent or None, min det F) at z; :class:`fem.assembly.InvertedElements` when inverted."""
        y, Q = z[:-1], float(z[-1])
        x = self.full(y)
        R_x, K = self.solid.axisymmetric(x, Q, tangent)
        r, g, extra = self._reduced(x, Q, R_x)
        R = np.append(r, 0.0)
        scale = max(abs(Q), 1e-3) * float(np.linalg.norm(g))  # the pressure load, never below that of 1e-3 MPa
        if self.control is not None:
            R[self.n_red] = r[self.control]
        R[self.constrained_dofs] = scale
        return R, (self._bordered(K, g, extra) if tangent else None), self.min_jacobian(z)

    def _bordered(self, K: sp.spmatrix, g: np.ndarray, extra: tuple | None) -> sp.csr_matrix:
        """[[Tᵀ (K + the entry ``extra``) T, Tᵀ ∂R/∂Q], [0, 0]] with the rows of y_e and Q swapped under displacement
        control, every structural entry and diagonal kept (a fixed pattern, so the factorisation's analysis is
        reused along the path; sparse sums and products would drop entries that happen to be zero)."""
        c = K.tocoo()
        rows, cols, data = c.row, c.col, c.data
        if extra is not None:
            rows, cols, data = np.r_[rows, extra[0]], np.r_[cols, extra[1]], np.r_[data, extra[2]]
        r, q = self._map[rows], self._map[cols]
        ok = (r >= 0) & (q >= 0)
        n = self.n_red + 1
        rows = np.r_[r[ok], self._g_rows, np.arange(n)]
        cols = np.r_[q[ok], np.full(len(self._g_rows), self.n_red), np.arange(n)]
        data = np.r_[data[ok], g[self._g_rows], np.zeros(n)]
        if self.control is not None:
            e = self.control
            rows = np.where(rows == e, self.n_red, np.where(rows == self.n_red, e, rows))
        return sp.csr_matrix((data, (rows, cols)), shape=(n, n))

    def matrix(self, A: sp.csr_matrix) -> sp.csr_matrix:
        """A with zero rows and columns and a unit diagonal at the prescribed slot (A's pattern kept)."""
        c = A.tocoo()
        drop = self.constrained[c.row] | self.constrained[c.col]
        n = A.shape[0]
        return sp.csr_matrix((np.r_[np.where(drop, 0.0, c.data), self.constrained.astype(float)],
                              (np.r_[c.row, np.arange(n)], np.r_[c.col, np.arange(n)])), shape=A.shape)

    def matvec(self, A: sp.csr_matrix, v: np.ndarray) -> np.ndarray:
        return A @ v

    def norms(self, R: np.ndarray) -> tuple[float, float, float]:
        """(‖R‖ of the free force rows, ‖R‖ of the volume rows, the pressure load's force scale)."""
        return (float(np.linalg.norm(R[self._force_row])), float(np.linalg.norm(R[self._volume_row])),
                float(np.linalg.norm(R[self.constrained])))

    def min_jacobian(self, z: np.ndarray) -> float:
        """Smallest det F at the quadrature points of the state z."""
        u = self.full(z[:-1])[: self.solid.n_u0].reshape(-1, 2)
        return float(np.min(np.linalg.det(self.solid.deformation_gradient(u))))


class AxisymmetricPath:
    """Equilibria of one :class:`fem.axisym.harmonic.HarmonicSolid` under a :class:`Reduction`, by the Newton
    driver and the load stepping of the 3-D solid (:class:`AxisymmetricSystem`).

    Parameters
    ----------
    solid : HarmonicSolid
    reduction : Reduction
    thrust : EndThrust, optional
    options : SolveOptions
        Newton and stepping controls (:data:`PATH_OPTIONS`); the steps are set per call.
    """

    def __init__(self, solid: HarmonicSolid, reduction: Reduction, thrust: EndThrust | None = None,
                 options: SolveOptions = PATH_OPTIONS) -> None:
        self.solid, self.red, self.thrust, self.options = solid, reduction, thrust, options
        self.linear = make_solver(options.linear_solver)
        self.system = AxisymmetricSystem(solid, reduction, thrust, linear=self.linear)
        self.T, self.n_red = self.system.T, self.system.n_red

    def full(self, y: np.ndarray) -> np.ndarray:
        return self.system.full(y)

    def solve(self, y: np.ndarray, Q: float, control: tuple) -> tuple[np.ndarray, float, int]:
        """Equilibrium from (y, Q) with ``control = (dof, value)``: x[dof] moved to ``value`` in one increment
        (halved on failure), Q free.

        ``dof`` indexes x (the full axisymmetric vector; it must be a free dof). Returns (y, Q, iterations).

        Raises
        ------
        fem.newton.SolveFailed
            When the increments cannot converge within the cut-back limits.
        """
        col = self.T.getrow(control[0]).indices
        if len(col) != 1:
            raise ValueError(f"AxisymmetricPath.solve: control dof {control[0]} is not a free dof")
        system = AxisymmetricSystem(self.solid, self.red, self.thrust, control=int(col[0]), linear=self.linear)
        opts = replace(self.options, initial_step=1.0, max_step=1.0)
        start = Control(float(self.full(y)[control[0]]))
        reached, reports, _ = follow_path(NewtonSolver(system, opts.linear_solver), np.append(y, Q), start,
                                          Control(float(control[1])), (1.0,), opts)
        z = reached[-1][0]
        return z[:-1], float(z[-1]), sum(r.iterations for r in reports)

    def follow(self, y: np.ndarray, Q0: float, Q1: float, steps: int = 4,
               previous: tuple[np.ndarray, float] | None = None):
        """From equilibrium (y, Q0) to pressure Q1 in ``steps`` increments (halved on failure, regrown after).

        Each increment starts from the secant through the last two equilibria (``previous`` is the one
        before (y, Q0), if known), which leaves Newton a correction of second order in the step.
        Returns (y, Q, (y_before, Q_before)) with the last equilibrium before the end for the next call.

        Raises
        ------
        fem.newton.SolveFailed
            When the increments cannot converge within the cut-back limits.
        """
        if abs(Q1 - Q0) <= 1e-15 * max(1.0, abs(Q1)):
            return y, Q0, previous
        opts = replace(self.options, initial_step=1.0 / steps, max_step=1.0 / steps)
        hist = None
        if previous is not None and (Q0 - previous[1]) * (Q1 - Q0) > 0:
            hist = (np.append(previous[0], previous[1]), (previous[1] - Q0) / (Q1 - Q0))
        reached, _, hist = follow_path(NewtonSolver(self.system, opts.linear_solver), np.append(y, Q0),
                                       Control(Q0), Control(Q1), (1.0,), opts, history=hist)
        z = reached[-1][0]  # its pressure is Q1 to round-off (the prescribed step applied by the linear solve)
        before = None if hist is None else (hist[0][:-1], float(hist[0][-1]))
        return z[:-1], Q1, before


def harmonic_response(solid: HarmonicSolid, n: int, x: np.ndarray, Q: float, fixed: np.ndarray,
                      values: np.ndarray, linear_solver: str = "auto") -> tuple[np.ndarray, np.ndarray, float]:
    """Linear harmonic-n field with prescribed amplitudes ``values`` at dofs ``fixed`` (others free).

    Returns the amplitudes y (all harmonic dofs), the generalised reactions K y and the second
    variation yᵀ K y (twice the energy of the perturbation over the whole turn).
    """
    K = solid.harmonic_tangent(n, x, Q).tocsr()
    size = K.shape[0]
    fixed = np.asarray(fixed, np.int64)
    free = np.ones(size, bool)
    free[fixed] = False
    y = np.zeros(size)
    y[fixed] = values
    lin = make_solver(linear_solver)
    Kff, b = with_diagonal(K[free][:, free]), -(K[free][:, fixed] @ y[fixed])
    try:
        lin.factorize(Kff, symmetric=False)
        y[free] = lin.solve(b)
    except LinearSolverError as exc:  # near a limit point the refined solve can miss its tolerance
        log.info("harmonic response: %s; solving with SuperLU", exc)
        lin = make_solver("superlu")
        lin.factorize(Kff, symmetric=False)
        y[free] = lin.solve(b)
    f = K @ y
    return y, f, float(y @ f)
