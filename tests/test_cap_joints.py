"""The cap joints (whisker_opt.experiment.cap_joints): the registry, the series law of the ``compliant`` joint
against a bar's closed form, the tied limit on the whisker, and the run file's one-line refusals.

The closed form: a bar of the cap's rubber, c × b × b, held axially at x = 0 (symmetry planes y = b/2,
z = b/2), pulled by a dead force F at x = c, its moduli × s. Small-strain theory:

    u_x(c) = F c / (E_cap s A) = F / A · [c / E_cap + 1 / k_j]

by the joint's definition of s (whisker_opt/experiment/caps/compliant.py): the cap and the joint in series.
The factor s is defined with the incompressible E_cap = 3μ_cap; at K/μ = 1000 the scaled modulus
9K(sμ)/(3K + sμ) differs from s·E_cap by at most sμ/(3K) < 4e-4, and the load's strain (1e-5 at most, F = 1e-6 N) adds
its own order: the test holds 1e-3. The series law is exact where the cap contracts freely; a cap bonded to a stiffer
body is held back at the interface (the shape-factor stiffening of a bonded layer: with the body of the bar's
other half, u_x reads 8 % below the series sum at k_j = 0.05 N/mm³), which the joint's docstring states.
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean, ScaledMaterial
from fem.mesh import boundary_faces
from fem.meshgen import box_mesh
from fem.problem import DeadTraction, Dirichlet, Problem
from fem.state import State
from geometry.design import WhiskerDesign
from tests.folder_helpers import assert_run_file_refused
from whisker_opt.experiment.cap_joints import CAP_JOINTS, JOINTS, cap_factor, listing
from whisker_opt.experiment.caps import compliant
from whisker_opt.experiment.rubber_laws import rubber_material
from whisker_opt.experiment.spec import SceneSpec, cap_elements


def test_registry_is_the_list_of_names():
    """The joints are the modules of whisker_opt/experiment/caps/, 'tied' first and the scene's default."""
    import pkgutil

    import whisker_opt.experiment.caps as pkg

    assert CAP_JOINTS == ("tied", "compliant")
    assert set(CAP_JOINTS) == {m.name for m in pkgutil.iter_modules(pkg.__path__)}
    assert SceneSpec(WhiskerDesign()).cap_joint == "tied"
    assert JOINTS["compliant"].parameters == ("cap_joint_k",)
    assert "compliant: " in listing() and "(reads cap_joint_k)" in listing()


def test_the_factor_is_the_series_law():
    """s = 1/(1 + 3μ/(k c)): a joint as stiff as the cap's own thickness halves its modulus; tied is 1."""
    spec = SceneSpec(WhiskerDesign(), cap_joint="compliant", cap_joint_k=1.5)
    mu = 0.5
    assert cap_factor("compliant", spec, 2.0, mu) == pytest.approx(1.0 / (1.0 + 3.0 * mu / (1.5 * 2.0)), rel=1e-15)
    assert cap_factor("compliant", SceneSpec(WhiskerDesign(), cap_joint="compliant", cap_joint_k=0.75), 2.0,
                      mu) == pytest.approx(0.5, rel=1e-15)
    assert cap_factor("tied", spec, 2.0, mu) == 1.0
    assert rubber_material("neo_hookean", "same", 0.14, 0.0, np.zeros(3, bool)) == NeoHookean(0.14, 0.0)


@pytest.mark.parametrize("k_j", [0.05, 0.5, 5.0])
def test_a_bar_of_the_compliant_cap_extends_by_the_series_closed_form(k_j):
    L, b, c, mu, K = 2.0, 1.0, 2.0, 1.0, 1000.0
    mesh = box_mesh(L, b, b, 4, 2, 2)
    X = mesh.points
    cap = cap_elements(mesh, c + 1e-9)
    assert cap.all()
    s = compliant.factor({"cap_joint_k": k_j}, c, mu)
    mat = rubber_material("neo_hookean", "same", mu / 2, 2.0 / K, cap, s)
    assert isinstance(mat, ScaledMaterial)
    _, _, f6 = boundary_faces(mesh.cells)
    pull = f6[np.all(np.isclose(X[f6][:, :, 0], L), axis=1)]
    held = (Dirichlet(np.nonzero(np.isclose(X[:, 0], 0.0))[0], (0,), "base"),
            Dirichlet(np.nonzero(np.isclose(X[:, 1], b / 2))[0], (1,), "sym y"),
            Dirichlet(np.nonzero(np.isclose(X[:, 2], b / 2))[0], (2,), "sym z"))
    prob = Problem(mesh, mat, dirichlet=held, tractions=(DeadTraction(pull, "pull"),))
    F, A = 1e-6, b * b
    load = LoadState((), (0.0, 0.0, 0.0), (np.array([F / A, 0.0, 0.0]),))
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob), load, fractions=(1.0,))
    u = states[-1].u
    expected = F / A * (c / (3.0 * mu) + 1.0 / k_j)
    np.testing.assert_allclose(u[np.isclose(X[:, 0], L), 0], expected, rtol=1e-3)


def test_a_stiff_joint_is_the_tied_cap():
    """k_j = 10⁴ N/mm³ on the default design (c = 2 mm, μ = 0.28 MPa): s within 5e-5 of 1."""
    spec = SceneSpec(WhiskerDesign(), cap_joint="compliant", cap_joint_k=1e4)
    from whisker_opt.experiment.scene import scene_cap_factor

    assert scene_cap_factor(spec) == pytest.approx(1.0, abs=5e-5)
    assert scene_cap_factor(SceneSpec(WhiskerDesign())) == 1.0


def test_the_deck_refuses_a_compliant_cap():
    from whisker_opt.output.scene_deck import deck_refusal

    assert deck_refusal(SceneSpec(WhiskerDesign(), cap_joint="compliant")).startswith("material.cap_joint: "
                                                                                   "'compliant';")


def test_the_viewer_computes_the_law_the_scene_solved_with():
    """A run of a compliant cap: the viewer's law of the run's config is the scene's, cap scaled by s < 1."""
    from whisker_opt.experiment.scene import scene_material
    from whisker_opt.viewer.rubber import run_rubber

    mesh = box_mesh(4.0, 1.0, 1.0, 8, 1, 1)
    cfg = {"material": {"cap_joint": "compliant", "cap_joint_k": 0.7}, "design": {"c": 1.0}}
    law = run_rubber(cfg).law(mesh.points, mesh.cells)
    scene = scene_material(mesh, SceneSpec(WhiskerDesign(c=1.0), cap_joint="compliant", cap_joint_k=0.7))
    np.testing.assert_allclose(law.factor, scene.factor)
    assert law.factor.min() < 1.0 and law.factor.max() == 1.0


@pytest.mark.parametrize("text, message", [
    ("material: {cap_joint: glued}\n", r"material\.cap_joint: 'glued'"),
    ("material: {cap_joint: compliant, cap_joint_k: 0}\n", r"material\.cap_joint_k: 0 is outside the allowed range "
                                                          r"\(0, 10000\]"),
])
def test_run_file_refuses_bad_joints_in_one_line(tmp_path, text, message):
    assert_run_file_refused(tmp_path, text, message)
