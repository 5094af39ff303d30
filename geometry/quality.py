"""Mesh quality measures and the per-mesh report.

* Radius ratio of the straight (vertex) tet, 1 for the regular tet, 0 when degenerate::

      rho = 3 r_in / R_circ,   r_in = 3 V / A_total,
      R_circ = |a^2 (b x c) + b^2 (c x a) + c^2 (a x b)| / (12 V)

  with a, b, c the edge vectors from vertex 0 (Shewchuk, "What is a good linear
  finite element?", 2002).
* Jacobian ratio of the curved TET10: ``min det J / max det J`` over its 10 nodes and
  the 4 Gauss points (1 for a straight-sided tet, <= 0 when inverted).
* Volume ``sum_e sum_q det J(xi_q) w_q`` (degree-3 rule) against
  :func:`geometry.analytic.solid_volume`; cavity area ``sum_f sum_q |X_,1 x X_,2| w_q``
  (degree-4 triangle rule on the tri6 faces) against :func:`geometry.analytic.cavity_area`.
* Elements through the wall, two ways:

  - ``elements_through_wall``: the minimum over radial lines (5 axial positions spread
    over the chamber, 8 angles) from ``r_i(x)`` to ``r_o(x)`` of the number of
    straight-sided tets the line passes through (exact segment-tet intersection). For unstructured
    tets this counts ~3.7 per edge length through the wall (see :mod:`geometry.sizing`);
  - ``wall_layers``: ``t / median radial extent`` of the elements whose vertex centroid
    lies in the wall (``c < x < l``), the number of element *layers* a structured mesh
    with the same element size would have.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from fem import element
from fem.mesh import jacobian_determinants, volumes
from fem.quadrature import tri_rule
from geometry import analytic
from geometry.design import WhiskerDesign
from geometry.locate import PointLocator
from geometry.quadratic import CHECK_POINTS


@dataclass(frozen=True)
class MeshReport:
    """Measured properties of one mesh (see module docstring for the definitions)."""

    n_nodes: int
    n_elements: int
    n_vertices: int
    quality_min: float
    quality_median: float
    jacobian_ratio_min: float
    volume: float
    volume_analytic: float
    volume_error: float
    cavity_area: float
    cavity_area_analytic: float
    cavity_area_error: float
    elements_through_wall: int
    elements_through_wall_median: float
    wall_layers: float
    h_wall: float
    method: str
    seconds: float = 0.0
    boundary_off_surface: int = 0
    boundary_offset_max: float = 0.0

    def as_dict(self) -> dict:
        return {k: (float(v) if isinstance(v, (np.floating,)) else v) for k, v in dataclasses.asdict(self).items()}


def radius_ratio(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """``3 r_in / R_circ`` of the straight tets on the first four nodes, shape (n_el,)."""
    X = points[tets[:, :4]]  # (n_el, 4, 3)
    a, b, c = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]  # (n_el, 3)
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    area = 0.0
    for i, j, k in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)):
        area = area + 0.5 * np.linalg.norm(np.cross(X[:, j] - X[:, i], X[:, k] - X[:, i]), axis=1)
    r_in = 3.0 * vol / area
    num = (
        (a * a).sum(1)[:, None] * np.cross(b, c)
        + (b * b).sum(1)[:, None] * np.cross(c, a)
        + (c * c).sum(1)[:, None] * np.cross(a, b)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        R = np.linalg.norm(num, axis=1) / (12.0 * vol)
        rho = np.where(vol > 0, 3.0 * r_in / R, 0.0)
    return rho


def jacobian_ratio(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """``min det J / max det J`` over nodes and Gauss points per element, shape (n_el,)."""
    dj = jacobian_determinants(points, cells, CHECK_POINTS)  # (n_el, 14)
    return dj.min(axis=1) / np.abs(dj).max(axis=1)


def surface_area(points: np.ndarray, faces6: np.ndarray, degree: int = 4) -> float:
    """Area of curved tri6 faces, ``sum_f sum_q |dX/ds1 x dX/ds2| w_q``."""
    if len(faces6) == 0:
        return 0.0
    rule = tri_rule(degree)
    dN = element.tri6_shape_gradients(rule.points)  # (n_qp, 6, 2)
    X = points[faces6]  # (n_f, 6, 3)
    T = np.einsum("fai,qaj->fqij", X, dN)  # (n_f, n_qp, 3, 2)
    n = np.cross(T[..., 0], T[..., 1])  # (n_f, n_qp, 3)
    return float((np.linalg.norm(n, axis=-1) @ rule.weights).sum())


def wall_crossings(
    design: WhiskerDesign, locator: PointLocator, n_x: int = 5, n_theta: int = 8, min_length: float = 1e-6
) -> np.ndarray:
    """Elements crossed by radial lines through the wall, shape (n_x * n_theta,).

    Each line runs from ``r_i(x)`` to ``r_o(x)`` at ``x = c + (l - c)(i + 0.43)/n_x`` and
    angle ``2 pi (k + 0.3)/n_theta`` (offsets keep the lines off the station planes and
    node lines of structured meshes). Along ``q(s) = A + s (B - A)``, s in [0, 1], the
    barycentric coordinates of a straight tet are linear, ``lam_i(s) = alpha_i + beta_i s``;
    the line crosses the tet where all are >= 0, an interval of s; a tet counts when that
    interval is longer than ``min_length`` (relative to the line).
    """
    d = design
    xs = d.c + (d.l - d.c) * (np.arange(n_x) + 0.43) / n_x
    ths = 2.0 * np.pi * (np.arange(n_theta) + 0.3) / n_theta
    X, TH = np.meshgrid(xs, ths, indexing="ij")  # (n_x, n_theta)
    X, TH = X.ravel(), TH.ravel()
    dirs = np.stack([np.zeros_like(TH), np.cos(TH), np.sin(TH)], axis=1)  # (n_l, 3)
    A = np.stack([X, np.zeros_like(X), np.zeros_like(X)], axis=1) + d.r_inner(X)[:, None] * dirs
    D = d.t * dirs  # (n_l, 3), B - A
    Xv = locator.points[locator.cells[:, :4], 0]  # (n_el, 4) vertex x
    xmin, xmax = Xv.min(axis=1), Xv.max(axis=1)
    out = np.zeros(len(X), dtype=np.int64)
    for i in range(len(X)):
        el = np.nonzero((xmin <= X[i]) & (xmax >= X[i]))[0]  # only tets spanning the line's x
        Tinv, x0 = locator.Tinv[el], locator.x0[el]  # (n, 3, 3), (n, 3)
        a3 = np.einsum("eij,ej->ei", Tinv, A[i] - x0)  # (n, 3)
        b3 = np.einsum("eij,j->ei", Tinv, D[i])  # (n, 3)
        al = np.concatenate([1.0 - a3.sum(1, keepdims=True), a3], axis=1)  # (n, 4)
        be = np.concatenate([-b3.sum(1, keepdims=True), b3], axis=1)  # (n, 4)
        with np.errstate(divide="ignore", invalid="ignore"):
            root = -al / be
        lo = np.max(np.where(be > 0, root, -np.inf), axis=1, initial=0.0)
        hi = np.min(np.where(be < 0, root, np.inf), axis=1, initial=1.0)
        ok = np.all((be != 0) | (al >= 0), axis=1)
        out[i] = int(np.sum(ok & (hi - lo > min_length)))
    return out


def wall_layers(design: WhiskerDesign, points: np.ndarray, cells: np.ndarray) -> float:
    """``t / median radial extent`` of the wall elements (see module docstring)."""
    X = points[cells[:, :4]]  # (n_el, 4, 3)
    r = np.hypot(X[..., 1], X[..., 2])  # (n_el, 4)
    xc = X[..., 0].mean(axis=1)
    wall = (xc > design.c) & (xc < design.l)
    if not wall.any():
        return 0.0
    ext = r[wall].max(axis=1) - r[wall].min(axis=1)
    return float(design.t / np.median(ext))


def make_report(
    design: WhiskerDesign,
    points: np.ndarray,
    cells: np.ndarray,
    cavity_faces: np.ndarray,
    locator: PointLocator,
    h_wall: float,
    method: str,
    seconds: float = 0.0,
    jac_ratio: np.ndarray | None = None,
    off_surface: tuple[int, float] = (0, 0.0),
) -> MeshReport:
    """Measure a finished mesh (see module docstring); ``jac_ratio`` reuses known Jacobian ratios,
    ``off_surface`` is (count, largest distance [mm]) of boundary vertices the TET10 upgrade left
    off their surface."""
    rho = radius_ratio(points, cells)
    jr = jacobian_ratio(points, cells) if jac_ratio is None else jac_ratio
    vol = float(volumes(points, cells, degree=3).sum())
    v_ex = analytic.solid_volume(design)
    area = surface_area(points, cavity_faces)
    a_ex = analytic.cavity_area(design)
    cross = wall_crossings(design, locator)
    return MeshReport(
        n_nodes=int(len(points)),
        n_elements=int(len(cells)),
        n_vertices=int(len(np.unique(cells[:, :4]))),
        quality_min=float(rho.min()),
        quality_median=float(np.median(rho)),
        jacobian_ratio_min=float(jr.min()),
        volume=vol,
        volume_analytic=v_ex,
        volume_error=(vol - v_ex) / v_ex,
        cavity_area=area,
        cavity_area_analytic=a_ex,
        cavity_area_error=(area - a_ex) / a_ex,
        elements_through_wall=int(cross.min()),
        elements_through_wall_median=float(np.median(cross)),
        wall_layers=wall_layers(design, points, cells),
        h_wall=float(h_wall),
        method=method,
        seconds=float(seconds),
        boundary_off_surface=int(off_surface[0]),
        boundary_offset_max=float(off_surface[1]),
    )
