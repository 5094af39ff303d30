"""Hyperelastic membrane on 6-node boundary triangles: a thin sheet bonded to the solid's surface.

A sheet of thickness t (which may vary over the surface, and vanish outside a footprint) is bonded to a
face set Γ0 of the solid and moves with it. Its stored energy is the plane-stress Saint Venant–Kirchhoff
energy of the surface Green–Lagrange strain (Ciarlet 2000, *Mathematical Elasticity* vol. III, §1.11:
the membrane limit of a thin St Venant–Kirchhoff plate; Bonet & Wood 2008, §6.4.2 for the law)::

    Π_m = ∫_Γ0 t W(E_s) dA0,
    E_s = ½ (F_sᵀ F_s − I_2),                      F_s = Σ_a x_a ⊗ ∂N_a/∂S    (3 × 2)
    W   = Y/(2(1 − ν²)) [ (1 − ν) tr(E_s²) + ν (tr E_s)² ]  =  μ tr(E_s²) + (λ̂/2) (tr E_s)²

with S = (S_1, S_2) Cartesian coordinates in an orthonormal reference tangent basis (e_1 = X,1/|X,1|,
e_2 = n0 × e_1) at each quadrature point, μ = Y/(2(1 + ν)) and the plane-stress λ̂ = Yν/(1 − ν²).
The second Piola–Kirchhoff stress is S = ∂W/∂E_s = λ̂ tr(E_s) I_2 + 2μ E_s, the nodal residual (the
sheet's internal force, first derivative of Π_m)::

    R_ai = ∫ t (F_s S)_iβ ∂N_a/∂S_β dA0

and the tangent (second derivative) its material and geometric parts::

    K_aibk = ∫ t [ B_ai : ℂ : B_bk + (∂N_a/∂S · S · ∂N_b/∂S) δ_ik ] dA0,
    B_ai,αβ = ½ (F_iα ∂N_a/∂S_β + F_iβ ∂N_a/∂S_α),   ℂ = λ̂ I_2 ⊗ I_2 + 2μ 𝕀

(Bonet & Wood 2008, §9.4 for the split). A rigid motion x = Q X + c gives F_s = Q [e_1 e_2], so
E_s = 0: no energy and no force. The sheet's bending stiffness (Y t³/12) and its offset from the surface
(t/2) are left out: for a sheet much thinner than the radius of curvature of the surface they are of
relative order t/R. The law is adequate for a stiff sheet's small strains; a large membrane stretch
under compression would need a law that is polyconvex.

The surface integrals use the triangle rule of the problem's face degree (at least 4: on a flat face
F_s is linear in the face coordinates and W of degree 4).
"""

from __future__ import annotations

import numpy as np

from fem.faces import face_geometry

#: Lowest triangle-rule degree: exact for W on flat faces.
MIN_DEGREE = 4


def lame_plane_stress(youngs_modulus: float, poisson: float) -> tuple[float, float]:
    """(λ̂, μ) of the plane-stress law: λ̂ = Yν/(1 − ν²), μ = Y/(2(1 + ν)) [MPa]."""
    return youngs_modulus * poisson / (1.0 - poisson**2), 0.5 * youngs_modulus / (1.0 + poisson)


