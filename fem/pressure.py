"""Follower pressure on 6-node boundary triangles and its consistent tangent.

A pressure p acting on the current surface gives the traction t = −p n da. With the
face parametrised by s = (s1, s2) on the reference triangle, n da = x,1 × x,2 ds, so
the nodal forces (internal-minus-external sign convention, R = f_int − f_ext) are::

    R_a = p ∫ N_a (x,1 × x,2) ds

and their derivative with respect to the nodal positions x_b (using
(u × v) = skew(u) v)::

    ∂R_a/∂x_b = p ∫ N_a [ N_b,2 skew(x,1) − N_b,1 skew(x,2) ] ds

which is not symmetric in general (symmetric in sum over a closed, fully loaded
surface). Bonet & Wood (2008) §8.4; Simo, Taylor & Wriggers (1991).
"""

from __future__ import annotations

import numpy as np

from fem import element
from fem.quadrature import tri_rule


def _skew(v: np.ndarray) -> np.ndarray:
    """skew(v) w = v × w; v shape (..., 3) -> (..., 3, 3)."""
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], -1),
            np.stack([v[..., 2], z, -v[..., 0]], -1),
            np.stack([-v[..., 1], v[..., 0], z], -1),
        ],
        -2,
    )


class PressureKernel:
    """Vectorised follower-pressure forces/tangent for one set of faces.

    Parameters
    ----------
    faces : ndarray (n_f, 6)
        Global node indices (outward orientation).
    degree : int
        Exactness of the triangle rule (≥ 4 integrates N·(x,1 × x,2) exactly on
        flat-sided faces with quadratic displacement).
    """

    def __init__(self, faces: np.ndarray, degree: int = 4) -> None:
        self.faces = np.asarray(faces, dtype=np.int64)
        rule = tri_rule(degree)
        self.w = rule.weights  # (n_qp,)
        self.N = element.tri6_shape_functions(rule.points)  # (n_qp, 6)
        self.dN = element.tri6_shape_gradients(rule.points)  # (n_qp, 6, 2)

    def evaluate(self, x: np.ndarray, p: float, need_tangent: bool = True):
        """Nodal residual contributions and tangent blocks.

        Parameters
        ----------
        x : ndarray (n_nodes, 3)
            Current positions.
        p : float
            Pressure magnitude.

        Returns
        -------
        R : ndarray (n_f, 6, 3)
        K : ndarray (n_f, 6, 3, 6, 3) or None
            ``K[f, a, i, b, k] = ∂R[f, a, i]/∂x[b, k]``.
        """
        xf = x[self.faces]  # (n_f, 6, 3)
        # contractions over the face nodes/points as (broadcast) matrix products, which
        # numpy runs an order of magnitude faster than the equivalent multi-operand einsums
        # (the figure: benchmarks/results/bench_fem.md, "Figures moved from the FE core's docstrings
        # and comments")
        t1 = np.matmul(self.dN[:, :, 0], xf)  # (n_f, n_qp, 3)  Σ_a dN_a,1 x_a
        t2 = np.matmul(self.dN[:, :, 1], xf)  # (n_f, n_qp, 3)
        nda = np.cross(t1, t2)  # (n_f, n_qp, 3)
        Nw = self.w[:, None] * self.N  # (n_qp, 6)
        R = p * np.matmul(Nw.T, nda)  # (n_f, 6, 3)  Σ_q w N_a (t1 × t2)
        if not need_tangent:
            return R, None
        n_f, nq = nda.shape[:2]
        # K[f, a, i, b, k] = p Σ_q Nw_qa (dN_qb,2 S1_fqik − dN_qb,1 S2_fqik)
        S = np.concatenate([_skew(t1).reshape(n_f, nq, 9), -_skew(t2).reshape(n_f, nq, 9)], axis=1)  # (n_f, 2 n_qp, 9)
        M = np.concatenate([(Nw[:, :, None] * self.dN[:, None, :, 1]).reshape(nq, 36),
                            (Nw[:, :, None] * self.dN[:, None, :, 0]).reshape(nq, 36)], axis=0)  # (2 n_qp, 36) [q, ab]
        K = p * np.matmul(np.swapaxes(S, 1, 2), M)  # (n_f, 9, 36) [ik, ab]
        return R, K.reshape(n_f, 3, 3, 6, 6).transpose(0, 3, 1, 4, 2)  # (n_f, 6, 3, 6, 3)

    def enclosed_volume(self, x: np.ndarray) -> float:
        """Volume enclosed by the faces if they form a closed surface (divergence theorem).

        V = −(1/3) ∫ x · n da with n pointing out of the *solid*, i.e. into the cavity.
        """
        xf = x[self.faces]
        t1 = np.einsum("qa,fai->fqi", self.dN[:, :, 0], xf)
        t2 = np.einsum("qa,fai->fqi", self.dN[:, :, 1], xf)
        xq = np.einsum("qa,fai->fqi", self.N, xf)
        return float(-np.einsum("q,fqi,fqi->", self.w, xq, np.cross(t1, t2)) / 3.0)
