"""Follower pressure on the boundary edges of a body of revolution: axisymmetric and harmonic terms.

A boundary edge with local coordinate s, swept around the axis, is the surface x(s, Θ) =
r e_r(Θ) + z e_z. Traversed with the body on its left, its outward normal area element is
n da = (x,Θ × x,s) ds dΘ = r (z' e_r − r' e_z) ds dΘ (' = d/ds). A pressure p pushes on it with the
traction −p n, so with R = f_int − f_ext the edge adds::

    R_a = p ∫∫ N_a n da  =  2π p ∫ N_a r (z', −r') ds                       (axisymmetric)

Linearised along a harmonic field Δu = (a cos nΘ, b cos nΘ, c sin nΘ) about the axisymmetric
state, with the test field (â, b̂, ĉ) of the same form and ∫cos² = ∫sin² = π::

    δ²W = π p ∫ [ â (r b' + z'(a + n c)) + ĉ (z'(n a + c) − n r' b) − b̂ (r a' + r'(a + n c)) ] ds

(n = 0 and c = 0, with 2π, is the axisymmetric tangent). Not symmetric in general; symmetric in sum over
a closed surface. Derived from x,Θ = r e_θ and ∂e_r/∂Θ = e_θ, ∂e_θ/∂Θ = −e_r; the 3-D form is
:mod:`fem.pressure` (Bonet & Wood 2008, §8.4).
"""

from __future__ import annotations

import math

import numpy as np

from fem.axisym import quad9


class EdgePressureKernel:
    """Residual and tangents of a follower pressure on 3-node boundary edges of an (R, Z) mesh.

    Parameters
    ----------
    X : ndarray (n_nodes, 2)
        Reference (R, Z).
    edges : ndarray (n_e, 3)
        (start, middle, end) with the body on the left.
    n_gauss : int
        Gauss points per edge (4 integrates N r z' exactly for quadratic edges).
    """

    def __init__(self, X: np.ndarray, edges: np.ndarray, n_gauss: int = 4) -> None:
        self.X = np.asarray(X, float)
        self.edges = np.asarray(edges, np.int64)
        s, self.w = quad9.gauss_1d(n_gauss)
        self.N, self.dN = quad9.line_shape(s)  # (n_qp, 3) each

    def _geometry(self, u: np.ndarray):
        x = (self.X + u)[self.edges]  # (n_e, 3, 2)
        xq = np.einsum("qa,eai->eqi", self.N, x)  # (n_e, n_qp, 2)  current (r, z)
        dx = np.einsum("qa,eai->eqi", self.dN, x)  # (n_e, n_qp, 2)  (r', z')
        return xq[..., 0], dx[..., 0], dx[..., 1]

    def residual0(self, u: np.ndarray, p: float) -> np.ndarray:
        """2π p ∫ N_a r (z', −r') ds, scattered to (2 n_nodes,)."""
        r, rp, zp = self._geometry(u)
        f = 2.0 * math.pi * p * np.einsum("q,qa,eq->eaq", self.w, self.N, r)  # (n_e, 3, n_qp)
        Re = np.stack([np.einsum("eaq,eq->ea", f, zp), -np.einsum("eaq,eq->ea", f, rp)], axis=-1)  # (n_e, 3, 2)
        out = np.zeros(2 * len(self.X))
        np.add.at(out, (2 * self.edges[..., None] + np.arange(2)).ravel(), Re.ravel())
        return out

    def tangent(self, u: np.ndarray, p: float, n: int):
        """COO triplets (rows, cols, values) of the linearised pressure term of harmonic n (n = 0: the
        axisymmetric tangent, dofs (u_r, u_z)). Dofs of node m: 2m + k (n = 0) or 3m + k (n ≥ 1), k = r, z, θ.
        """
        r, rp, zp = self._geometry(u)
        fac = (2.0 if n == 0 else 1.0) * math.pi * p
        NN = np.einsum("q,qa,qb->qab", self.w, self.N, self.N)  # (n_qp, 3, 3)  w N_a N_b
        NdN = np.einsum("q,qa,qb->qab", self.w, self.N, self.dN)  # (n_qp, 3, 3)  w N_a N_b'
        zNN = np.einsum("eq,qab->eab", zp, NN)  # (n_e, 3, 3)
        rNN = np.einsum("eq,qab->eab", rp, NN)
        rNdN = np.einsum("eq,qab->eab", r, NdN)
        nd = 2 if n == 0 else 3
        blocks = {(0, 0): zNN, (0, 1): rNdN, (1, 0): -(rNdN + rNN)}
        if n > 0:
            blocks.update({(0, 2): n * zNN, (2, 0): n * zNN, (2, 1): -n * rNN, (2, 2): zNN, (1, 2): -n * rNN})
        rows, cols, vals = [], [], []
        for (i, k), blk in blocks.items():
            ri = nd * self.edges[:, :, None] + i  # (n_e, 3, 1)
            ck = nd * self.edges[:, None, :] + k  # (n_e, 1, 3)
            rows.append(np.broadcast_to(ri, blk.shape).ravel())
            cols.append(np.broadcast_to(ck, blk.shape).ravel())
            vals.append(fac * blk.ravel())
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
