"""Quadratic tetrahedral meshes: the container, P1 -> P2 upgrade, faces and volumes.

Everything here is plain numpy; node order is VTK_QUADRATIC_TETRA (see
:mod:`fem.element`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem import element


class MeshError(ValueError):
    """A mesh that cannot be used: bad shapes, indices or inverted elements."""


@dataclass(frozen=True)
class TetMesh:
    """A 10-node tetrahedral mesh.

    Attributes
    ----------
    points : ndarray, shape (n_nodes, 3), float64
        Reference (undeformed) node coordinates.
    cells : ndarray, shape (n_elements, 10), int64
        Node indices per element in VTK_QUADRATIC_TETRA order.
    """

    points: np.ndarray
    cells: np.ndarray

    def __post_init__(self) -> None:
        pts = np.ascontiguousarray(self.points, dtype=np.float64)
        cells = np.ascontiguousarray(self.cells, dtype=np.int64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise MeshError(f"TetMesh.points: shape {pts.shape}, expected (n_nodes, 3)")
        if cells.ndim != 2 or cells.shape[1] != 10:
            raise MeshError(f"TetMesh.cells: shape {cells.shape}, expected (n_elements, 10)")
        if cells.size and (cells.min() < 0 or cells.max() >= len(pts)):
            raise MeshError(
                f"TetMesh.cells: node index range [{cells.min()}, {cells.max()}] "
                f"outside [0, {len(pts) - 1}]"
            )
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "cells", cells)

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def n_elements(self) -> int:
        return len(self.cells)


def signed_volumes_linear(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes of the straight tetrahedra spanned by the first four nodes.

    ``V = det[x1 - x0, x2 - x0, x3 - x0] / 6``; positive for VTK orientation.

    Returns
    -------
    ndarray, shape (n_elements,)
    """
    x = points[tets[:, :4]]  # (n_el, 4, 3)
    e = x[:, 1:] - x[:, :1]  # (n_el, 3, 3)
    return np.linalg.det(e) / 6.0


def orient_linear(points: np.ndarray, tets4: np.ndarray) -> np.ndarray:
    """Return a copy of linear tets with vertices 1 and 2 swapped where the volume is negative."""
    tets4 = np.array(tets4, dtype=np.int64, copy=True)
    neg = signed_volumes_linear(points, tets4) < 0
    tets4[neg, 1], tets4[neg, 2] = tets4[neg, 2].copy(), tets4[neg, 1].copy()
    return tets4


def p1_to_p2(points: np.ndarray, tets4: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Upgrade linear tets to 10-node tets with straight-edge midpoints.

    Parameters
    ----------
    points : ndarray, shape (n_vertices, 3)
    tets4 : ndarray, shape (n_elements, 4)

    Returns
    -------
    points10 : ndarray, shape (n_vertices + n_edges, 3)
        Vertices first (unchanged numbering), then one midpoint per unique edge.
    cells10 : ndarray, shape (n_elements, 10)
        VTK_QUADRATIC_TETRA connectivity.
    edges : ndarray, shape (n_edges, 2)
        Vertex pair (sorted) of each midside node ``n_vertices + k``.
    """
    points = np.asarray(points, dtype=np.float64)
    tets4 = np.asarray(tets4, dtype=np.int64)
    n_v = len(points)
    all_edges = np.sort(tets4[:, element.EDGES], axis=2).reshape(-1, 2)  # (n_el*6, 2)
    edges, inverse = np.unique(all_edges, axis=0, return_inverse=True)
    mid = 0.5 * (points[edges[:, 0]] + points[edges[:, 1]])
    cells10 = np.hstack([tets4, n_v + inverse.reshape(-1, 6)])
    return np.vstack([points, mid]), cells10, edges


def boundary_faces(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Faces that belong to exactly one element.

    Parameters
    ----------
    cells : ndarray, shape (n_elements, 10)

    Returns
    -------
    elem : ndarray, shape (n_faces,)
        Owning element of each boundary face.
    local_face : ndarray, shape (n_faces,)
        Local face number 0..3 (Abaqus S1..S4).
    faces6 : ndarray, shape (n_faces, 6)
        6-node triangles, outward oriented (see :data:`fem.element.FACES`).
    """
    cells = np.asarray(cells, dtype=np.int64)
    n_el = len(cells)
    f6 = cells[:, element.FACES]  # (n_el, 4, 6)
    key = np.sort(f6[:, :, :3], axis=2).reshape(-1, 3)  # (n_el*4, 3)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = counts[inv.ravel()] == 1
    idx = np.nonzero(once)[0]
    elem = idx // 4
    local = idx % 4
    return elem, local, f6.reshape(-1, 6)[idx] if n_el else np.zeros((0, 6), np.int64)


def jacobian_determinants(points: np.ndarray, cells: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Isoparametric Jacobian determinants ``det(dX/dxi)`` at local points.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
    cells : ndarray, shape (n_elements, 10)
    xi : ndarray, shape (n_qp, 3)

    Returns
    -------
    ndarray, shape (n_elements, n_qp)
    """
    dN = element.shape_gradients(xi)  # (n_qp, 10, 3)
    X = points[cells]  # (n_el, 10, 3)
    J = np.einsum("eai,qaj->eqij", X, dN)  # (n_el, n_qp, 3, 3)
    return np.linalg.det(J)


def mapped_points(points: np.ndarray, cells: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Reference positions X(ξ) = Σ_a N_a(ξ) X_a of the local points ``xi`` (n_qp, 3) in every element,
    shape (n_elements, n_qp, 3); arguments as :func:`jacobian_determinants`."""
    return np.einsum("qa,eai->eqi", element.shape_functions(xi), points[cells])  # (n_el, n_qp, 3)


def volumes(points: np.ndarray, cells: np.ndarray, degree: int = 3) -> np.ndarray:
    """Element volumes of (possibly curved) 10-node tets, shape (n_elements,)."""
    from fem.quadrature import tet_rule

    rule = tet_rule(degree)
    return jacobian_determinants(points, cells, rule.points) @ rule.weights