class MembraneKernel:
    """Reference geometry of one :class:`fem.problem.Membrane`: the surface gradients of the shape functions.

    Parameters
    ----------
    points : ndarray (n_nodes, 3)
        Reference node coordinates.
    faces : ndarray (n_f, 6)
        6-node triangles (corners a, b, c, then mid-edges ab, bc, ca); either orientation.
    degree : int
        Exactness of the triangle rule (raised to :data:`MIN_DEGREE` when lower).

    Attributes
    ----------
    dNdS : ndarray (n_f, n_qp, 6, 2)
        ∂N_a/∂S_β in the orthonormal reference tangent basis.
    wdA : ndarray (n_f, n_qp)
        Quadrature weight times the reference area element.
    points : ndarray (n_f, n_qp, 3)
        Reference positions of the quadrature points.
    """

    def __init__(self, points: np.ndarray, faces: np.ndarray, degree: int = MIN_DEGREE) -> None:
        g = face_geometry(points, faces, max(int(degree), MIN_DEGREE), "MembraneKernel")
        self.faces = g.faces
        e1 = g.a1 / np.linalg.norm(g.a1, axis=-1, keepdims=True)  # (n_f, n_qp, 3)
        e2 = np.cross(g.normal, e1)  # (n_f, n_qp, 3)
        basis = np.stack([e1, e2], axis=-1)  # (n_f, n_qp, 3, 2)
        jac = np.matmul(np.stack([g.a1, g.a2], axis=-2), basis)  # (n_f, n_qp, 2, 2)  J_αβ = X,α · e_β
        # ∂N/∂ξ_α = Σ_β J_αβ ∂N/∂S_β, so ∂N/∂S = ∂N/∂ξ · J⁻ᵀ
        self.dNdS = np.matmul(g.dN[None], np.swapaxes(np.linalg.inv(jac), -1, -2))  # (n_f, n_qp, 6, 2)
        self.wdA = g.wdA  # (n_f, n_qp)
        self.points = g.points  # (n_f, n_qp, 3)
        self.n_qp = g.n_qp

    def surface_gradient(self, x: np.ndarray) -> np.ndarray:
        """F_s = Σ_a x_a ⊗ ∂N_a/∂S at every quadrature point of the current positions ``x`` (n_nodes, 3),
        shape (n_f, n_qp, 3, 2)."""
        xt = np.swapaxes(x[self.faces], 1, 2)[:, None]  # (n_f, 1, 3, 6)
        return np.matmul(xt, self.dNdS)  # (n_f, n_qp, 3, 2)

    def strain(self, x: np.ndarray) -> np.ndarray:
        """Surface Green–Lagrange strain E_s = ½ (F_sᵀ F_s − I_2), shape (n_f, n_qp, 2, 2)."""
        Fs = self.surface_gradient(x)
        return 0.5 * (np.matmul(np.swapaxes(Fs, -1, -2), Fs) - np.eye(2))  # (n_f, n_qp, 2, 2)

    def energy(self, x: np.ndarray, thickness: np.ndarray, youngs_modulus: float, poisson: float) -> float:
        """Π_m = Σ_q t w dA0 [μ tr(E_s²) + (λ̂/2) (tr E_s)²] (``thickness`` broadcast to (n_f, n_qp))."""
        lam, mu = lame_plane_stress(youngs_modulus, poisson)
        E = self.strain(x)
        tr = E[..., 0, 0] + E[..., 1, 1]  # (n_f, n_qp)
        W = mu * np.sum(E * E, axis=(-1, -2)) + 0.5 * lam * tr**2  # (n_f, n_qp)
        return float(np.sum(thickness * self.wdA * W))

    def evaluate(self, x: np.ndarray, thickness: np.ndarray, youngs_modulus: float, poisson: float,
                 need_tangent: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Residual R[f, a, i] = ∂Π_m/∂x_ai (n_f, 6, 3) and tangent K[f, a, i, b, k] (n_f, 6, 3, 6, 3) or None.

        See the module docstring for both formulas.
        """
        lam, mu = lame_plane_stress(youngs_modulus, poisson)
        G = self.dNdS  # (n_f, n_qp, 6, 2)
        Fs = self.surface_gradient(x)  # (n_f, n_qp, 3, 2)
        E = 0.5 * (np.matmul(np.swapaxes(Fs, -1, -2), Fs) - np.eye(2))  # (n_f, n_qp, 2, 2)
        S = 2.0 * mu * E  # (n_f, n_qp, 2, 2)
        tr = E[..., 0, 0] + E[..., 1, 1]  # (n_f, n_qp)
        S[..., 0, 0] += lam * tr
        S[..., 1, 1] += lam * tr
        tw = np.broadcast_to(thickness, self.wdA.shape) * self.wdA  # (n_f, n_qp)
        P = np.matmul(Fs, S)  # (n_f, n_qp, 3, 2)  F_s S
        R = np.sum(tw[..., None, None] * np.matmul(G, np.swapaxes(P, -1, -2)), axis=1)  # (n_f, 6, 3)
        if not need_tangent:
            return R, None
        n_f, nq = tw.shape
        # B_ai in the Voigt form (B_11, B_22, √2 B_12), so that B : ℂ : B' = Bv · D · Bv'
        Gi = G[:, :, :, None, :]  # (n_f, n_qp, 6, 1, 2)
        Fi = Fs[:, :, None, :, :]  # (n_f, n_qp, 1, 3, 2)
        Bv = np.stack([Gi[..., 0] * Fi[..., 0], Gi[..., 1] * Fi[..., 1],
                       np.sqrt(0.5) * (Gi[..., 1] * Fi[..., 0] + Gi[..., 0] * Fi[..., 1])],
                      axis=-1).reshape(n_f, nq, 18, 3)  # (n_f, n_qp, 6·3, 3)
        D = lam * np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 0.0]]) + 2.0 * mu * np.eye(3)  # (3, 3)
        BD = (Bv @ D) * tw[..., None, None]  # (n_f, n_qp, 18, 3)
        Km = np.matmul(BD.transpose(0, 2, 1, 3).reshape(n_f, 18, 3 * nq),
                       Bv.transpose(0, 1, 3, 2).reshape(n_f, 3 * nq, 18))  # (n_f, 18, 18)  Σ_q t w B D Bᵀ
        GS = np.matmul(G, S) * tw[..., None, None]  # (n_f, n_qp, 6, 2)
        Kg = np.matmul(GS.transpose(0, 2, 1, 3).reshape(n_f, 6, 2 * nq),
                       G.transpose(0, 1, 3, 2).reshape(n_f, 2 * nq, 6))  # (n_f, 6, 6)  Σ_q t w G S Gᵀ
        K = Km.reshape(n_f, 6, 3, 6, 3)  # (n_f, a, i, b, k)
        for i in range(3):
            K[:, :, i, :, i] += Kg
        return R, K
