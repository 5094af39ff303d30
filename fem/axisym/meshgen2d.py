"""Structured meshes of 9-node quadrilaterals in the (R, Z) half-plane.

Every mesh here is the image of a uniform grid of the parameter square under a fixed smooth map
(transfinite interpolation of each block's four boundary curves; Gordon & Hall 1973). Level L
subdivides every parameter cell into L × L, so the meshes of a refinement sequence are nested and
their element size falls as 1/L everywhere: an observed order of convergence is meaningful.

Two layouts:

* :func:`grid_mesh`: a tensor grid on given breakpoints in R and Z, each interval split into a
  number of cells with an optional geometric grading (a rectangular inclusion is a set of cells);
* :func:`inclusion_mesh`: a rectangle with a round inclusion (an O-grid around it, optional rings
  of given radii around the inclusion, a mapped square at its centre), for a fibre's section.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from fem.axisym.quad9 import EDGES, gauss_1d, shape_gradients

Curve = Callable[[np.ndarray], np.ndarray]  # t (n,) in [0, 1] -> points (n, 2)


@dataclass(frozen=True)
class QuadMesh:
    """A mesh of 9-node quadrilaterals in the (R, Z) half-plane.

    Attributes
    ----------
    points : ndarray (n_nodes, 2)
        Reference (R, Z) coordinates.
    cells : ndarray (n_el, 9) int
        Node indices in :mod:`fem.axisym.quad9` order, counter-clockwise.
    region : ndarray (n_el,) int
        Index into ``region_names`` of each element.
    region_names : tuple of str
    """

    points: np.ndarray
    cells: np.ndarray
    region: np.ndarray
    region_names: tuple[str, ...] = field(default=("solid",))

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def n_elements(self) -> int:
        return len(self.cells)

    def elements_of(self, name: str) -> np.ndarray:
        """Indices of the elements of region ``name`` (empty when it has none)."""
        if name not in self.region_names:
            return np.zeros(0, dtype=np.int64)
        return np.nonzero(self.region == self.region_names.index(name))[0]

    def boundary_edges(self) -> np.ndarray:
        """Edges (n_b, 3) = (start, middle, end) that belong to one element, traversed with it on the left."""
        e = self.cells[:, EDGES].reshape(-1, 3)  # (4 n_el, 3)
        key = np.sort(e[:, [0, 2]], axis=1)
        _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        return e[cnt[inv.ravel()] == 1]

    def edges_where(self, predicate: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """Boundary edges whose three nodes all satisfy ``predicate(points (n, 2)) -> bool (n,)``."""
        b = self.boundary_edges()
        ok = predicate(self.points[b.ravel()]).reshape(b.shape)
        return b[np.all(ok, axis=1)]

    def nodes_where(self, predicate: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """Indices of the nodes that satisfy ``predicate(points (n, 2)) -> bool (n,)``."""
        return np.nonzero(predicate(self.points))[0]

    def min_jacobian(self) -> float:
        """Smallest det ∂(R, Z)/∂(ξ, η) over a 3 × 3 Gauss rule (> 0 for a valid mesh)."""
        s, _ = gauss_1d(3)
        xi = np.array([[a, b] for b in s for a in s])
        dN = shape_gradients(xi)  # (n_qp, 9, 2)
        J = np.einsum("qak,eai->eqik", dN, self.points[self.cells])  # (n_el, n_qp, 2, 2)
        return float(np.linalg.det(J).min())


def graded(beta: float = 0.0) -> Callable[[np.ndarray], np.ndarray]:
    """A smooth monotone map of [0, 1] onto itself, g(t) = (e^{βt} − 1)/(e^β − 1).

    β > 0 packs the points towards t = 0 (cells there are e^β times smaller than at t = 1);
    β < 0 towards t = 1; β = 0 is uniform.
    """
    if abs(beta) < 1e-12:
        return lambda t: np.asarray(t, float)
    return lambda t: np.expm1(-beta * np.asarray(t, float)) / math.expm1(-beta)


def _line(p0, p1) -> Curve:
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    return lambda t: p0 + np.asarray(t, float)[:, None] * (p1 - p0)


def _arc(centre, radius: float, a0: float, a1: float) -> Curve:
    c = np.asarray(centre, float)
    return lambda t: c + radius * np.stack([np.cos(a0 + (a1 - a0) * t), np.sin(a0 + (a1 - a0) * t)], axis=1)


@dataclass(frozen=True)
class _Block:
    """A mapped block: boundary curves bottom (u), right (v), top (u), left (v); cell counts; region."""

    bottom: Curve
    right: Curve
    top: Curve
    left: Curve
    nu: int
    nv: int
    region: str
    gu: Callable = graded(0.0)
    gv: Callable = graded(0.0)

    def lattice(self) -> np.ndarray:
        """Transfinite interpolation at the (2nu + 1) × (2nv + 1) node parameters -> (2nv+1, 2nu+1, 2)."""
        u = self.gu(np.linspace(0.0, 1.0, 2 * self.nu + 1))
        v = self.gv(np.linspace(0.0, 1.0, 2 * self.nv + 1))
        B, T = self.bottom(u), self.top(u)  # (nu2, 2)
        L, R = self.left(v), self.right(v)  # (nv2, 2)
        P00, P10, P01, P11 = B[0], B[-1], T[0], T[-1]
        U, V = u[None, :, None], v[:, None, None]
        return ((1 - V) * B[None] + V * T[None] + (1 - U) * L[:, None] + U * R[:, None]
                - (1 - U) * (1 - V) * P00 - U * (1 - V) * P10 - (1 - U) * V * P01 - U * V * P11)


def _assemble(blocks: list[_Block], region_names: tuple[str, ...]) -> QuadMesh:
    """Glue blocks: nodes that coincide (to 1e-9 of the mesh's extent) are merged."""
    pts, cells, region = [], [], []
    offset = 0
    for blk in blocks:
        lat = blk.lattice()  # (2nv+1, 2nu+1, 2)
        n_v, n_u = lat.shape[:2]
        idx = offset + np.arange(n_v * n_u).reshape(n_v, n_u)
        pts.append(lat.reshape(-1, 2))
        i, j = np.meshgrid(2 * np.arange(blk.nu), 2 * np.arange(blk.nv), indexing="xy")
        i, j = i.ravel(), j.ravel()
        c = np.stack([idx[j, i], idx[j, i + 2], idx[j + 2, i + 2], idx[j + 2, i], idx[j, i + 1], idx[j + 1, i + 2],
                      idx[j + 2, i + 1], idx[j + 1, i], idx[j + 1, i + 1]], axis=1)  # (nu nv, 9)
        cells.append(c)
        region.append(np.full(len(c), region_names.index(blk.region)))
        offset += n_v * n_u
    P = np.concatenate(pts)
    scale = float(np.ptp(P, axis=0).max())
    key = np.round(P / (1e-9 * scale)).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # keep nodes in order of first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    cells = rank[inv.ravel()][np.concatenate(cells)]
    mesh = QuadMesh(P[first[order]], cells, np.concatenate(region), region_names)
    if mesh.min_jacobian() <= 0:
        raise ValueError("meshgen2d: a block is inverted (non-positive Jacobian); check the layout's dimensions")
    return mesh


def grid_mesh(r_breaks, z_breaks, r_counts, z_counts, level: int = 1, r_betas=None, z_betas=None,
              inside: Callable[[float, float], str] | None = None,
              region_names: tuple[str, ...] = ("solid",)) -> QuadMesh:
    """A tensor-grid mesh on breakpoints, interval k split into ``counts[k] * level`` cells.

    Parameters
    ----------
    r_breaks, z_breaks : sequence of float
        Increasing breakpoints in R and Z.
    r_counts, z_counts : sequence of int
        Cells per interval at level 1.
    level : int
        Refinement level (≥ 1); every interval gets ``level`` times its cells.
    r_betas, z_betas : sequence of float, optional
        Grading of each interval (:func:`graded`; 0 uniform).
    inside : callable (R_c, Z_c) -> region name, optional
        Region of a cell from its centre (default: ``region_names[0]``).
    region_names : tuple of str
    """
    if level < 1:
        raise ValueError(f"grid_mesh: level={level} must be >= 1")

    def lines(breaks, counts, betas):
        betas = betas or [0.0] * len(counts)
        out = []
        for a, b, n, beta in zip(breaks, breaks[1:], counts, betas):
            t = graded(beta)(np.linspace(0.0, 1.0, 2 * n * level + 1))
            out.append(a + (b - a) * t[:-1])
        return np.concatenate(out + [np.array([breaks[-1]], float)])

    rl, zl = lines(list(r_breaks), list(r_counts), r_betas), lines(list(z_breaks), list(z_counts), z_betas)
    nr, nz = (len(rl) - 1) // 2, (len(zl) - 1) // 2
    RR, ZZ = np.meshgrid(rl, zl, indexing="xy")  # (2nz+1, 2nr+1)
    idx = np.arange(RR.size).reshape(RR.shape)
    i, j = np.meshgrid(2 * np.arange(nr), 2 * np.arange(nz), indexing="xy")
    i, j = i.ravel(), j.ravel()
    cells = np.stack([idx[j, i], idx[j, i + 2], idx[j + 2, i + 2], idx[j + 2, i], idx[j, i + 1], idx[j + 1, i + 2],
                      idx[j + 2, i + 1], idx[j + 1, i], idx[j + 1, i + 1]], axis=1)
    pts = np.column_stack([RR.ravel(), ZZ.ravel()])
    centres = pts[cells[:, 8]]
    if inside is None:
        region = np.zeros(len(cells), dtype=np.int64)
    else:
        region = np.array([region_names.index(inside(r, z)) for r, z in centres], dtype=np.int64)
    return QuadMesh(pts, cells, region, tuple(region_names))


def inclusion_mesh(r_lo: float, r_hi: float, height: float, centre_r: float, radius: float,
                   rings: tuple[float, ...] = (), level: int = 1, n_quarter: int = 4, n_core: int = 2,
                   n_ring: int = 1, n_gap: int = 4, n_side: int = 3, gap_beta: float = 2.5,
                   side_beta: float = 1.0, box_half_width: float | None = None,
                   region_names: tuple[str, ...] | None = None) -> QuadMesh:
    """A rectangle [r_lo, r_hi] × [0, height] with a round inclusion centred at (centre_r, height/2).

    The inclusion (radius ``radius``) sits in a box [centre_r − w, centre_r + w] × [0, height]; an
    O-grid of four blocks joins its circle (or the outermost of ``rings``) to the box, graded towards
    the circle; concentric ``rings`` (radii > radius) form layers of their own regions
    (``region_names[1 + k]``); inside the circle a mapped square of half the radius and four blocks.
    Columns of matrix fill the rectangle left and right of the box (left out when they have no width).

    Parameters
    ----------
    r_lo, r_hi, height : float
        The rectangle.
    centre_r, radius : float
        The inclusion's centre (Z = height/2) and radius.
    rings : tuple of float
        Radii of layers around the inclusion, increasing, each < the box's half-size.
    level : int
        Refinement level: every count below times ``level``.
    n_quarter : int
        Cells along each quarter of the circle (and along each box side).
    n_core, n_ring, n_gap, n_side : int
        Cells across the inclusion's core ring, across each layer, from the circle to the box, and
        across each side column.
    gap_beta, side_beta : float
        Gradings (:func:`graded`) from the circle to the box and from the box outwards.
    box_half_width : float, optional
        w; default min(height/2, centre_r − r_lo, r_hi − centre_r).
    region_names : tuple of str, optional
        Names of: the inclusion, one per ring, the matrix (default 'inclusion', 'ring0', …, 'matrix').
    """
    h = height / 2.0
    w = box_half_width or min(h, centre_r - r_lo, r_hi - centre_r)
    outer = (radius,) + tuple(rings)
    if region_names is None:
        region_names = ("inclusion",) + tuple(f"ring{k}" for k in range(len(rings))) + ("matrix",)
    if not (r_lo <= centre_r - w and centre_r + w <= r_hi and outer[-1] < 0.95 * min(w, h)):
        raise ValueError(f"inclusion_mesh: radius {outer[-1]:.4g} does not fit a box of half-size "
                         f"{min(w, h):.4g} inside [{r_lo}, {r_hi}] x [0, {height}]")
    if len(region_names) != len(outer) + 1:
        raise ValueError(f"inclusion_mesh: region_names needs {len(outer) + 1} names, got {region_names!r}")
    c = np.array([centre_r, h])
    box = [c + d for d in (np.array([-w, -h]), np.array([w, -h]), np.array([w, h]), np.array([-w, h]))]
    ang = [math.atan2(p[1] - c[1], p[0] - c[0]) for p in box]
    ang = [a if a > ang[0] - 1e-12 else a + 2 * math.pi for a in ang] + [ang[0] + 2 * math.pi]

    def on_circle(rad, k):
        return c + rad * np.array([math.cos(ang[k]), math.sin(ang[k])])

    L = level
    blocks: list[_Block] = []
    core = [c + 0.5 * radius * np.array([math.cos(a), math.sin(a)]) for a in ang[:4]]
    blocks.append(_Block(_line(core[0], core[1]), _line(core[1], core[2]), _line(core[3], core[2]),
                         _line(core[0], core[3]), n_quarter * L, n_quarter * L, region_names[0]))
    radii = (0.5 * radius,) + outer
    for k in range(4):
        k1 = (k + 1) % 4
        # layers from the inside out: v runs inwards (CCW orientation), bottom = outer curve
        for m in range(len(radii) - 1):
            r_in, r_out = radii[m], radii[m + 1]
            inner_curve = (_line(core[k], core[k1]) if m == 0 else _arc(c, r_in, ang[k], ang[k + 1]))
            n_v = (n_core if m == 0 else n_ring) * L
            blocks.append(_Block(_arc(c, r_out, ang[k], ang[k + 1]), _line(on_circle(r_out, k1), (core[k1] if m == 0 else on_circle(r_in, k1))),
                                 inner_curve, _line(on_circle(r_out, k), (core[k] if m == 0 else on_circle(r_in, k))),
                                 n_quarter * L, n_v, region_names[m]))
        # the O-grid from the box side (v = 0) to the outermost circle (v = 1), finer at the circle
        blocks.append(_Block(_line(box[k], box[k1]), _line(box[k1], on_circle(outer[-1], k1)),
                             _arc(c, outer[-1], ang[k], ang[k + 1]), _line(box[k], on_circle(outer[-1], k)),
                             n_quarter * L, n_gap * L, region_names[-1], gv=graded(-gap_beta)))
    if centre_r - w > r_lo + 1e-12 * height:
        lo = np.array([r_lo, 0.0]), np.array([r_lo, height])
        blocks.append(_Block(_line(lo[0], box[0]), _line(box[0], box[3]), _line(lo[1], box[3]),
                             _line(lo[0], lo[1]), n_side * L, n_quarter * L, region_names[-1], gu=graded(-side_beta)))
    if centre_r + w < r_hi - 1e-12 * height:
        hi = np.array([r_hi, 0.0]), np.array([r_hi, height])
        blocks.append(_Block(_line(box[1], hi[0]), _line(hi[0], hi[1]), _line(box[2], hi[1]),
                             _line(box[1], box[2]), n_side * L, n_quarter * L, region_names[-1], gu=graded(side_beta)))
    return _assemble(blocks, tuple(region_names))
