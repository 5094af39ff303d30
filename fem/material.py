"""Hyperelastic materials for the mixed displacement–pressure formulation.

The strain energy is split into an isochoric part, a function of the modified
first invariant Ī1 = J^{-2/3} tr(FᵀF), and a volumetric part handled by the
element pressure of :mod:`fem.assembly`::

    W(F) = W_iso(Ī1) + (1/D1) (J - 1)²          (Abaqus/CalculiX convention)

Only the isochoric part is implemented by a material class: the mixed form
replaces (1/D1)(J − 1)² by its Legendre transform p (J − 1) − (D1/4) p², so D1 = 0
(full incompressibility) is admissible. Any I1-based law (neo-Hookean, Yeoh) is
one subclass giving W_iso and its first two derivatives in Ī1.

References
----------
Holzapfel, *Nonlinear Solid Mechanics* (2000), §6.4–6.5 (isochoric/volumetric split).
Bonet & Wood, *Nonlinear Continuum Mechanics for FEA* (2008), §6.6 (mixed u–p).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _check(name: str, field: str, value: float, lo: float, hi: float = np.inf) -> None:
    if not (np.isfinite(value) and lo <= value <= hi):
        raise ValueError(f"{name}.{field}={value!r} outside the allowed range [{lo}, {hi}]")


class IsochoricI1Material:
    """Base class: W_iso = f(Ī1) with Ī1 = J^{-2/3} I1.

    Subclasses implement :meth:`f_derivatives` and define ``d1`` (volumetric
    compliance, 1/MPa, ≥ 0) and ``shear_modulus``.
    """

    d1: float

    @property
    def shear_modulus(self) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def f_derivatives(self, i1bar: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f(Ī1), f'(Ī1), f''(Ī1), each the shape of ``i1bar``."""
        raise NotImplementedError  # pragma: no cover - abstract

    # ------------------------------------------------------------------ kernels
    def energy(self, F: np.ndarray) -> np.ndarray:
        """Isochoric energy density W_iso(F), shape ``F.shape[:-2]``."""
        J = np.linalg.det(F)
        i1bar = J ** (-2.0 / 3.0) * np.einsum("...iJ,...iJ->...", F, F)  # (...)
        return self.f_derivatives(i1bar)[0]

    def stress_tangent(self, F: np.ndarray, G: np.ndarray, J: np.ndarray, need_tangent: bool = True):
        """First Piola stress and material tangent of the isochoric part.

        With I1 = F:F and G = F⁻¹ (so ∂J/∂F = J Gᵀ)::

            ∂Ī1/∂F_iJ        = 2 J^{-2/3} [F_iJ − (I1/3) G_Ji]
            ∂²Ī1/∂F_iJ∂F_kL  = 2 J^{-2/3} [δ_ik δ_JL − (2/3) F_iJ G_Lk − (2/3) G_Ji F_kL
                                            + (2/9) I1 G_Ji G_Lk + (1/3) I1 G_Jk G_Li]
            P = f' ∂Ī1/∂F,   A = f'' ∂Ī1/∂F ⊗ ∂Ī1/∂F + f' ∂²Ī1/∂F∂F

        (Holzapfel 2000, eqs. 6.80–6.90 written in F; checked against finite
        differences in tests/test_fem_tangent.py.)

        Parameters
        ----------
        F, G : ndarray, shape (..., 3, 3)
            Deformation gradient and its inverse.
        J : ndarray, shape (...)
            det F (> 0).

        Returns
        -------
        P : ndarray (..., 3, 3)
        A : ndarray (..., 3, 3, 3, 3) or None
            ``A[..., i, J, k, L] = ∂P_iJ/∂F_kL``.
        """
        I1 = np.einsum("...iJ,...iJ->...", F, F)  # (...)
        jm23 = J ** (-2.0 / 3.0)  # (...)
        i1bar = jm23 * I1
        _, df, d2f = self.f_derivatives(i1bar)
        Gt = np.swapaxes(G, -1, -2)  # G_Ji as [i, J]
        dI = 2.0 * jm23[..., None, None] * (F - (I1 / 3.0)[..., None, None] * Gt)  # (..., 3, 3)
        P = df[..., None, None] * dI
        if not need_tangent:
            return P, None
        eye = np.eye(3)
        c = 2.0 * jm23
        d2 = (
            np.einsum("ik,JL->iJkL", eye, eye)  # (3,3,3,3) broadcast
            - (2.0 / 3.0) * (np.einsum("...iJ,...kL->...iJkL", F, Gt) + np.einsum("...iJ,...kL->...iJkL", Gt, F))
            + (2.0 / 9.0) * I1[..., None, None, None, None] * np.einsum("...iJ,...kL->...iJkL", Gt, Gt)
            + (1.0 / 3.0) * I1[..., None, None, None, None] * np.einsum("...Jk,...Li->...iJkL", G, G)
        )  # (..., 3, 3, 3, 3)
        A = (c * df)[..., None, None, None, None] * d2 + d2f[..., None, None, None, None] * np.einsum(
            "...iJ,...kL->...iJkL", dI, dI
        )
        return P, A


    def stress_coefficients(self, F: np.ndarray, G: np.ndarray, J: np.ndarray):
        """First Piola stress and the scalar coefficients of its tangent.

        The tangent of :meth:`stress_tangent` is a sum of an identity term and dyads of
        F and Gᵀ (Holzapfel 2000, eqs. 6.80–6.90 written in F)::

            A_iJkL = a δ_ik δ_JL + b (Gᵀ⊗Gᵀ)_iJkL + g G_Jk G_Li
                     + h (F⊗Gᵀ + Gᵀ⊗F)_iJkL + d2f (dĪ1 ⊗ dĪ1)_iJkL

        with c = 2 J^{-2/3}: a = c f', b = (2/9) c f' I1, g = (1/3) c f' I1,
        h = −(2/3) c f', dĪ1 = c (F − (I1/3) Gᵀ). An element tangent then needs only
        the vectors dN·F and dN·G at each quadrature point (no 4th-order array):
        see :meth:`fem.assembly.Assembler.evaluate`. Same tangent as
        :meth:`stress_tangent` (tests/test_fem_tangent.py).

        Parameters
        ----------
        F, G : ndarray (..., 3, 3)
        J : ndarray (...)

        Returns
        -------
        P : ndarray (..., 3, 3)
        coef : dict of ndarray (...)
            'a', 'b', 'g', 'h', 'd2f'; and 'dI' (..., 3, 3).
        """
        I1 = np.einsum("...iJ,...iJ->...", F, F)  # (...)
        jm23 = J ** (-2.0 / 3.0)  # (...)
        _, df, d2f = self.f_derivatives(jm23 * I1)
        Gt = np.swapaxes(G, -1, -2)  # G_Ji as [i, J]
        c = 2.0 * jm23
        dI = c[..., None, None] * (F - (I1 / 3.0)[..., None, None] * Gt)  # (..., 3, 3)
        P = df[..., None, None] * dI
        cdf = c * df
        coef = {"a": cdf, "b": (2.0 / 9.0) * cdf * I1, "g": (1.0 / 3.0) * cdf * I1, "h": (-2.0 / 3.0) * cdf,
                "d2f": d2f, "dI": dI}
        return P, coef


