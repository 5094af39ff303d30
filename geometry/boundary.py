"""The six exact boundary patches of the whisker, face classification and projection.

Every boundary patch is a surface of revolution about x whose meridian (in the
(x, r) half-plane, r = sqrt(y^2 + z^2)) is a straight segment:

====  ===============  ==============================  ===========================
 id    name             meridian segment                outward normal (n_x, n_r)
====  ===============  ==============================  ===========================
 0     base             (0, 0) - (0, r_o(0))            (-1, 0)
 1     outer            (0, r_o(0)) - (L', r_o(L'))     (sin a, cos a)
 2     tip              (L', r_o(L')) - (L', 0)         (+1, 0)
 3     cavity_start     (c, 0) - (c, r_i(c))            (+1, 0)
 4     cavity_wall      (c, r_i(c)) - (l, r_i(l))       (-sin a, -cos a)
 5     cavity_end       (l, r_i(l)) - (l, 0)            (-1, 0)
====  ===============  ==============================  ===========================

(L' = L - trim; the outward normal of the *solid*: on the cavity it points into the
cavity.) The 3-D normal at angle theta is ``(n_x, n_r cos theta, n_r sin theta)``.

Classification of a boundary triangle with centroid meridian point q and unit normal
n: among the patches whose normal agrees (``n . n_k > 0.3``) the one with the smallest
distance from q to its meridian segment; if none agrees, the nearest one.

Projection onto a patch is the closest point on its meridian segment at the same
theta; a vertex shared by two adjacent patches goes to their common rim circle.
Mid-edge nodes on the cones are projected *radially at their x* onto
``r = r_o(x)`` (outer) or ``r = r_i(x)`` (cavity).
"""

from __future__ import annotations

import logging

import numpy as np

from geometry.design import WhiskerDesign

logger = logging.getLogger(__name__)

BASE, OUTER, TIP, CAVITY_START, CAVITY_WALL, CAVITY_END = range(6)
PATCH_NAMES = ("base", "outer", "tip", "cavity_start", "cavity_wall", "cavity_end")
CAVITY_PATCHES = (CAVITY_START, CAVITY_WALL, CAVITY_END)
CONE_PATCHES = (OUTER, CAVITY_WALL)

#: pairs of adjacent patches and the index of their shared meridian corner (see corners())
RIMS = {frozenset((BASE, OUTER)): 0, frozenset((OUTER, TIP)): 1,
        frozenset((CAVITY_START, CAVITY_WALL)): 2, frozenset((CAVITY_WALL, CAVITY_END)): 3}


def segments(d: WhiskerDesign) -> np.ndarray:
    """Meridian segments of the six patches, shape (6, 2, 2): [patch, end, (x, r)]."""
    Lt = d.length
    ro0, roL = d.r_outer(0.0), d.r_outer(Lt)
    ric, ril = d.r_inner(d.c), d.r_inner(d.l)
    return np.array(
        [
            [[0.0, 0.0], [0.0, ro0]],
            [[0.0, ro0], [Lt, roL]],
            [[Lt, roL], [Lt, 0.0]],
            [[d.c, 0.0], [d.c, ric]],
            [[d.c, ric], [d.l, ril]],
            [[d.l, ril], [d.l, 0.0]],
        ]
    )


def corners(d: WhiskerDesign) -> np.ndarray:
    """Rim circles' meridian points (x, r), shape (4, 2), indexed by :data:`RIMS`."""
    s = segments(d)
    return np.array([s[BASE, 1], s[OUTER, 1], s[CAVITY_START, 1], s[CAVITY_WALL, 1]])


def meridian_normals(d: WhiskerDesign) -> np.ndarray:
    """Outward (n_x, n_r) of each patch, shape (6, 2)."""
    a = np.arctan(d.tan_alpha)
    sa, ca = np.sin(a), np.cos(a)
    return np.array([[-1.0, 0.0], [sa, ca], [1.0, 0.0], [1.0, 0.0], [-sa, -ca], [-1.0, 0.0]])


def to_meridian(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, r, theta) of Cartesian points, each shape (n,)."""
    x = points[:, 0]
    r = np.hypot(points[:, 1], points[:, 2])
    th = np.arctan2(points[:, 2], points[:, 1])
    return x, r, th


def from_meridian(x: np.ndarray, r: np.ndarray, th: np.ndarray) -> np.ndarray:
    """Cartesian points from (x, r, theta), shape (n, 3)."""
    return np.stack([x, r * np.cos(th), r * np.sin(th)], axis=1)


def _closest_on_segments(q: np.ndarray, seg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of meridian points q (n, 2) on segments seg (k, 2, 2).

    Returns closest points (n, k, 2) and distances (n, k).
    """
    a = seg[:, 0]  # (k, 2)
    ab = seg[:, 1] - seg[:, 0]  # (k, 2)
    s = np.einsum("nkj,kj->nk", q[:, None, :] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-300)  # (n, k)
    s = np.clip(s, 0.0, 1.0)
    p = a[None] + s[..., None] * ab[None]  # (n, k, 2)
    return p, np.linalg.norm(p - q[:, None, :], axis=2)


