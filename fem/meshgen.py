"""Structured tetrahedral meshes of simple solids (boxes, extruded quads, tubes) for tests and benchmarks."""

from __future__ import annotations

import numpy as np

from fem.mesh import TetMesh, orient_linear, p1_to_p2

# Kuhn split of the unit cube into 6 tets sharing the main diagonal 0-6 (conforming across cubes)
_CUBE_TETS = np.array([[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]])
_CUBE_CORNERS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])


def hex_grid_tets(nx: int, ny: int, nz: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertices in [0,1]³ (grid index space scaled to unit) and Kuhn tets of an nx×ny×nz grid.

    Returns
    -------
    points : ndarray ((nx+1)(ny+1)(nz+1), 3) in [0, 1]³
    tets : ndarray (6·nx·ny·nz, 4)
    """
    for name, v in (("nx", nx), ("ny", ny), ("nz", nz)):
        if not (isinstance(v, (int, np.integer)) and v >= 1):
            raise ValueError(f"hex_grid_tets: {name}={v!r} must be an integer >= 1")
    ii, jj, kk = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
    pts = np.stack([ii.ravel() / nx, jj.ravel() / ny, kk.ravel() / nz], axis=1)

    def vid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    ci, cj, ck = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    ci, cj, ck = ci.ravel(), cj.ravel(), ck.ravel()
    corners = np.stack([vid(ci + o[0], cj + o[1], ck + o[2]) for o in _CUBE_CORNERS], axis=1)  # (n_hex, 8)
    tets = corners[:, _CUBE_TETS].reshape(-1, 4)
    return pts, tets


def box_mesh(lx: float, ly: float, lz: float, nx: int, ny: int, nz: int, distort: float = 0.0, seed: int = 0) -> TetMesh:
    """TET10 mesh of the box [0,lx]×[0,ly]×[0,lz]; optional random interior-node distortion.

    Parameters
    ----------
    distort : float
        Interior vertices are moved by up to ``distort`` × cell size (uniform random),
        boundary vertices stay on their faces (tangential moves only are not applied).
    """
    pts, tets = hex_grid_tets(nx, ny, nz)
    if distort > 0:
        rng = np.random.default_rng(seed)
        interior = np.all((pts > 1e-12) & (pts < 1 - 1e-12), axis=1)
        h = np.array([1.0 / nx, 1.0 / ny, 1.0 / nz])
        pts = pts.copy()
        pts[interior] += distort * h * rng.uniform(-1, 1, size=(int(interior.sum()), 3))
    pts = pts * np.array([lx, ly, lz])
    tets = orient_linear(pts, tets)
    p10, c10, _ = p1_to_p2(pts, tets)
    return TetMesh(p10, c10)


def map_mesh(mesh: TetMesh, fn) -> TetMesh:
    """Apply a smooth map ``fn(points) -> points`` to all nodes (mid-edge nodes follow curves)."""
    return TetMesh(fn(mesh.points), mesh.cells)


def tube_sector_mesh(r_in: float, r_out: float, height: float, n_r: int, n_theta: int, n_z: int,
                     theta: float = np.pi / 2) -> TetMesh:
    """A sector 0 ≤ φ ≤ theta of a thick tube, r_in ≤ r ≤ r_out, 0 ≤ z ≤ height (curved P2 edges)."""
    base = box_mesh(1.0, 1.0, 1.0, n_r, n_theta, n_z)

    def fn(p):
        r = r_in + (r_out - r_in) * p[:, 0]
        phi = theta * p[:, 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi), height * p[:, 2]], axis=1)

    return map_mesh(base, fn)
