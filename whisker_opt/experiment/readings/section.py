"""``section``: the gauge's strain from the curvature of the wall's sections and the wall cell's transfer.

A global–local reading. The section curvature over the gauge is a section integral of the 3-D solution, as the
contact force is; the outer surface's strain per unit curvature of a pressurised, fibre-wound wall is the
local quantity that the whisker's mesh does not resolve, and the periodic wall cell (docs/physics.md §14)
gives converged. At each gauge end x_k (x_ss and x_ss + e) the plane x = a + b y + c z is fitted, area-weighted,
to the deformed positions of the wall's cross-section (:func:`points`, located with the gauge);
its tilt about z is φ_k = arctan b. The mean curvature over the gauge is

    κ = (φ₂ − φ₁) / s,   s = c (Δφ/2) / sin(Δφ/2),

with c the distance between the two sections' deformed centroids (s is the arc through them, exact for a
circular arc). Relative to contact onset, the reading is the log strain of a surface line whose stretch per
unit curvature is the wall's,

    ε = ξ · ln(1 + G(Q) r_o (κ(δ) − κ(0))),   G(Q) = g(Q) (1 + ε_z(Q)),

r_o the reference outer radius at the gauge centre, g and ε_z the stored cell's gauge transfer (per reference
length) and axial strain at the wall's mid-chamber station and the scene's pressure
(:meth:`whisker_opt.wall.law.WallLaw.gauge_transfer`, through the reader's context). At Q = 0, G = 1: plane
sections. ξ is applied by :class:`whisker_opt.experiment.gauge.GaugeReader`.
"""

from __future__ import annotations

import math

import numpy as np

NAME = "section"
ORDER = 2  # place in the registry (the default reading first)
DESCRIPTION = ("log strain of the wall's outer surface from the section curvature over the gauge and the wall "
               "cell's transfer G(Q), relative to contact onset, times ξ")


def points(design, n_r: int = 4, n_theta: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Sampling points of the wall's cross-sections at the gauge's two ends, shape (2 n_r n_theta, 3), and their
    area weights r w_r normalised to sum 1 per section, shape (2, n_r n_theta): Gauss–Legendre in r over
    r_i … r_o, equal angles offset by half a step."""
    s, w = np.polynomial.legendre.leggauss(n_r)
    th = 2.0 * np.pi * (np.arange(n_theta) + 0.5) / n_theta  # (n_theta,)
    pts, wts = [], []
    for x in (design.x_ss, design.x_ss + design.e):
        ri, ro = design.r_inner(x), design.r_outer(x)
        r = ri + 0.5 * (ro - ri) * (s + 1.0)  # (n_r,)
        R, T = np.meshgrid(r, th, indexing="ij")  # (n_r, n_theta)
        pts.append(np.stack([np.full(R.size, float(x)), (R * np.cos(T)).ravel(), (R * np.sin(T)).ravel()], axis=1))
        wt = np.repeat(w * r, n_theta)
        wts.append(wt / wt.sum())
    return np.vstack(pts), np.stack(wts)


def _tilt(mesh, u: np.ndarray, hosts: np.ndarray, coords: np.ndarray, w: np.ndarray) -> tuple[float, np.ndarray]:
    """Tilt about z of the plane fitted to the deformed section points, and their centroid."""
    from fem.query import positions_at

    xyz = positions_at(mesh, u, hosts, coords)  # (m, 3)
    sw = np.sqrt(w)  # (m,)
    A = np.stack([np.ones(len(xyz)), xyz[:, 1], xyz[:, 2]], axis=1) * sw[:, None]  # (m, 3)
    coef = np.linalg.lstsq(A, xyz[:, 0] * sw, rcond=None)[0]  # (3,)
    return math.atan(coef[1]), w @ xyz


def state(mesh, u: np.ndarray, gauge) -> float:
    """The mean section curvature κ over the gauge of displacement ``u`` [1/mm] (module docstring)."""
    site = gauge.sites[NAME]
    m = site.data.shape[1]
    (p1, c1), (p2, c2) = (_tilt(mesh, u, site.host_elements[k * m:(k + 1) * m], site.local_coords[k * m:(k + 1) * m],
                                site.data[k]) for k in (0, 1))
    d = p2 - p1
    chord = float(np.linalg.norm(c2 - c1))
    arc = chord if d == 0.0 else chord * (0.5 * d) / math.sin(0.5 * d)
    return d / arc


def relative(now: float, onset: float, gauge, context=None) -> float:
    """``ln(1 + G r_o (κ − κ₀))``: the uncalibrated reading (G = 1 without a context)."""
    transfer = 1.0 if context is None else context.wall_transfer
    return math.log1p(transfer * gauge.radius * (now - onset))