@dataclass(frozen=True)
class NeoHookean(IsochoricI1Material):
    """Neo-Hookean solid, W = C10 (Ī1 − 3) + (1/D1)(J − 1)².

    Parameters
    ----------
    c10 : float
        MPa, > 0 (shear modulus μ = 2 C10).
    d1 : float
        1/MPa, ≥ 0; 0 is fully incompressible (bulk modulus K = 2/D1).
    """

    c10: float
    d1: float = 0.0

    def __post_init__(self) -> None:
        _check("NeoHookean", "c10", self.c10, 1e-12)
        _check("NeoHookean", "d1", self.d1, 0.0)

    @property
    def shear_modulus(self) -> float:
        return 2.0 * self.c10

    def f_derivatives(self, i1bar):
        return self.c10 * (i1bar - 3.0), np.full_like(i1bar, self.c10), np.zeros_like(i1bar)


@dataclass(frozen=True)
class Yeoh(IsochoricI1Material):
    """Yeoh solid, W = Σ_k C_k0 (Ī1 − 3)^k + (1/D1)(J − 1)² (Yeoh 1993).

    Parameters
    ----------
    c : tuple of float
        (C10, C20, C30, ...) in MPa; C10 > 0.
    d1 : float
        1/MPa, ≥ 0.
    """

    c: tuple[float, ...]
    d1: float = 0.0

    def __post_init__(self) -> None:
        if len(self.c) < 1:
            raise ValueError("Yeoh.c=() must hold at least C10")
        _check("Yeoh", "c[0]", self.c[0], 1e-12)
        _check("Yeoh", "d1", self.d1, 0.0)

    @property
    def shear_modulus(self) -> float:
        return 2.0 * self.c[0]

    def f_derivatives(self, i1bar):
        x = i1bar - 3.0
        f = np.zeros_like(i1bar)
        df = np.zeros_like(i1bar)
        d2f = np.zeros_like(i1bar)
        for k, ck in enumerate(self.c, start=1):
            f += ck * x**k
            df += k * ck * x ** (k - 1)
            if k >= 2:
                d2f += k * (k - 1) * ck * x ** (k - 2)
        return f, df, d2f


