"""Reference geometry of 6-node triangle faces at the points of a triangle rule: the one place a surface term
(springs, bonded sheets) gets its tangents, normals and area elements.

On a 6-node triangle with shape functions N_a(ξ) and reference corner/mid-edge positions X_a, the tangents are
X,α = Σ_a ∂N_a/∂ξ_α X_a, the area element dA = |X,1 × X,2| dξ and the unit normal n0 = X,1 × X,2 / |X,1 × X,2|
(its sign follows the node order; a term that needs an outward normal takes outward faces).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem import element
from fem.quadrature import tri_rule

__all__ = ["FaceGeometry", "face_geometry"]


@dataclass(frozen=True, eq=False)
class FaceGeometry:
    """The reference geometry of a set of faces at a rule's points.

    Attributes
    ----------
    faces : ndarray (n_f, 6)
    N : ndarray (n_qp, 6)
        Shape functions at the rule's points.
    dN : ndarray (n_qp, 6, 2)
        Their derivatives ∂N_a/∂ξ_α.
    X : ndarray (n_f, 6, 3)
        Reference node positions of each face.
    a1, a2 : ndarray (n_f, n_qp, 3)
        Reference tangents X,1 and X,2.
    normal : ndarray (n_f, n_qp, 3)
        Unit normal n0.
    dA : ndarray (n_f, n_qp)
        |X,1 × X,2|.
    wdA : ndarray (n_f, n_qp)
        Rule weight times dA.
    """

    faces: np.ndarray
    N: np.ndarray
    dN: np.ndarray
    X: np.ndarray
    a1: np.ndarray
    a2: np.ndarray
    normal: np.ndarray
    dA: np.ndarray
    wdA: np.ndarray

    @property
    def n_qp(self) -> int:
        return self.N.shape[0]

    @property
    def points(self) -> np.ndarray:
        """Reference positions of the rule's points, shape (n_f, n_qp, 3)."""
        return np.matmul(self.N[None], self.X)  # (n_f, n_qp, 3)


def face_geometry(points: np.ndarray, faces: np.ndarray, degree: int, owner: str) -> FaceGeometry:
    """The reference geometry of ``faces`` (n_f, 6) of ``points`` (n_nodes, 3) at the triangle rule of ``degree``.

    Raises
    ------
    ValueError
        A face of zero area (``owner`` names the term in the message).
    """
    faces = np.asarray(faces, dtype=np.int64)
    rule = tri_rule(int(degree))
    N = element.tri6_shape_functions(rule.points)  # (n_qp, 6)
    dN = element.tri6_shape_gradients(rule.points)  # (n_qp, 6, 2)
    X = np.asarray(points, float)[faces]  # (n_f, 6, 3)
    a1 = np.matmul(dN[:, :, 0], X)  # (n_f, n_qp, 3)  X,1
    a2 = np.matmul(dN[:, :, 1], X)  # (n_f, n_qp, 3)  X,2
    nda = np.cross(a1, a2)  # (n_f, n_qp, 3)
    dA = np.linalg.norm(nda, axis=-1)  # (n_f, n_qp)
    if np.any(dA <= 0):
        raise ValueError(f"{owner}: {int(np.sum(np.any(dA <= 0, axis=1)))} faces of zero area")
    return FaceGeometry(faces=faces, N=N, dN=dN, X=X, a1=a1, a2=a2, normal=nda / dA[..., None], dA=dA,
                        wdA=rule.weights[None, :] * dA)
