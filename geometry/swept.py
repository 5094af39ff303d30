"""Structured swept tet mesh of the whisker: a triangulated cross-section swept along x.

fTetWild meshes are isotropic and refine near the surface, so they need thousands of
elements to get a few through the 2-3 mm chamber wall. The whisker is a solid of
revolution, so a swept mesh resolves it with far fewer elements:

*Cross-section* (the (y, z) plane at fixed x, angle ``theta`` measured from +y about +x,
``y = r cos(theta)``, ``z = r sin(theta)``): ``n_theta`` equal angular sectors (a node
line at ``theta = 0``, the gauge side); ``n_wall`` radial layers of quads (each split
into two triangles) between the core radius and the outer radius; the core disc
inside is triangulated by rings that halve the node count inwards
(ring of n nodes -> ring of n/2 at radius ``rho (1 - 0.9 * 2 pi / n)``) down to at most 8
nodes, closed by a fan to the centre. A cross-section node sits at radius

    r = a r_core(x) + b r_o(x)        (core nodes: b = 0; wall ring j: a = 1 - j/n_wall, b = j/n_wall)

with ``r_core(x)`` the cavity radius ``r_i(x)`` on ``[c, l]`` and fractions of ``r_o(x)``
outside (:func:`core_radius`; the same radial map as :mod:`geometry.template`, so a
swept mesh maps onto the swept mesh of another design).

*Axial stations*: knots ``0, c, x_ss, x_ss + e, l, f_k L', L'`` (the gauge window is a
whole number of layers, at least two, when ``c < x_ss`` and ``x_ss + e < l``; the
``contact_fractions`` f_k of :class:`geometry.sizing.MeshSizing`, default 0.5 and 0.75,
give a node ring at those contact positions ``a L'`` of the scene); the cap gets
``round(c / h_cap)`` layers, each chamber interval ``round(length / dz)`` with
``dz = axial_pitch_fraction * fibre_pitch``; the body is graded, layer size
``h(s) = min(h_body, dz + grading * s, max(dz, min(1.5, 3 / n_wall) r_o))`` at distance ``s``
from the chamber end (the last bound keeps the elements of a slender tip from getting
long and thin: about 6 ring thicknesses at most).

*Elements*: every triangle of the section times every axial layer is a prism (core
triangles are left out over ``[c, l]``: the cavity); each prism is split into three
tets by the vertex-index rule of Dompierre et al. (1999), "How to subdivide pyramids,
prisms and hexahedra into tetrahedra", IMR: every quadrilateral face is cut by the
diagonal through its smallest-index vertex, which makes the split conforming across
shared faces for any vertex numbering.

Vertices lie exactly on the analytic surfaces (polygonal rings); the TET10 upgrade
(:func:`geometry.quadratic.upgrade`) puts the mid-edge nodes on the curved surfaces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fem.mesh import orient_linear, signed_volumes_linear
from geometry.design import WhiskerDesign


@dataclass(frozen=True)
class CrossSection:
    """Triangulated unit cross-section (see module docstring).

    Attributes
    ----------
    theta : ndarray, shape (n,)
        Node angles [rad].
    a, b : ndarray, shape (n,)
        Radius coefficients, ``r = a r_core + b r_o``.
    tris : ndarray, shape (n_t, 3) int64
        Triangles (counter-clockwise in the (y, z) plane).
    core : ndarray, shape (n_t,) bool
        Triangles inside the core radius (removed over the cavity).
    """

    theta: np.ndarray
    a: np.ndarray
    b: np.ndarray
    tris: np.ndarray
    core: np.ndarray


def graded_angles(theta: np.ndarray, grading: float) -> np.ndarray:
    """Node angles moved towards the gauge side: ``θ' = θ − β sin θ`` (θ from +y, β = ``grading``).

    The map is monotone and odd for 0 <= β < 1, keeps the node lines at θ = 0 (the gauge's generator) and
    θ = π, and scales the angular spacing by ``dθ'/dθ = 1 − β cos θ``: sectors (1 − β) times the uniform ones
    at the gauge and (1 + β) times on the far side, with their number unchanged.
    """
    return theta - grading * np.sin(theta)


def cross_section(n_theta: int, n_wall: int, grading: float = 0.0) -> CrossSection:
    """The unit cross-section with ``n_theta`` sectors and ``n_wall`` wall layers.

    ``grading`` (β in [0, 0.9]) narrows the sectors at the gauge side (θ = 0) by the factor 1 − β
    (:func:`graded_angles`); 0 gives equal sectors.
    """
    if not 0.0 <= grading <= 0.9:
        raise ValueError(f"cross_section: grading={grading!r} outside the allowed range [0, 0.9]")
    if n_theta < 6 or n_theta % 2:
        raise ValueError(f"cross_section: n_theta={n_theta} must be even and >= 6")
    if n_wall < 1:
        raise ValueError(f"cross_section: n_wall={n_wall} must be >= 1")
    theta, a, b = [0.0], [0.0], [0.0]  # node 0: the centre
    tris: list[tuple[int, int, int]] = []
    core: list[bool] = []

    # core rings, innermost first: sizes n_theta, n_theta/2, ... down to <= 8 (even only)
    sizes, radii = [n_theta], [1.0]
    while sizes[-1] > 8 and sizes[-1] % 2 == 0:
        n = sizes[-1]
        radii.append(radii[-1] * (1.0 - 0.9 * 2.0 * math.pi / n))
        sizes.append(n // 2)
    sizes, radii = sizes[::-1], radii[::-1]
    rings: list[np.ndarray] = []
    for n, rho in zip(sizes, radii):
        start = len(theta)
        theta.extend(2.0 * math.pi * np.arange(n) / n)
        a.extend([rho] * n)
        b.extend([0.0] * n)
        rings.append(np.arange(start, start + n))
    # fan from the centre to the innermost ring
    r0 = rings[0]
    for k in range(len(r0)):
        tris.append((0, r0[k], r0[(k + 1) % len(r0)]))
        core.append(True)
    # halving transitions: inner ring of n nodes, outer ring of 2n nodes
    for inner, outer in zip(rings[:-1], rings[1:]):
        n = len(inner)
        for k in range(n):
            i0, i1 = inner[k], inner[(k + 1) % n]
            o0, o1, o2 = outer[2 * k], outer[2 * k + 1], outer[(2 * k + 2) % (2 * n)]
            tris.extend([(i0, o0, o1), (i0, o1, i1), (i1, o1, o2)])
            core.extend([True] * 3)
    # wall layers: ring j = 0 is the core boundary (rings[-1]), ring n_wall the outer surface
    prev = rings[-1]
    n = n_theta
    for j in range(1, n_wall + 1):
        start = len(theta)
        theta.extend(2.0 * math.pi * np.arange(n) / n)
        a.extend([1.0 - j / n_wall] * n)
        b.extend([j / n_wall] * n)
        ring = np.arange(start, start + n)
        for k in range(n):
            p0, p1 = prev[k], prev[(k + 1) % n]
            q0, q1 = ring[k], ring[(k + 1) % n]
            # alternate the diagonal so that the section has no preferred direction
            if k % 2 == 0:
                tris.extend([(p0, q0, q1), (p0, q1, p1)])
            else:
                tris.extend([(p0, q0, p1), (p1, q0, q1)])
            core.extend([False, False])
        prev = ring
    return CrossSection(
        graded_angles(np.asarray(theta, float), grading), np.asarray(a, float), np.asarray(b, float),
        np.asarray(tris, np.int64), np.asarray(core, bool),
    )


#: core fraction r_core / r_o the body relaxes to, over BODY_CORE_RELAX mm from x = l
BODY_CORE_FRACTION = 0.5
BODY_CORE_RELAX = 10.0


def core_radius(d: WhiskerDesign, x: np.ndarray) -> np.ndarray:
    """``r_core(x)``: ``r_i(x)`` on [c, l], ``rho_c r_o(x)`` (cap), ``rho_b(x) r_o(x)`` (body).

    ``rho_c = r_i(c)/r_o(c)``; in the body the fraction moves linearly from
    ``rho_l = r_i(l)/r_o(l)`` to :data:`BODY_CORE_FRACTION` over :data:`BODY_CORE_RELAX`
    mm, so a thick wall (small cavity) does not leave a needle-thin core in a slender tip.
    Continuous in x.
    """
    x = np.asarray(x, dtype=float)
    ro = d.r_outer(x)
    rho_c = d.r_inner(d.c) / d.r_outer(d.c)
    rho_l = d.r_inner(d.l) / d.r_outer(d.l)
    s = np.clip((x - d.l) / BODY_CORE_RELAX, 0.0, 1.0)
    rho_b = rho_l + (BODY_CORE_FRACTION - rho_l) * s
    return np.where(x < d.c, rho_c * ro, np.where(x > d.l, rho_b * ro, ro - d.t))


#: Closest a contact ring may come to the tip face [mm]: a pusher held in the rig sits this close to the tip
#: of a whisker that the chamber has extended by less than a millimetre (the slab of elements between the
#: ring and the tip face is then this thin; it carries only the contact load).
TIP_KNOT_GAP = 0.25


def axial_knots(d: WhiskerDesign, contact_fractions: tuple[float, ...] = ()) -> list[float]:
    """``[0, c, x_ss, x_ss + e, l, f_1 L', f_2 L', ..., L']``.

    The gauge knots only when strictly inside (c, l); a contact knot ``f L'`` only when
    it lies in the body more than 1 mm from ``l`` and the previous knot, and more than
    :data:`TIP_KNOT_GAP` from the tip.
    """
    k = [0.0, d.c]
    if d.c < d.x_ss and d.x_ss + d.e < d.l:
        k += [d.x_ss, d.x_ss + d.e]
    k.append(d.l)
    for f in sorted(set(float(f) for f in contact_fractions)):
        x = f * d.length
        if d.l + 1.0 < x < d.length - TIP_KNOT_GAP and x > k[-1] + 1.0:
            k.append(x)
    return k + [d.length]


def axial_stations(
    d: WhiskerDesign,
    h_cap: float,
    dz: float,
    h_body: float,
    grading: float,
    min_gauge_layers: int = 2,
    radius_factor: float = 1.5,
    contact_fractions: tuple[float, ...] = (),
) -> np.ndarray:
    """Axial node positions (see module docstring), shape (n_z + 1,), increasing."""
    knots = axial_knots(d, contact_fractions)
    xs = [np.array([0.0])]
    xs.append(np.linspace(0.0, d.c, max(1, round(d.c / h_cap)) + 1)[1:])
    chamber = [k for k in knots if d.c <= k <= d.l]  # c, [x_ss, x_ss + e,] l
    gauge = (d.x_ss, d.x_ss + d.e)
    for x0, x1 in zip(chamber[:-1], chamber[1:]):
        n_min = min_gauge_layers if (x0, x1) == gauge else 1
        xs.append(np.linspace(x0, x1, max(n_min, round((x1 - x0) / dz)) + 1)[1:])
    # body: h(s) = min(h_body, dz + g s, max(dz, radius_factor r_o)); N(s) = int_0^s ds'/h(s') layers,
    # distributed over the body intervals between knots (each a whole number of layers)
    Lb = d.length - d.l
    hb = max(h_body, dz)
    s = np.linspace(0.0, Lb, 4001)
    h = np.minimum(np.minimum(hb, dz + grading * s), np.maximum(dz, radius_factor * d.r_outer(d.l + s)))
    N = np.concatenate([[0.0], np.cumsum(0.5 * (1.0 / h[1:] + 1.0 / h[:-1]) * np.diff(s))])
    body = [k for k in knots if k >= d.l]
    for x0, x1 in zip(body[:-1], body[1:]):
        n0, n1 = np.interp([x0 - d.l, x1 - d.l], s, N)
        n = max(1, round(n1 - n0))
        xb = d.l + np.interp(np.linspace(n0, n1, n + 1), N, s)
        xb[0], xb[-1] = x0, x1
        xs.append(xb[1:])
    return np.concatenate(xs)


def swept_mesh(
    design: WhiskerDesign,
    n_theta: int,
    n_wall: int,
    stations: np.ndarray,
    grading: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Linear swept tet mesh (vertices on the exact surfaces, polygonal in theta).

    Parameters
    ----------
    design : WhiskerDesign
    n_theta, n_wall : int
        Sectors and wall layers of the cross-section.
    stations : ndarray, shape (n_z + 1,)
        Axial node positions from 0 to ``design.length`` (must contain c and l).
    grading : float
        Sectors narrowed towards the gauge side (:func:`cross_section`).

    Returns
    -------
    points : ndarray, shape (n, 3) float64
    tets : ndarray, shape (m, 4) int64, positively oriented
    """
    d = design
    cs = cross_section(n_theta, n_wall, grading)
    xs = np.asarray(stations, float)
    n2, nz = len(cs.theta), len(xs) - 1
    # points: station-major
    X = np.repeat(xs, n2)  # (nz+1)*n2
    rc = core_radius(d, X)
    ro = d.r_outer(X)
    A, B, TH = np.tile(cs.a, nz + 1), np.tile(cs.b, nz + 1), np.tile(cs.theta, nz + 1)
    R = A * rc + B * ro
    pts = np.stack([X, R * np.cos(TH), R * np.sin(TH)], axis=1)
    # prisms
    xm = 0.5 * (xs[:-1] + xs[1:])
    cavity_layer = (xm > d.c) & (xm < d.l)  # (nz,)
    prisms = []
    for k in range(nz):
        tr = cs.tris[~cs.core] if cavity_layer[k] else cs.tris
        prisms.append(np.hstack([tr + k * n2, tr + (k + 1) * n2]))
    P = np.vstack(prisms)  # (n_prism, 6)
    tets = split_prisms(P)
    used = np.unique(tets)
    remap = -np.ones(len(pts), dtype=np.int64)
    remap[used] = np.arange(len(used))
    pts, tets = pts[used], remap[tets]
    tets = orient_linear(pts, tets)
    vol = signed_volumes_linear(pts, tets)
    if vol.min() <= 0:  # pragma: no cover - construction error
        raise RuntimeError(f"swept mesh of {d.describe()}: {np.sum(vol <= 0)} degenerate tets")
    return np.ascontiguousarray(pts), np.ascontiguousarray(tets)


#: prism relabelings putting each vertex at position 0 (bottom 0,1,2; top 3,4,5 above them)
_PRISM_PERM = np.array(
    [[0, 1, 2, 3, 4, 5], [1, 2, 0, 4, 5, 3], [2, 0, 1, 5, 3, 4],
     [3, 5, 4, 0, 2, 1], [4, 3, 5, 1, 0, 2], [5, 4, 3, 2, 1, 0]]
)


def split_prisms(P: np.ndarray) -> np.ndarray:
    """Split prisms (n, 6) into 3 tets each by the smallest-index rule (Dompierre 1999), (3n, 4)."""
    m = np.argmin(P, axis=1)
    V = np.take_along_axis(P, _PRISM_PERM[m], axis=1)  # (n, 6) with the smallest index at 0
    d15 = np.minimum(V[:, 1], V[:, 5]) < np.minimum(V[:, 2], V[:, 4])
    t_a = np.stack([V[:, [0, 1, 2, 5]], V[:, [0, 1, 5, 4]], V[:, [0, 4, 5, 3]]], axis=1)
    t_b = np.stack([V[:, [0, 1, 2, 4]], V[:, [0, 4, 2, 5]], V[:, [0, 4, 5, 3]]], axis=1)
    return np.where(d15[:, None, None], t_a, t_b).reshape(-1, 4)


def build_swept(design: WhiskerDesign, sizing) -> tuple[np.ndarray, np.ndarray]:
    """Swept linear mesh of ``design`` for a :class:`geometry.sizing.MeshSizing`.

    ``n_wall = max(1, round(wall_layers))`` radial layers (``round(t / h_wall)`` for an
    absolute ``h_wall``), ``n_theta`` sectors, axial layers from ``h_cap``,
    ``axial_pitch_fraction * fibre_pitch``, ``h_body``, ``grading`` and
    ``radius_factor = min(1.5, 3 / n_wall)``
    (module docstring), the sectors graded towards the gauge by ``theta_grading``.
    """
    hw = sizing.wall_size(design)
    n_wall = max(1, round(design.t / hw))
    st = axial_stations(
        design, sizing.cap_size(design), sizing.axial_pitch_fraction * design.fibre_pitch, sizing.h_body, sizing.grading,
        radius_factor=min(1.5, 3.0 / n_wall), contact_fractions=tuple(sizing.contact_fractions),
    )
    return swept_mesh(design, int(sizing.n_theta), n_wall, st, float(sizing.theta_grading))
