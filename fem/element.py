"""The 10-node quadratic tetrahedron (TET10) and its 6-node triangular faces.

Node order is VTK_QUADRATIC_TETRA (identical to Abaqus/CalculiX C3D10; Gmsh swaps
the last two edge nodes): vertices 0-3, then the mid-edge nodes of the edges
(0,1), (1,2), (0,2), (0,3), (1,3), (2,3).

Local (reference) coordinates ``xi = (xi1, xi2, xi3)`` place vertex 0 at the origin
and vertices 1, 2, 3 on the unit axes. With barycentric coordinates
``L0 = 1 - xi1 - xi2 - xi3, L1 = xi1, L2 = xi2, L3 = xi3`` the shape functions are
(Zienkiewicz & Taylor, *The Finite Element Method*, vol. 1, sec. 6.7)::

    N_i  = L_i (2 L_i - 1)          i = 0..3      (vertices)
    N_ij = 4 L_i L_j                 (i, j) edge   (mid-edge nodes)

Faces are numbered like the Abaqus/CalculiX surface labels S1..S4 and listed as
6-node triangles (corners a, b, c, then mid-edge nodes ab, bc, ca) ordered so
that ``(x_b - x_a) x (x_c - x_a)`` points *out of* the element for a positively
oriented tetrahedron.
"""

from __future__ import annotations

import numpy as np

#: reference coordinates of the four vertices, shape (4, 3)
VERTICES = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])

#: vertex pairs of the six edges, in mid-edge node order (nodes 4..9), shape (6, 2)
EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]], dtype=np.int64)

#: reference coordinates of all ten nodes, shape (10, 3)
NODES = np.vstack([VERTICES, 0.5 * (VERTICES[EDGES[:, 0]] + VERTICES[EDGES[:, 1]])])

#: the four faces as 6-node triangles (a, b, c, ab, bc, ca), outward oriented,
#: numbered like Abaqus S1..S4: S1=(1,2,3), S2=(1,4,2), S3=(2,4,3), S4=(3,4,1)
#: in Abaqus' 1-based corner numbers. Shape (4, 6).
FACES = np.array(
    [
        [0, 2, 1, 6, 5, 4],  # S1, opposite vertex 3
        [0, 1, 3, 4, 8, 7],  # S2, opposite vertex 2
        [1, 2, 3, 5, 9, 8],  # S3, opposite vertex 0
        [0, 3, 2, 7, 9, 6],  # S4, opposite vertex 1
    ],
    dtype=np.int64,
)

#: reference coordinates of the six nodes of the 6-node triangle (a, b, c, ab, bc, ca)
TRI6_NODES = np.array(
    [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]]
)


def barycentric(xi: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(L0, L1, L2, L3)`` of local points.

    Parameters
    ----------
    xi : ndarray, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 4)
    """
    xi = np.asarray(xi, dtype=float)
    return np.concatenate([1.0 - xi.sum(axis=-1, keepdims=True), xi], axis=-1)


def shape_functions(xi: np.ndarray) -> np.ndarray:
    """TET10 shape functions at local points.

    Parameters
    ----------
    xi : ndarray, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 10)
    """
    lam = barycentric(xi)  # (..., 4)
    corner = lam * (2.0 * lam - 1.0)  # (..., 4)
    edge = 4.0 * lam[..., EDGES[:, 0]] * lam[..., EDGES[:, 1]]  # (..., 6)
    return np.concatenate([corner, edge], axis=-1)


def shape_gradients(xi: np.ndarray) -> np.ndarray:
    """Derivatives of the TET10 shape functions with respect to ``xi``.

    Parameters
    ----------
    xi : ndarray, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 10, 3)
        ``dN[..., a, j] = dN_a / dxi_j``.
    """
    lam = barycentric(xi)  # (..., 4)
    # dL_i/dxi_j, shape (4, 3)
    dlam = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    corner = (4.0 * lam - 1.0)[..., :, None] * dlam  # (..., 4, 3)
    i, j = EDGES[:, 0], EDGES[:, 1]
    edge = 4.0 * (lam[..., i, None] * dlam[j] + lam[..., j, None] * dlam[i])  # (..., 6, 3)
    return np.concatenate([corner, edge], axis=-2)


def tri6_shape_functions(s: np.ndarray) -> np.ndarray:
    """6-node triangle shape functions (node order a, b, c, ab, bc, ca).

    Parameters
    ----------
    s : ndarray, shape (..., 2)

    Returns
    -------
    ndarray, shape (..., 6)
    """
    s = np.asarray(s, dtype=float)
    l0 = 1.0 - s[..., 0] - s[..., 1]
    l1, l2 = s[..., 0], s[..., 1]
    return np.stack(
        [l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0],
        axis=-1,
    )


def tri6_shape_gradients(s: np.ndarray) -> np.ndarray:
    """Derivatives of the 6-node triangle shape functions, shape (..., 6, 2)."""
    s = np.asarray(s, dtype=float)
    l0 = 1.0 - s[..., 0] - s[..., 1]
    l1, l2 = s[..., 0], s[..., 1]
    d0 = np.array([-1.0, -1.0])
    d1 = np.array([1.0, 0.0])
    d2 = np.array([0.0, 1.0])
    e = lambda a: a[..., None]  # noqa: E731  (broadcast a scalar field against a 2-vector)
    return np.stack(
        [
            e(4 * l0 - 1) * d0,
            e(4 * l1 - 1) * d1,
            e(4 * l2 - 1) * d2,
            4 * (e(l0) * d1 + e(l1) * d0),
            4 * (e(l1) * d2 + e(l2) * d1),
            4 * (e(l2) * d0 + e(l0) * d2),
        ],
        axis=-2,
    )
