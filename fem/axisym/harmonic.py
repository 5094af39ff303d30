"""An axisymmetric solid at finite strain and its Fourier-harmonic tangent ("semi-analytical" elements).

A body of revolution is meshed in the (R, Z) half-plane with 9-node quadrilaterals (:mod:`fem.axisym.quad9`).
Its displacement, in the cylindrical basis (e_r, e_z, e_θ) at the reference angle Θ, is

    u = u_r e_r + u_z e_z + u_θ e_θ,

and the gradient of x = X + u in physical components (rows r, z, θ; columns R, Z, Θ) is exactly::

    F = I + [[∂u_r/∂R, ∂u_r/∂Z, (∂u_r/∂Θ − u_θ)/R],
             [∂u_z/∂R, ∂u_z/∂Z,  ∂u_z/∂Θ / R      ],
             [∂u_θ/∂R, ∂u_θ/∂Z, (∂u_θ/∂Θ + u_r)/R]]

(Zienkiewicz & Taylor, vol. 2, ch. 9; Bathe, *Finite Element Procedures*, §5.4). The **axisymmetric
state** has u_θ = 0 and no Θ dependence: a nonlinear problem in (u_r, u_z) with the mixed potential of
:mod:`fem.assembly` (P1disc element pressure, ``W_iso + p(J − 1) − (D1/4)p²``, so D1 = 0 is exact
incompressibility), integrated over dV = R dR dZ dΘ.

The **harmonic n** perturbation about that state is δu_r = a cos nΘ, δu_z = b cos nΘ, δu_θ = c sin nΘ,
δp = q cos nΘ. Its gradient has cos-type components (rR, rZ, zR, zZ, θΘ) and sin-type ones (rΘ, zΘ,
θR, θZ); with Ĝ the amplitudes::

    Ĝ_rΘ = −(n a + c)/R,  Ĝ_zΘ = −n b/R,  Ĝ_θΘ = (n c + a)/R,  Ĝ_θR = ∂c/∂R, Ĝ_θZ = ∂c/∂Z, …

The axisymmetric state is symmetric under Θ → −Θ, so the material tangent A = ∂²W/∂F∂F couples
cos-type components only with cos-type ones and sin-type with sin-type; ∫cos² = ∫sin² = π over a turn
(n ≥ 1). The second variation of the potential for harmonic n is therefore exactly::

    δ²Π_n = π ∫ [Ĝ : A : Ĝ + 2 q J F⁻ᵀ : Ĝ − (D1/2) q²] R dR dZ + pressure,

with A = ∂²W_iso/∂F∂F + p ∂²J/∂F∂F: the 3-D tangent evaluated on Ĝ, with π in place of 2π
(:meth:`HarmonicSolid.harmonic_tangent`).
Harmonics do not couple about an axisymmetric state, so each n is a 2-D problem of three displacement
amplitudes per node.

Fibre rings are either meshed with their own material, or carry a hoop stiffness on top of the host
(:class:`HoopFibre`: the St Venant–Kirchhoff fibre energy ½ k E_θ² with one mean strain per element,
as :mod:`fem.fibre_field` in 3-D). A region's hoop displacement can be given its own nodes on an
interface (``slide``): the two sides then share u_r, u_z and slide freely along the hoop in the
harmonics (frictionless contact that keeps the normal and in-plane gap closed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fem.assembly import InvertedElements
from fem.axisym import quad9
from fem.axisym.harmonic_pressure import EdgePressureKernel
from fem.material import IsochoricI1Material

# (i, J, k, kind): a non-zero entry of the gradient operator for a node's shape function:
# row i of F (r, z, θ), column J (R, Z, Θ), displacement component k (r, z, θ), and what multiplies it:
# 'R' ∂N/∂R, 'Z' ∂N/∂Z, 'n' n N/R, '-n' −n N/R, '1' N/R, '-1' −N/R.
_B_TERMS = (
    (0, 0, 0, "R"), (0, 1, 0, "Z"), (0, 2, 0, "-n"), (0, 2, 2, "-1"),
    (1, 0, 1, "R"), (1, 1, 1, "Z"), (1, 2, 1, "-n"),
    (2, 0, 2, "R"), (2, 1, 2, "Z"), (2, 2, 2, "n"), (2, 2, 0, "1"),
)


@dataclass(frozen=True, eq=False)
class Region:
    """Elements that share one material law."""

    elements: np.ndarray
    law: IsochoricI1Material


@dataclass(frozen=True, eq=False)
class HoopFibre:
    """A hoop fibre stiffness k [MPa] on top of the host in ``elements`` (one mean fibre strain each)."""

    elements: np.ndarray
    stiffness: float


def _csr(parts, size: int) -> sp.csr_matrix:
    """One CSR matrix from COO triplets, duplicates summed and every structural entry kept (zeros included),
    so that the pattern does not depend on the values (a factorisation's analysis is then reused)."""
    rows, cols, vals = (np.concatenate(a) for a in zip(*parts))
    return sp.csr_matrix((vals, (rows, cols)), shape=(size, size))


class HarmonicSolid:
    """The axisymmetric state and the harmonic tangents of a body of revolution meshed with Q9 elements.

    Parameters
    ----------
    points : ndarray (n_nodes, 2)
        Reference (R, Z); R > 0 at every quadrature point.
    cells : ndarray (n_el, 9)
        :mod:`fem.axisym.quad9` connectivity, counter-clockwise.
    regions : sequence of Region
        Every element in exactly one region.
    hoop_fibres : sequence of HoopFibre
    pressure_edges : ndarray (n_e, 3), optional
        Boundary edges (body on their left) loaded by the follower pressure.
    slide : tuple (elements, nodes), optional
        The hoop displacement u_θ of ``elements`` at ``nodes`` is its own unknown in the harmonics.
    n_gauss : int
        Gauss points per direction (3 integrates the Q9 stiffness of a straight-sided element).

    Unknowns of the axisymmetric state: ``x = [u (n_nodes, 2) ravelled, p (n_el, 3) ravelled]``.
    Unknowns of harmonic n: ``y = [amplitudes (n_nodes, 3) ravelled, extra hoop dofs, q (n_el, 3)]``.
    """

    def __init__(self, points, cells, regions, hoop_fibres=(), pressure_edges=None, slide=None, n_gauss: int = 3):
        self.X = np.asarray(points, float)
        self.cells = np.asarray(cells, np.int64)
        self.n_nodes, self.n_el = len(self.X), len(self.cells)
        xi, w = quad9.gauss_square(n_gauss)
        N = quad9.shape_functions(xi)  # (n_qp, 9)
        dN = quad9.shape_gradients(xi)  # (n_qp, 9, 2)
        Xe = self.X[self.cells]  # (n_el, 9, 2)
        Jm = np.einsum("qak,eai->eqik", dN, Xe)  # (n_el, n_qp, 2, 2)  ∂X_i/∂ξ_k
        det = np.linalg.det(Jm)  # (n_el, n_qp)
        if np.any(det <= 0):
            raise ValueError(f"HarmonicSolid: {int(np.sum(np.any(det <= 0, 1)))} elements with det J <= 0")
        self.dNdX = np.einsum("qak,eqki->eqai", dN, np.linalg.inv(Jm))  # (n_el, n_qp, 9, 2)
        self.N = np.broadcast_to(N, (self.n_el,) + N.shape)  # (n_el, n_qp, 9)
        self.Rq = np.einsum("qa,ea->eq", N, Xe[..., 0])  # (n_el, n_qp)
        if np.any(self.Rq <= 0):
            raise ValueError("HarmonicSolid: the mesh reaches R <= 0 at a quadrature point")
        self.wR = w[None, :] * det * self.Rq  # (n_el, n_qp)  w |J| R
        self.Np = quad9.pressure_basis(xi)  # (n_qp, 3)
        self.laws = np.full(self.n_el, -1)
        self.regions = tuple(regions)
        for k, reg in enumerate(self.regions):
            self.laws[np.asarray(reg.elements)] = k
        if np.any(self.laws < 0):
            raise ValueError(f"HarmonicSolid: {int(np.sum(self.laws < 0))} elements in no region")
        self.d1 = np.array([float(self.regions[k].law.d1) for k in self.laws])  # (n_el,)
        self.hoop = tuple(hoop_fibres)
        self.pressure = None if pressure_edges is None else EdgePressureKernel(self.X, pressure_edges)
        self.n_u0 = 2 * self.n_nodes
        self._slide(slide)

    # ---------------------------------------------------------------- dof maps
    def _slide(self, slide) -> None:
        """Harmonic dof map: 3 amplitudes per node; the sliding elements' u_θ at the interface nodes apart."""
        e3 = 3 * self.cells[:, :, None] + np.arange(3)  # (n_el, 9, 3)
        n_extra = 0
        if slide is not None:
            els, nodes = (np.asarray(a, np.int64) for a in slide)
            extra = np.full(self.n_nodes, -1)
            extra[nodes] = 3 * self.n_nodes + np.arange(len(nodes))
            n_extra = len(nodes)
            sub = e3[els]
            hit = extra[self.cells[els]] >= 0  # (n_sel, 9)
            sub[..., 2] = np.where(hit, extra[self.cells[els]], sub[..., 2])
            e3[els] = sub
        self.edofs_h = e3.reshape(self.n_el, 27)
        self.n_uh = 3 * self.n_nodes + n_extra
        self.edofs_0 = (2 * self.cells[:, :, None] + np.arange(2)).reshape(self.n_el, 18)

    def pdofs(self, n_u: int) -> np.ndarray:
        """Element pressure dofs (n_el, 3) after ``n_u`` displacement dofs."""
        return n_u + 3 * np.arange(self.n_el)[:, None] + np.arange(3)

    # ---------------------------------------------------------------- kinematics
    def deformation_gradient(self, u: np.ndarray) -> np.ndarray:
        """F of the axisymmetric state u (n_nodes, 2) at the quadrature points -> (n_el, n_qp, 3, 3)."""
        ue = u[self.cells]  # (n_el, 9, 2)
        H = np.einsum("eai,eqaJ->eqiJ", ue, self.dNdX)  # (n_el, n_qp, 2, 2)
        ur = np.einsum("eqa,ea->eq", self.N, ue[..., 0])  # (n_el, n_qp)
        F = np.zeros(H.shape[:2] + (3, 3))
        F[..., :2, :2] = np.eye(2) + H
        F[..., 2, 2] = 1.0 + ur / self.Rq
        return F

    def _B(self, n: int, els: np.ndarray, ndof: int) -> np.ndarray:
        """Gradient operator of harmonic n: B[e, q, 3i+J, 3a+k] (n_sel, n_qp, 9, 9·ndof)."""
        dN = self.dNdX[els]  # (n_sel, n_qp, 9, 2)
        NR = self.N[els] / self.Rq[els][..., None]  # (n_sel, n_qp, 9)  N/R
        val = {"R": dN[..., 0], "Z": dN[..., 1], "n": n * NR, "-n": -n * NR, "1": NR, "-1": -NR}
        B = np.zeros(dN.shape[:2] + (9, 9, ndof))
        for i, J, k, kind in _B_TERMS:
            if k < ndof:
                B[:, :, 3 * i + J, :, k] += val[kind]
        return B.reshape(dN.shape[:2] + (9, 9 * ndof))

    def _material(self, F: np.ndarray, p: np.ndarray, els: np.ndarray):
        """Stress and tangent with the volumetric term: P, A (flattened 9 × 9), J, JG (J F⁻ᵀ flattened)."""
        J = np.linalg.det(F)  # (n_sel, n_qp)
        # a hoop stretch ≤ 0 is a ring through the axis: inverted in 3-D, even where the mirrored section keeps J > 0
        bad = (J <= 0) | ~np.isfinite(J) | (F[..., 2, 2] <= 0)
        if np.any(bad):
            raise InvertedElements(int(np.sum(bad)), float(np.nanmin(J)) if np.any(np.isfinite(J)) else math.nan)
        G = np.linalg.inv(F)  # (n_sel, n_qp, 3, 3)
        P = np.empty_like(F)
        A = np.empty(F.shape + (3, 3))
        for k, reg in enumerate(self.regions):
            sel = self.laws[els] == k
            if sel.any():
                P[sel], A[sel] = reg.law.stress_tangent(F[sel], G[sel], J[sel])
        pq = np.einsum("qj,ej->eq", self.Np, p)  # (n_sel, n_qp)
        Gt = np.swapaxes(G, -1, -2)
        JG = J[..., None, None] * Gt  # (n_sel, n_qp, 3, 3)  J F⁻ᵀ
        P = P + pq[..., None, None] * JG
        A = A + (pq * J)[..., None, None, None, None] * (
            np.einsum("...Ji,...Lk->...iJkL", G, G) - np.einsum("...Jk,...Li->...iJkL", G, G))  # (n_sel, n_qp, 3,3,3,3)
        s = F.shape[:2]
        return P.reshape(s + (9,)), A.reshape(s + (9, 9)), J, JG.reshape(s + (9,))

    # ---------------------------------------------------------------- the axisymmetric state
    def axisymmetric(self, x: np.ndarray, pressure: float = 0.0, need_tangent: bool = True):
        """Residual (n_u0 + 3 n_el,) and tangent (csr) of the axisymmetric state x at cavity pressure ``pressure``.

        R_u = 2π ∫ P : δF R dA + pressure;   R_p = 2π ∫ N_p (J − 1 − (D1/2) p) R dA.
        """
        u, p = x[: self.n_u0].reshape(-1, 2), x[self.n_u0:].reshape(-1, 3)
        els = np.arange(self.n_el)
        F = self.deformation_gradient(u)
        P, A, J, JG = self._material(F, p, els)
        B = self._B(0, els, 2)  # (n_el, n_qp, 9, 18)
        phi = 2.0 * math.pi
        wR = phi * self.wR  # (n_el, n_qp)
        pq = np.einsum("qj,ej->eq", self.Np, p)
        Ru = np.einsum("eq,eqI,eqIa->ea", wR, P, B)  # (n_el, 18)
        Rp = np.einsum("eq,qj,eq->ej", wR, self.Np, J - 1.0 - 0.5 * self.d1[:, None] * pq)  # (n_el, 3)
        R = np.zeros(self.n_u0 + 3 * self.n_el)
        np.add.at(R, self.edofs_0, Ru)
        R[self.n_u0:] += Rp.ravel()
        for hf in self.hoop:
            self._hoop_axisym(hf, F, B, phi, R)
        if self.pressure is not None and pressure != 0.0:
            R[: self.n_u0] += self.pressure.residual0(u, pressure)
        if not need_tangent:
            return R, None
        parts = [self._blocks(B, A, JG, wR, self.edofs_0, self.pdofs(self.n_u0))]
        parts += [self._hoop_tangent(hf, F, B, phi, self.edofs_0) for hf in self.hoop]
        if self.pressure is not None and pressure != 0.0:
            parts.append(self.pressure.tangent(u, pressure, 0))
        return R, _csr(parts, len(R))

    def _blocks(self, B, A, JG, wR, edofs, pdofs):
        """COO triplets of [K_uu K_up; K_pu K_pp] from B, A, J F⁻ᵀ and the weights."""
        Kuu = np.einsum("eq,eqIa,eqIJ,eqJb->eab", wR, B, A, B, optimize=True)  # (n_el, nd, nd)
        Kup = np.einsum("eq,eqIa,eqI,qj->eaj", wR, B, JG, self.Np)  # (n_el, nd, 3)
        Kpp = -0.5 * self.d1[:, None, None] * np.einsum("eq,qi,qj->eij", wR, self.Np, self.Np)  # (n_el, 3, 3)
        nd = edofs.shape[1]
        r = [np.repeat(edofs, nd, axis=1), np.repeat(edofs, 3, axis=1), np.repeat(pdofs, nd, axis=1),
             np.repeat(pdofs, 3, axis=1)]
        c = [np.tile(edofs, nd), np.tile(pdofs, nd), np.tile(edofs, 3), np.tile(pdofs, 3)]
        v = [Kuu.reshape(self.n_el, -1), Kup.reshape(self.n_el, -1), np.swapaxes(Kup, 1, 2).reshape(self.n_el, -1),
             Kpp.reshape(self.n_el, -1)]
        return (np.concatenate([a.ravel() for a in r]), np.concatenate([a.ravel() for a in c]),
                np.concatenate([a.ravel() for a in v]))

    # ---------------------------------------------------------------- hoop fibres
    def _hoop_strain(self, hf: HoopFibre, F: np.ndarray):
        """Weights c_q = w R k, C_e, λ_θ and the element mean Green strain Ē along the hoop."""
        els = np.asarray(hf.elements)
        c = self.wR[els] * hf.stiffness  # (n_sel, n_qp)
        C = c.sum(axis=1)  # (n_sel,)
        lam = F[els, :, 2, 2]  # (n_sel, n_qp)  F e_Θ = λ_θ e_θ in the axisymmetric state
        Eb = np.einsum("eq,eq->e", c, 0.5 * (lam**2 - 1.0)) / C  # (n_sel,)
        return els, c, C, lam, Eb

    def _hoop_axisym(self, hf, F, B, phi, R):
        els, c, C, lam, Eb = self._hoop_strain(hf, F)
        b = np.einsum("eq,eq,eqa->ea", c, lam, B[els][:, :, 8, :])  # (n_sel, 18)  Σ c λ ∂F_θΘ/∂u
        np.add.at(R, self.edofs_0[els], phi * Eb[:, None] * b)

    def _hoop_tangent(self, hf, F, B, phi, edofs):
        """COO triplets of phi [b bᵀ / C + Ē Σ_q c Σ_i B_iΘᵀ B_iΘ] (the fibre term's second variation)."""
        els, c, C, lam, Eb = self._hoop_strain(hf, F)
        Bs = B[els]  # (n_sel, n_qp, 9, nd)
        b = np.einsum("eq,eq,eqa->ea", c, lam, Bs[:, :, 8, :])  # (n_sel, nd)
        col = Bs[:, :, [2, 5, 8], :]  # (n_sel, n_qp, 3, nd)  rows rΘ, zΘ, θΘ of B
        Ke = phi * (np.einsum("ea,eb->eab", b, b) / C[:, None, None]
                    + Eb[:, None, None] * np.einsum("eq,eqia,eqib->eab", c, col, col))  # (n_sel, nd, nd)
        ed = edofs[els]
        nd = ed.shape[1]
        return np.repeat(ed, nd, 1).ravel(), np.tile(ed, nd).ravel(), Ke.ravel()

    # ---------------------------------------------------------------- harmonics
    def harmonic_tangent(self, n: int, x: np.ndarray, pressure: float = 0.0) -> sp.csr_matrix:
        """Tangent of harmonic n ≥ 1 about the axisymmetric state x: π ∫ Bₙᵀ A Bₙ R dA + couplings + pressure.

        The quadratic form yᵀ K y is the second variation of the potential along the harmonic field of
        amplitudes y (over the whole turn).
        """
        if n < 1:
            raise ValueError(f"harmonic_tangent: n={n} must be >= 1 (n = 0 is the axisymmetric tangent)")
        u, p = x[: self.n_u0].reshape(-1, 2), x[self.n_u0:].reshape(-1, 3)
        els = np.arange(self.n_el)
        F = self.deformation_gradient(u)
        _, A, _, JG = self._material(F, p, els)
        B = self._B(n, els, 3)  # (n_el, n_qp, 9, 27)
        wR = math.pi * self.wR
        size = self.n_uh + 3 * self.n_el
        parts = [self._blocks(B, A, JG, wR, self.edofs_h, self.pdofs(self.n_uh))]
        parts += [self._hoop_tangent(hf, F, B, math.pi, self.edofs_h) for hf in self.hoop]
        if self.pressure is not None and pressure != 0.0:
            parts.append(self.pressure.tangent(u, pressure, n))
        return _csr(parts, size)
