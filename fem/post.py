"""Nodal post-processing of a TET10 displacement field: deformation gradient, logarithmic
strain and the von Mises stress of the neo-Hookean law.

Each element evaluates ``F = I + ∂u/∂X`` at its own 10 nodes with the quadratic shape
functions of :mod:`fem.element`; a node takes the average over the elements sharing it.
A displacement that is linear in X (a homogeneous deformation) is reproduced exactly by
the P2 interpolation, so every node then carries that deformation's F, curved elements
included. The point queries of :mod:`fem.query` evaluate the same quantities at chosen
points inside elements instead.

All functions are vectorised over elements and nodes; they use numpy only.
"""

from __future__ import annotations

import numpy as np

from fem import element


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


def von_mises_neo_hookean(F: np.ndarray, c10: float) -> np.ndarray:
    """Von Mises stress of the decoupled neo-Hookean law ``W = C10 (Ī₁ - 3) + U(J)``.

    The deviatoric Cauchy stress is::

        s = 2 C10 J^(-5/3) dev(B),   B = F Fᵀ,   dev(B) = B - (tr B / 3) I

    (the volumetric part ``U(J)``, hence the pressure, does not enter) and
    ``σ_vM = sqrt(3/2 s:s)``. Incompressible closed forms: a uniaxial stretch λ gives
    ``2 C10 (λ² - 1/λ)``, a simple shear γ gives ``2 C10 γ sqrt(3 + γ²)``.

    Parameters
    ----------
    F : ndarray, shape (k, 3, 3)
    c10 : float
        [MPa].

    Returns
    -------
    ndarray, shape (k,)
        [MPa].
    """
    F = np.asarray(F, dtype=float)
    J = np.linalg.det(F)  # (k,)
    B = np.einsum("kij,klj->kil", F, F)  # (k, 3, 3) F Fᵀ
    dev = B - np.einsum("kii->k", B)[:, None, None] / 3.0 * np.eye(3)  # (k, 3, 3)
    sdev = 2.0 * c10 * np.abs(J)[:, None, None] ** (-5.0 / 3.0) * dev  # (k, 3, 3)
    return np.sqrt(1.5 * np.einsum("kij,kij->k", sdev, sdev))  # (k,)
