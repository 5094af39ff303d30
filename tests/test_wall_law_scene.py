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
    assert soft.eps["line"][-1] > emb.eps["line"][-1] * 1.01  # a softer chamber bends more under the gauge
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


def _neo_hookean_pk2(c10: float, F: np.ndarray) -> np.ndarray:
    """S̄ = 2 C10 J^(-2/3) (I − (I1/3) C⁻¹), the neo-Hookean isochoric second Piola–Kirchhoff stress, (k, 3, 3)."""
    C = np.einsum("kiJ,kiL->kJL", F, F)  # (k, 3, 3)  FᵀF
    i1 = np.einsum("kii->k", C)  # (k,)
    return (2 * c10 * np.linalg.det(F) ** (-2 / 3))[:, None, None] * (np.eye(3) - (i1 / 3)[:, None, None]
                                                                      * np.linalg.inv(C))


@pytest.mark.parametrize("law", [{"wall_law": "sliding"}, {"wall_law": "calibrated", "wall_slope": -2.0}])
def test_the_stored_stress_is_the_stress_the_deflection_solved(law, tmp_path, monkeypatch):
    """The result files and von_mises_max carry the stress of the law the deflection was solved with.

    At a node of the wall alone (every element around it a wall element) the law's Cauchy stress is, in
    closed form from the rubber (neo-Hookean, C10) and the nodal F of the deflected and the pressurised
    state, σ = J⁻¹ F [c S̄(C) − (c − 1) S̄(C_p)] Fᵀ + p I; everywhere it is the stress of the very problem
    the Newton solve was handed (fem.post.problem_strain_stress); at the pressurised state that law's
    stress is the pressurised one (the wall law keeps its equilibrium). The rubber alone differs by
    (c − 1) [S̄(C) − S̄(C_p)] pushed forward.
    """
    pv = pytest.importorskip("pyvista")

    import whisker_opt.experiment.scene as scene
    from fem import post
    from fem.material import von_mises_stress
    from whisker_opt.output.scenes import write_scene_files

    handed = []

    def recording(problem, *args, **kwargs):
        handed.append(problem)
        return solve_path(problem, *args, **kwargs)

    solve_path = scene.solve_path
    monkeypatch.setattr(scene, "solve_path", recording)
    spec = SceneSpec(WhiskerDesign(), sizing=COARSE, Q=0.2, deflection=2.0, n_deflection_steps=1, **law)
    res = run_scene(spec, keep_states=True)
    problem, c = handed[-1], spec.law.factor(spec.Q, spec.design)
    assert problem.frozen_stresses and abs(c - 1) > 0.05  # the deflection was solved with the law
    write_scene_files(tmp_path, "s", res)
    stored = pv.read(tmp_path / "s_deflected.vtu").point_data
    sigma = stored["cauchy_stress"][:, [0, 3, 5, 3, 1, 4, 5, 4, 2]].reshape(-1, 3, 3)  # XX YY ZZ XY YZ XZ -> 3x3

    mesh, dfl, pre = res.mesh.mesh, res.states["deflected"], res.states["pressurised"]
    scale = np.abs(sigma).max()
    wall = np.zeros(mesh.n_elements, dtype=bool)
    wall[chamber_elements(mesh.points, mesh.cells, spec.design)] = True
    only_wall = np.ones(mesh.n_nodes, dtype=bool)
    np.logical_and.at(only_wall, mesh.cells.ravel(), np.repeat(wall, mesh.cells.shape[1]))
    assert only_wall.sum() > 50
    F, used = post.nodal_deformation_gradient(mesh.points, mesh.cells, dfl.u)  # (n_used, 3, 3)
    F = F[only_wall[used]]  # (k, 3, 3)
    F_p = post.nodal_deformation_gradient(mesh.points, mesh.cells, pre.u)[0][only_wall[used]]  # (k, 3, 3)
    S = c * _neo_hookean_pk2(spec.c10, F) - (c - 1) * _neo_hookean_pk2(spec.c10, F_p)  # (k, 3, 3)
    p = post.element_to_nodes(mesh.cells, dfl.p, mesh.n_nodes)[only_wall]  # (k,)
    closed = np.einsum("kiJ,kJL,kjL->kij", F, S, F) / np.linalg.det(F)[:, None, None] + p[:, None, None] * np.eye(3)
    np.testing.assert_allclose(sigma[only_wall], closed, rtol=0, atol=1e-12 * scale)
    rubber_alone = post.problem_strain_stress(handed[0], dfl.u, dfl.p)[1][only_wall]  # the pressurisation's law
    assert np.abs(rubber_alone - closed).max() > 1e-4 * scale

    solved = post.problem_strain_stress(problem, dfl.u, dfl.p)[1]  # (n_nodes, 3, 3)
    np.testing.assert_allclose(sigma, solved, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(stored["von_mises"], von_mises_stress(solved), rtol=0, atol=1e-12 * scale)
    assert res.von_mises_max == pytest.approx(np.nanmax(von_mises_stress(solved)), rel=1e-12)
    at_p = post.problem_strain_stress(problem, pre.u, pre.p)[1]
    np.testing.assert_allclose(at_p, post.problem_strain_stress(handed[0], pre.u, pre.p)[1], rtol=0, atol=1e-12 * scale)
