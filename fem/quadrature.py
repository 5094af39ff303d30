"""Quadrature rules on the reference tetrahedron and triangle.

The reference tetrahedron has vertices (0,0,0), (1,0,0), (0,1,0), (0,0,1) and
volume 1/6; the reference triangle (0,0), (1,0), (0,1) has area 1/2. Weights sum to
those measures.

Rules
-----
* tetrahedron, degree 1: centroid.
* tetrahedron, degree 2: the classical 4-point rule (Keast 1986, rule 2), the rule
  Abaqus/CalculiX use for C3D10: points at barycentric (a, b, b, b) permutations with
  a = (5 + 3 sqrt 5)/20, b = (5 - sqrt 5)/20.
* any higher degree: the Stroud conical-product rule (Stroud 1971, sec. 2.4), i.e.
  Gauss-Jacobi points on the collapsed cube. All weights are positive, which keeps
  the quadrature of a convex energy convex.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import roots_jacobi


@dataclass(frozen=True)
class QuadratureRule:
    """Points and weights of a quadrature rule on a reference simplex.

    Attributes
    ----------
    points : ndarray, shape (n_qp, dim)
    weights : ndarray, shape (n_qp,)
    degree : int
        Polynomials up to this total degree are integrated exactly.
    """

    points: np.ndarray
    weights: np.ndarray
    degree: int


def _gauss_jacobi_01(n: int, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Jacobi nodes/weights on [0, 1] for the weight (1 - t)**alpha."""
    x, w = roots_jacobi(n, alpha, 0.0)  # weight (1-x)^alpha on [-1, 1]
    t = 0.5 * (x + 1.0)
    return t, w / 2.0 ** (alpha + 1.0)


def tet_rule(degree: int = 2) -> QuadratureRule:
    """Quadrature rule on the reference tetrahedron exact to ``degree``.

    Parameters
    ----------
    degree : int
        Required polynomial degree of exactness (>= 1).
    """
    if degree < 1:
        raise ValueError(f"tet_rule: degree={degree} must be >= 1")
    if degree == 1:
        return QuadratureRule(np.array([[0.25, 0.25, 0.25]]), np.array([1.0 / 6.0]), 1)
    if degree == 2:
        a = (5.0 + 3.0 * np.sqrt(5.0)) / 20.0
        b = (5.0 - np.sqrt(5.0)) / 20.0
        pts = np.array([[b, b, b], [a, b, b], [b, a, b], [b, b, a]])
        return QuadratureRule(pts, np.full(4, 1.0 / 24.0), 2)
    n = (degree + 2) // 2
    t1, w1 = _gauss_jacobi_01(n, 2.0)
    t2, w2 = _gauss_jacobi_01(n, 1.0)
    t3, w3 = _gauss_jacobi_01(n, 0.0)
    T1, T2, T3 = np.meshgrid(t1, t2, t3, indexing="ij")
    W = (w1[:, None, None] * w2[None, :, None] * w3[None, None, :]).ravel()
    x = T1.ravel()
    y = (T2 * (1.0 - T1)).ravel()
    z = (T3 * (1.0 - T1) * (1.0 - T2)).ravel()
    # map: xi1 = x... the collapsed map (t1, t2, t3) -> (z, y, x) keeps all in the simplex
    pts = np.stack([z, y, x], axis=1)
    return QuadratureRule(pts, W, degree)


def tri_rule(degree: int = 4) -> QuadratureRule:
    """Quadrature rule on the reference triangle exact to ``degree`` (positive weights).

    Degree 1 is the centroid; higher degrees use the Stroud conical product.
    """
    if degree < 1:
        raise ValueError(f"tri_rule: degree={degree} must be >= 1")
    if degree == 1:
        return QuadratureRule(np.array([[1.0 / 3.0, 1.0 / 3.0]]), np.array([0.5]), 1)
    n = (degree + 2) // 2
    t1, w1 = _gauss_jacobi_01(n, 1.0)
    t2, w2 = _gauss_jacobi_01(n, 0.0)
    T1, T2 = np.meshgrid(t1, t2, indexing="ij")
    W = (w1[:, None] * w2[None, :]).ravel()
    x = T1.ravel()
    y = (T2 * (1.0 - T1)).ravel()
    return QuadratureRule(np.stack([y, x], axis=1), W, degree)
