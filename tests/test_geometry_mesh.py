"""Template (fast-path) meshes: TET10 order, exact boundary, tags, fibres, storage, cache.

Everything here maps shipped template meshes (no fTetWild), so it is fast; the fresh
fTetWild path is exercised in test_geometry_fresh.py.
"""

import numpy as np
import pytest

from fem import element
from fem.mesh import boundary_faces, jacobian_determinants, signed_volumes_linear
from fem.quadrature import tet_rule, tri_rule
from geometry import analytic
from geometry import boundary as bd
from geometry.design import InvalidDesignError, WhiskerDesign
from geometry.mesh import FIBRE_DS_MAX, MeshSizing, TemplateError, WhiskerMesh, build_mesh
from whisker_opt.experiment.fidelity import PRESETS
from geometry.quality import radius_ratio
from geometry.swept import core_radius
from geometry.template import TEMPLATE_DIR, available_sizings, load_templates, map_points, select_template


@pytest.fixture(scope="module")
def wm():
    return build_mesh(WhiskerDesign(), MeshSizing(), method="template")


def test_templates_are_shipped_and_small():
    files = list(TEMPLATE_DIR.glob("*.npz"))
    assert len(files) >= 6
    assert sum(f.stat().st_size for f in files) < 2e6
    templated = {name for name, p in PRESETS.items() if p.template}
    assert set(available_sizings()) == templated and "reference" not in templated
    for name in templated:  # every preset but the reference is served by a template
        assert select_template(WhiskerDesign(), PRESETS[name].sizing) is not None
    assert select_template(WhiskerDesign(), PRESETS["reference"].sizing) is None


def test_reference_preset_is_swept_for_each_design():
    """The ``reference`` preset has no template: ``auto`` sweeps its mesh (5 wall layers, 20 sectors)."""
    r = build_mesh(WhiskerDesign(), PRESETS["reference"].sizing, method="auto").report
    assert r.method == "swept"
    assert r.wall_layers == pytest.approx(5.0, rel=0.05)


@pytest.mark.parametrize(("preset", "lo", "hi"), [("coarse", 700, 1100), ("default", 900, 1500), ("fine", 5000, 9000)])
def test_preset_sizes_of_the_default_design(preset, lo, hi):
    """Element budgets of the presets (speed target), wall layers and accuracy."""
    r = build_mesh(WhiskerDesign(), PRESETS[preset].sizing, method="template").report
    assert lo <= r.n_elements <= hi
    assert r.wall_layers == pytest.approx(PRESET_LAYERS[preset], rel=0.05)
    assert abs(r.volume_error) < 1e-3 and abs(r.cavity_area_error) < 1e-3


def test_node_order_and_positive_jacobians(wm):
    m = wm.mesh
    assert m.points.dtype == np.float64 and m.cells.shape[1] == 10
    assert (signed_volumes_linear(m.points, m.cells) > 0).all()
    for deg in (2, 3):
        assert (jacobian_determinants(m.points, m.cells, tet_rule(deg).points) > 0).all()
    # mid-edge nodes in VTK order (0,1),(1,2),(0,2),(0,3),(1,3),(2,3): for the swept/template mesh each
    # lies at the cylindrical midpoint of its edge (x averaged, theta halved, r averaged along a ring or
    # quadratic mean across rings) when both ends are in the wall region r >= r_core(x), else at the
    # straight midpoint (geometry.quadratic, cylindrical=True)
    X = m.points[m.cells]
    A, B = X[:, element.EDGES[:, 0]].reshape(-1, 3), X[:, element.EDGES[:, 1]].reshape(-1, 3)
    straight = 0.5 * (A + B)
    xa, ra, ta = bd.to_meridian(A)
    xb, rb, tb = bd.to_meridian(B)
    d = wm.design
    rca, rcb = core_radius(d, xa), core_radius(d, xb)
    wall = (ra >= rca * (1 - 1e-7)) & (rb >= rcb * (1 - 1e-7))
    fa, fb = (ra - rca) / (d.r_outer(xa) - rca), (rb - rcb) / (d.r_outer(xb) - rcb)
    rm = np.where(np.abs(fa - fb) > 1e-6, np.sqrt(0.5 * (ra**2 + rb**2)), 0.5 * (ra + rb))
    cyl = bd.from_meridian(0.5 * (xa + xb), rm, ta + 0.5 * np.angle(np.exp(1j * (tb - ta))))
    expect = np.where(wall[:, None], cyl, straight)
    h = np.linalg.norm(B - A, axis=1)
    assert np.abs(X[:, 4:].reshape(-1, 3) - expect).max() < 1e-9 * d.D
    assert 0.2 < wall.mean() < 0.95  # both kinds occur
    dev = np.linalg.norm(X[:, 4:].reshape(-1, 3) - straight, axis=1)
    # edges are only mildly curved: sagitta / chord 0.10 for a pure 45° arc; edges that also cross the
    # single wall layer of the default preset reach 0.186 (measured); positivity is asserted above
    assert (dev / h).max() < 0.2