@dataclass(frozen=True, eq=False)
class ElementwiseMaterial(IsochoricI1Material):
    """A different isochoric law in each group of elements (e.g. a stiff cap on a soft body).

    Element e uses ``materials[element_material[e]]``: its W_iso = f_k(Ī1) with k the
    element's group, so the stress, the tangent coefficients of
    :meth:`IsochoricI1Material.stress_coefficients` and the energy are those of each
    element's own law (the assembly integrates element by element; a material interface
    along element faces is exact for a perfect bond). Vectorised: every law is evaluated
    once on the elements of its group. Arrays handed to :meth:`f_derivatives` (and so
    to :meth:`energy`, :meth:`stress_tangent`, :meth:`stress_coefficients`) must have one
    row per element, shape (n_el, ...), as the assembler's (n_el, n_qp) quadrature arrays
    do. The tangent is checked against central finite differences in
    tests/test_model_form.py.

    Parameters
    ----------
    materials : tuple of IsochoricI1Material
        The laws, at least one; all must share one ``d1`` (the volumetric term is
        assembled with a single D1, :mod:`fem.assembly`).
    element_material : ndarray (n_el,) int
        Index into ``materials`` of each element.

    Notes
    -----
    ``shear_modulus`` is the largest small-strain shear modulus of the laws (a stiffness
    scale, not a property of the composite).
    """

    materials: tuple
    element_material: np.ndarray

    def __post_init__(self) -> None:
        mats = tuple(self.materials)
        if not mats or not all(isinstance(m, IsochoricI1Material) for m in mats):
            raise ValueError(f"ElementwiseMaterial.materials={self.materials!r}: must be a non-empty tuple of "
                             "IsochoricI1Material")
        d1s = {float(m.d1) for m in mats}
        if len(d1s) != 1:
            raise ValueError(f"ElementwiseMaterial.materials: every law needs the same d1, got {sorted(d1s)}")
        idx = np.ascontiguousarray(self.element_material, dtype=np.int64).ravel()
        if idx.size and (idx.min() < 0 or idx.max() >= len(mats)):
            raise ValueError(f"ElementwiseMaterial.element_material: index outside [0, {len(mats) - 1}]")
        object.__setattr__(self, "materials", mats)
        object.__setattr__(self, "element_material", idx)

    @property
    def d1(self) -> float:
        return float(self.materials[0].d1)

    @property
    def shear_modulus(self) -> float:
        return max(m.shear_modulus for m in self.materials)

    @property
    def n_elements(self) -> int:
        return len(self.element_material)

    def f_derivatives(self, i1bar):
        i1bar = np.asarray(i1bar, dtype=float)
        if i1bar.shape[:1] != (self.n_elements,):
            raise ValueError(f"ElementwiseMaterial.f_derivatives: array of shape {i1bar.shape}, expected "
                             f"({self.n_elements}, ...) (one row per element)")
        out = (np.empty_like(i1bar), np.empty_like(i1bar), np.empty_like(i1bar))
        for k, mat in enumerate(self.materials):
            sel = self.element_material == k  # (n_el,)
            if not sel.any():
                continue
            for o, v in zip(out, mat.f_derivatives(i1bar[sel])):
                o[sel] = v
        return out
