"""Nodal post-processing of a TET10 displacement field: deformation gradient, logarithmic
strain, and the Cauchy and von Mises stresses of the solved law of the mixed u–p form
(each law computes its own stress, :meth:`fem.material.IsochoricI1Material.cauchy_stress`).

Each element evaluates ``F = I + ∂u/∂X`` at its own 10 nodes with the quadratic shape
functions of :mod:`fem.element`; a node takes the average over the elements sharing it.
A displacement that is linear in X (a homogeneous deformation) is reproduced exactly by
the P2 interpolation, so every node then carries that deformation's F, curved elements
included. The point queries of :mod:`fem.query` evaluate the same quantities at chosen
points inside elements instead. The element pressure of the mixed formulation (constant
per element) goes to the nodes by the same unweighted mean (:func:`element_to_nodes`), and so does a
frozen stress held at the quadrature points (:func:`frozen_stress_at_nodes`); the stress of a state
solved with a problem is that problem's own (:func:`problem_strain_stress`).
Symmetric tensors are stored with 6 components in VTK's order XX, YY, ZZ, XY, YZ, XZ
(:func:`symmetric_components`).

All functions are vectorised over elements and nodes; they use numpy only.
"""

from __future__ import annotations

import numpy as np

from fem import element
from fem.quadrature import tet_rule


