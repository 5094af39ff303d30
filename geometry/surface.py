"""Closed triangulated boundary of the whisker, built analytically (input to fTetWild).

Each of the two shells (outer: base disc + outer cone + tip disc; inner: the cavity with
its two flat ends) is a meridian polyline from the axis back to the axis, revolved in
``n_theta`` equal angular steps; consecutive rings are joined by two triangles per
step, rings on the axis collapse to one vertex (triangle fans). Vertices lie exactly
on the analytic surfaces; the chordal deviation of the polygonal rings is
``R (1 - cos(pi / n_theta))`` (0.005 mm for R = 9, n_theta = 96).
Triangles are oriented with normals out of the solid (into the cavity on the inner
shell).
"""

from __future__ import annotations

import math

import numpy as np

from geometry.design import WhiskerDesign


def _polyline(corners: list[tuple[float, float]], h: float) -> np.ndarray:
    """Meridian polyline through ``corners`` with segments no longer than ``h``, shape (m, 2)."""
    out = []
    for a, b in zip(corners[:-1], corners[1:]):
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = max(1, int(math.ceil(np.linalg.norm(b - a) / h)))
        s = np.linspace(0.0, 1.0, n + 1)[:-1, None]
        out.append(a + s * (b - a))
    out.append(np.asarray(corners[-1], float)[None])
    return np.vstack(out)


def revolve_polyline(profile: np.ndarray, n_theta: int) -> tuple[np.ndarray, np.ndarray]:
    """Revolve a meridian polyline (x, r) about x; first and last points must have r = 0.

    Returns
    -------
    points : ndarray, shape (n, 3)
    tris : ndarray, shape (n_t, 3)
        Oriented with ``(b - a) x (c - a)`` pointing to the left of the walking
        direction along the profile (for a profile walked base -> tip along the outer
        surface: outward).
    """
    th = np.linspace(0.0, 2.0 * math.pi, n_theta, endpoint=False)
    pts: list[np.ndarray] = []
    rings: list[np.ndarray] = []
    n = 0
    for x, r in profile:
        if r == 0.0:
            pts.append(np.array([[x, 0.0, 0.0]]))
            rings.append(np.array([n]))
            n += 1
        else:
            pts.append(np.stack([np.full(n_theta, x), r * np.cos(th), r * np.sin(th)], axis=1))
            rings.append(np.arange(n, n + n_theta))
            n += n_theta
    k = np.arange(n_theta)
    k1 = (k + 1) % n_theta
    tris = []
    for A, B in zip(rings[:-1], rings[1:]):
        if len(A) == 1 and len(B) == 1:
            continue
        if len(A) == 1:
            tris.append(np.stack([np.full(n_theta, A[0]), B[k1], B[k]], axis=1))
        elif len(B) == 1:
            tris.append(np.stack([A[k], A[k1], np.full(n_theta, B[0])], axis=1))
        else:
            tris.append(np.stack([A[k], A[k1], B[k1]], axis=1))
            tris.append(np.stack([A[k], B[k1], B[k]], axis=1))
    return np.vstack(pts), np.vstack(tris).astype(np.int64)


def closed_surface(design: WhiskerDesign, h: float = 0.5, n_theta: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """Watertight triangulated boundary of the solid (two shells), outward oriented.

    Parameters
    ----------
    design : WhiskerDesign
    h : float
        Maximum meridian segment length [mm].
    n_theta : int
        Angular divisions.

    Returns
    -------
    points : ndarray, shape (n, 3) float64
    tris : ndarray, shape (n_t, 3) int64
    """
    d = design
    Lt = d.length
    outer = _polyline([(0.0, 0.0), (0.0, d.r_outer(0.0)), (Lt, d.r_outer(Lt)), (Lt, 0.0)], h)
    inner = _polyline([(d.c, 0.0), (d.c, d.r_inner(d.c)), (d.l, d.r_inner(d.l)), (d.l, 0.0)], h)
    p1, t1 = revolve_polyline(outer, n_theta)
    p2, t2 = revolve_polyline(inner, n_theta)
    tris = np.vstack([_orient_out(p1, t1, +1), _orient_out(p2, t2, -1) + len(p1)])
    return np.vstack([p1, p2]), tris


def _orient_out(points: np.ndarray, tris: np.ndarray, sign: int) -> np.ndarray:
    """Flip a closed shell so its enclosed signed volume has the given sign.

    Signed volume of a closed oriented triangulation: ``sum a . (b x c) / 6``
    (divergence theorem); positive when the normals point outward.
    """
    a, b, c = points[tris[:, 0]], points[tris[:, 1]], points[tris[:, 2]]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    return tris if np.sign(vol) == sign else tris[:, ::-1].copy()
