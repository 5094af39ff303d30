"""Structured swept mesher (geometry.swept): conformity, exact surfaces, counts, template equivalence."""

import math

import numpy as np
import pytest

from fem.mesh import boundary_faces, jacobian_determinants, p1_to_p2, signed_volumes_linear
from fem.quadrature import tet_rule
from geometry import analytic
from geometry import boundary as bd
from geometry.design import WhiskerDesign
from geometry.mesh import MeshSizing, build_mesh
from geometry.swept import (
    axial_knots,
    axial_stations,
    build_swept,
    core_radius,
    cross_section,
    split_prisms,
    swept_mesh,
)
from geometry.template import map_points


@pytest.mark.parametrize(("n_theta", "n_wall"), [(8, 1), (10, 1), (12, 2), (16, 3), (20, 2)])
def test_cross_section_tiles_the_unit_disc(n_theta, n_wall):
    cs = cross_section(n_theta, n_wall)
    # with r_core = 1, r_o = 2: polygonal area = sum of triangle areas, all counter-clockwise
    r = cs.a * 1.0 + cs.b * 2.0
    P = np.stack([r * np.cos(cs.theta), r * np.sin(cs.theta)], axis=1)
    a, b, c = (P[cs.tris[:, k]] for k in range(3))
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert (area2 > 0).all()
    poly = 0.5 * n_theta * math.sin(2 * math.pi / n_theta) * 2.0**2  # inscribed regular polygon of radius 2
    assert 0.5 * area2.sum() == pytest.approx(poly, rel=1e-12)
    # the core triangles tile the inner polygon of radius 1
    core_poly = 0.5 * n_theta * math.sin(2 * math.pi / n_theta)
    assert 0.5 * area2[cs.core].sum() == pytest.approx(core_poly, rel=1e-12)
    assert (~cs.core).sum() == 2 * n_theta * n_wall


def test_prism_split_is_conforming_for_any_numbering():
    """Two prisms sharing a quad face, random vertex numbers: the shared quad is cut by the same diagonal."""
    rng = np.random.default_rng(0)
    # 2 triangles (0,1,2), (1,3,2) in the plane, extruded: vertex v at z=0, v+4 at z=1
    base = np.array([[0, 1, 2], [1, 3, 2]])
    for _ in range(200):
        perm = rng.permutation(8)
        P = np.hstack([base, base + 4])
        tets = split_prisms(perm[P])
        # faces of all tets: interior faces appear exactly twice, boundary faces once, none more
        f = np.sort(np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]]), axis=1)
        _, counts = np.unique(f, axis=0, return_counts=True)
        assert counts.max() == 2
        assert (counts == 2).sum() == 2 * 3 - 2 + 2  # 2 inside each prism + 2 on the shared quad
        # volume: each prism has volume 1/2 * base area
        X = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
        pts = np.vstack([X, X + [0, 0, 1]])[np.argsort(perm)]
        assert np.abs(signed_volumes_linear(pts, tets)).sum() == pytest.approx(1.0)


@pytest.fixture(scope="module")
def default_swept():
    d = WhiskerDesign()
    return d, build_swept(d, MeshSizing())


def test_swept_mesh_is_a_valid_conforming_mesh(default_swept):
    d, (pts, tets) = default_swept
    assert (signed_volumes_linear(pts, tets) > 0).all()
    _, cells, _ = p1_to_p2(pts, tets)
    faces = np.sort(np.concatenate([cells[:, list(k)] for k in ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3))]), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    assert counts.max() == 2  # no face shared by 3 tets
    # every boundary face lies on one of the six exact patches
    _, _, f6 = boundary_faces(cells)
    cls = bd.classify_faces(d, pts, f6[:, :3])
    for k in range(6):
        v = np.unique(f6[cls == k][:, :3])
        assert bd.patch_distance(d, pts[v], k).max() < 1e-9, bd.PATCH_NAMES[k]
    assert set(np.unique(cls)) == set(range(6))
    # straight-sided volume: polygonal cross-sections slightly smaller than the exact solid
    vol = signed_volumes_linear(pts, tets).sum()
    assert 0.9 * analytic.solid_volume(d) < vol < analytic.solid_volume(d)


