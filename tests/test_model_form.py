"""Model-form options of the scene: rubber law, a cap of another rubber, the base support.

References
----------
* Yeoh (1993): incompressible uniaxial tension of W = C10 (I1 − 3) + C20 (I1 − 3)² has the
  nominal stress P = 2 (λ − λ⁻²) [C10 + 2 C20 (I1 − 3)], I1 = λ² + 2/λ. A homogeneous
  deformation lies in the P2 space, so the FE reaction reproduces it to solver round-off.
* Per-element laws (:class:`fem.material.ElementwiseMaterial`): the assembled tangent is the
  exact Jacobian of the residual (central finite differences, ≤ 1e-6 relative, as in
  tests/test_fem_tangent.py) and the residual the gradient of the discrete energy.
* The cap is the region x < c of the design (geometry/design.py): its elements, and only
  they, get the cap's law.
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.assembly import Assembler
from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import ElementwiseMaterial, NeoHookean, Yeoh
from fem.mesh import TetMesh
from fem.meshgen import box_mesh
from fem.problem import Dirichlet, Problem
from fem.state import State
from geometry.design import WhiskerDesign
from geometry.mesh import build_mesh
from whisker_opt.experiment.fidelity import PRESETS
from whisker_opt.experiment.scene import base_dirichlet, cap_elements, pressurise, scene_material
from whisker_opt.experiment.rubber_laws import RUBBER_LAWS
from whisker_opt.experiment.spec import SceneSpec
from tests.test_fem_tangent import energy_gradient_fd

H = 1e-6
TOL = 1e-6


def _on(X, axis, value):
    return np.nonzero(np.isclose(X[:, axis], value, atol=1e-12))[0]


def _yeoh_nominal(lam, c10, c20):
    i1 = lam**2 + 2.0 / lam
    return 2.0 * (lam - lam**-2) * (c10 + 2.0 * c20 * (i1 - 3.0))


@pytest.mark.parametrize("name", sorted(n for n in RUBBER_LAWS if n.startswith("yeoh_")))
@pytest.mark.parametrize("lam", [1.8, 0.8])
def test_yeoh_uniaxial_reaction_matches_closed_form(name, lam):
    """One unit cube (6 tets), symmetry supports, end face pulled to λ: the end reaction is the
    closed-form nominal stress of each shipped Yeoh law (1e-8 relative)."""
    c10, c20 = RUBBER_LAWS[name].constants
    mesh = box_mesh(1.0, 1.0, 1.0, 1, 1, 1)
    X = mesh.points
    x1 = _on(X, 0, 1.0)
    sets = (Dirichlet(_on(X, 0, 0.0), (0,)), Dirichlet(_on(X, 1, 0.0), (1,)), Dirichlet(_on(X, 2, 0.0), (2,)),
            Dirichlet(x1, (0,)))
    prob = Problem(mesh, Yeoh((c10, c20), 0.0), dirichlet=sets)
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob),
                           LoadState((), (0.0, 0.0, 0.0, lam - 1.0)), fractions=(0.5, 1.0))
    st = states[-1]
    R = Assembler(prob).evaluate(st.u, st.p, (), False)[0]
    reaction = R[3 * x1].sum()
    ref = _yeoh_nominal(lam, c10, c20)
    assert abs(reaction - ref) <= 1e-8 * abs(ref)
    # and the Yeoh term matters at this stretch (the test separates it from neo-Hookean C10)
    assert abs(ref - _yeoh_nominal(lam, c10, 0.0)) > 1e-4 * abs(ref)


def test_shipped_yeoh_constants_pass_through_the_published_points():
    """RUBBER_LAWS reproduce the fit of benchmarks/studies/fit_rubber_tds.py (both data points to 0.1 %)."""
    from benchmarks.studies import fit_rubber_tds as fit

    for name, (s100, sb, eb) in fit.TDS.items():
        c10, c20 = RUBBER_LAWS[f"yeoh_{name}"].constants
        got = _yeoh_nominal(np.array([2.0, 1.0 + eb / 100.0]), c10, c20)
        np.testing.assert_allclose(got, np.array([s100, sb]) * fit.PSI, rtol=1e-3)
        np.testing.assert_allclose((c10, c20), fit.fit(s100, sb, eb), rtol=1e-3)


# ---------------------------------------------------------------------- per-element laws
@pytest.fixture(scope="module")
def mesh():
    """Distorted 1×1×2-cell P2 box (12 tets), as in tests/test_fem_tangent.py."""
    m = box_mesh(1.0, 1.0, 2.0, 1, 1, 2)
    X = m.points
    Y = X + 0.08 * np.stack([np.sin(2.0 * X[:, 2]) + X[:, 1] ** 2, np.cos(1.5 * X[:, 0]) * X[:, 2],
                             0.5 * X[:, 0] * X[:, 1]], axis=1)
    return TetMesh(Y, m.cells)


def _two_laws(mesh, d1):
    upper = (mesh.points[mesh.cells[:, :4], 2].mean(axis=1) > 1.0).astype(np.int64)  # (n_el,)
    return ElementwiseMaterial((NeoHookean(0.5, d1), Yeoh((0.9, -0.05, 0.02), d1)), upper)


def _state(problem, seed):
    rng = np.random.default_rng(seed)
    return 0.05 * rng.standard_normal((problem.mesh.n_nodes, 3)), 0.3 * rng.standard_normal(problem.mesh.n_elements)


@pytest.mark.parametrize("d1", [0.0, 0.4])
def test_elementwise_tangent_matches_fd(mesh, d1):
    """K of the two-law material = central-FD Jacobian of its residual (all blocks), and symmetric."""
    prob = Problem(mesh, _two_laws(mesh, d1))
    asm = Assembler(prob, kernel="numpy")
    u, p = _state(prob, 2)
    R, data, _ = asm.evaluate(u, p, (), True)
    K = asm.pattern.matrix(data).toarray()
    x = np.concatenate([u.ravel(), p])
    n_u = prob.n_u
    cols = []
    for j in range(len(x)):
        xp, xm = x.copy(), x.copy()
        xp[j] += H
        xm[j] -= H
        cols.append((asm.evaluate(xp[:n_u].reshape(-1, 3), xp[n_u:], (), False)[0]
                     - asm.evaluate(xm[:n_u].reshape(-1, 3), xm[n_u:], (), False)[0]) / (2 * H))
    Kfd = np.stack(cols, axis=1)
    assert np.abs(K - Kfd).max() / np.abs(Kfd).max() <= TOL
    assert np.abs(K - K.T).max() <= 1e-12 * np.abs(K).max()
    # the compiled kernel assembles the same tangent
    _, data_jit, _ = Assembler(prob, kernel="auto").evaluate(u, p, (), True)
    np.testing.assert_allclose(data_jit, data, rtol=0, atol=1e-12 * np.abs(data).max())


def test_elementwise_residual_is_energy_gradient_and_each_element_keeps_its_law(mesh):
    """R = ∂Π/∂x by central FD; and the energy is the sum of each group's own law's energy."""
    mat = _two_laws(mesh, 0.0)
    prob = Problem(mesh, mat)
    asm = Assembler(prob)
    u, p = _state(prob, 5)
    R = asm.evaluate(u, p, (), False)[0]
    g = energy_gradient_fd(asm, u, p)
    assert np.abs(g - R).max() / np.abs(R).max() <= TOL
    F, _, _ = asm.deformation(u)
    W = mat.energy(F)  # (n_el, n_qp)
    for k, law in enumerate(mat.materials):
        sel = mat.element_material == k
        assert 0 < sel.sum() < len(sel)
        np.testing.assert_allclose(W[sel], law.energy(F[sel]), rtol=1e-14)


def test_elementwise_material_refuses_bad_input(mesh):
    with pytest.raises(ValueError, match="same d1"):
        ElementwiseMaterial((NeoHookean(0.5, 0.0), NeoHookean(0.5, 0.1)), np.zeros(12, int))
    with pytest.raises(ValueError, match=r"index outside \[0, 1\]"):
        ElementwiseMaterial((NeoHookean(0.5), NeoHookean(0.6)), np.full(12, 2))
    with pytest.raises(ValueError, match="one row per element"):
        ElementwiseMaterial((NeoHookean(0.5), NeoHookean(0.6)), np.zeros(12, int)).f_derivatives(np.ones(5))


# ---------------------------------------------------------------------- the whisker's options
@pytest.fixture(scope="module")
def wm():
    return build_mesh(WhiskerDesign(), PRESETS["coarse"].sizing, method="auto")


def test_default_options_are_todays_model(wm):
    """Defaults: one neo-Hookean law of C10/D1 and the fully clamped base."""
    spec = SceneSpec(WhiskerDesign())
    assert (spec.rubber, spec.cap_rubber, spec.base_support) == ("neo_hookean", "same", "clamped")
    assert scene_material(wm.mesh, spec) == NeoHookean(spec.c10, spec.d1)
    (base,) = base_dirichlet(wm, spec)
    assert base.components == (0, 1, 2)
    np.testing.assert_array_equal(base.nodes, wm.node_sets["base"])


def test_cap_law_goes_to_exactly_the_elements_below_c(wm):
    """The cap's law is on the elements lying in x ≤ c and nowhere else; no element straddles x = c
    (judged by all ten nodes, independently of the centroid rule of cap_elements)."""
    d = wm.design
    spec = SceneSpec(d, rubber="yeoh_dragon_skin_10", cap_rubber="yeoh_dragon_skin_30")
    mat = scene_material(wm.mesh, spec)
    assert isinstance(mat, ElementwiseMaterial)
    xn = wm.mesh.points[wm.mesh.cells, 0]  # (n_el, 10)
    tol = 1e-9 * d.L
    below, above = np.all(xn <= d.c + tol, axis=1), np.all(xn >= d.c - tol, axis=1)
    assert np.all(below | above)
    np.testing.assert_array_equal(mat.element_material == 1, below)
    np.testing.assert_array_equal(cap_elements(wm.mesh, wm.design.c), below)
    assert 0 < below.sum() < len(below)
    assert mat.materials == (Yeoh(RUBBER_LAWS["yeoh_dragon_skin_10"].constants),
                             Yeoh(RUBBER_LAWS["yeoh_dragon_skin_30"].constants))
    # a cap of the body's own law is one law
    assert scene_material(wm.mesh, SceneSpec(d, rubber="yeoh_dragon_skin_30", cap_rubber="yeoh_dragon_skin_30")) == \
        Yeoh(RUBBER_LAWS["yeoh_dragon_skin_30"].constants)


def test_every_rubber_is_its_registered_factory_with_its_own_constants(monkeypatch):
    """The registry holds every name of every module of whisker_opt/experiment/rubbers/ (neo_hookean first) and
    rubber_law builds each by its module's factory with its own constants: the neo-Hookean law of the material
    section's C10, a Yeoh law of its own constants (C10 not read), D1 for all; a law added to the registry
    alone (here a three-term Yeoh of made-up constants) is built by rubber_law and rubber_material."""
    import importlib
    import pkgutil
    import types

    import whisker_opt.experiment.rubber_laws as laws_mod
    import whisker_opt.experiment.rubbers as pkg
    from whisker_opt.experiment.rubber_laws import RUBBERS, RubberLaw, rubber_law, rubber_material
    from whisker_opt.experiment.rubbers.yeoh import make as yeoh

    mods = [importlib.import_module(f"{pkg.__name__}.{m.name}") for m in pkgutil.iter_modules(pkg.__path__)]
    assert sorted(RUBBERS) == sorted(n for m in mods for n in m.LAWS) and RUBBERS == tuple(RUBBER_LAWS)
    assert RUBBERS[:4] == ("neo_hookean", "yeoh_dragon_skin_30", "yeoh_dragon_skin_10", "yeoh_ecoflex_00_30")
    for m in mods:
        for name, (constants, source) in m.LAWS.items():
            assert RUBBER_LAWS[name] == RubberLaw(m.make, constants, source) and source
            assert rubber_law(name, 0.21, 0.03) == m.make(constants, 0.21, 0.03)
    assert rubber_law("neo_hookean", 0.21, 0.03) == NeoHookean(0.21, 0.03)
    for name in (n for n in RUBBERS if n.startswith("yeoh_")):
        law = rubber_law(name, 0.21, 0.03)
        assert law == Yeoh(RUBBER_LAWS[name].constants, 0.03) and law.c[0] != 0.21
    with pytest.raises(ValueError, match="^rubber 'no_such_rubber': must be " + " or ".join(map(repr, RUBBERS)) + "$"):
        rubber_law("no_such_rubber", 0.21, 0.0)
    added = RubberLaw(yeoh, (0.1, -2e-3, 5e-5), "a test's constants")
    monkeypatch.setattr(laws_mod, "RUBBER_LAWS", types.MappingProxyType({**RUBBER_LAWS, "yeoh_three_terms": added}))
    assert rubber_law("yeoh_three_terms", 0.21, 0.01) == Yeoh((0.1, -2e-3, 5e-5), 0.01)
    cap = np.array([True, False, False])
    two = rubber_material("neo_hookean", "yeoh_three_terms", 0.21, 0.01, cap)
    assert two.materials == (NeoHookean(0.21, 0.01), Yeoh((0.1, -2e-3, 5e-5), 0.01))
    np.testing.assert_array_equal(two.element_material, [1, 0, 0])


def test_sliding_base_sets(wm):
    """'sliding': all base nodes held axially, only r ≤ D/4 held in y, z; the DOF sets do not overlap."""
    spec = SceneSpec(wm.design, base_support="sliding")
    ax, rad = base_dirichlet(wm, spec)
    base = wm.node_sets["base"]
    np.testing.assert_array_equal(ax.nodes, base)
    assert ax.components == (0,) and rad.components == (1, 2)
    r = np.linalg.norm(wm.mesh.points[base, 1:], axis=1)
    np.testing.assert_array_equal(rad.nodes, base[r <= wm.design.D / 4 + 1e-9])
    assert 0 < len(rad.nodes) < len(base)


def test_sliding_base_lets_the_rim_move_and_clamped_does_not(wm):
    """Pressurised to 0.02 MPa, the outer base rim moves radially only with the sliding support;
    no base node moves axially with either."""
    out = {}
    for support in ("clamped", "sliding"):
        spec = SceneSpec(wm.design, Q=0.02, base_support=support, sizing=PRESETS["coarse"].sizing,
                         n_pressure_steps=1)
        u = pressurise(spec, wm).state.u
        base = wm.node_sets["base"]
        r = np.linalg.norm(wm.mesh.points[base, 1:], axis=1)
        rim = base[r > 0.45 * wm.design.D]
        out[support] = (np.abs(u[rim, 1:]).max(), np.abs(u[base, 0]).max(), u[wm.node_sets["tip"], 0].mean())
    assert out["clamped"][0] == 0.0 and out["sliding"][0] > 1e-4
    assert out["clamped"][1] == 0.0 and out["sliding"][1] == 0.0
    assert out["clamped"][2] > 0.1 and out["sliding"][2] > 0.1  # the chamber extends either way


@pytest.mark.parametrize("field, value", [("rubber", "rubber"), ("cap_rubber", "steel"), ("base_support", "glued"),
                                          ("fibre_model", "lines")])
def test_scene_spec_refuses_unknown_options(field, value):
    with pytest.raises(ValueError, match=rf"SceneSpec\.{field}='{value}': must be"):
        SceneSpec(WhiskerDesign(), **{field: value})


def test_fibre_model_key_chooses_trusses_or_the_smeared_field():
    """material.fibre_model reaches the FE problem: 'embedded' gives one truss chain per helix and no field,
    'smeared' one field over the chamber wall holding the same E_f A_f × helix length (within 1 %) and no truss."""
    from fem.assembly import topology_for
    from whisker_opt import wiring
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt.experiment.scene import make_problem

    d = WhiskerDesign()
    wm = build_mesh(d, PRESETS["coarse"].sizing, method="swept")
    probs = {}
    for model in ("embedded", "smeared"):
        cfg = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"}, "material": {"fibre_model": model}})
        spec = wiring.scene_spec(cfg, d, 0.2)
        assert spec.fibre_model == model
        probs[model] = make_problem(wm, spec, None)
    emb, sm = probs["embedded"], probs["smeared"]
    assert len(emb.trusses) == d.n_fibres and emb.fibre_fields == ()
    assert sm.trusses == () and len(sm.fibre_fields) == 1
    line = d.fibre_E * d.fibre_area * sum(f.length for f in wm.fibres)
    stored = float(topology_for(sm).field_kernels[0].wk.sum())
    assert stored == pytest.approx(line, rel=0.01)


def test_compensable_trim_root_of_the_study():
    """benchmarks/studies/model_form.py: the root of ε(L − Δ, 0) = target on a linear ε(Δ) is exact; a target
    below ε(L, 0) compensates nothing, one above the largest trim's reading lies beyond it."""
    from benchmarks.studies import model_form

    trims = [0.0, 1.0, 2.0, 5.0, 10.0]
    eps = [1.0 + 0.1 * t for t in trims]
    assert model_form.compensable_trim(trims, eps, 1.35) == pytest.approx(3.5, abs=1e-9)
    assert model_form.compensable_trim(trims, eps, 0.99) == 0.0
    assert model_form.compensable_trim(trims, eps, 2.5) == float("inf")


