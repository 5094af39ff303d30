"""Elastic surface support: distributed linear springs on reference boundary faces (a Winkler foundation).

A face set Γ rests on springs of normal stiffness k_n and tangential stiffness k_t per reference area
[N/mm³] acting on the displacement u, split along the reference unit normal n0 (Winkler 1867; the
tangential part as Pasternak-free shear springs, Kerr 1964, "Elastic and viscoelastic foundation
models", J. Appl. Mech. 31)::

    Π_s = ½ ∫_Γ [ k_n (u·n0)² + k_t |u − (u·n0) n0|² ] dA
        = ½ ∫_Γ [ k_t |u|² + (k_n − k_t) (u·n0)² ] dA

With u = Σ_a N_a u_a on a 6-node triangle (dA = |X,1 × X,2| ds, n0 = X,1 × X,2 / |X,1 × X,2|) the energy
is the quadratic form Π_s = ½ Σ_f u_fᵀ K_f u_f of the face blocks::

    K[a i, b k] = ∫ N_a N_b [ k_t δ_ik + (k_n − k_t) n0_i n0_k ] dA

whose first derivative is the residual R_a = Σ_b K_ab u_b (the spring force on the body is −R) and
whose second is the (constant, symmetric) tangent K. On a flat face n0 and dA are constant and the
integrand N_a N_b is of degree 4, so the triangle rule of degree 4 integrates it exactly; on a curved
(quadratic) face it is a rational function and the rule is an approximation that converges with the
face's curvature.
"""

from __future__ import annotations

import numpy as np

from fem.faces import face_geometry

#: Lowest triangle-rule degree: exact for N_a N_b on flat faces.
MIN_DEGREE = 4


class SupportKernel:
    """Geometry of one :class:`fem.problem.ElasticSupport`: the face mass matrices the stiffnesses scale.

    Parameters
    ----------
    points : ndarray (n_nodes, 3)
        Reference node coordinates.
    faces : ndarray (n_f, 6)
        6-node triangles (corners a, b, c, then mid-edges ab, bc, ca); either orientation (n0 enters
        only as n0 ⊗ n0).
    degree : int
        Exactness of the triangle rule (raised to :data:`MIN_DEGREE` when lower).

    Attributes
    ----------
    m0 : ndarray (n_f, 6, 6)
        ∫ N_a N_b dA.
    mn : ndarray (n_f, 6, 3, 6, 3)
        ∫ N_a N_b n0_i n0_k dA.
    area : ndarray (n_f,)
        Reference area of each face.
    """

    def __init__(self, points: np.ndarray, faces: np.ndarray, degree: int = MIN_DEGREE) -> None:
        g = face_geometry(points, faces, max(int(degree), MIN_DEGREE), "SupportKernel")
        self.faces = g.faces
        self.area = g.wdA.sum(axis=1)  # (n_f,)
        self.m0 = np.einsum("fq,qa,qb->fab", g.wdA, g.N, g.N)  # (n_f, 6, 6)
        self.mn = np.einsum("fq,qa,qb,fqi,fqk->faibk", g.wdA, g.N, g.N, g.normal, g.normal)  # (n_f, 6, 3, 6, 3)

    def blocks(self, k_n: float, k_t: float) -> np.ndarray:
        """Face stiffness blocks ``K[f, a, i, b, k]`` = k_t m0_ab δ_ik + (k_n − k_t) mn_aibk, shape (n_f, 6, 3, 6, 3)."""
        K = (k_n - k_t) * self.mn  # (n_f, 6, 3, 6, 3)
        for i in range(3):
            K[:, :, i, :, i] += k_t * self.m0
        return K

    def residual(self, u: np.ndarray, k_n: float, k_t: float) -> np.ndarray:
        """R[f, a, i] = Σ_b K[f, a, i, b, k] u_bk, shape (n_f, 6, 3): ∂Π_s/∂u."""
        uf = u[self.faces]  # (n_f, 6, 3)
        un = np.einsum("faibk,fbk->fai", self.mn, uf)  # (n_f, 6, 3)  ∫ N_a (u·n0) n0_i dA
        ut = np.matmul(self.m0, uf)  # (n_f, 6, 3)  ∫ N_a u_i dA
        return k_t * ut + (k_n - k_t) * un

    def energy(self, u: np.ndarray, k_n: float, k_t: float) -> float:
        """Π_s = ½ Σ_f u_f · R_f."""
        return float(0.5 * np.sum(u[self.faces] * self.residual(u, k_n, k_t)))

    def force(self, u: np.ndarray, k_n: float, k_t: float) -> np.ndarray:
        """Resultant force the springs exert on the body, −Σ_f Σ_a R[f, a], shape (3,) [N]."""
        return -self.residual(u, k_n, k_t).sum(axis=(0, 1))
