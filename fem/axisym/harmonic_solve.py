"""Equilibrium paths of the axisymmetric state and linear harmonic responses about it.

The axisymmetric unknowns x are restricted to ``x = T y + x_fixed`` (:class:`Reduction`): fixed dofs
take prescribed values, tied groups share one unknown (a mirror plane kept plane and free to move),
and a tied group may carry an axial force (the thrust of a closed end, :class:`EndThrust`). The cavity
pressure Q is an unknown too, so one Newton iteration on (y, Q) follows either a prescribed pressure
(load control) or a prescribed displacement (passing a limit point)::

    [ Tᵀ K T    Tᵀ ∂R/∂Q ] [Δy]     [ Tᵀ R ]
    [   c_y       c_Q    ] [ΔQ] = − [  c   ]

with c = Q − Q* or c = x_k − x_k* (Crisfield, *Non-linear Finite Element Analysis of Solids and
Structures*, vol. 1, §9.2, displacement control). Linear systems by SuperLU (2-D problems).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fem.axisym.harmonic import HarmonicSolid
from fem.linsolve import LinearSolverError, make_solver

log = logging.getLogger(__name__)


def with_diagonal(A: sp.spmatrix) -> sp.csr_matrix:
    """A in CSR with every diagonal entry stored (explicit zeros where A has none): the pressure rows of an
    incompressible mixed system have a zero diagonal, and a symmetric factorisation reads the upper triangle."""
    c = A.tocoo()
    n = A.shape[0]
    return sp.csr_matrix((np.r_[c.data, np.zeros(n)], (np.r_[c.row, np.arange(n)], np.r_[c.col, np.arange(n)])),
                         shape=A.shape)


class HarmonicSolveFailed(RuntimeError):
    """Newton did not converge on the axisymmetric state."""


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


class AxisymmetricPath:
    """Newton on (y, Q) for one :class:`fem.axisym.harmonic.HarmonicSolid` under a :class:`Reduction`.

    An iteration ends the solve when the residual of the state it starts from is below ``tol`` times the
    step's force scale (the larger of the first residual and the pressure load of max(Q, 1e-3)), or below
    10³ ``tol`` times it while falling by less than a factor 0.3 (the round-off floor, which a quadratically
    converging Newton reaches in one more step); the update is applied in both cases.
    """

    def __init__(self, solid: HarmonicSolid, reduction: Reduction, thrust: EndThrust | None = None,
                 tol: float = 1e-10, max_iter: int = 25, linear_solver: str = "auto") -> None:
        self.solid, self.red, self.thrust = solid, reduction, thrust
        self.linear = make_solver(linear_solver)
        self.T = reduction.matrix()
        self.tol, self.max_iter = tol, max_iter
        self.n_red = self.T.shape[1]
        self.x_fixed = np.zeros(reduction.size)
        n_free = self.n_red - len(reduction.ties)
        self.tie_col = [n_free + k for k in range(len(reduction.ties))]
        self._map = np.full(reduction.size, -1)  # full dof -> its reduced unknown (-1: fixed)
        Tc = self.T.tocoo()
        self._map[Tc.row] = Tc.col

    def full(self, y: np.ndarray) -> np.ndarray:
        return self.T @ y + self.x_fixed

    def _system(self, y: np.ndarray, Q: float, need_tangent: bool = True):
        x = self.full(y)
        R, K = self.solid.axisymmetric(x, Q, need_tangent)
        dRdQ = np.zeros_like(R)
        if self.solid.pressure is not None:
            dRdQ[: self.solid.n_u0] = self.solid.pressure.residual0(x[: self.solid.n_u0].reshape(-1, 2), 1.0)
        r = self.T.T @ R
        g = self.T.T @ dRdQ
        extra = None
        if self.thrust is not None:
            N, dNdQ, dNdu = self.thrust.force(x, Q)
            col = self.tie_col[self.thrust.tie]
            r[col] -= N
            g[col] -= dNdQ
            extra = (self.red.ties[self.thrust.tie][0], self.thrust.radius_dof, -dNdu)
        return r, g, (self._reduce(K, extra) if need_tangent else None)

    def _reduce(self, K: sp.spmatrix, extra: tuple | None = None) -> sp.csr_matrix:
        """Tᵀ (K + the entry ``extra`` = (row, col, value)) T with every structural entry kept (a fixed
        pattern, so the factorisation's analysis is reused along the path; sparse sums and products would
        drop entries that happen to be zero)."""
        c = K.tocoo()
        rows, cols, data = c.row, c.col, c.data
        if extra is not None:
            rows, cols, data = np.r_[rows, extra[0]], np.r_[cols, extra[1]], np.r_[data, extra[2]]
        r, q = self._map[rows], self._map[cols]
        ok = (r >= 0) & (q >= 0)
        return sp.csr_matrix((data[ok], (r[ok], q[ok])), shape=(self.n_red, self.n_red))

    def solve(self, y: np.ndarray, Q: float, control: tuple | None = None) -> tuple[np.ndarray, float, int]:
        """Equilibrium from (y, Q): at pressure Q (``control=None``) or with ``control = (dof, value)``.

        ``dof`` indexes x (the full axisymmetric vector; it must be a free dof). Returns (y, Q, iterations).
        """
        y = y.copy()
        e = None
        if control is not None:
            col = self.T.getrow(control[0]).indices
            if len(col) != 1:
                raise ValueError(f"AxisymmetricPath.solve: control dof {control[0]} is not a free dof")
            e = int(col[0])
        scale, rn_prev = None, np.inf
        for it in range(1, self.max_iter + 1):
            r, g, K = self._system(y, Q)
            if scale is None:  # the step's force scale, never below that of a 1e-3 (MPa) pressure
                gn = np.linalg.norm(g)
                scale = max(np.linalg.norm(r), abs(Q) * gn, 1e-3 * gn, 1e-12)
            c = 0.0 if e is None else float(self.full(y)[control[0]] - control[1])
            if e is None:
                d = self._linear_solve(K, -r)
                dQ = 0.0
            else:
                A = sp.bmat([[K, g[:, None]], [sp.csr_matrix(([1.0], ([0], [e])), shape=(1, self.n_red)), None]],
                            format="csr")
                sol = self._linear_solve(A, -np.append(r, c))
                d, dQ = sol[:-1], sol[-1]
            if not np.all(np.isfinite(d)):
                raise HarmonicSolveFailed(f"non-finite Newton correction at iteration {it}")
            y += d
            Q += dQ
            rn = np.linalg.norm(r)
            c_ok = abs(c) <= 1e-12 * (1 + abs(control[1] if control else 0))
            if rn <= self.tol * scale and c_ok:
                return y, Q, it
            # at the round-off floor: small and no longer falling (Newton would fall quadratically)
            if rn <= 1e3 * self.tol * scale and rn > 0.3 * rn_prev and c_ok:
                return y, Q, it
            rn_prev = rn
        raise HarmonicSolveFailed(f"Newton did not converge in {self.max_iter} iterations (|R| = {rn:.3g}, "
                                  f"scale {scale:.3g})")

    def _linear_solve(self, A: sp.spmatrix, b: np.ndarray) -> np.ndarray:
        """A⁻¹ b with the path's solver; SuperLU when its refined solve misses the tolerance."""
        try:
            self.linear.factorize(with_diagonal(A), symmetric=False)
            return self.linear.solve(b)
        except LinearSolverError as exc:
            log.info("harmonic path: %s; solving with SuperLU", exc)
            return spla.splu(with_diagonal(A).tocsc(), permc_spec="COLAMD").solve(b)

    def follow(self, y: np.ndarray, Q0: float, Q1: float, steps: int = 4, max_cuts: int = 8,
               previous: tuple[np.ndarray, float] | None = None):
        """From equilibrium (y, Q0) to pressure Q1 in ``steps`` increments, halving a failed one.

        Each increment starts from the secant through the last two equilibria (``previous`` is the one
        before (y, Q0), if known), which leaves Newton a correction of second order in the step.
        Returns (y, Q, (y_before, Q_before)) with the last equilibrium before the end for the next call.
        """
        Q, h = Q0, (Q1 - Q0) / steps
        cuts = 0
        prev = previous
        while abs(Q1 - Q) > 1e-15 * max(1.0, abs(Q1)):
            target = Q + h if abs(Q1 - Q - h) > 1e-12 * abs(h) and (Q1 - Q - h) * h > 0 else Q1
            start = y
            if prev is not None and (Q - prev[1]) * (target - Q) > 0:
                start = y + (y - prev[0]) * ((target - Q) / (Q - prev[1]))
            try:
                y_new, _, _ = self.solve(start, target)
            except (HarmonicSolveFailed, FloatingPointError) as exc:
                cuts += 1
                if cuts > max_cuts:
                    raise HarmonicSolveFailed(f"pressure {target:.6g}: {exc} after {max_cuts} cut-backs") from exc
                h /= 2
                continue
            prev = (y, Q)
            y, Q = y_new, target
        return y, Q, prev


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
    except LinearSolverError as exc:
        log.info("harmonic response: %s; solving with SuperLU", exc)
        y[free] = spla.splu(Kff.tocsc(), permc_spec="COLAMD").solve(b)
    f = K @ y
    return y, f, float(y @ f)