def _surface_gaps(wm) -> dict[str, np.ndarray]:
    """Distance of every node from each boundary patch's exact surface, by node-set name."""
    d, P = wm.design, wm.mesh.points
    x, r, _ = bd.to_meridian(P)
    return {
        "outer": np.abs(r - d.r_outer(x)), "cavity_wall": np.abs(r - d.r_inner(x)), "base": np.abs(x),
        "tip": np.abs(x - d.length), "cavity_start": np.abs(x - d.c), "cavity_end": np.abs(x - d.l),
    }


def _off_surface_vertices(wm) -> set[int]:
    """Boundary vertices (corner nodes) that lie off their patch's exact surface."""
    off: set[int] = set()
    for name, gap in _surface_gaps(wm).items():
        nodes = wm.node_sets[name]
        bad = nodes[gap[nodes] > 1e-9]
        off.update(bad[bad < wm.report.n_vertices].tolist())
    return off


def test_boundary_nodes_on_exact_surfaces(wm):
    """Boundary nodes lie on their exact surfaces, except the vertices the TET10 upgrade reports
    it kept off (to avoid an inverted sliver): at most that many, each within the reported
    distance, and few (<= 0.2 % of the boundary vertices, <= 5 % of the wall thickness off)."""
    d, r_ = wm.design, wm.report
    worst, n_boundary = 0.0, set()
    for name, gap in _surface_gaps(wm).items():
        nodes = wm.node_sets[name]
        n_boundary.update(nodes[nodes < r_.n_vertices].tolist())
        bad = nodes[gap[nodes] > 1e-9]  # a mid-edge node is off when a vertex of its edge is
        worst = max(worst, float(gap[bad].max()) if len(bad) else 0.0)
    assert len(_off_surface_vertices(wm)) <= r_.boundary_off_surface
    assert worst <= r_.boundary_offset_max + 1e-9
    assert r_.boundary_off_surface <= max(1, 0.002 * len(n_boundary))
    assert r_.boundary_offset_max <= 0.05 * d.t


