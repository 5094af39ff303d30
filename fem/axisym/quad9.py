"""The 9-node Lagrange quadrilateral (Q2) and its discontinuous linear pressure (P1disc).

Reference square ξ, η ∈ [−1, 1]. Node order: corners 0–3 counter-clockwise from (−1, −1),
mid-edge nodes 4 (edge 0–1), 5 (1–2), 6 (2–3), 7 (3–0), centre 8::

    3 --- 6 --- 2
    |           |
    7     8     5
    |           |
    0 --- 4 --- 1

Shape functions are products of the 1-D quadratic Lagrange polynomials
l₋(s) = s(s − 1)/2, l₀(s) = 1 − s², l₊(s) = s(s + 1)/2 (Zienkiewicz & Taylor, *The Finite
Element Method*, vol. 1, §8.6). The pressure of the mixed Q2/P1disc pair is linear on each
element in the reference coordinates, q = (1, ξ, η); the pair satisfies the inf–sup condition
and does not lock as the material becomes incompressible (Boffi, Brezzi & Fortin 2013, §8.6.3).
Edges are 3-node quadratic lines with local coordinate s ∈ [−1, 1].
"""

from __future__ import annotations

import numpy as np

#: Reference coordinates (ξ, η) of the nine nodes.
NODES = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [0, -1], [1, 0], [0, 1], [-1, 0], [0, 0]], dtype=float)

#: The element's four edges as 3-node lines (start, middle, end), counter-clockwise.
EDGES = np.array([[0, 4, 1], [1, 5, 2], [2, 6, 3], [3, 7, 0]])


def _lagrange_1d(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values and derivatives of l₋, l₀, l₊ at s (n,) -> two arrays (n, 3) in the order −1, 0, +1."""
    val = np.stack([0.5 * s * (s - 1.0), 1.0 - s * s, 0.5 * s * (s + 1.0)], axis=-1)  # (n, 3)
    der = np.stack([s - 0.5, -2.0 * s, s + 0.5], axis=-1)  # (n, 3)
    return val, der


_INDEX = (NODES + 1).astype(int)  # (9, 2): which 1-D polynomial (0, 1, 2) in ξ and in η


def shape_functions(xi: np.ndarray) -> np.ndarray:
    """N_a at the points ``xi`` (n, 2) -> (n, 9)."""
    lx, _ = _lagrange_1d(xi[:, 0])
    ly, _ = _lagrange_1d(xi[:, 1])
    return lx[:, _INDEX[:, 0]] * ly[:, _INDEX[:, 1]]  # (n, 9)


def shape_gradients(xi: np.ndarray) -> np.ndarray:
    """∂N_a/∂(ξ, η) at ``xi`` (n, 2) -> (n, 9, 2)."""
    lx, dx = _lagrange_1d(xi[:, 0])
    ly, dy = _lagrange_1d(xi[:, 1])
    gx = dx[:, _INDEX[:, 0]] * ly[:, _INDEX[:, 1]]  # (n, 9)
    gy = lx[:, _INDEX[:, 0]] * dy[:, _INDEX[:, 1]]  # (n, 9)
    return np.stack([gx, gy], axis=-1)


def line_shape(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quadratic line (start, middle, end): values (n, 3) and d/ds (n, 3) at s (n,)."""
    val, der = _lagrange_1d(s)
    return val[:, [0, 1, 2]], der[:, [0, 1, 2]]


def pressure_basis(xi: np.ndarray) -> np.ndarray:
    """The P1disc pressure basis (1, ξ, η) at ``xi`` (n, 2) -> (n, 3)."""
    return np.column_stack([np.ones(len(xi)), xi[:, 0], xi[:, 1]])


def gauss_1d(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss–Legendre points and weights on [−1, 1]."""
    return np.polynomial.legendre.leggauss(n)


def gauss_square(n: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Tensor n × n Gauss rule on [−1, 1]²: points (n², 2), weights (n²,); exact to degree 2n − 1 per axis."""
    s, w = gauss_1d(n)
    pts = np.array([[a, b] for b in s for a in s])
    wts = np.array([wa * wb for wb in w for wa in w])
    return pts, wts
