"""What the Newton driver needs of a discretised nonlinear problem, and the 3-D solid's answer.

:class:`fem.newton.NewtonSolver` and the load stepping of :mod:`fem.loadpath` know a problem only through
:class:`NonlinearSystem`: a state vector x of unknowns, some of them *prescribed* by the load (their values
set, their residual rows a reaction), the residual R(x) under a load and its tangent, and the measures of
the acceptance rule (the residual norms and the volume that scales the constraint residual). Two systems
implement it: :class:`SolidSystem` here (the 10-node tetrahedral solid of :mod:`fem.assembly`) and
:class:`fem.axisym.harmonic_solve.AxisymmetricSystem` (the axisymmetric state of a body of revolution with
its cavity pressure as an unknown).

A load is any object with ``interpolate(other, s)`` (``(1 − s)·self + s·other``), such as
:class:`fem.loads.LoadState` or :class:`fem.axisym.harmonic_solve.Control`; the system turns it into
prescribed values and the loads of its residual.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp

from fem.assembly import Assembler
from fem.linsolve import LinearSolver, make_solver
from fem.problem import Problem


@runtime_checkable
class NonlinearSystem(Protocol):
    """A residual and its tangent over a vector of unknowns, some prescribed by the load.

    Attributes
    ----------
    constrained : ndarray of bool, shape (n,)
        The prescribed unknowns: their rows of the solved system are identity rows (their values come
        from the load), their entries of R are reactions (never a convergence measure).
    constrained_dofs : ndarray of int
        Their indices.
    volume : float
        The scale of the constraint residual ‖R_p‖ (``SolveOptions.vtol`` is relative to it).
    symmetric : bool or None
        The factorisation hint passed to :meth:`fem.linsolve.LinearSolver.factorize` (None: the solver probes).
    """

    constrained: np.ndarray
    constrained_dofs: np.ndarray
    volume: float
    symmetric: bool | None

    def prescribed(self, load) -> tuple[np.ndarray, np.ndarray]:
        """(indices, values) of the prescribed unknowns under ``load``."""

    def evaluate(self, x: np.ndarray, load, tangent: bool) -> tuple:
        """(R, tangent data or None, min det F) at ``x`` under ``load``; :class:`fem.assembly.InvertedElements`
        when an element is inverted there."""

    def matrix(self, data) -> sp.csr_matrix:
        """The matrix to factorise: the tangent with identity rows and columns at the prescribed unknowns."""

    def matvec(self, data, v: np.ndarray) -> np.ndarray:
        """K v with the whole tangent (the prescribed columns included)."""

    def norms(self, R: np.ndarray) -> tuple[float, float, float]:
        """(‖R_u‖ of the free force rows, ‖R_p‖ of the constraint rows, the force scale of the load)."""

    def min_jacobian(self, x: np.ndarray) -> float:
        """Smallest det F of the state ``x``."""

    def linear_solver(self, name: str) -> LinearSolver:
        """The linear solver ``name`` of :func:`fem.linsolve.make_solver`, shared by the system's solves."""


class _Constraint:
    """Elimination of prescribed DOFs by zeroing rows/columns (unit diagonal).

    Keeping the full pattern lets every Dirichlet set share one sparsity pattern and
    one PARDISO analysis.
    """

    def __init__(self, problem: Problem, pattern) -> None:
        self.dofs = problem.constrained_dofs()
        n = pattern.n_dofs
        self.is_c = np.zeros(n, dtype=bool)
        self.is_c[self.dofs] = True
        rows = np.repeat(np.arange(n), np.diff(pattern.indptr))
        self.zero_mask = self.is_c[rows] | self.is_c[pattern.indices]
        self.diag_pos = pattern.diag[self.dofs]
        self.free_u = ~self.is_c[: problem.n_u]
        self.n_u = problem.n_u

    def apply(self, data: np.ndarray) -> np.ndarray:
        d = data.copy()
        d[self.zero_mask] = 0.0
        d[self.diag_pos] = 1.0
        return d


class SolidSystem:
    """The mixed u–p solid of a :class:`fem.problem.Problem` as a :class:`NonlinearSystem`.

    Unknowns: displacements (3 per node), then element pressures; the prescribed unknowns are the
    Dirichlet components, whose values the :class:`fem.loads.LoadState` gives. The tangent data is the
    assembler's values on its fixed sparsity pattern.

    Parameters
    ----------
    problem : Problem
    """

    #: the solver probes the symmetry itself (relative 1e-11): a follower-pressure tangent that is
    #: non-symmetric only at that level (the whisker's, dominated by the fibres) is factorised as symmetric
    #: and the checked refinement on the full matrix removes the difference: 2.9 s instead of 3.7 s for the
    #: intact default scene with the same reading to 1e-11 (telling it "non-symmetric" forced LU)
    symmetric = None

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.assembler = Assembler(problem)
        self._con = _Constraint(problem, self.assembler.pattern)
        self.constrained = self._con.is_c
        self.constrained_dofs = self._con.dofs
        self.volume = float(self.assembler.topo.vol.sum())

    def linear_solver(self, name: str) -> LinearSolver:
        """Cached on the problem, so problems sharing a sparsity pattern share its analysis."""
        skey = ("linear_solver", name, id(self.assembler.pattern))
        solver = self.problem._cache.get(skey)
        if solver is None:
            solver = make_solver(name)
            self.problem._cache[skey] = solver
        return solver

    def prescribed(self, load) -> tuple[np.ndarray, np.ndarray]:
        return load.prescribed_vector(self.problem)

    def evaluate(self, x: np.ndarray, load, tangent: bool) -> tuple:
        n_u = self.problem.n_u
        return self.assembler.evaluate(x[:n_u].reshape(-1, 3), x[n_u:], load.pressures, tangent, load.tractions)

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        return self.assembler.pattern.matrix(self._con.apply(data))

    def matvec(self, data: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.assembler.pattern.matrix(data) @ v

    def norms(self, R: np.ndarray) -> tuple[float, float, float]:
        """(‖R_u‖ on free DOFs, ‖R_p‖, ‖R_u‖ on prescribed DOFs = the reaction norm)."""
        con = self._con
        ru = R[: con.n_u][con.free_u]
        return (float(np.linalg.norm(ru)), float(np.linalg.norm(R[con.n_u:])),
                float(np.linalg.norm(R[: con.n_u][~con.free_u])))

    def min_jacobian(self, x: np.ndarray) -> float:
        return self.assembler.min_jacobian(x[: self.problem.n_u].reshape(-1, 3))