def test_face_sets_cover_the_boundary_and_are_outward(wm):
    d, P, fs = wm.design, wm.mesh.points, wm.face_sets
    _, _, allf = boundary_faces(wm.mesh.cells)
    n = sum(len(fs[k]) for k in ("base", "outer", "tip", "cavity"))
    assert n == len(allf)
    assert len(fs["cavity"]) == len(fs["cavity_wall"]) + len(fs["cavity_start"]) + len(fs["cavity_end"])

    off = np.array(sorted(_off_surface_vertices(wm)), dtype=np.int64)  # reported, checked above

    def normals(f):
        f = f[~np.isin(f[:, :3], off).any(axis=1)]  # a face with a vertex kept off its plane tilts
        a, b, c = P[f[:, 0]], P[f[:, 1]], P[f[:, 2]]
        nn = np.cross(b - a, c - a)
        return nn / np.linalg.norm(nn, axis=1, keepdims=True), (a + b + c) / 3

    n, _ = normals(fs["base"])
    assert (n[:, 0] < -0.999).all()
    n, _ = normals(fs["tip"])
    assert (n[:, 0] > 0.999).all()
    n, cen = normals(fs["outer"])
    assert (np.einsum("ij,ij->i", n[:, 1:], cen[:, 1:]) > 0).all()  # away from the axis
    n, cen = normals(fs["cavity_wall"])
    assert (np.einsum("ij,ij->i", n[:, 1:], cen[:, 1:]) < 0).all()  # into the cavity
    assert (normals(fs["cavity_start"])[0][:, 0] > 0.999).all()
    assert (normals(fs["cavity_end"])[0][:, 0] < -0.999).all()
    # closed cavity: enclosed volume -(1/3) int X . n dA over the curved tri6 faces = cavity volume
    rule = tri_rule(4)
    N, dN = element.tri6_shape_functions(rule.points), element.tri6_shape_gradients(rule.points)
    Xf = P[fs["cavity"]]  # (n_f, 6, 3)
    Xq = np.einsum("qa,fai->fqi", N, Xf)  # (n_f, n_qp, 3)
    T = np.einsum("fai,qaj->fqij", Xf, dN)  # (n_f, n_qp, 3, 2)
    nA = np.cross(T[..., 0], T[..., 1])  # (n_f, n_qp, 3) area-scaled outward normal
    vol = -(np.einsum("fqi,fqi->fq", Xq, nA) @ rule.weights).sum() / 3
    assert vol == pytest.approx(analytic.cavity_volume(d), rel=1e-3)


def test_gauge_footprint(wm):
    d, P = wm.design, wm.mesh.points
    g = wm.face_sets["gauge"]
    assert len(g) >= 4
    cen = P[g].mean(axis=1)
    assert (cen[:, 0] >= d.x_ss).all() and (cen[:, 0] <= d.x_ss + d.e).all()
    assert (cen[:, 1] > 0).all()
    assert np.degrees(np.abs(np.arctan2(cen[:, 2], cen[:, 1]))).max() <= d.gauge_half_angle_deg
    assert set(wm.node_sets["gauge"]) <= set(wm.node_sets["outer"])


def test_fibres_located(wm):
    d = wm.design
    assert len(wm.fibres) == 2
    for f in wm.fibres:
        X = wm.mesh.points[wm.mesh.cells[f.host_elements]]  # (n, 10, 3)
        N = element.shape_functions(f.local_coords)
        assert np.abs(np.einsum("na,nai->ni", N, X) - f.points_ref).max() < 1e-8
        lam = element.barycentric(f.local_coords)
        assert lam.min() >= 0.0
        assert f.segments.shape == (len(f.points_ref) - 1, 2)
        seg = np.linalg.norm(np.diff(f.points_ref, axis=0), axis=1)
        assert seg.max() <= min(0.5 * MeshSizing().wall_size(d), FIBRE_DS_MAX) + 1e-9
        assert f.length == pytest.approx(analytic.fibre_length(d), rel=1e-3)
        x, r, _ = bd.to_meridian(f.points_ref)
        assert np.allclose(r, d.r_fibre(x))


def test_report(wm):
    r = wm.report
    d = wm.design
    assert r.n_nodes == wm.mesh.n_nodes and r.n_elements == wm.mesh.n_elements
    assert abs(r.volume_error) < 5e-3 and abs(r.cavity_area_error) < 1e-2
    assert r.quality_min > 0.05 and r.jacobian_ratio_min > 0.25
    # default preset: one P2 layer through the wall (two tets on a radial line), chosen by
    # measurement (geometry.sizing.MeshSizing.preset); the 'fine' preset has three layers
    assert r.elements_through_wall >= 2 * MeshSizing().wall_layers
    assert r.wall_layers == pytest.approx(MeshSizing().wall_layers, rel=0.05)
    assert r.method.startswith("template:")
    assert r.volume_analytic == pytest.approx(analytic.solid_volume(d))
    assert set(r.as_dict()) >= {"n_nodes", "volume_error", "elements_through_wall", "quality_min"}


