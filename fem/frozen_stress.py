"""A prescribed (frozen) second Piola–Kirchhoff stress field as an energy term.

A stress T that does not depend on the deformation, held on a set of elements, has the energy
(Bonet & Wood 2008, §5.5, the work of a stress on the Green–Lagrange strain E = ½(C − I))::

    Π_T = Σ_e Σ_q w_q  T_JL E_JL = Σ_e Σ_q w_q ½ T_JL (C_JL − δ_JL),      C = FᵀF

Its first variation gives the nodal forces and its second the initial-stress ("geometric")
stiffness of T, with g_a = ∇N_a (reference gradients)::

    R[a, i]    = Σ_q w (F T)_iL g_aL
    K[ai, bk]  = δ_ik Σ_q w g_aJ T_JL g_bL

Used with a material whose moduli are scaled, it changes a body's incremental material stiffness
about a stressed state without moving that state's equilibrium (:class:`fem.material.ScaledMaterial`):
c W̄ + Π_T with T = −(c − 1) S̄_p has the stress S̄_p and the material tangent c ℂ̄ at C = C_p.
"""

from __future__ import annotations

import numpy as np


class FrozenStressKernel:
    """Residual, tangent and energy of one :class:`fem.problem.FrozenStress` term.

    Parameters
    ----------
    dNdX : ndarray (n_el, n_qp, 10, 3)
        Reference shape-function gradients of the whole mesh.
    wdet : ndarray (n_el, n_qp)
        Quadrature weight × reference Jacobian.
    elements : ndarray (n_sel,) int
        Elements that carry the stress.
    stress : ndarray (n_sel, n_qp, 3, 3)
        Symmetric second Piola–Kirchhoff stress T at each quadrature point [MPa].
    """

    def __init__(self, dNdX, wdet, elements, stress) -> None:
        self.elements = np.asarray(elements, dtype=np.int64)
        self.T = np.asarray(stress, float)  # (n_sel, n_qp, 3, 3)
        self.w = wdet[self.elements]  # (n_sel, n_qp)
        self.g = dNdX[self.elements]  # (n_sel, n_qp, 10, 3)

    def energy(self, F: np.ndarray) -> float:
        """Σ_e Σ_q w ½ T:(C − I)."""
        Fs = F[self.elements]  # (n_sel, n_qp, 3, 3)
        C = np.matmul(np.swapaxes(Fs, -1, -2), Fs)  # (n_sel, n_qp, 3, 3)  FᵀF
        return float(0.5 * np.einsum("eq,eqJL,eqJL->", self.w, self.T, C - np.eye(3)))

    def evaluate(self, F: np.ndarray, need_tangent: bool = True):
        """Element residuals (n_sel, 10, 3) and element tangents (n_sel, 30, 30) or None.

        Parameters
        ----------
        F : ndarray (n_el, n_qp, 3, 3)
            Deformation gradient of the whole mesh.
        """
        FT = np.matmul(F[self.elements], self.T)  # (n_sel, n_qp, 3, 3)  (F T)_iL
        Re = np.einsum("eq,eqaL,eqiL->eai", self.w, self.g, FT)  # (n_sel, 10, 3)
        if not need_tangent:
            return Re, None
        n = len(self.elements)
        gT = np.matmul(self.g * self.w[..., None, None], self.T)  # (n_sel, n_qp, 10, 3)  w g_aJ T_JL
        Kg = np.einsum("eqaL,eqbL->eab", gT, self.g)  # (n_sel, 10, 10)
        Ke = np.zeros((n, 10, 3, 10, 3))
        for i in range(3):
            Ke[:, :, i, :, i] = Kg
        return Re, Ke.reshape(n, 30, 30)
