"""Linear tets -> 10-node tets whose boundary lies on the exact whisker surfaces.

Steps (see :mod:`geometry.boundary` for the patches):

1. classify the boundary triangles (unless the classes are given, e.g. by a template);
2. project boundary *vertices* onto their patch (rim vertices onto rim circles),
   undoing the move of any vertex whose projection would invert a linear tet;
3. upgrade to TET10 with :func:`fem.mesh.p1_to_p2` (straight mid-edge nodes, VTK order);
4. project the mid-edge nodes of boundary edges that lie on a cone (outer surface or
   cavity wall) radially at their x onto ``r_o(x)`` / ``r_i(x)``; flat patches need
   nothing (the midpoint of two points of a plane lies in it);
5. undo step 4 for any element whose isoparametric Jacobian ``det(dX/dxi)`` would not
   stay positive at its nodes and degree-2 quadrature points.

With ``cylindrical=True`` (structured swept meshes and templates mapped from them,
:mod:`geometry.swept`), step 3 places the mid-edge node of every edge whose two ends
lie in the *wall region* ``r >= r_core(x)`` (the wall rings of the swept section, see
:func:`geometry.swept.core_radius`) at the midpoint in cylindrical coordinates::

    x_m = (x_a + x_b)/2,   theta_m = theta_a + wrap(theta_b - theta_a)/2,
    r_m = (r_a + r_b)/2                  (both ends on one ring of the section)
    r_m = sqrt((r_a^2 + r_b^2)/2)        (ends on different rings)

so element edges follow the circles of the section instead of their chords. The
quadratic mean across rings makes ``r dr/ds`` (the polar map's Jacobian) nearly
constant along a radial edge instead of growing like r, so a single thick wedge-shaped
layer (coarse meshes of thick walls, ``r_i / r_o`` down to ~0.2) keeps a Jacobian ratio
~0.4 instead of ``r_i / r_o``. Boundary edges on the cones lie on one ring and so on the
exact surfaces (``r_o`` and ``r_i`` are linear in x),
and the elements of a thin wall are not pinched by the chord-to-arc offset of their
boundary edges (with straight interiors the offset, ``r (1 - cos(pi / n_theta))``, can
approach the layer thickness ``t / n_wall`` and flatten the Jacobian). Edges with an end
inside the core disc stay straight (the polar map is singular on the axis).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from fem import element
from fem.mesh import boundary_faces, jacobian_determinants, p1_to_p2, signed_volumes_linear
from fem.quadrature import tet_rule
from geometry import boundary as bd
from geometry.design import WhiskerDesign

logger = logging.getLogger(__name__)

#: local points where the P2 Jacobian is checked: the 10 nodes and the 4-point rule
CHECK_POINTS = np.vstack([element.NODES, tet_rule(2).points])


@dataclass(frozen=True)
class QuadraticMesh:
    """Result of :func:`upgrade`.

    Attributes
    ----------
    points : ndarray, shape (n_nodes, 3)
    cells : ndarray, shape (n_el, 10)
    face_elem, face_local : ndarray, shape (n_f,)
        Owning element and local face of each boundary face.
    faces6 : ndarray, shape (n_f, 6)
        Outward boundary tri6 faces (:func:`fem.mesh.boundary_faces` order).
    face_class : ndarray, shape (n_f,)
        Patch id of each boundary face.
    n_unprojected : int
        Boundary vertices left (partly) off their patch to avoid inversion.
    max_unprojected_offset : float
        Largest distance [mm] of such a vertex from its patch.
    n_unsnapped : int
        Elements whose curved mid-edge nodes were reverted to straight.
    jacobian_ratio : ndarray, shape (n_el,)
        ``min det J / max |det J|`` over :data:`CHECK_POINTS` (reused by the report).
    """

    points: np.ndarray
    cells: np.ndarray
    face_elem: np.ndarray
    face_local: np.ndarray
    faces6: np.ndarray
    face_class: np.ndarray
    n_unprojected: int = 0
    max_unprojected_offset: float = 0.0
    n_unsnapped: int = 0
    jacobian_ratio: np.ndarray | None = None  # (n_el,) min det J / max |det J| at CHECK_POINTS


def _project_safely(d: WhiskerDesign, pts: np.ndarray, tets4: np.ndarray, tris: np.ndarray, cls: np.ndarray):
    """Project the boundary vertices onto their exact surfaces without inverting a tet.

    A vertex whose full projection inverts a neighbouring tet (a thin fTetWild sliver
    next to the surface) is moved back towards its straight position, halving the
    projected distance (1/2, 1/4, 1/8 of it) and at last leaving it where it was, until
    no tet is inverted.

    Returns
    -------
    points : ndarray, shape (n_v, 3)
    n_off : int
        Vertices left off their surface.
    max_offset : float
        Largest distance [mm] of such a vertex from its projection (0 when none).
    """
    target = bd.project_vertices(d, pts, tris, cls)
    proj = target.copy()
    moved = np.any(target != pts, axis=1)
    frac = np.ones(len(pts))  # share of the projection each vertex keeps
    for _ in range(20):
        bad = signed_volumes_linear(proj, tets4) <= 0
        if not bad.any():
            break
        vs = np.unique(tets4[bad])
        vs = vs[moved[vs] & (frac[vs] > 0.0)]
        if len(vs) == 0:
            break
        half = 0.5 * frac[vs]
        frac[vs] = np.where(half < 0.1, 0.0, half)
        proj[vs] = pts[vs] + frac[vs, None] * (target[vs] - pts[vs])
    off = moved & (frac < 1.0)
    max_offset = float(np.linalg.norm(target[off] - proj[off], axis=1).max()) if off.any() else 0.0
    if off.any():
        logger.warning("%d boundary vertices kept up to %.3g mm off their surface to avoid inverted tets",
                       off.sum(), max_offset)
    return proj, int(off.sum()), max_offset


def upgrade(
    design: WhiskerDesign,
    points1: np.ndarray,
    tets4: np.ndarray,
    face_class: np.ndarray | None = None,
    cylindrical: bool = False,
    topology: tuple | None = None,
) -> QuadraticMesh:
    """Build the boundary-conforming TET10 mesh (see module docstring).

    Parameters
    ----------
    design : WhiskerDesign
    points1 : ndarray, shape (n_v, 3)
        Vertices (positively oriented tets assumed).
    tets4 : ndarray, shape (n_el, 4)
    face_class : ndarray, shape (n_f,), optional
        Patch ids of the boundary faces in :func:`fem.mesh.boundary_faces` order; by
        default classified geometrically.
    cylindrical : bool
        Cylindrical mid-edge nodes in the wall region (module docstring).
    topology : tuple, optional
        ``(cells, edges, face_elem, face_local, faces6)`` of these tets as returned by
        :func:`topology`, when already known (template meshes: computed once).

    Returns
    -------
    QuadraticMesh
    """
    pts = np.asarray(points1, dtype=np.float64)
    tets4 = np.asarray(tets4, dtype=np.int64)
    cells, edges, felem, flocal, faces6 = topology if topology is not None else mesh_topology(pts, tets4)
    tris = faces6[:, :3]
    if face_class is None:
        face_class = bd.classify_faces(design, pts, tris)
    face_class = np.asarray(face_class, dtype=np.int64)
    if len(face_class) != len(faces6):
        raise ValueError(f"upgrade: face_class has {len(face_class)} entries, mesh has {len(faces6)} boundary faces")
    pts, n_unproj, max_off = _project_safely(design, pts, tets4, tris, face_class)
    n_v = len(pts)
    mid = 0.5 * (pts[edges[:, 0]] + pts[edges[:, 1]])
    if cylindrical:
        mid = cylindrical_midpoints(design, pts, edges, mid)
    points = np.vstack([pts, mid])
    straight = points.copy()
    for patch in bd.CONE_PATCHES:
        nodes = np.unique(faces6[face_class == patch][:, 3:])
        nodes = nodes[nodes >= n_v]
        points[nodes] = bd.project_radially(design, points[nodes], patch)
    detj = jacobian_determinants(points, cells, CHECK_POINTS)  # (n_el, n_check)
    bad = np.nonzero(detj.min(axis=1) <= 0)[0]
    if len(bad):
        nodes = np.unique(cells[bad][:, 4:])
        points[nodes] = straight[nodes]
        logger.warning("%d elements: curved mid-edge nodes reverted to straight (Jacobian <= 0)", len(bad))
        detj = jacobian_determinants(points, cells, CHECK_POINTS)
    jr = detj.min(axis=1) / np.abs(detj).max(axis=1)
    return QuadraticMesh(points, cells, felem, flocal, faces6, face_class, n_unproj, max_off, len(bad), jr)


def mesh_topology(points1: np.ndarray, tets4: np.ndarray) -> tuple:
    """``(cells10, edges, face_elem, face_local, faces6)`` of linear tets (p1_to_p2 + boundary_faces)."""
    _, cells, edges = p1_to_p2(points1, tets4)
    felem, flocal, faces6 = boundary_faces(cells)
    return cells, edges, felem, flocal, faces6


def cylindrical_midpoints(d: WhiskerDesign, pts: np.ndarray, edges: np.ndarray, mid: np.ndarray) -> np.ndarray:
    """Replace straight midpoints of wall-region edges by cylindrical ones (module docstring).

    Parameters
    ----------
    pts : ndarray, shape (n_v, 3)
    edges : ndarray, shape (n_e, 2)
    mid : ndarray, shape (n_e, 3)
        Straight midpoints.

    Returns
    -------
    ndarray, shape (n_e, 3)
    """
    from geometry.swept import core_radius

    x, r, th = bd.to_meridian(pts)
    rc = core_radius(d, x)
    in_wall = r >= rc * (1.0 - 1e-7)  # (n_v,)
    frac = (r - rc) / np.maximum(d.r_outer(x) - rc, 1e-300)  # wall fraction: ring 0 .. 1
    sel = in_wall[edges[:, 0]] & in_wall[edges[:, 1]]
    a, b = edges[sel, 0], edges[sel, 1]
    dth = np.angle(np.exp(1j * (th[b] - th[a])))  # wrapped to (-pi, pi]
    across = np.abs(frac[a] - frac[b]) > 1e-6  # joins two rings: quadratic-mean radius
    rm = np.where(across, np.sqrt(0.5 * (r[a] ** 2 + r[b] ** 2)), 0.5 * (r[a] + r[b]))
    out = mid.copy()
    out[sel] = bd.from_meridian(0.5 * (x[a] + x[b]), rm, th[a] + 0.5 * dth)
    return out
