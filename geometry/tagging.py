"""Named node and face sets of a whisker mesh, and the fibres located in their host tets.

Face sets are outward tri6 faces (rows of :func:`fem.mesh.boundary_faces`):

* ``base``  - the clamped face x = 0;
* ``cavity`` - every face of the cavity: its cone and both flat ends (pressure load);
  also split as ``cavity_wall``, ``cavity_start`` (x = c), ``cavity_end`` (x = l);
* ``outer`` - the outer cone;
* ``tip``   - the (cut) tip face x = L - trim;
* ``gauge`` - the outer faces under the strain gauge: face centroid (mean of its six
  nodes) with ``x_ss <= x <= x_ss + e`` and angle from +y about x,
  ``|atan2(z, y)| <= gauge_half_angle_deg``.

Node sets hold every node (corner and mid-edge) of the faces of the same name.

Fibres: each helix (:mod:`geometry.fibres`) is sampled with segments no longer than
``fibre_ds_factor * h_wall`` (half the wall element size by default) and every point
is located (element + xi, :mod:`geometry.locate`). Points on the boundary (fibre
radius fraction 0 or 1) may fall a hair outside the curved P2 face: their xi is
clipped to the reference tet (barycentrics clipped at 0 and renormalised).
"""

from __future__ import annotations


import numpy as np

from geometry import boundary as bd
from geometry.design import WhiskerDesign
from geometry.errors import GeometryError
from geometry.fibres import FibrePath, fibre_phases, sample_helix
from geometry.locate import PointLocator
from geometry.quadratic import QuadraticMesh

FACE_SET_NAMES = ("base", "cavity", "outer", "tip", "gauge", "cavity_wall", "cavity_start", "cavity_end")


class FibreLocationError(RuntimeError, GeometryError):
    """A fibre point lies outside the mesh."""


def gauge_mask(design: WhiskerDesign, points: np.ndarray, faces6: np.ndarray) -> np.ndarray:
    """Which faces' centroids lie in the gauge window (see module docstring), shape (n_f,)."""
    cen = points[faces6].mean(axis=1)  # (n_f, 3)
    ang = np.degrees(np.abs(np.arctan2(cen[:, 2], cen[:, 1])))
    x = cen[:, 0]
    return (x >= design.x_ss) & (x <= design.x_ss + design.e) & (ang <= design.gauge_half_angle_deg)


def footprint_mask(points: np.ndarray, x_lo: float, x_hi: float, width: float) -> np.ndarray:
    """Which of ``points`` (..., 3) lie on a rectangle of the outer surface centred on the +y generator: axial
    position ``x_lo <= x <= x_hi`` and arc length ``|r atan2(z, y)| <= width/2`` from the +y generator
    (r = sqrt(y² + z²)), shape (...). The footprint of a sheet bonded over the gauge (the ``gauge`` face set
    selects by angle, this by arc length, the sheet's own width)."""
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    arc = np.hypot(y, z) * np.abs(np.arctan2(z, y))
    return (x >= x_lo) & (x <= x_hi) & (arc <= 0.5 * width)


def face_sets(design: WhiskerDesign, qm: QuadraticMesh) -> dict[str, np.ndarray]:
    """The named outward tri6 face sets, each shape (n_f, 6) int64."""
    f, c = qm.faces6, qm.face_class
    sets = {
        "base": f[c == bd.BASE],
        "cavity": f[np.isin(c, bd.CAVITY_PATCHES)],
        "outer": f[c == bd.OUTER],
        "tip": f[c == bd.TIP],
        "cavity_wall": f[c == bd.CAVITY_WALL],
        "cavity_start": f[c == bd.CAVITY_START],
        "cavity_end": f[c == bd.CAVITY_END],
    }
    outer = sets["outer"]
    sets["gauge"] = outer[gauge_mask(design, qm.points, outer)]
    return {k: np.ascontiguousarray(v, dtype=np.int64) for k, v in sets.items()}


def node_sets(faces: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """All nodes of each face set (sorted unique), each shape (n,) int64."""
    return {k: np.unique(v).astype(np.int64) for k, v in faces.items()}


def _clip_to_tet(xi: np.ndarray) -> np.ndarray:
    lam = np.concatenate([1.0 - xi.sum(axis=1, keepdims=True), xi], axis=1)  # (n, 4)
    lam = np.clip(lam, 0.0, None)
    lam /= lam.sum(axis=1, keepdims=True)
    return lam[:, 1:]


def locate_fibres(
    design: WhiskerDesign,
    locator: PointLocator,
    ds: float,
    tol: float = 1e-3,
) -> tuple[FibrePath, ...]:
    """Sample every fibre helix with segments <= ``ds`` and locate its points.

    Raises
    ------
    FibreLocationError
        A point's best host has a barycentric coordinate below ``-tol``.
    """
    out = []
    for phase in fibre_phases(design):
        pts = sample_helix(design, phase, ds)
        loc = locator.locate(pts, tol=tol)
        if not loc.inside.all():
            bad = np.nonzero(~loc.inside)[0]
            raise FibreLocationError(
                f"{len(bad)} of {len(pts)} points of the fibre with phase {phase:.3f} rad lie outside the mesh "
                f"(first at {pts[bad[0]].round(4).tolist()}, fibre_radius_frac={design.fibre_radius_frac})"
            )
        seg = np.stack([np.arange(len(pts) - 1), np.arange(1, len(pts))], axis=1).astype(np.int64)
        out.append(FibrePath(pts, loc.host_elements, _clip_to_tet(loc.local_coords), seg, float(phase)))
    return tuple(out)


def band_nodes(points: np.ndarray, nodes: np.ndarray, x_max: float, tol: float = 1e-9) -> np.ndarray:
    """The nodes of a set at x ≤ ``x_max`` (within ``tol`` relative to the set's axial extent), shape (k,) int64:
    the band of a surface from the base up to ``x_max``, e.g. the outer surface a holder grips.

    Raises
    ------
    ValueError
        No node of the set lies there.
    """
    nodes = np.asarray(nodes, dtype=np.int64)
    x = points[nodes, 0]
    span = float(x.max() - x.min()) if len(x) else 0.0
    sel = nodes[x <= x_max + tol * max(span, 1.0)]
    if len(sel) == 0:
        raise ValueError(f"band_nodes: no node at x <= {x_max:g} mm (the set starts at x = {x.min():g} mm)")
    return sel