def test_save_load_roundtrip(wm, tmp_path):
    p = wm.save(tmp_path / "m.npz")
    back = WhiskerMesh.load(p)
    assert np.array_equal(back.mesh.points, wm.mesh.points)
    assert np.array_equal(back.mesh.cells, wm.mesh.cells)
    assert back.design == wm.design and back.report == wm.report and back.sizing == wm.sizing
    for k in wm.face_sets:
        assert np.array_equal(back.face_sets[k], wm.face_sets[k])
        assert np.array_equal(back.node_sets[k], wm.node_sets[k])
    for a, b in zip(back.fibres, wm.fibres):
        assert np.array_equal(a.local_coords, b.local_coords) and np.array_equal(a.host_elements, b.host_elements)


def test_template_path_is_deterministic():
    d = WhiskerDesign(alpha=4.1, l=11.0, t=2.7)
    a = build_mesh(d, method="template")
    b = build_mesh(d, method="template")
    assert np.array_equal(a.mesh.points, b.mesh.points) and np.array_equal(a.mesh.cells, b.mesh.cells)


def test_cache(tmp_path):
    d = WhiskerDesign(alpha=3.0, t=4.0, l=12.0, trim=5.0)
    a = build_mesh(d, method="template", cache_dir=tmp_path)
    files = list(tmp_path.glob("*.npz"))
    assert len(files) == 1
    b = build_mesh(d, method="template", cache_dir=tmp_path)
    assert np.array_equal(a.mesh.points, b.mesh.points) and b.report == a.report


def test_map_takes_surfaces_onto_surfaces():
    tpl = load_templates()[0]
    src = tpl.design
    dst = WhiskerDesign(alpha=5.7, l=10.5, t=2.2, trim=8.0)
    rng = np.random.default_rng(0)
    th = rng.uniform(0, 2 * np.pi, 200)

    def pts(x, r):
        return np.stack([x, r * np.cos(th), r * np.sin(th)], axis=1)

    x = rng.uniform(src.c, src.l, 200)
    m = map_points(src, dst, pts(x, src.r_inner(x)))
    xm, rm, _ = bd.to_meridian(m)
    assert np.allclose(rm, dst.r_inner(xm)) and (xm >= dst.c - 1e-12).all() and (xm <= dst.l + 1e-12).all()
    x = rng.uniform(0, src.length, 200)
    m = map_points(src, dst, pts(x, src.r_outer(x)))
    xm, rm, _ = bd.to_meridian(m)
    assert np.allclose(rm, dst.r_outer(xm)) and xm.max() <= dst.length + 1e-12
    r = rng.uniform(0, src.r_inner(src.c), 200)
    m = map_points(src, dst, pts(np.full(200, src.c), r))
    xm, rm, _ = bd.to_meridian(m)
    assert np.allclose(xm, dst.c) and (rm <= dst.r_inner(dst.c) + 1e-12).all()


#: structured wall layers of each preset's templates (MeshSizing.wall_layers rounded)
PRESET_LAYERS = {"coarse": 1, "default": 1, "fine": 3}


