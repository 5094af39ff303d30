"""Solution state of the mixed u–p problem."""

from __future__ import annotations

from dataclasses import dataclass

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
    """

    u: np.ndarray
    p: np.ndarray

    @classmethod
    def zero(cls, problem) -> "State":
        """The undeformed, unstressed state of ``problem``."""
        return cls(np.zeros((problem.mesh.n_nodes, 3)), np.zeros(problem.mesh.n_elements))

    def as_vector(self) -> np.ndarray:
        """Concatenated DOF vector [u.ravel(), p]."""
        return np.concatenate([self.u.ravel(), self.p])

    @classmethod
    def from_vector(cls, x: np.ndarray, n_nodes: int) -> "State":
        n_u = 3 * n_nodes
        return cls(x[:n_u].reshape(n_nodes, 3).copy(), x[n_u:].copy())