def test_axial_stations_hit_the_knots():
    d = WhiskerDesign(l=11.3, trim=7.0)
    st = axial_stations(d, h_cap=2.0, dz=1.5, h_body=8.0, grading=0.5, contact_fractions=(0.75, 0.5))
    assert st[0] == 0.0 and st[-1] == d.length and (np.diff(st) > 0).all()
    knots = axial_knots(d, (0.5, 0.75))
    assert len(knots) == 8 and knots[5:7] == [0.5 * d.length, 0.75 * d.length]
    for k in knots:
        assert np.min(np.abs(st - k)) < 1e-12
    g = st[(st >= d.x_ss - 1e-12) & (st <= d.x_ss + d.e + 1e-12)]
    assert len(g) >= 3  # the gauge window holds >= 2 whole layers
    body = np.diff(st[st >= d.l])
    # graded from ~dz up to ~h_body (the layer counts are rounded per knot interval)
    assert body.max() <= 8.0 * 1.25 and body[0] < 2 * 1.5


def test_swept_tet10_exact_volume_and_curved_jacobians():
    d = WhiskerDesign(alpha=5.5, t=2.1, l=14.0)
    wm = build_mesh(d, MeshSizing(), method="swept")
    r = wm.report
    assert r.method == "swept"
    assert abs(r.volume_error) < 1e-3 and abs(r.cavity_area_error) < 1e-3
    assert r.jacobian_ratio_min > 0.4  # thin wall: cylindrical mid-edge nodes keep the elements unpinched
    assert (jacobian_determinants(wm.mesh.points, wm.mesh.cells, tet_rule(3).points) > 0).all()
    x, rr, _ = bd.to_meridian(wm.mesh.points)
    o = wm.node_sets["outer"]
    assert np.abs(rr[o] - d.r_outer(x[o])).max() < 1e-9
    cw = wm.node_sets["cavity_wall"]
    assert np.abs(rr[cw] - d.r_inner(x[cw])).max() < 1e-9


def test_template_map_of_a_swept_mesh_is_the_swept_mesh_of_the_target():
    """The template map moves the structure of one design onto another: ring nodes stay on their rings."""
    src = WhiskerDesign(alpha=3.3, t=3.6, l=12.5)
    dst = WhiskerDesign(alpha=5.1, t=2.3, l=14.2, trim=6.0)
    sizing = MeshSizing()
    pts, tets = build_swept(src, sizing)
    m = map_points(src, dst, pts, sizing.contact_fractions)
    assert (signed_volumes_linear(m, tets) > 0).all()
    xs, rs, ts = bd.to_meridian(pts)
    xm, rm, tm = bd.to_meridian(m)
    # wall fraction and angle are invariants of the map
    fs = (rs - core_radius(src, xs)) / (src.r_outer(xs) - core_radius(src, xs))
    fm = (rm - core_radius(dst, xm)) / (dst.r_outer(xm) - core_radius(dst, xm))
    wall = fs >= -1e-9
    assert np.abs(fs[wall] - fm[wall]).max() < 1e-9
    on = rs > 1e-9
    assert np.abs(np.angle(np.exp(1j * (ts[on] - tm[on])))).max() < 1e-12
    # the gauge window and the region knots map onto the target's
    for ks, kd in zip(axial_knots(src, sizing.contact_fractions), axial_knots(dst, sizing.contact_fractions)):
        assert np.all(np.abs(xm[np.abs(xs - ks) < 1e-12] - kd) < 1e-9)


def test_swept_counts_scale_with_the_section():
    d = WhiskerDesign()
    st = axial_stations(d, 2.0, 2.0, 8.0, 0.5)
    n12 = len(swept_mesh(d, 12, 2, st)[1])
    n16 = len(swept_mesh(d, 16, 2, st)[1])
    cs12, cs16 = cross_section(12, 2), cross_section(16, 2)
    n_cav = int(np.sum((0.5 * (st[1:] + st[:-1]) > d.c) & (0.5 * (st[1:] + st[:-1]) < d.l)))
    nz = len(st) - 1
    for n, cs in ((n12, cs12), (n16, cs16)):
        assert n == 3 * (len(cs.tris) * nz - cs.core.sum() * n_cav)


