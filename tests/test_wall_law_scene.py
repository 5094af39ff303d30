"""The wall law in the whisker scene (:mod:`whisker_opt.wall.law`): closed form, invariants, refusals.

* Q = 0, no fibres: a law scales the chamber's rubber by c(0), so the tip stiffness follows the clamped
  tapered beam with E·c(0) over the chamber (Castigliano, :func:`whisker_opt.analysis.beam.castigliano_deflection`).
  The beam's own offset from the 3-D solid (shear, base flexibility: 3–4 %, tests/test_contact_force.py)
  cancels in the ratio law / embedded, which must match the beam's ratio within 1 %.
* Q > 0: the law acts about the pressurised state only, so the extension Δl(Q) is the embedded model's to
  the last digit, and a softer wall (c < 1) reads more at the gauge and needs less force.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from geometry.design import WhiskerDesign
from whisker_opt.analysis.beam import castigliano_deflection, second_moment
from whisker_opt.experiment.fidelity import PRESETS
from whisker_opt.experiment.scene import run_scene
from whisker_opt.experiment.spec import SceneSpec
from whisker_opt.wall.law import WallLaw, chamber_elements, mid_chamber_wall

COARSE = PRESETS["coarse"].sizing


def _beam_stiffness(d: WhiskerDesign, E: float, c_chamber: float) -> float:
    def EI(x):
        return E * (c_chamber if d.c < x < d.l else 1.0) * float(second_moment(d, x, "exact"))

    return 1.0 / castigliano_deflection(d.length, EI, breakpoints=(d.c, d.l))


def test_law_at_zero_pressure_follows_the_beam_with_a_scaled_chamber():
    d = WhiskerDesign(n_fibres=0)
    base = SceneSpec(d, sizing=COARSE, Q=0.0, deflection=0.3, n_deflection_steps=1)
    law = replace(base, wall_law="sliding")
    c0 = law.law.factor(0.0, d)
    assert 0.6 < c0 < 0.9  # the sliding fibres' wall is softer unpressurised (stored table)
    k_emb, k_law = run_scene(base).contact_stiffness, run_scene(law).contact_stiffness
    E = 6.0 * base.c10
    expect = _beam_stiffness(d, E, c0) / _beam_stiffness(d, E, 1.0)
    print(f"c(0) = {c0:.4f}: FE ratio {k_law / k_emb:.5f}, beam ratio {expect:.5f}")
    assert k_law / k_emb == pytest.approx(expect, rel=0.01)
    assert k_law < k_emb


@pytest.fixture(scope="module")
def pressurised_pair():
    d = WhiskerDesign()
    base = SceneSpec(d, sizing=COARSE, Q=0.2, deflection=2.0, n_deflection_steps=2)
    soft = replace(base, wall_law="calibrated", wall_slope=-2.0)  # c(0.2) = 0.6
    return run_scene(base), run_scene(soft)


def test_law_leaves_the_pressurisation_and_softens_the_bending(pressurised_pair):
    emb, soft = pressurised_pair
    assert soft.delta_l == pytest.approx(emb.delta_l, rel=1e-12)  # the same pressurised state (solver round-off)
    assert soft.eps_line[-1] > emb.eps_line[-1] * 1.01  # a softer chamber bends more under the gauge
    assert soft.contact_force[-1] < emb.contact_force[-1]


def test_identity_laws_change_nothing():
    d = WhiskerDesign()
    assert WallLaw("embedded").identity and WallLaw("calibrated", 0.0).identity
    assert WallLaw("calibrated", 0.0).factor(0.2, d) == 1.0
    assert WallLaw("calibrated", -2.0).factor(0.2, d) == pytest.approx(0.6)


def test_table_law_is_read_at_mid_chamber_and_refuses_outside_the_table():
    d = WhiskerDesign()
    r_i, t = mid_chamber_wall(d)
    assert t == d.t and r_i == pytest.approx(d.r_outer(0.5 * (d.c + d.l)) - d.t)
    assert WallLaw("sliding").factor(0.2, d) == pytest.approx(2619.9 / 2415.0, rel=2e-3)  # the table's entries
    with pytest.raises(ValueError, match=r"Q = 0.3 MPa: outside the 'sliding' table, .* at Q 0..0.2 MPa"):
        WallLaw("sliding").factor(0.3, d)
    with pytest.raises(ValueError, match=r"outside the 'sliding' table"):
        WallLaw("sliding").factor(0.1, replace(d, t=0.5))


def test_chamber_elements_are_the_wall():
    from geometry.mesh import build_mesh

    d = WhiskerDesign()
    wm = build_mesh(d, COARSE)
    el = chamber_elements(wm.mesh.points, wm.mesh.cells, d)
    x = wm.mesh.points[wm.mesh.cells[el, :4], 0].mean(axis=1)
    r = np.linalg.norm(wm.mesh.points[wm.mesh.cells[el, :4], 1:], axis=2).mean(axis=1)
    assert np.all((x > d.c) & (x < d.l))
    assert np.all(r > d.r_inner(x) - 1e-9)  # nothing inside the cavity
    assert 0 < len(el) < wm.mesh.n_elements


@pytest.mark.parametrize("changes, match", [
    ({"wall_law": "glued"}, "wall_law"),
    ({"wall_slope": -1.0}, "read only by material.wall_law 'calibrated'"),
    ({"wall_law": "calibrated", "wall_slope": -5.0}, r"wall_slope=-5.0: must lie in"),
])
def test_bad_laws_are_refused_in_one_line(changes, match):
    with pytest.raises(ValueError, match=match) as exc:
        SceneSpec(WhiskerDesign(), **changes)
    assert "\n" not in str(exc.value)
