"""The fibre helices smeared over the chamber wall: stiffness and direction at quadrature points.

The ``n`` helices of :mod:`geometry.fibres` (pitch p, radius r_f(x) = r_i(x) + frac·t over
c ≤ x ≤ l) are replaced by a continuum family of helices of the same pitch and handedness.
At a point (x, r, θ) of the wall the fibre direction is the helix tangent::

    a = (e_x + r_f'(x) e_r + (2π r_f / p) e_θ) / s,   s = √(1 + r_f'² + (2π r_f / p)²)

(s = fibre length per unit axial length of one helix), and the fibre stiffness per volume
(:mod:`fem.fibre_field`) is::

    k(x, r) = E_f A_f · n s / (2π r) · w(r − r_f(x))

with a radial profile w of unit integral, so that ∫ k 2πr dr = n s E_f A_f: per unit axial
length the smeared field stores exactly the axial stiffness of the n discrete fibres. The
profile is uniform over the band centred on the fibre radius that reaches the nearer wall
surface, ``w(ρ) = 1/(2h)`` for |ρ| < h, h = min(frac, 1 − frac)·t (frac = ½: the whole
wall). A uniform band is represented exactly by the element layers of a structured wall
mesh at frac = ½ on every mesh level; a profile peaked at r_f is not (its element means
alternate between odd and even numbers of wall layers, which made Δl non-monotone under
refinement: benchmarks/results/fibre_models.md).

k (times the window c ≤ x ≤ l) is replaced by its element mean, integrated with a
degree-8 rule over each curved element, so that every element carries exactly its share
of the fibre stiffness however the element layers of the wall fall relative to r_f (the
embedded line's stiffness instead acts through whichever element holds the line, which
changes with the mesh). Homogenisation of a fibre winding whose spacing p/n (1.5 mm in
the default design) is below the wall thickness: Holzapfel, Gasser & Ogden (2000) for the
anisotropic energy, Spencer (1984) for the continuum fibre family.
"""

from __future__ import annotations

import math

import numpy as np

from fem.mesh import TetMesh, jacobian_determinants, mapped_points
from fem.problem import SmearedFibres
from fem.quadrature import tet_rule
from geometry.design import WhiskerDesign
from geometry.fibres import helix_hoop_and_speed

#: Degree of the rule that integrates the radial profile over each element.
PROFILE_RULE_DEGREE = 8
_CHUNK = 4096


def profile_half_width(design: WhiskerDesign) -> float:
    """Half-width h of the radial profile: the distance from r_f to the nearer wall surface [mm]."""
    f = design.fibre_radius_frac
    return min(f, 1.0 - f) * design.t


def _stiffness(design: WhiskerDesign, X: np.ndarray) -> np.ndarray:
    """k(x, r) = E_f A_f n s / (2π r) · w(r − r_f(x)) · [c ≤ x ≤ l] at points X (..., 3) [MPa]."""
    x = X[..., 0]
    r = np.hypot(X[..., 1], X[..., 2])
    h = profile_half_width(design)
    rho = r - design.r_fibre(x)
    w = np.where(np.abs(rho) < h, 0.5 / h, 0.0)
    _, s = helix_hoop_and_speed(design, x)
    k = design.fibre_E * design.fibre_area * design.n_fibres * s / (2.0 * math.pi * np.maximum(r, 1e-12)) * w
    return np.where((x >= design.c) & (x <= design.l), k, 0.0)


def _element_means(mesh: TetMesh, design: WhiskerDesign, cells: np.ndarray) -> np.ndarray:
    """Mean of k over each element of ``cells`` (n, 10) [MPa]."""
    rule = tet_rule(PROFILE_RULE_DEGREE)
    out = np.empty(len(cells))
    for s in range(0, len(cells), _CHUNK):
        chunk = cells[s:s + _CHUNK]  # (m, 10)
        Xp = mapped_points(mesh.points, chunk, rule.points)  # (m, n_p, 3)
        wdv = rule.weights * jacobian_determinants(mesh.points, chunk, rule.points)  # (m, n_p)
        out[s:s + _CHUNK] = np.sum(wdv * _stiffness(design, Xp), axis=1) / np.sum(wdv, axis=1)
    return out


def smeared_fibres(mesh: TetMesh, design: WhiskerDesign, quadrature_degree: int = 2) -> SmearedFibres:
    """The :class:`fem.problem.SmearedFibres` of ``design``'s winding on ``mesh``.

    Parameters
    ----------
    mesh : TetMesh
        Whisker mesh (x axial, reference configuration).
    design : WhiskerDesign
    quadrature_degree : int
        Degree of the tet rule of the problem (one column of the field per point).

    Returns
    -------
    SmearedFibres
        Over the elements whose profile mean is positive (none without fibres).
    """
    centroids = mesh.points[mesh.cells[:, :4]].mean(axis=1)  # (n_el, 3)
    reach = profile_half_width(design) + 2.0 * design.t  # generous: curved elements span about one wall
    r_c = np.hypot(centroids[:, 1], centroids[:, 2])
    cand = np.nonzero((centroids[:, 0] > design.c - design.t) & (centroids[:, 0] < design.l + design.t)
                      & (np.abs(r_c - design.r_fibre(centroids[:, 0])) < reach))[0]
    kbar = _element_means(mesh, design, mesh.cells[cand])  # (n_cand,)
    el = cand[kbar > 0.0]
    kbar = kbar[kbar > 0.0]
    rule = tet_rule(quadrature_degree)
    Xq = mapped_points(mesh.points, mesh.cells[el], rule.points)  # (n, n_qp, 3)
    x = Xq[..., 0]
    th = np.arctan2(Xq[..., 2], Xq[..., 1])
    drf = -design.tan_alpha  # r_f'(x)
    hoop, s = helix_hoop_and_speed(design, x)  # (n, n_qp) each
    e_r = np.stack([np.zeros_like(th), np.cos(th), np.sin(th)], axis=-1)  # (n, n_qp, 3)
    e_t = np.stack([np.zeros_like(th), -np.sin(th), np.cos(th)], axis=-1)
    a = (np.array([1.0, 0.0, 0.0]) + drf * e_r + hoop[..., None] * e_t) / s[..., None]  # (n, n_qp, 3)
    return SmearedFibres(el, np.repeat(kbar[:, None], len(rule.weights), axis=1), a)
