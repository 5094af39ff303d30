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
    compliance, 1/MPa, ≥ 0) and ``shear_modulus``. Each law then answers for its own
    stress: the solver's :meth:`stress_tangent` / :meth:`stress_coefficients`, and for
    post-processing :meth:`cauchy_stress` and :meth:`von_mises` (built on the same
    :meth:`stress_tangent`, so what is written is the stress that was solved) and
    :meth:`at_nodes` (the law at the nodes of a mesh).
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

    # ------------------------------------------------------------------ stress measures
    def cauchy_stress(self, F: np.ndarray, p) -> np.ndarray:
        """Cauchy stress of the mixed u–p law: this law's isochoric stress plus the pressure.

        With P_iso the first Piola stress of :meth:`stress_tangent` and the volumetric term
        p J F⁻ᵀ of :mod:`fem.assembly` (∂[p (J − 1)]/∂F)::

            σ = J⁻¹ (P_iso + p J F⁻ᵀ) Fᵀ = J⁻¹ P_iso Fᵀ + p I

        For an Ī1 law, P_iso = 2 f'(Ī1) J^{-2/3} (F − (I1/3) F⁻ᵀ), so σ = 2 f'(Ī1) J^{-5/3}
        dev(F Fᵀ) + p I (Holzapfel 2000, eq. 6.103): the mean stress tr σ / 3 is p (positive
        in tension, :class:`fem.state.State`), the deviator does not depend on p.
        Incompressible uniaxial stretch λ with σ_yy = σ_zz = 0 gives
        σ_xx = 2 f'(Ī1) (λ² − 1/λ), Ī1 = λ² + 2/λ (μ (λ² − 1/λ) for the neo-Hookean law).
        For the 'displacement' formulation pass p = 2 (J − 1) / D1. The result is made
        exactly symmetric, ½ (σ + σᵀ) (the two differ by round-off).

        Parameters
        ----------
        F : ndarray, shape (..., 3, 3)
            Deformation gradients, det F > 0. A law with one row per element
            (:class:`ElementwiseMaterial`) needs F of shape (n_rows, ..., 3, 3).
        p : float or ndarray, shape (...)
            Pressure [MPa], > 0 in tension.

        Returns
        -------
        ndarray, shape (..., 3, 3)
            [MPa].
        """
        F = np.asarray(F, dtype=float)
        J = np.linalg.det(F)  # (...)
        G = np.linalg.inv(F)  # (..., 3, 3)
        P_iso, _ = self.stress_tangent(F, G, J, need_tangent=False)  # (..., 3, 3)
        p = np.broadcast_to(np.asarray(p, dtype=float), J.shape)  # (...)
        P = P_iso + (p * J)[..., None, None] * np.swapaxes(G, -1, -2)  # (..., 3, 3) P_iso + p J F⁻ᵀ
        sigma = np.einsum("...iJ,...kJ->...ik", P, F) / J[..., None, None]  # (..., 3, 3) J⁻¹ P Fᵀ
        return 0.5 * (sigma + np.swapaxes(sigma, -1, -2))

    def von_mises(self, F: np.ndarray, p=0.0) -> np.ndarray:
        """Von Mises stress of :meth:`cauchy_stress` (:func:`von_mises_stress`).

        σ_vM = sqrt(3/2 s:s), s the deviator of σ; p drops out of s for every Ī1 law, so
        any pressure (e.g. 0) gives the same value. Incompressible uniaxial stretch λ:
        σ_vM = 2 f'(Ī1) |λ² − 1/λ|.

        Parameters
        ----------
        F : ndarray, shape (..., 3, 3)
        p : float or ndarray, shape (...)
            Pressure [MPa].

        Returns
        -------
        ndarray, shape (...)
            [MPa].
        """
        return von_mises_stress(self.cauchy_stress(F, p))

    def at_nodes(self, cells: np.ndarray, used: np.ndarray | None = None) -> "IsochoricI1Material":
        """The law at the nodes of a mesh: the law itself (one law everywhere).

        :class:`ElementwiseMaterial` returns its laws with one row per node instead, for
        nodal post-processing (:func:`fem.post.nodal_strain_stress`).

        Parameters
        ----------
        cells : ndarray, shape (n_el, n_nodes_per_el)
        used : ndarray of bool, shape (n_nodes,), optional
            The nodes the rows stand for (no effect here).

        Returns
        -------
        IsochoricI1Material
        """
        return self


