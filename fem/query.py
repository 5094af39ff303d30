"""Point queries on a displacement field: values at (host element, local coordinates).

Used by gauges and fibres: only the requested points are evaluated, no full field.
For a point with reference position X(ξ) = Σ N_a(ξ) X_a::

    u(ξ) = Σ N_a(ξ) u_a,     F = I + Σ u_a ⊗ ∇_X N_a,   ∇_X N_a = (∂X/∂ξ)⁻ᵀ ∇_ξ N_a
    Lagrangian log (Hencky) strain  E_H = ½ ln C = ½ Σ ln(λ_k²) N_k ⊗ N_k   (C = FᵀF)
    Eulerian log strain             e_H = ln V   = ½ ln(F Fᵀ)
"""

from __future__ import annotations

import numpy as np

from fem import element
from fem.mesh import TetMesh


def _prepare(mesh: TetMesh, host_elements, local_coords):
    he = np.asarray(host_elements, dtype=np.int64).ravel()
    xi = np.asarray(local_coords, dtype=float).reshape(-1, 3)
    if len(he) != len(xi):
        raise ValueError(f"{len(he)} host_elements but {len(xi)} local_coords")
    if he.size and (he.min() < 0 or he.max() >= mesh.n_elements):
        raise ValueError(f"host_elements outside [0, {mesh.n_elements - 1}]")
    return he, xi


def positions_at(mesh: TetMesh, u: np.ndarray | None, host_elements, local_coords) -> np.ndarray:
    """Current (or, with u=None, reference) positions of the points, shape (n, 3)."""
    he, xi = _prepare(mesh, host_elements, local_coords)
    N = element.shape_functions(xi)  # (n, 10)
    X = np.einsum("na,nai->ni", N, mesh.points[mesh.cells[he]])  # (n, 3)
    if u is None:
        return X
    return X + np.einsum("na,nai->ni", N, u[mesh.cells[he]])


def displacement_at(mesh: TetMesh, u: np.ndarray, host_elements, local_coords) -> np.ndarray:
    """Displacement at the points, shape (n, 3)."""
    he, xi = _prepare(mesh, host_elements, local_coords)
    N = element.shape_functions(xi)  # (n, 10)
    return np.einsum("na,nai->ni", N, u[mesh.cells[he]])  # (n, 3)


def deformation_gradient_at(mesh: TetMesh, u: np.ndarray, host_elements, local_coords) -> np.ndarray:
    """Deformation gradient F at the points, shape (n, 3, 3)."""
    he, xi = _prepare(mesh, host_elements, local_coords)
    dN = element.shape_gradients(xi)  # (n, 10, 3)
    Xe = mesh.points[mesh.cells[he]]  # (n, 10, 3)
    J0 = np.einsum("nai,naj->nij", Xe, dN)  # (n, 3, 3) dX_i/dxi_j
    dNdX = np.einsum("naj,nji->nai", dN, np.linalg.inv(J0))  # (n, 10, 3)
    return np.eye(3) + np.einsum("nai,naJ->niJ", u[mesh.cells[he]], dNdX)  # (n, 3, 3)


def _sym_log(S: np.ndarray) -> np.ndarray:
    w, v = np.linalg.eigh(S)  # (n, 3), (n, 3, 3)
    return np.einsum("nik,nk,njk->nij", v, np.log(w), v)


def log_strain_at(mesh: TetMesh, u: np.ndarray, host_elements, local_coords, frame: str = "lagrangian") -> np.ndarray:
    """Logarithmic strain at the points, shape (n, 3, 3).

    Parameters
    ----------
    frame : {'lagrangian', 'eulerian'}
        ½ ln(FᵀF) (material axes) or ½ ln(F Fᵀ) = ln V (spatial axes, Abaqus' LE).
    """
    F = deformation_gradient_at(mesh, u, host_elements, local_coords)
    if frame == "lagrangian":
        return 0.5 * _sym_log(np.einsum("nkI,nkJ->nIJ", F, F))
    if frame == "eulerian":
        return 0.5 * _sym_log(np.einsum("niK,njK->nij", F, F))
    raise ValueError(f"log_strain_at: frame={frame!r}, allowed 'lagrangian', 'eulerian'")
