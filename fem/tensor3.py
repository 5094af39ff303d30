"""Closed-form determinant and inverse of stacks of 3×3 matrices.

``numpy.linalg.det``/``inv`` call LAPACK once per matrix; for the ~10⁴ deformation
gradients of an assembly the cofactor formulas below are an order of magnitude faster
and agree to round-off (the timing: ``benchmarks/results/bench_fem.md``, "Figures moved from the FE
core's docstrings and comments").
"""

from __future__ import annotations

import numpy as np


def det3(F: np.ndarray) -> np.ndarray:
    """det F by the rule of Sarrus, shape ``F.shape[:-2]``."""
    return (F[..., 0, 0] * (F[..., 1, 1] * F[..., 2, 2] - F[..., 1, 2] * F[..., 2, 1])
            - F[..., 0, 1] * (F[..., 1, 0] * F[..., 2, 2] - F[..., 1, 2] * F[..., 2, 0])
            + F[..., 0, 2] * (F[..., 1, 0] * F[..., 2, 1] - F[..., 1, 1] * F[..., 2, 0]))


def det_inv3(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(det F, F⁻¹) from the adjugate: F⁻¹ = adj(F) / det F.

    Parameters
    ----------
    F : ndarray (..., 3, 3)

    Returns
    -------
    J : ndarray (...)
    G : ndarray (..., 3, 3)
        Inverse; entries are inf/nan where ``J == 0`` (callers check J first).
    """
    a, b, c = F[..., 0, 0], F[..., 0, 1], F[..., 0, 2]
    d, e, f = F[..., 1, 0], F[..., 1, 1], F[..., 1, 2]
    g, h, i = F[..., 2, 0], F[..., 2, 1], F[..., 2, 2]
    adj = np.empty_like(F)
    adj[..., 0, 0] = e * i - f * h
    adj[..., 1, 0] = f * g - d * i
    adj[..., 2, 0] = d * h - e * g
    adj[..., 0, 1] = c * h - b * i
    adj[..., 1, 1] = a * i - c * g
    adj[..., 2, 1] = b * g - a * h
    adj[..., 0, 2] = b * f - c * e
    adj[..., 1, 2] = c * d - a * f
    adj[..., 2, 2] = a * e - b * d
    J = a * adj[..., 0, 0] + b * adj[..., 1, 0] + c * adj[..., 2, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        G = adj / J[..., None, None]
    return J, G