def classify_faces(d: WhiskerDesign, points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Patch id of each outward-oriented boundary triangle (see module docstring).

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    tris : ndarray, shape (n_f, 3)
        Corner nodes, ordered so that ``(b - a) x (c - a)`` points out of the solid.

    Returns
    -------
    ndarray, shape (n_f,), int64
    """
    P = points[tris]  # (n_f, 3, 3)
    cen = P.mean(axis=1)  # (n_f, 3)
    nrm = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])  # (n_f, 3)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    x, r, th = to_meridian(cen)
    mn = meridian_normals(d)  # (6, 2)
    n3 = np.stack(
        [np.broadcast_to(mn[:, 0], (len(th), 6)), mn[:, 1] * np.cos(th)[:, None], mn[:, 1] * np.sin(th)[:, None]],
        axis=2,
    )  # (n_f, 6, 3)
    agree = np.einsum("fkj,fj->fk", n3, nrm)  # (n_f, 6)
    _, dist = _closest_on_segments(np.stack([x, r], axis=1), segments(d))  # (n_f, 6)
    masked = np.where(agree > 0.3, dist, np.inf)
    cls = np.argmin(masked, axis=1)
    none = ~np.isfinite(masked.min(axis=1))
    if none.any():
        logger.debug("classify_faces: %d faces with no agreeing normal, using distance only", none.sum())
        cls[none] = np.argmin(dist[none], axis=1)
    return cls.astype(np.int64)


def project_vertices(d: WhiskerDesign, points: np.ndarray, tris: np.ndarray, face_class: np.ndarray) -> np.ndarray:
    """Move boundary vertices onto their exact patches (corners onto rim circles).

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    tris : ndarray, shape (n_f, 3)
    face_class : ndarray, shape (n_f,)

    Returns
    -------
    ndarray, shape (n, 3)
        Copy of ``points`` with the boundary vertices projected.
    """
    out = np.array(points, dtype=np.float64, copy=True)
    n = len(points)
    member = np.zeros((n, 6), dtype=bool)
    for k in range(3):
        member[tris[:, k], face_class] = True
    count = member.sum(axis=1)
    x, r, th = to_meridian(points)
    seg = segments(d)
    cor = corners(d)
    # single patch: closest point on its meridian segment
    one = np.nonzero(count == 1)[0]
    if len(one):
        k = np.argmax(member[one], axis=1)
        p, _ = _closest_on_segments(np.stack([x[one], r[one]], axis=1), seg)
        pk = p[np.arange(len(one)), k]  # (m, 2)
        out[one] = from_meridian(pk[:, 0], pk[:, 1], th[one])
    # two or more patches: rim circle if the pair is adjacent, else nearest segment among them
    multi = np.nonzero(count >= 2)[0]
    odd = 0
    if len(multi):
        mask = member[multi] @ (1 << np.arange(6))  # (m,) bit mask of patches
        rim = np.full(len(multi), -1, dtype=np.int64)
        for pair, idx in RIMS.items():
            rim[mask == sum(1 << k for k in pair)] = idx
        ok = rim >= 0
        c = cor[rim[ok]]
        out[multi[ok]] = from_meridian(c[:, 0], c[:, 1], th[multi[ok]])
        for v in multi[~ok]:
            odd += 1
            ks = np.nonzero(member[v])[0]
            p, dist = _closest_on_segments(np.array([[x[v], r[v]]]), seg)
            kk = ks[np.argmin(dist[0, ks])]
            out[v] = from_meridian(p[0, kk, :1], p[0, kk, 1:], th[v : v + 1])[0]
    if odd:
        logger.debug("project_vertices: %d vertices on non-adjacent patches", odd)
    return out


def project_radially(d: WhiskerDesign, points: np.ndarray, patch: int) -> np.ndarray:
    """Radial projection at fixed x onto the cone ``patch`` (OUTER or CAVITY_WALL), shape (n, 3)."""
    x, r, th = to_meridian(points)
    rt = d.r_outer(x) if patch == OUTER else d.r_inner(x)
    return from_meridian(x, np.asarray(rt, dtype=float) * np.ones_like(x), th)


def patch_distance(d: WhiskerDesign, points: np.ndarray, patch: int) -> np.ndarray:
    """Distance of points to one patch (meridian distance), shape (n,)."""
    x, r, _ = to_meridian(points)
    _, dist = _closest_on_segments(np.stack([x, r], axis=1), segments(d)[patch : patch + 1])
    return dist[:, 0]