def von_mises_stress(sigma: np.ndarray) -> np.ndarray:
    """Von Mises equivalent stress ``σ_vM = sqrt(3/2 s:s)``, ``s = σ − (tr σ / 3) I``.

    Parameters
    ----------
    sigma : ndarray, shape (..., 3, 3)
        Cauchy stresses [MPa].

    Returns
    -------
    ndarray, shape (...)
        [MPa], ≥ 0.
    """
    sigma = np.asarray(sigma, dtype=float)
    s = sigma - (np.einsum("...ii->...", sigma) / 3.0)[..., None, None] * np.eye(3)  # (..., 3, 3)
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", s, s))  # (...)


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
    to :meth:`energy`, :meth:`stress_tangent`, :meth:`stress_coefficients`,
    :meth:`cauchy_stress`, :meth:`von_mises`) must have one row per element, shape (n_el, ...),
    as the assembler's (n_el, n_qp) quadrature arrays do; :meth:`at_nodes` gives the same laws
    with one row per node. The tangent is checked against central finite differences in
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

    def at_nodes(self, cells: np.ndarray, used: np.ndarray | None = None) -> "ElementwiseMaterial":
        """The laws with one row per node: a node takes the law of the lowest group among the
        elements holding it (a node on an interface takes the first law's, e.g. the body's).

        Parameters
        ----------
        cells : ndarray, shape (n_el, n_nodes_per_el)
            The elements of ``element_material``, in order.
        used : ndarray of bool, shape (n_nodes,), optional
            The nodes the rows stand for, in node order, each held by some element (default:
            the nodes held by some element, as :func:`fem.post.nodal_deformation_gradient` returns).

        Returns
        -------
        ElementwiseMaterial
            ``element_material`` of shape (n_used,).
        """
        cells = np.asarray(cells, dtype=np.int64)
        if len(cells) != self.n_elements:
            raise ValueError(f"ElementwiseMaterial.at_nodes: {len(cells)} cells, expected {self.n_elements}")
        n_nodes = (int(cells.max()) + 1 if cells.size else 0) if used is None else len(used)
        node_group = np.full(n_nodes, np.iinfo(np.int64).max)  # (n_nodes,)
        np.minimum.at(node_group, cells.ravel(), np.repeat(self.element_material, cells.shape[1]))
        held = node_group < len(self.materials)  # (n_nodes,)
        used = held if used is None else np.asarray(used, dtype=bool)
        if not held[used].all():
            raise ValueError("ElementwiseMaterial.at_nodes: a used node is held by no element")
        return ElementwiseMaterial(self.materials, node_group[used])

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


@dataclass(frozen=True, eq=False)
class ScaledMaterial(IsochoricI1Material):
    """A law whose isochoric energy is multiplied by a factor per element: W_iso,e = s_e f(Ī1).

    Every modulus of an Ī1 law enters W_iso linearly, so this is the same law with its moduli
    scaled by s_e in element e (stress and tangent scale with it; the volumetric term, D1, does
    not). With s_e = c on a region and the frozen stress −(c − 1) S̄_p of :mod:`fem.frozen_stress`,
    the region keeps the stress S̄_p of a state p while its incremental material stiffness about
    p becomes c times the law's. Arrays handed to :meth:`f_derivatives` must have one row per
    element, as :class:`ElementwiseMaterial`'s.

    Parameters
    ----------
    base : IsochoricI1Material
    factor : ndarray (n_el,)
        s_e > 0 per element.
    """

    base: IsochoricI1Material
    factor: np.ndarray

    def __post_init__(self) -> None:
        s = np.ascontiguousarray(self.factor, dtype=float).ravel()
        if not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ValueError("ScaledMaterial.factor: every element's factor must be finite and > 0")
        object.__setattr__(self, "factor", s)

    @property
    def d1(self) -> float:
        return float(self.base.d1)

    @property
    def shear_modulus(self) -> float:
        return float(self.base.shear_modulus * self.factor.max(initial=1.0))

    @property
    def n_elements(self) -> int:
        return len(self.factor)

    def at_nodes(self, cells: np.ndarray, used: np.ndarray | None = None) -> "ScaledMaterial":
        """The law with one row per node: a node takes the mean factor of the elements holding it,
        s_n = (1 / |E_n|) Σ_{e ∈ E_n} s_e.

        The stress is linear in s, so a node's stress is the mean of its elements' laws at the
        node's F, as a frozen stress at the nodes is the mean over the same elements
        (:func:`fem.post.frozen_stress_at_nodes`): on the edge of a region with s = c and the
        frozen stress −(c − 1) S̄_p the two stay paired: s_n with −(s_n − 1) S̄_p.
        """
        cells = np.asarray(cells, dtype=np.int64)
        if len(cells) != self.n_elements:
            raise ValueError(f"ScaledMaterial.at_nodes: {len(cells)} cells, expected {self.n_elements}")
        n_nodes = (int(cells.max()) + 1 if cells.size else 0) if used is None else len(used)
        total = np.bincount(cells.ravel(), np.repeat(self.factor, cells.shape[1]), minlength=n_nodes)  # (n_nodes,)
        cnt = np.bincount(cells.ravel(), minlength=n_nodes)  # (n_nodes,)
        held = cnt > 0
        used = held if used is None else np.asarray(used, dtype=bool)
        if not held[used].all():
            raise ValueError("ScaledMaterial.at_nodes: a used node is held by no element")
        base = self.base.at_nodes(cells, used)
        return ScaledMaterial(base, total[used] / cnt[used])

    def f_derivatives(self, i1bar):
        i1bar = np.asarray(i1bar, dtype=float)
        if i1bar.shape[:1] != (self.n_elements,):
            raise ValueError(f"ScaledMaterial.f_derivatives: array of shape {i1bar.shape}, expected "
                             f"({self.n_elements}, ...) (one row per element)")
        s = self.factor.reshape((-1,) + (1,) * (i1bar.ndim - 1))
        return tuple(s * v for v in self.base.f_derivatives(i1bar))