@pytest.mark.parametrize("beta", [0.3, 0.7])
def test_graded_section_narrows_the_sectors_at_the_gauge_and_tiles_the_disc(beta):
    """Grading moves the nodes towards θ = 0 by θ' = θ − β sin θ: the sector at the gauge is (1 − β)·2π/n
    to first order, the far one (1 + β)·2π/n, the node lines at θ = 0 and π stay, and the triangles still tile
    the polygon through the moved outer nodes."""
    n = 16
    cs, cs0 = cross_section(n, 2, grading=beta), cross_section(n, 2)
    assert np.array_equal(cs.tris, cs0.tris) and np.array_equal(cs.a, cs0.a)
    outer = np.flatnonzero(cs.b == 1.0)
    th = np.sort(np.mod(cs.theta[outer], 2 * math.pi))
    assert th[0] == 0.0 and th[n // 2] == pytest.approx(math.pi, abs=1e-15)
    h = 2 * math.pi / n
    assert th[1] == pytest.approx(h - beta * math.sin(h), rel=1e-14)  # exact map of the first node
    assert th[1] / h == pytest.approx(1 - beta, abs=0.02)
    far = th[n // 2 + 1] - th[n // 2]
    assert far / h == pytest.approx(1 + beta, abs=0.02)
    r = cs.a * 1.0 + cs.b * 2.0
    P = np.stack([r * np.cos(cs.theta), r * np.sin(cs.theta)], axis=1)
    a, b, c = (P[cs.tris[:, k]] for k in range(3))
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert (area2 > 0).all()
    ring = np.sort(np.mod(cs.theta[outer], 2 * math.pi))
    poly = 0.5 * 4.0 * np.sum(np.sin(np.diff(np.append(ring, 2 * math.pi))))  # polygon through the outer nodes
    assert 0.5 * area2.sum() == pytest.approx(poly, rel=1e-12)


def test_graded_swept_mesh_is_valid_and_equal_sectors_keep_their_keys():
    d = WhiskerDesign()
    graded = MeshSizing(n_theta=8, theta_grading=0.5, name="graded")
    pts, tets = build_swept(d, graded)
    pts0, tets0 = build_swept(d, MeshSizing(n_theta=8))
    assert pts.shape == pts0.shape and np.array_equal(tets, tets0)
    assert (signed_volumes_linear(pts, tets) > 0).all()
    # the gauge generator (θ = 0: +y, z = 0) keeps its node line on the outer surface
    on_gen = (np.abs(pts[:, 2]) < 1e-12) & (pts[:, 1] > 0)
    assert np.allclose(pts[on_gen & (pts[:, 1] > 0.99 * d.r_outer(pts[:, 0]))][:, 1],
                       d.r_outer(pts[on_gen & (pts[:, 1] > 0.99 * d.r_outer(pts[:, 0]))][:, 0]))
    # the quadratic arcs' volume error per sector grows as its width^5: Σ w_k^5 / (n h^5) times the equal sectors'
    r, r0 = (build_mesh(d, sz, method="swept").report for sz in (graded, MeshSizing(n_theta=8)))
    th = 2 * math.pi * np.arange(9) / 8
    w = np.diff(th - 0.5 * np.sin(th))
    assert r.volume_error / r0.volume_error == pytest.approx(np.sum(w**5) / (8 * (2 * math.pi / 8) ** 5), rel=0.05)
    assert r.jacobian_ratio_min > 0.4
    assert MeshSizing(n_theta=8).key() == MeshSizing(n_theta=8, theta_grading=0.0).key()
    assert "theta_grading" not in MeshSizing().as_dict() and graded.key() != MeshSizing(n_theta=8, name="graded").key()
    with pytest.raises(ValueError, match="theta_grading"):
        MeshSizing(theta_grading=0.95)
