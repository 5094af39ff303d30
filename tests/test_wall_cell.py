"""The wall cell (whisker_opt.wallcell.cell): closed forms where the fibre is rubber, and the mechanisms' bounds.

References
----------
* A cell whose fibre section is rubber is a closed-end tube: its extension at pressure Q is the exact
  closed-end tube's (tests/tube_closed_form.py) and it bends as a beam, EI = 3μ π (r_o⁴ − r_i⁴)/4, with a
  gauge transfer of 1 at every gauge position (plane sections stay plane).
* A fibre that slides along the hoop relaxes a constraint of the bonded one, so by the minimum of the
  potential energy its cell is no stiffer in bending (equal axisymmetric state, n = 1 energy lower or equal).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.tube_closed_form import closed_end_tube
from whisker_opt.wallcell.cell import PRESSURES, Resolution, WallCell, WallGeometry
from whisker_opt.wallcell.mechanisms import VARIANTS, WallMechanism

GEO = WallGeometry(r_i=5.0, t=3.0)


def test_a_cell_of_rubber_is_the_closed_end_tube():
    cell = WallCell(GEO, WallMechanism(name="rubber", fibre_law="none"), Resolution(level=1))
    mu = 2 * 0.14
    rows = cell.sweep((0.0, 0.05))
    # the bending field is quadratic, which the curved (mapped) elements around the fibre carry to ~1e-6
    assert rows[0]["EI"] == pytest.approx(3 * mu * math.pi * (GEO.r_o**4 - GEO.r_i**4) / 4, rel=1e-5)
    assert rows[0]["g_min"] == pytest.approx(1.0, abs=1e-5) and rows[0]["g_max"] == pytest.approx(1.0, abs=1e-5)
    u = cell.x[: cell.solid.n_u0].reshape(-1, 2)
    lam_a = 1 + u[cell.pin, 0] / GEO.r_i
    P, lam = closed_end_tube(lam_a, GEO.r_i, GEO.r_o, mu)
    assert P == pytest.approx(0.05, rel=1e-4)  # the inflation field is no polynomial: Q2's error at level 1
    assert 1 + rows[1]["ez"] == pytest.approx(lam, rel=1e-4)
    assert rows[1]["ur_ring"] == pytest.approx(rows[1]["ur_gap"], rel=1e-5)  # uniform along the tube


def test_a_sliding_fibre_is_no_stiffer_than_a_bonded_one():
    res = Resolution(level=1)
    bonded = WallCell(GEO, VARIANTS["bonded"], res).sweep((0.0, 0.1))
    sliding = WallCell(GEO, VARIANTS["sliding"], res).sweep((0.0, 0.1))
    for b, s in zip(bonded, sliding):
        assert s["ez"] == pytest.approx(b["ez"], rel=1e-9)  # the same axisymmetric state
        assert s["EI"] < b["EI"]


def test_the_cell_converges_under_refinement():
    """EI(0) of the bonded default-like cell approaches its limit monotonically (levels 1, 2, 3)."""
    ei = [WallCell(GEO, VARIANTS["bonded"], Resolution(level=k)).sweep((0.0,))[0]["EI"] for k in (1, 2, 3)]
    d1, d2 = ei[0] - ei[1], ei[1] - ei[2]
    assert d1 > 0 and d2 > 0 and d2 < 0.5 * d1


@pytest.mark.parametrize("field, value", [("bond", "glued"), ("fibre_poisson", 0.5), ("c10", -1.0),
                                          ("section", "oval")])
def test_a_bad_mechanism_names_its_field(field, value):
    with pytest.raises(ValueError, match=f"WallMechanism.{field}="):
        WallMechanism(**{field: value})


def test_a_fibre_outside_the_wall_is_refused():
    with pytest.raises(ValueError, match="WallGeometry.r_f"):
        WallGeometry(r_i=5.0, t=3.0, r_f=5.1)


def test_the_study_pressures_start_unloaded():
    assert PRESSURES[0] == 0.0 and np.all(np.diff(PRESSURES) > 0)