@pytest.mark.parametrize("preset", ["coarse", "default", "fine"])
def test_fast_path_100_random_designs_in_the_ga_box(preset):
    sizing = PRESETS[preset].sizing
    layers = PRESET_LAYERS[preset]
    rng = np.random.default_rng(2024)
    worst_vol, worst_area, worst_q = 0.0, 0.0, 1.0
    for _ in range(100):
        d = WhiskerDesign(
            alpha=rng.uniform(2.5, 6.0),
            l=rng.uniform(10.0, 15.0),
            t=rng.uniform(2.0, 6.0),
            trim=float(rng.choice([0.0, rng.uniform(5.0, 10.0)])),
        )
        wm = build_mesh(d, sizing, method="template")  # raises if the quality gate fails
        r = wm.report
        worst_vol = max(worst_vol, abs(r.volume_error))
        worst_area = max(worst_area, abs(r.cavity_area_error))
        worst_q = min(worst_q, r.quality_min)
        assert (jacobian_determinants(wm.mesh.points, wm.mesh.cells, tet_rule(2).points) > 0).all()
        assert r.wall_layers == pytest.approx(layers, rel=0.05)
        # a radial line crosses >= 2 of the 3 tets a wall prism is split into, per layer
        assert r.elements_through_wall >= 2 * layers
        assert len(wm.fibres) == 2 and len(wm.face_sets["gauge"]) >= 2
    assert worst_vol <= 1e-3 and worst_area <= 1e-3 and worst_q > 0.08


@pytest.mark.parametrize("preset", ["coarse", "default"])
def test_fibres_located_in_the_strongly_curved_elements_of_a_box_corner(preset):
    """The thickest, steepest, shortest corner of the GA box: on the coarse mesh a fibre point's host
    is a strongly curved element whose straight tet misses the point by more than the element."""
    d = WhiskerDesign(alpha=6.0, l=15.0, t=6.0, trim=10.0)
    wm = build_mesh(d, PRESETS[preset].sizing, method="template")
    for f in wm.fibres:
        X = wm.mesh.points[wm.mesh.cells[f.host_elements]]  # (n, 10, 3)
        N = element.shape_functions(f.local_coords)
        assert np.abs(np.einsum("na,nai->ni", N, X) - f.points_ref).max() < 1e-8
        assert element.barycentric(f.local_coords).min() >= 0.0


def test_template_refuses_absolute_sizing():
    with pytest.raises(TemplateError):
        build_mesh(WhiskerDesign(), MeshSizing(h_wall=0.9), method="template")


def test_invalid_design_refused_before_meshing():
    with pytest.raises(InvalidDesignError, match="tip radius"):
        build_mesh(WhiskerDesign(alpha=9.0), method="fresh")


def test_radius_ratio_of_regular_tet_is_one():
    s = np.sqrt(2.0)
    P = np.array([[1, 0, -1 / s], [-1, 0, -1 / s], [0, 1, 1 / s], [0, -1, 1 / s]], float)
    t = np.array([[0, 1, 2, 3]])
    if signed_volumes_linear(P, t)[0] < 0:
        t = t[:, [0, 2, 1, 3]]
    assert radius_ratio(P, t)[0] == pytest.approx(1.0)


def test_node_rings_at_the_gauge_window_and_contact_positions():
    """Whole element layers over the gauge window; node rings at x = f L' (f = contact_fractions)."""
    for d in (WhiskerDesign(), WhiskerDesign(alpha=5.6, l=10.4, t=5.5, trim=8.3)):
        sizing = MeshSizing()
        wm = build_mesh(d, sizing, method="template")
        x = wm.mesh.points[:, 0]
        for xk in (d.x_ss, d.x_ss + d.e, *(f * d.length for f in sizing.contact_fractions)):
            ring = np.abs(x - xk) < 1e-9
            assert ring.sum() >= 2 * sizing.n_theta  # a full node ring across the section


def test_fresh_path_keeps_three_wall_layers():
    """fTetWild meshes get >= 3 element sizes through the wall whatever the preset."""
    from geometry.mesh import fresh_sizing

    d = WhiskerDesign()
    assert fresh_sizing(MeshSizing()).wall_layers == 3.0
    assert fresh_sizing(MeshSizing()).wall_size(d) == pytest.approx(d.t / 3.0)
    assert fresh_sizing(PRESETS["fine"].sizing) == PRESETS["fine"].sizing
    absolute = MeshSizing(h_wall=2.0)
    assert fresh_sizing(absolute) == absolute  # the user's absolute size is kept
