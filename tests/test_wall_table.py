"""The stored wall-law table (whisker_opt.wall.table) and what a wall law does to the reading (wallcell.reading).

References
----------
* With the bare tube's EI, no extension and a gauge transfer of 1, the wall-cell beam is the beam model of
  :mod:`whisker_opt.analysis.beam` with E₂ = E (its exact tube, no thinning): same ε/δ.
* :func:`inferred_k` inverts the thesis' beam model: the ratio that model gives at k = 0.8 returns k = 0.8.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geometry.design import WhiskerDesign
from whisker_opt.analysis.beam import BeamModel
from whisker_opt.wallcell.reading import cell_sensitivity, inferred_k
from whisker_opt.wall.table import WallTable, default_path

MU = 0.28


def _entry(variant, r_i, t, scale):
    q = np.array([0.0, 0.1, 0.2])
    return {"variant": variant, "r_i": r_i, "t": t, "EI": list(scale * (1 - q)), "ez": list(q),
            "g": list(1 - q / 2), "g_min": list(1 - q), "g_max": list(1 + 0 * q), "ur_ring": list(-q),
            "ur_gap": list(-q)}


@pytest.fixture()
def table():
    pts = [(4.0, 2.0, 1.0), (6.0, 2.0, 2.0), (4.0, 4.0, 3.0), (6.0, 4.0, 4.0)]
    return WallTable((0.0, 0.1, 0.2), tuple(_entry("law", r, t, s) for r, t, s in pts), {"code": "test"})


def test_the_table_round_trips_and_interpolates_linearly(tmp_path, table):
    table.save(tmp_path / "t.json")
    back = WallTable.load(tmp_path / "t.json")
    assert back.entries == table.entries and back.provenance == {"code": "test"}
    assert back.lookup("law", "EI", 4.0, 2.0) == pytest.approx([1.0, 0.9, 0.8])
    # bilinear data (scale = 1 + (r_i − 4)/2 + (t − 2)) is linear on each Delaunay triangle
    assert back.lookup("law", "EI", 5.0, 3.0)[0] == pytest.approx(2.5)
    assert back.ratio("law", 5.0, 3.0) == pytest.approx([1.0, 0.9, 0.8])


def test_the_table_refuses_what_it_does_not_hold(table):
    with pytest.raises(ValueError, match=r"outside the 'law' table, whose walls span r_i 4..6 mm, t 2..4 mm and r_i \+ t 6..10 mm "
                       r"\(inside the hull of its points\), at Q 0..0.2 MPa"):
        table.lookup("law", "EI", 7.0, 3.0)
    with pytest.raises(ValueError, match="wall law 'glued': not in the table; allowed law"):
        table.lookup("glued", "EI", 5.0, 3.0)
    with pytest.raises(ValueError, match="wall-law quantity 'E': allowed"):
        table.lookup("law", "E", 5.0, 3.0)


def test_a_table_of_another_format_is_refused(tmp_path):
    p = tmp_path / "t.json"
    p.write_text('{"format": 99, "pressures": [], "entries": []}')
    with pytest.raises(ValueError, match="format 99, this version reads 1"):
        WallTable.load(p)


def test_the_shipped_table_holds_every_variant_at_the_default_wall():
    from whisker_opt.wallcell.cell import WallGeometry
    from whisker_opt.wallcell.mechanisms import VARIANTS

    table = WallTable.load(default_path())
    geo = WallGeometry.of_design(WhiskerDesign())
    assert set(table.variants) == set(VARIANTS)
    assert table.provenance["resolution"]["level"] >= 3
    for v in table.variants:
        ratio = table.ratio(v, geo.r_i, geo.t)
        assert ratio[0] == 1.0 and np.all(np.isfinite(ratio[:3]))


def test_the_bare_wall_beam_is_the_beam_model():
    d = WhiskerDesign()
    x = 0.5 * (d.c + d.l)
    r_o = float(d.r_outer(x))
    ei_bare = 3 * MU * math.pi * (r_o**4 - (r_o - d.t) ** 4) / 4
    model = BeamModel(E=3 * MU, soften_unpressurised=False, wall_thinning="none")
    for a in (0.5, 1.0):
        assert cell_sensitivity(d, ei_bare, 0.0, 1.0, x, MU, a) == pytest.approx(model.sensitivity(d, a, 0.0),
                                                                                  rel=1e-8)


def test_inferred_k_inverts_the_thesis_model():
    d = WhiskerDesign()
    model = BeamModel()
    base = BeamModel(softening=lambda q: 1.0).sensitivity(d, 1.0, 0.0)
    ratio = BeamModel(softening=lambda q: 0.8).sensitivity(d, 1.0, 0.15) / base
    assert inferred_k(d, ratio, 0.15, model=model) == pytest.approx(0.8, rel=1e-8)


def test_the_gauge_transfer_is_the_cells_g_times_its_extension():
    """G(Q) = g(Q)(1 + ε_z(Q)) of the law's table variant at the design's mid-chamber wall: 1 at Q = 0 (plane
    sections of the unpressurised cell), the stored product at a table pressure, a smooth cubic between them."""
    from geometry.design import WhiskerDesign
    from whisker_opt.wall.law import WallLaw, mid_chamber_wall
    from whisker_opt.wall.table import WallTable

    d = WhiskerDesign()
    table = WallTable.load()
    r_i, t = mid_chamber_wall(d)
    for law, variant in (("embedded", "bonded"), ("calibrated", "bonded"), ("sliding", "sliding")):
        g, ez = table.lookup(variant, "g", r_i, t), table.lookup(variant, "ez", r_i, t)
        G = WallLaw(law).gauge_transfer
        assert G(0.0, d) == pytest.approx(1.0, abs=1e-9)
        for k, q in enumerate(table.pressures):
            assert G(q, d) == pytest.approx(g[k] * (1 + ez[k]), rel=1e-12)
        mid = G(0.125, d)
        assert min(G(0.1, d), G(0.15, d)) < mid < max(G(0.1, d), G(0.15, d))
    with pytest.raises(ValueError, match=r"Q = 0.3 MPa outside the wall table's \[0, 0.2\] MPa"):
        WallLaw().gauge_transfer(0.3, d)
