"""CAD solid and fibre wires against closed forms (truncated cones, conical helix)."""

import math

import numpy as np
import pytest

from geometry import analytic
from geometry.design import InvalidDesignError, WhiskerDesign
from geometry.fibres import fibre_phases, helix_xyz, sample_helix

cq = pytest.importorskip("cadquery")
from geometry.cad import build_cavity, build_fibre_wires, build_solid, export_step, export_stl  # noqa: E402

DESIGNS = [
    WhiskerDesign(),
    WhiskerDesign(alpha=6.0, l=10.0, t=2.0, trim=10.0),
    WhiskerDesign(alpha=2.5, l=15.0, t=6.0),
    WhiskerDesign(alpha=0.0, fibre_radius_frac=0.2),
]


@pytest.mark.parametrize("d", DESIGNS, ids=lambda d: d.describe())
def test_solid_and_cavity_volume_and_area(d):
    solid = build_solid(d)
    assert solid.isValid()
    assert solid.Volume() == pytest.approx(analytic.solid_volume(d), rel=1e-6)
    cav = build_cavity(d)
    assert cav.Volume() == pytest.approx(analytic.cavity_volume(d), rel=1e-6)
    assert cav.Area() == pytest.approx(analytic.cavity_area(d), rel=1e-6)
    # total boundary area = outer cone + base + tip + cavity
    total = analytic.outer_lateral_area(d) + analytic.base_area(d) + analytic.tip_area(d) + analytic.cavity_area(d)
    assert solid.Area() == pytest.approx(total, rel=1e-6)
    bb = solid.BoundingBox()
    assert (bb.xmin, bb.xmax) == pytest.approx((0.0, d.length), abs=1e-6)
    assert bb.ymax == pytest.approx(d.D / 2, abs=1e-6)


def test_frustum_closed_forms_against_quadrature():
    from scipy.integrate import quad

    h, r1, r2 = 13.0, 5.9, 5.25
    v, _ = quad(lambda x: math.pi * (r1 + (r2 - r1) * x / h) ** 2, 0, h)
    assert analytic.frustum_volume(h, r1, r2) == pytest.approx(v, rel=1e-12)
    s = math.hypot(h, r1 - r2)
    a, _ = quad(lambda x: 2 * math.pi * (r1 + (r2 - r1) * x / h) * s / h, 0, h)
    assert analytic.frustum_lateral_area(h, r1, r2) == pytest.approx(a, rel=1e-12)


@pytest.mark.parametrize("d", DESIGNS, ids=lambda d: d.describe())
def test_fibre_length_closed_form_quadrature_cad_and_polyline(d):
    exact = analytic.fibre_length(d)
    assert analytic.helix_length_quad(d.r_fibre(0.0), d.tan_alpha, d.fibre_pitch, d.c, d.l) == pytest.approx(
        exact, rel=1e-10
    )
    wires = build_fibre_wires(d)
    assert len(wires) == d.n_fibres
    for w in wires:
        assert w.Length() == pytest.approx(exact, rel=1e-6)
    # polyline chord error ~ s^2 kappa^2 / 24 per unit length -> second-order convergence
    errs = [exact - analytic.polyline_length(sample_helix(d, 0.0, ds)) for ds in (0.4, 0.2)]
    assert errs[0] > 0 and errs[1] > 0
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.05)


def test_double_helix_geometry():
    d = WhiskerDesign()
    ph = fibre_phases(d)
    assert ph == pytest.approx([0.0, math.pi])
    x = np.linspace(d.c, d.l, 50)
    a, b = helix_xyz(d, x, ph[0]), helix_xyz(d, x, ph[1])
    assert np.allclose(b, a * [1, -1, -1])  # rotated by 180 deg about x
    assert np.allclose(np.hypot(a[:, 1], a[:, 2]), d.r_inner(x) + 0.5 * d.t)  # mid-wall
    # pitch: one full turn per 3 mm
    p0, p1 = helix_xyz(d, np.array([5.0, 8.0]), 0.0)
    assert p1[1:] / np.hypot(*p1[1:]) == pytest.approx(p0[1:] / np.hypot(*p0[1:]))
    pts = sample_helix(d, 0.0, 0.3)
    assert pts[0, 0] == d.c and pts[-1, 0] == d.l
    assert np.linalg.norm(np.diff(pts, axis=0), axis=1).max() <= 0.3 + 1e-9


def test_export_step_and_stl(tmp_path):
    d = WhiskerDesign()
    solid = build_solid(d)
    step = export_step(solid, tmp_path / "w.step", fibres=build_fibre_wires(d))
    stl = export_stl(solid, tmp_path / "w.stl")
    assert step.stat().st_size > 1000 and stl.stat().st_size > 1000
    back = cq.importers.importStep(str(tmp_path / "w.step"))
    vols = [s.Volume() for s in back.solids().vals()]
    assert max(vols) == pytest.approx(analytic.solid_volume(d), rel=1e-6)


def test_cad_refuses_invalid_design():
    with pytest.raises(InvalidDesignError):
        build_solid(WhiskerDesign(t=9.0))