def nodal_deformation_gradient(points: np.ndarray, cells: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Deformation gradient at the nodes, averaged over the elements sharing each node.

    In element e at its node n (local coordinates ξ_n)::

        F = I + (∂u/∂ξ)(∂X/∂ξ)⁻¹,   ∂u/∂ξ = Σ_a u_a ⊗ ∇_ξ N_a(ξ_n),   ∂X/∂ξ = Σ_a X_a ⊗ ∇_ξ N_a(ξ_n)

    and the nodal value is the mean of F over the elements holding the node.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
        Reference coordinates X.
    cells : ndarray, shape (n_el, 10)
        TET10 connectivity (:mod:`fem.element` node order, which is VTK's).
    u : ndarray, shape (n_nodes, 3)
        Nodal displacements.

    Returns
    -------
    F : ndarray, shape (k, 3, 3)
        At the ``k`` nodes used by some cell, in node order.
    used : ndarray of bool, shape (n_nodes,)
        Which nodes ``F`` refers to.
    """
    X = np.asarray(points, dtype=float)
    u = np.asarray(u, dtype=float)
    cells = np.asarray(cells, dtype=np.int64)
    dN = element.shape_gradients(element.NODES)  # (10, 10, 3): dN[n, a, k] = dN_a/dξ_k at node n
    J = np.einsum("eai,nak->enik", X[cells], dN)  # (n_el, 10, 3, 3) dX_i/dξ_k
    H = np.einsum("eai,nak->enik", u[cells], dN)  # (n_el, 10, 3, 3) du_i/dξ_k
    F = np.eye(3) + np.einsum("enik,enkj->enij", H, np.linalg.inv(J))  # (n_el, 10, 3, 3)
    n = len(X)
    Fn = np.zeros((n, 9))
    np.add.at(Fn, cells.ravel(), F.reshape(-1, 9))
    cnt = np.bincount(cells.ravel(), minlength=n).astype(float)
    used = cnt > 0
    return (Fn[used] / cnt[used, None]).reshape(-1, 3, 3), used


def spread_to_nodes(values: np.ndarray, used: np.ndarray, fill: float = np.nan) -> np.ndarray:
    """Values at the used nodes (e.g. of :func:`nodal_deformation_gradient`) as an array over
    all nodes, ``fill`` at the others.

    Parameters
    ----------
    values : ndarray, shape (k, ...)
    used : ndarray of bool, shape (n_nodes,)
        With ``k`` True entries.
    fill : float

    Returns
    -------
    ndarray, shape (n_nodes, ...)
    """
    values = np.asarray(values, dtype=float)
    out = np.full((len(used), *values.shape[1:]), fill)
    out[np.asarray(used, dtype=bool)] = values
    return out


def eulerian_log_strain(F: np.ndarray) -> np.ndarray:
    """Eulerian logarithmic (Hencky) strain ``ln V = ½ ln(F Fᵀ)`` (Abaqus' LE).

    With the spectral decomposition ``B = F Fᵀ = Σ_k λ_k² n_k ⊗ n_k`` (λ_k the principal
    stretches, n_k the spatial principal directions)::

        ln V = Σ_k ln λ_k n_k ⊗ n_k = Σ_k ½ ln(λ_k²) n_k ⊗ n_k

    A rigid rotation gives zero; a stretch λ along x gives ``ln λ`` in xx.

    Parameters
    ----------
    F : ndarray, shape (k, 3, 3)

    Returns
    -------
    ndarray, shape (k, 3, 3)
    """
    F = np.asarray(F, dtype=float)
    B = np.einsum("kij,klj->kil", F, F)  # (k, 3, 3) F Fᵀ
    lam2, vec = np.linalg.eigh(B)  # (k, 3) λ², (k, 3, 3) columns n_k
    half_log = 0.5 * np.log(np.maximum(lam2, 1e-300))  # (k, 3) ln λ
    return np.einsum("kia,ka,kja->kij", vec, half_log, vec)  # (k, 3, 3)


def axial_log_strain(points: np.ndarray, cells: np.ndarray, u: np.ndarray, axis: int = 0) -> np.ndarray:
    """Nodal axial Hencky strain ``LE_xx = (½ ln(F Fᵀ))_xx`` of a TET10 displacement field.

    F from :func:`nodal_deformation_gradient`, the log strain from
    :func:`eulerian_log_strain`; ``axis`` picks the diagonal component (0 = x).

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
        Reference coordinates.
    cells : ndarray, shape (n_el, 10)
    u : ndarray, shape (n_nodes, 3)
    axis : {0, 1, 2}

    Returns
    -------
    ndarray, shape (n_nodes,)
        NaN at nodes not used by any cell.
    """
    F, used = nodal_deformation_gradient(points, cells, u)
    return spread_to_nodes(eulerian_log_strain(F)[:, axis, axis], used)


#: Component order of a symmetric tensor stored with 6 components, VTK's and ParaView's:
#: XX, YY, ZZ, XY, YZ, XZ (:func:`symmetric_components`).
SYMMETRIC_COMPONENTS: tuple[str, ...] = ("XX", "YY", "ZZ", "XY", "YZ", "XZ")
_SYM_ROW = np.array([0, 1, 2, 0, 1, 0])
_SYM_COL = np.array([0, 1, 2, 1, 2, 2])


def symmetric_components(T: np.ndarray) -> np.ndarray:
    """The 6 independent components of symmetric tensors in VTK's order XX, YY, ZZ, XY, YZ, XZ.

    ``out[:, k] = T[:, i_k, j_k]`` with ``(i_k, j_k)`` = (0,0), (1,1), (2,2), (0,1), (1,2),
    (0,2) (:data:`SYMMETRIC_COMPONENTS`); the tensors are taken as symmetric, the lower
    triangle is not read.

    Parameters
    ----------
    T : ndarray, shape (k, 3, 3)

    Returns
    -------
    ndarray, shape (k, 6)
    """
    T = np.asarray(T, dtype=float)
    return T[:, _SYM_ROW, _SYM_COL]


def element_to_nodes(cells: np.ndarray, values: np.ndarray, n_nodes: int, fill: float = np.nan) -> np.ndarray:
    """Nodal mean of element-constant values over the elements sharing each node.

    ``v_n = (1 / |E_n|) Σ_{e ∈ E_n} v_e`` with ``E_n`` the elements holding node n; the
    same unweighted mean as :func:`nodal_deformation_gradient`, so that a field that is
    the same in every element is reproduced exactly.

    Parameters
    ----------
    cells : ndarray, shape (n_el, 10)
    values : ndarray, shape (n_el,)
        One value per element (e.g. the P0 pressure of the mixed u–p formulation).
    n_nodes : int
    fill : float
        Value at nodes used by no cell.

    Returns
    -------
    ndarray, shape (n_nodes,)
    """
    cells = np.asarray(cells, dtype=np.int64)
    values = np.asarray(values, dtype=float)
    per_node = np.repeat(values, cells.shape[1])  # (n_el * 10,) the value of each cell's node slot
    total = np.bincount(cells.ravel(), per_node, minlength=n_nodes)  # (n_nodes,)
    cnt = np.bincount(cells.ravel(), minlength=n_nodes)  # (n_nodes,)
    out = np.full(n_nodes, float(fill))
    used = cnt > 0
    out[used] = total[used] / cnt[used]
    return out


def nodal_strain_stress(points: np.ndarray, cells: np.ndarray, u: np.ndarray, p: np.ndarray | None, material,
                        formulation: str = "mixed", frozen: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Nodal Eulerian log strain and Cauchy stress of a solved u–p state.

    F at the nodes from :func:`nodal_deformation_gradient`; ``ln V`` from
    :func:`eulerian_log_strain`; σ from the law's own
    :meth:`~fem.material.IsochoricI1Material.cauchy_stress` at the nodes
    (:meth:`~fem.material.IsochoricI1Material.at_nodes`: with one law per element group a node
    takes the law of the lowest group among its elements)::

        σ = J⁻¹ (P_iso + p J F⁻ᵀ) Fᵀ  [+ J⁻¹ F T Fᵀ]

    with the nodal pressure p: the mean of the element pressures around the node
    (:func:`element_to_nodes`) for the 'mixed' formulation, ``2 (J − 1) / D1`` of the nodal
    F for 'displacement'; the bracket is the push-forward of a frozen second Piola–Kirchhoff
    stress T at the nodes (``frozen``, :func:`frozen_stress_at_nodes`), whose first Piola stress
    is F T (:mod:`fem.frozen_stress`). The stress of a solved problem, frozen stresses included,
    is :func:`problem_strain_stress`.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
    cells : ndarray, shape (n_el, 10)
    u : ndarray, shape (n_nodes, 3)
        [mm].
    p : ndarray, shape (n_el,) or None
        Element pressures [MPa] (mixed formulation; > 0 in tension).
    material : fem.material.IsochoricI1Material
        The solved law (one row per element of ``cells`` for
        :class:`fem.material.ElementwiseMaterial`); its ``d1`` [1/MPa] serves the
        'displacement' formulation.
    formulation : {'mixed', 'displacement'}
    frozen : ndarray, shape (n_nodes, 3, 3), optional
        A frozen second Piola–Kirchhoff stress T at the nodes [MPa], added to the law's stress.

    Returns
    -------
    log_strain : ndarray, shape (n_nodes, 3, 3)
    sigma : ndarray, shape (n_nodes, 3, 3)
        [MPa]. Both NaN at nodes used by no cell.
    """
    F, used = nodal_deformation_gradient(points, cells, u)
    if formulation == "mixed":
        if p is None:
            raise ValueError("nodal_strain_stress: the mixed formulation needs the element pressures p")
        pn = element_to_nodes(cells, p, len(used))[used]  # (k,)
    elif formulation == "displacement":
        d1 = float(material.d1)
        if not d1 > 0:
            raise ValueError(f"nodal_strain_stress: the displacement formulation needs D1 > 0, got {d1!r}")
        pn = 2.0 * (np.linalg.det(F) - 1.0) / d1  # (k,)
    else:
        raise ValueError(f"nodal_strain_stress: formulation={formulation!r}, allowed 'mixed', 'displacement'")
    sigma = material.at_nodes(cells, used).cauchy_stress(F, pn)  # (k, 3, 3)
    if frozen is not None:
        FTF = np.einsum("kiJ,kJL,kjL->kij", F, np.asarray(frozen, dtype=float)[used], F)  # (k, 3, 3)  F T Fᵀ
        sigma_t = FTF / np.linalg.det(F)[:, None, None]  # (k, 3, 3)
        sigma = sigma + 0.5 * (sigma_t + np.swapaxes(sigma_t, -1, -2))
    return spread_to_nodes(eulerian_log_strain(F), used), spread_to_nodes(sigma, used)


def quadrature_to_nodes(qp: np.ndarray) -> np.ndarray:
    """Matrix that takes values at a tet rule's points to the 10 TET10 nodes: the linear field
    through them, least squares over the points.

    With the linear basis φ(ξ) = (1, ξ₁, ξ₂, ξ₃), Φ_q = φ(ξ_q) at the points and Φ_n = φ(ξ_n) at
    the nodes, the values v_q go to ``v_n = Φ_n Φ⁺ v_q`` (Φ⁺ the pseudo-inverse): exact for a field
    linear in ξ (so in X, the map of a straight-sided element being affine), and an interpolation for
    the 4-point rule of degree 2. Needs at least 4 points not in one plane (every rule of degree ≥ 2).

    Parameters
    ----------
    qp : ndarray, shape (n_qp, 3)
        Local coordinates of the rule's points.

    Returns
    -------
    ndarray, shape (10, n_qp)
    """
    qp = np.asarray(qp, dtype=float)
    if len(qp) < 4:
        raise ValueError(f"quadrature_to_nodes: {len(qp)} points, a linear field needs at least 4")
    phi_q = np.hstack([np.ones((len(qp), 1)), qp])  # (n_qp, 4)
    phi_n = np.hstack([np.ones((len(element.NODES), 1)), element.NODES])  # (10, 4)
    return phi_n @ np.linalg.pinv(phi_q)  # (10, n_qp)


def frozen_stress_at_nodes(cells: np.ndarray, frozen_stresses, qp: np.ndarray, n_nodes: int) -> np.ndarray:
    """Frozen second Piola–Kirchhoff stresses (:class:`fem.problem.FrozenStress`) at the nodes.

    Each carrying element takes its quadrature-point values T_q to its own nodes
    (:func:`quadrature_to_nodes`); a node takes the mean over *all* the elements holding it, those
    that carry no frozen stress counting with T = 0::

        T_n = (1 / |E_n|) Σ_{e ∈ E_n} Σ_q M_{n_e q} T_{e q}

    the same unweighted mean as :func:`nodal_deformation_gradient`, and as the factor of
    :meth:`fem.material.ScaledMaterial.at_nodes`, so that a node on the edge of a region with
    the law c W̄ + ½ T:(C − I) takes the mean of its elements' laws.

    Parameters
    ----------
    cells : ndarray, shape (n_el, 10)
    frozen_stresses : sequence of fem.problem.FrozenStress
        Their stresses at the points ``qp``.
    qp : ndarray, shape (n_qp, 3)
        The problem's tet rule.
    n_nodes : int

    Returns
    -------
    ndarray, shape (n_nodes, 3, 3)
        [MPa]; 0 at nodes of no carrying element.
    """
    cells = np.asarray(cells, dtype=np.int64)
    M = quadrature_to_nodes(qp)  # (10, n_qp)
    total = np.zeros((n_nodes, 9))
    for fs in frozen_stresses:
        Tn = np.einsum("nq,eqij->enij", M, fs.stress)  # (n_sel, 10, 3, 3)
        np.add.at(total, cells[fs.elements].ravel(), Tn.reshape(-1, 9))
    cnt = np.bincount(cells.ravel(), minlength=n_nodes).astype(float)  # (n_nodes,)
    return (total / np.maximum(cnt, 1.0)[:, None]).reshape(-1, 3, 3)


def problem_strain_stress(problem, u: np.ndarray, p: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Nodal log strain and Cauchy stress of a state solved with ``problem``: the stress of its own
    constitutive law, the one its residual integrates.

    The problem's material (:meth:`~fem.material.IsochoricI1Material.at_nodes`, e.g. a
    :class:`~fem.material.ScaledMaterial`'s scaled moduli) with its mixed pressure and its frozen
    stresses at the nodes (each one's own :attr:`~fem.problem.FrozenStress.nodal`, else
    :func:`frozen_stress_at_nodes`) in :func:`nodal_strain_stress`::

        σ = J⁻¹ (P_iso + p J F⁻ᵀ) Fᵀ + J⁻¹ F T Fᵀ

    Without frozen stresses this is :func:`nodal_strain_stress` of the material alone, to the bit.
    Trusses, smeared fibres and loads are not stresses of the solid and are left out.

    Parameters
    ----------
    problem : fem.problem.Problem
    u : ndarray, shape (n_nodes, 3)
    p : ndarray, shape (n_el,) or None
        Element pressures (None for the 'displacement' formulation).

    Returns
    -------
    log_strain, sigma : ndarray, shape (n_nodes, 3, 3)
        As :func:`nodal_strain_stress`.
    """
    mesh = problem.mesh
    frozen = None
    if problem.frozen_stresses:
        given = [fs.nodal for fs in problem.frozen_stresses if fs.nodal is not None]
        rest = [fs for fs in problem.frozen_stresses if fs.nodal is None]
        frozen = sum(given, frozen_stress_at_nodes(mesh.cells, rest, tet_rule(problem.quadrature_degree).points,
                                                   mesh.n_nodes))  # (n_nodes, 3, 3)
    return nodal_strain_stress(mesh.points, mesh.cells, u, p, problem.material, problem.formulation, frozen)
