"""Smeared fibre reinforcement: an anisotropic strain-energy term with one fibre strain per element.

A family of fibres smeared over a region of the host mesh has, at each point, the energy
density of a linear fibre in Green–Lagrange / St Venant–Kirchhoff form along the reference
direction a (|a| = 1)::

    E_a = ½ (a·C a − 1),   ψ_f = ½ k E_a²          (k: fibre stiffness per volume, MPa)

(Bonet & Wood 2008, §6.5; k = E_f A_f ρ_L with ρ_L the fibre length per volume). Stiff
fibres (k/μ ~ 10³) make E_a ≈ 0 a constraint; imposed at every quadrature point of a P2
tetrahedron it made coarse whisker meshes too stiff (benchmarks/results/fibre_models.md), as incompressibility
does. As the mean dilatation does for J, the
element therefore carries one fibre strain, its k-weighted mean (c_q = w_q k_q,
C_e = Σ_q c_q)::

    Ē_e = Σ_q c_q E_a,q / C_e,     Π_f = Σ_e ½ C_e Ē_e²

which equals ∫ ψ_f dV for a homogeneous deformation and converges to it under refinement
(Simo, Taylor & Pister 1985 for the mean-dilatation argument). With g_a = ∇N_a · a and
f = F a (∂E_a/∂u_ai = f_i g_a), b[a, i] = Σ_q c_q f_i g_a::

    R[a, i]    = Ē_e b[a, i]
    K[ai, bk]  = b[a, i] b[b, k] / C_e + Ē_e Σ_q c_q g_a g_b δ_ik

The same energy integrated along a single fibre line is :mod:`fem.truss`.
"""

from __future__ import annotations

import numpy as np


class FibreFieldKernel:
    """Residual, tangent and energy of one :class:`fem.problem.SmearedFibres` term.

    Parameters
    ----------
    dNdX : ndarray (n_el, n_qp, 10, 3)
        Reference shape-function gradients of the whole mesh.
    wdet : ndarray (n_el, n_qp)
        Quadrature weight × reference Jacobian.
    elements : ndarray (n_sel,) int
        Reinforced elements.
    stiffness : ndarray (n_sel, n_qp)
        k at each quadrature point [MPa].
    directions : ndarray (n_sel, n_qp, 3)
        Unit reference fibre direction a at each quadrature point.
    """

    def __init__(self, dNdX, wdet, elements, stiffness, directions) -> None:
        self.elements = np.asarray(elements, dtype=np.int64)
        self.a = np.asarray(directions, float)  # (n_sel, n_qp, 3)
        self.wk = wdet[self.elements] * np.asarray(stiffness, float)  # (n_sel, n_qp)  c_q = w k
        C = self.wk.sum(axis=1)  # (n_sel,)  C_e
        self.C = np.where(C > 0.0, C, 1.0)  # an element of zero stiffness stores nothing (its c_q are 0)
        self.g = np.einsum("eqaJ,eqJ->eqa", dNdX[self.elements], self.a)  # (n_sel, n_qp, 10)  ∇N_a·a

    def _strains(self, F: np.ndarray):
        """f = F a at the points (n_sel, n_qp, 3) and the element mean fibre strain Ē (n_sel,)."""
        f = np.einsum("eqiJ,eqJ->eqi", F[self.elements], self.a)  # (n_sel, n_qp, 3)  F a
        E = 0.5 * (np.einsum("eqi,eqi->eq", f, f) - 1.0)  # (n_sel, n_qp)  E_a
        return f, np.einsum("eq,eq->e", self.wk, E) / self.C  # (n_sel,)  Ē_e

    def energy(self, F: np.ndarray) -> float:
        """Σ_e ½ C_e Ē_e²."""
        _, Eb = self._strains(F)
        return float(0.5 * np.sum(self.C * Eb**2))

    def evaluate(self, F: np.ndarray, need_tangent: bool = True):
        """Element residuals (n_sel, 10, 3) and element tangents (n_sel, 30, 30) or None.

        Parameters
        ----------
        F : ndarray (n_el, n_qp, 3, 3)
            Deformation gradient of the whole mesh.
        """
        f, Eb = self._strains(F)
        n = len(self.elements)
        b = np.einsum("eq,eqa,eqi->eai", self.wk, self.g, f).reshape(n, 30)  # (n_sel, 30)  Σ_q c g_a f_i
        Re = (Eb[:, None] * b).reshape(n, 10, 3)  # (n_sel, 10, 3)
        if not need_tangent:
            return Re, None
        Ke = ((b / self.C[:, None])[:, :, None] * b[:, None, :]).reshape(n, 10, 3, 10, 3)  # (n_sel, a, i, b, k)
        Kg = np.matmul(np.swapaxes(self.g * self.wk[..., None], 1, 2), self.g) * Eb[:, None, None]  # (n_sel, 10, 10)
        for i in range(3):
            Ke[:, :, i, :, i] += Kg
        return Re, Ke.reshape(n, 30, 30)
