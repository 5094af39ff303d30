"""The fresh fTetWild path on the default design: one real tetrahedralisation.

pytetwild meshes the analytic surface with the default preset's sizing raised to at least
three wall layers (:func:`geometry.mesh.fresh_sizing`); the TET10 upgrade puts boundary
nodes on the exact surfaces. The tag, surface and fibre checks of the template meshes
(tests/test_geometry_mesh.py) run here again on this unstructured mesh. The whole
acceptance table (default design and the eight box corners at L = 70 and 60) is
``benchmarks/performance/bench_mesh.py``.
"""

import numpy as np
import pytest

from fem.mesh import jacobian_determinants, signed_volumes_linear
from fem.quadrature import tet_rule
from geometry import analytic
from geometry.design import WhiskerDesign
from geometry.mesh import MeshSizing, build_mesh
from tests.test_geometry_mesh import (  # noqa: F401  (collected again with this module's fixture)
    test_boundary_nodes_on_exact_surfaces,
    test_face_sets_cover_the_boundary_and_are_outward,
    test_fibres_located,
    test_gauge_footprint,
)

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def wm():
    return build_mesh(WhiskerDesign(), MeshSizing(), method="fresh", num_threads=0)


def test_fresh_report_meets_issue_2(wm):
    """Volume within 0.5 %, cavity area within 1 %, >= 3 elements through the wall, none inverted."""
    r, d = wm.report, wm.design
    print(r.as_dict())
    assert r.method == "fresh"
    assert abs(r.volume_error) <= 5e-3 and abs(r.cavity_area_error) <= 1e-2
    assert r.volume_analytic == pytest.approx(analytic.solid_volume(d))
    assert r.elements_through_wall >= 3
    assert r.quality_min > 0.01 and r.jacobian_ratio_min > 0.0
    m = wm.mesh
    assert m.points.dtype == np.float64 and m.cells.shape[1] == 10
    assert (signed_volumes_linear(m.points, m.cells) > 0).all()
    assert (jacobian_determinants(m.points, m.cells, tet_rule(3).points) > 0).all()
    # the solid tip stays coarse: its median element is several times the wall's in volume
    # (measured 15.5×; the thin tip, radius ~2-3 mm, caps the size well below h_body)
    X = m.points[m.cells[:, :4]].mean(axis=1)  # (n_el, 3) vertex centroids
    vol = np.abs(signed_volumes_linear(m.points, m.cells))
    tip = X[:, 0] > d.l + 0.5 * (d.length - d.l)
    wall = (X[:, 0] > d.c) & (X[:, 0] < d.l)
    assert np.median(vol[tip]) > 8 * np.median(vol[wall])