def test_a_contact_ring_may_sit_close_to_the_tip():
    from geometry.swept import TIP_KNOT_GAP, axial_knots

    d = WhiskerDesign()
    L = d.length
    assert (L - 0.3) in axial_knots(d, ((L - 0.3) / L,))
    assert (L - 0.2) not in axial_knots(d, ((L - 0.2) / L,)) and TIP_KNOT_GAP == 0.25


def test_a_held_pusher_near_the_extended_tip_pushes_one_ring():
    """Pressures that extend the whisker by less than the band width put the held pusher's ring
    within 1 mm of the tip face: the band is that ring alone (not the face), and the reading
    continues the trend of the pressures whose ring lies farther from the tip (rising with Q,
    nearly linear over 0 ... 0.08 MPa)."""
    from whisker_opt import wiring
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt.experiment import contact
    from whisker_opt.experiment import scene as sc

    cfg = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"},
                                        "scene": {"contact_at": "reference", "deflection": 1.0}})
    seen = []

    def spy(wm, u, x, width, at_tip):
        nodes = contact.contact_band(wm, u, x, width, at_tip)
        seen.append(np.ptp(wm.mesh.points[nodes, 0]))
        return nodes

    eps, dl = [], []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sc, "contact_band", spy)
        for Q in (0.0, 0.04, 0.08):
            r = sc.run_scene(wiring.scene_spec(cfg, WhiskerDesign(), Q))
            eps.append(float(r.curve(np.array([1.0]), "line")[0]))
            dl.append(r.delta_l)
    assert 0.3 < dl[1] < 0.9 < 1.0 < dl[2]  # the middle pressure's ring is within 1 mm of the tip
    assert max(seen) < 1e-9  # one station each
    assert eps[0] < eps[1] < eps[2]
    assert eps[1] == pytest.approx(0.5 * (eps[0] + eps[2]), rel=0.01)


def test_smeared_fibres_on_one_wall_layer_are_warned(caplog):
    """The smeared winding on the one-layer presets logs a warning naming the fix; on `fine` it does not."""
    from whisker_opt import wiring
    from whisker_opt.config.model import WhiskerConfig

    def cfg(preset, model="smeared"):
        return WhiskerConfig.model_validate({"fidelity": {"preset": preset}, "material": {"fibre_model": model}})

    with caplog.at_level("WARNING", logger="whisker_opt.wiring"):
        assert wiring.warn_smeared_on_one_layer(cfg("default"))
    assert "fidelity.preset fine" in caplog.text
    assert not wiring.warn_smeared_on_one_layer(cfg("fine"))
    assert not wiring.warn_smeared_on_one_layer(cfg("default", "embedded"))
