"""Solution state of the mixed u–p problem."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class State:
    """Displacements and element pressures.

    Attributes
    ----------
    u : ndarray (n_nodes, 3)
        Nodal displacements [mm].
    p : ndarray (n_elements,)
        Element pressures [MPa] (the Lagrange multiplier of J = 1 when D1 = 0;
        p = 2(J̄ − 1)/D1 otherwise). Sign: p > 0 in tension.
    residual : ndarray (3 n_nodes + n_elements,) or None
        R = f_int − f_ext at this state under the load it was solved for
        (:meth:`fem.assembly.Assembler.evaluate`), as the Newton solve that converged to it
        last evaluated it; None when not known. At a prescribed DOF it is the support's
        reaction. Not part of equality.
    """

    u: np.ndarray
    p: np.ndarray
    residual: np.ndarray | None = field(default=None, compare=False, repr=False)

    @classmethod
    def zero(cls, problem) -> "State":
        """The undeformed, unstressed state of ``problem``."""
        return cls(np.zeros((problem.mesh.n_nodes, 3)), np.zeros(problem.mesh.n_elements))

    def as_vector(self) -> np.ndarray:
        """Concatenated DOF vector [u.ravel(), p]."""
        return np.concatenate([self.u.ravel(), self.p])

    @classmethod
    def from_vector(cls, x: np.ndarray, n_nodes: int, residual: np.ndarray | None = None) -> "State":
        """The state of the DOF vector ``x`` (copied), with its ``residual`` when known."""
        n_u = 3 * n_nodes
        return cls(x[:n_u].reshape(n_nodes, 3).copy(), x[n_u:].copy(), residual)
