"""Nodal post-processing of TET10 fields (fem.post) against closed forms.

A displacement linear in X, u = (F - I) X, is reproduced exactly by the P2 interpolation,
so every node carries F, on straight and on curved elements; its log strain and the
neo-Hookean von Mises stress then have closed forms.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem import element, post, query
from fem.material import ElementwiseMaterial, NeoHookean, Yeoh, von_mises_stress
from fem.mesh import TetMesh
from fem.meshgen import box_mesh, map_mesh


def _rot_x(th: float) -> np.ndarray:
    return np.array([[1, 0, 0], [0, math.cos(th), -math.sin(th)], [0, math.sin(th), math.cos(th)]])


def _rot_z(th: float) -> np.ndarray:
    return np.array([[math.cos(th), -math.sin(th), 0], [math.sin(th), math.cos(th), 0], [0, 0, 1]])


def _shear(g: float) -> np.ndarray:
    return np.array([[1.0, g, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def _uniaxial(lam: float) -> np.ndarray:
    return np.diag([lam, lam**-0.5, lam**-0.5])


MESHES = {
    "box": box_mesh(2.0, 1.0, 1.0, 2, 1, 1),
    "distorted": box_mesh(1.0, 1.0, 1.0, 2, 2, 2, distort=0.2, seed=3),
    "curved": map_mesh(
        box_mesh(1.0, 1.0, 1.0, 2, 2, 2),
        lambda p: np.c_[p[:, 0] * (1 + 0.3 * p[:, 1] ** 2), p[:, 1], p[:, 2] + 0.2 * np.sin(3 * p[:, 0])],
    ),
}
HOMOGENEOUS = {
    "uniaxial": _uniaxial(1.4),
    "shear": _shear(0.6),
    "rotated_stretch": _rot_z(0.5) @ np.diag([1.3, 0.9, 1.1]),
}


@pytest.mark.parametrize("mesh_name", MESHES)
@pytest.mark.parametrize("f_name", HOMOGENEOUS)
def test_nodal_F_of_a_homogeneous_deformation_is_exact(mesh_name, f_name):
    m, F = MESHES[mesh_name], HOMOGENEOUS[f_name]
    u = m.points @ (F - np.eye(3)).T
    Fn, used = post.nodal_deformation_gradient(m.points, m.cells, u)
    assert used.all() and Fn.shape == (m.n_nodes, 3, 3)
    np.testing.assert_allclose(Fn, np.broadcast_to(F, Fn.shape), atol=1e-12)


def test_nodal_F_of_one_element_equals_the_point_query():
    """Without averaging (one element), the nodal F of a quadratic field is the element's F at its nodes."""
    rng = np.random.default_rng(0)
    X = element.NODES + 0.05 * rng.standard_normal((10, 3))
    m = TetMesh(X, np.arange(10)[None, :])
    u = 0.1 * rng.standard_normal((10, 3))
    Fn, used = post.nodal_deformation_gradient(m.points, m.cells, u)
    Fq = query.deformation_gradient_at(m, u, np.zeros(10, dtype=np.int64), element.NODES)
    assert used.all()
    np.testing.assert_allclose(Fn, Fq, atol=1e-12)


def test_unused_nodes_are_flagged_and_nan():
    m = box_mesh(1.0, 1.0, 1.0, 1, 1, 1)
    pts = np.vstack([m.points, [[5.0, 5.0, 5.0]]])  # a node no cell uses
    u = np.zeros_like(pts)
    u[:, 0] = 0.2 * pts[:, 0]
    F, used = post.nodal_deformation_gradient(pts, m.cells, u)
    assert used[:-1].all() and not used[-1] and len(F) == len(pts) - 1
    le = post.axial_log_strain(pts, m.cells, u)
    assert np.isnan(le[-1])
    np.testing.assert_allclose(le[:-1], math.log(1.2), atol=1e-12)
    full = post.spread_to_nodes(F, used, fill=0.0)
    assert full.shape == (len(pts), 3, 3) and not full[-1].any()


def test_log_strain_closed_forms():
    lam = 1.4
    np.testing.assert_allclose(post.eulerian_log_strain(_uniaxial(lam)[None])[0],
                               np.diag([1.0, -0.5, -0.5]) * math.log(lam), atol=1e-14)
    R = _rot_x(0.7)
    np.testing.assert_allclose(post.eulerian_log_strain(R[None])[0], 0.0, atol=1e-14)  # no strain in a rotation
    # Eulerian: ln(V) of R·U is R ln(U) Rᵀ
    U = np.diag([1.3, 0.9, 1.1])
    np.testing.assert_allclose(post.eulerian_log_strain((R @ U)[None])[0], R @ np.diag(np.log([1.3, 0.9, 1.1])) @ R.T,
                               atol=1e-14)
    # simple shear γ: principal stretch λ = γ/2 + sqrt(1 + γ²/4); ln V in the xy plane is
    # ln λ / sqrt(γ² + 4) · [[γ, 2], [2, -γ]], and zero along z
    g = 0.6
    lp = math.log(g / 2 + math.sqrt(1 + g * g / 4))
    expected = lp / math.sqrt(g * g + 4) * np.array([[g, 2.0, 0.0], [2.0, -g, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(post.eulerian_log_strain(_shear(g)[None])[0], expected, atol=1e-14)


def test_axial_log_strain_on_a_mesh():
    m = MESHES["curved"]
    for axis in range(3):
        F = np.eye(3)
        F[axis, axis] = 1.25
        np.testing.assert_allclose(post.axial_log_strain(m.points, m.cells, m.points @ (F - np.eye(3)).T, axis=axis),
                                   math.log(1.25), atol=1e-12)
    # stretch λ along x, then a rotation θ about z: LE_xx = ln λ cos² θ
    lam, th = 1.3, 0.5
    F = _rot_z(th) @ np.diag([lam, 1.0, 1.0])
    np.testing.assert_allclose(post.axial_log_strain(m.points, m.cells, m.points @ (F - np.eye(3)).T),
                               math.log(lam) * math.cos(th) ** 2, atol=1e-12)


def test_von_mises_closed_forms():
    c10 = 0.14
    lam, g = 1.4, 0.6
    F = np.stack([_uniaxial(lam), _shear(g), _rot_x(0.7) @ _uniaxial(lam), 1.2 * np.eye(3), 1.1 * _uniaxial(lam)])
    vm = NeoHookean(c10).von_mises(F)
    uniaxial = 2 * c10 * (lam**2 - 1 / lam)
    np.testing.assert_allclose(vm, [
        uniaxial,
        2 * c10 * g * math.sqrt(3 + g * g),  # incompressible simple shear
        uniaxial,  # a superposed rotation changes nothing
        0.0,  # a pure dilation has no deviatoric stress
        1.1**-3 * uniaxial,  # J^(-5/3) dev(B) scales by s² · s⁻⁵ under F -> s F
    ], rtol=1e-12, atol=1e-14)


def test_von_mises_of_a_sheared_mesh():
    m, c10, g = MESHES["distorted"], 0.2, 0.3
    u = m.points @ (_shear(g) - np.eye(3)).T  # u = (γ y, 0, 0)
    F, used = post.nodal_deformation_gradient(m.points, m.cells, u)
    np.testing.assert_allclose(NeoHookean(c10).von_mises(F), 2 * c10 * g * math.sqrt(3 + g * g), rtol=1e-12)


# ------------------------------------------------------------------ Cauchy stress of the mixed u–p law at the nodes
def _uniaxial_pressure(lam: float, c10: float) -> float:
    """p making the lateral stress of an incompressible uniaxial stretch λ zero: 2 C10 (I1/3 - 1/λ)."""
    return 2 * c10 * ((lam**2 + 2 / lam) / 3 - 1 / lam)


def test_cauchy_stress_uniaxial_closed_form():
    """Incompressible uniaxial tension, laterally free: σ_xx = 2 C10 (λ² − 1/λ), all else 0."""
    c10 = 0.14
    for lam in (0.7, 1.0, 1.4, 2.5):
        p = _uniaxial_pressure(lam, c10)
        sigma = NeoHookean(c10).cauchy_stress(_uniaxial(lam)[None], np.array([p]))[0]
        np.testing.assert_allclose(sigma, np.diag([2 * c10 * (lam**2 - 1 / lam), 0.0, 0.0]), atol=1e-14)
        assert np.trace(sigma) / 3 == pytest.approx(p, abs=1e-14)  # p is the mean stress, > 0 in tension
        assert von_mises_stress(sigma[None])[0] == pytest.approx(abs(2 * c10 * (lam**2 - 1 / lam)), abs=1e-14)
    # a rotation superposed on it rotates σ: R σ Rᵀ
    lam, R = 1.4, _rot_x(0.7) @ _rot_z(0.3)
    sigma = NeoHookean(c10).cauchy_stress((R @ _uniaxial(lam))[None], _uniaxial_pressure(lam, c10))[0]
    np.testing.assert_allclose(sigma, R @ np.diag([2 * c10 * (lam**2 - 1 / lam), 0, 0]) @ R.T, atol=1e-14)
    # a rigid rotation leaves the pressure alone
    np.testing.assert_allclose(NeoHookean(c10).cauchy_stress(R[None], -0.3)[0], -0.3 * np.eye(3), atol=1e-14)


@pytest.mark.parametrize("f_name", [*HOMOGENEOUS, "dilated"])
def test_cauchy_stress_equals_the_material_stress(f_name):
    """σ = J⁻¹ (P_iso + p J F⁻ᵀ) Fᵀ with P_iso of fem.material.NeoHookean, the stress the solver
    assembles at its quadrature points (fem.assembly); on a curved mesh the nodal σ of a
    homogeneous deformation with one pressure in every element is that σ at every node."""
    c10, p = 0.17, -0.042
    F = 1.07 * _uniaxial(1.2) if f_name == "dilated" else HOMOGENEOUS[f_name]
    J, G = np.linalg.det(F), np.linalg.inv(F)
    P_iso, _ = NeoHookean(c10).stress_tangent(F[None], G[None], np.array([J]), need_tangent=False)
    P = P_iso[0] + p * J * G.T
    expected = P @ F.T / J
    np.testing.assert_allclose(NeoHookean(c10).cauchy_stress(F[None], p)[0], expected, atol=1e-14)
    m = MESHES["curved"]
    u = m.points @ (F - np.eye(3)).T
    le, sigma = post.nodal_strain_stress(m.points, m.cells, u, np.full(m.n_elements, p), NeoHookean(c10))
    np.testing.assert_allclose(sigma, np.broadcast_to(expected, sigma.shape), atol=1e-12)
    np.testing.assert_allclose(le, np.broadcast_to(post.eulerian_log_strain(F[None])[0], le.shape), atol=1e-12)
    # von Mises does not see the pressure
    np.testing.assert_allclose(von_mises_stress(sigma), NeoHookean(c10).von_mises(np.broadcast_to(F, sigma.shape)),
                               rtol=1e-12, atol=1e-14)


def test_displacement_formulation_pressure():
    """With the displacement formulation the pressure is 2 (J − 1) / D1 (fem.assembly)."""
    m, c10, d1 = MESHES["box"], 0.14, 0.5
    s = 1.05
    u = m.points * (s - 1.0)  # pure dilation: σ = 2 (J − 1)/D1 I
    _, sigma = post.nodal_strain_stress(m.points, m.cells, u, None, NeoHookean(c10, d1), formulation="displacement")
    np.testing.assert_allclose(sigma, np.broadcast_to(2 * (s**3 - 1) / d1 * np.eye(3), sigma.shape), atol=1e-12)
    with pytest.raises(ValueError, match="D1 > 0"):
        post.nodal_strain_stress(m.points, m.cells, u, None, NeoHookean(c10, 0.0), formulation="displacement")
    with pytest.raises(ValueError, match="element pressures"):
        post.nodal_strain_stress(m.points, m.cells, u, None, NeoHookean(c10))


def test_element_to_nodes_and_symmetric_components():
    m = MESHES["distorted"]
    np.testing.assert_allclose(post.element_to_nodes(m.cells, np.full(m.n_elements, 0.3), m.n_nodes), 0.3, atol=1e-15)
    # a node's value is the mean over its elements
    vals = np.arange(m.n_elements, dtype=float)
    node = int(m.cells[0, 0])
    holders = np.nonzero((m.cells == node).any(axis=1))[0]
    assert post.element_to_nodes(m.cells, vals, m.n_nodes)[node] == pytest.approx(vals[holders].mean())
    assert np.isnan(post.element_to_nodes(m.cells, vals, m.n_nodes + 1)[-1])  # a node no cell uses
    T = np.array([[[11, 12, 13], [12, 22, 23], [13, 23, 33]]], dtype=float)
    np.testing.assert_array_equal(post.symmetric_components(T)[0], [11, 22, 33, 12, 23, 13])
    assert post.SYMMETRIC_COMPONENTS == ("XX", "YY", "ZZ", "XY", "YZ", "XZ")


def test_cauchy_stress_of_a_yeoh_law_and_of_two_laws_by_element():
    """Any Ī1 law: σ = 2 f'(Ī1) J^(-5/3) dev B + p I equals J⁻¹ P Fᵀ of the material's own stress, at
    every node of a homogeneously deformed mesh; with one law per element group a node takes the
    law of the lowest group among its elements."""
    F = np.array([[1.3, 0.1, 0.0], [0.05, 0.9, 0.02], [0.0, -0.03, 0.86]])
    J, G = np.linalg.det(F), np.linalg.inv(F)
    yeoh, p = Yeoh((0.145, 6.07e-3, 1e-4)), -0.02

    def expected(law):
        P_iso = law.stress_tangent(F[None], G[None], np.array([J]), need_tangent=False)[0]
        return (P_iso[0] + p * J * G.T) @ F.T / J

    m = MESHES["curved"]
    u = m.points @ (F - np.eye(3)).T
    _, sigma = post.nodal_strain_stress(m.points, m.cells, u, np.full(m.n_elements, p), yeoh)
    np.testing.assert_allclose(sigma, np.broadcast_to(expected(yeoh), sigma.shape), atol=1e-12)
    # incompressible uniaxial closed form: σ_xx − σ_yy = 2 f'(I1) (λ² − 1/λ), I1 = λ² + 2/λ
    lam = 1.7
    Fu = np.diag([lam, lam ** -0.5, lam ** -0.5])
    i1 = lam ** 2 + 2 / lam
    s = yeoh.cauchy_stress(Fu[None], 0.0)[0]
    fprime = 0.145 + 2 * 6.07e-3 * (i1 - 3) + 3 * 1e-4 * (i1 - 3) ** 2
    assert s[0, 0] - s[1, 1] == pytest.approx(2 * fprime * (lam ** 2 - 1 / lam), rel=1e-12)
    # two laws: elements of group 1 everywhere but element 0
    soft = NeoHookean(0.04)
    groups = np.ones(m.n_elements, dtype=np.int64)
    groups[0] = 0
    mixed = ElementwiseMaterial((soft, yeoh), groups)
    _, sig2 = post.nodal_strain_stress(m.points, m.cells, u, np.full(m.n_elements, p), mixed)
    in0 = np.zeros(m.n_nodes, dtype=bool)
    in0[m.cells[0]] = True
    np.testing.assert_allclose(sig2[in0], np.broadcast_to(expected(soft), sig2[in0].shape), atol=1e-12)
    np.testing.assert_allclose(sig2[~in0], np.broadcast_to(expected(yeoh), sig2[~in0].shape), atol=1e-12)


def _neo_hookean_pk2(c10: float, F: np.ndarray) -> np.ndarray:
    """Isochoric second Piola–Kirchhoff stress of the neo-Hookean law, S̄ = 2 C10 J^(-2/3) (I − (I1/3) C⁻¹)."""
    C = F.T @ F
    return 2 * c10 * np.linalg.det(F) ** (-2 / 3) * (np.eye(3) - np.trace(C) / 3 * np.linalg.inv(C))


def test_problem_stress_is_the_scaled_law_with_its_frozen_stress():
    """fem.post.problem_strain_stress of a homogeneous deformation: σ = J⁻¹ F (s S̄ + T) Fᵀ + p I at every
    node, s and T the means over the node's elements (elements without them counting with s = 1,
    T = 0); a frozen stress given at the nodes is taken as given; without frozen stresses the stress
    is nodal_strain_stress of the material to the bit."""
    from fem.material import ScaledMaterial
    from fem.problem import FrozenStress, Problem

    m, c10, p, c = MESHES["distorted"], 0.21, -0.03, 1.6
    F = np.array([[1.3, 0.1, 0.0], [0.05, 0.9, 0.02], [0.0, -0.03, 0.86]])
    J = np.linalg.det(F)
    T = np.array([[0.02, -0.01, 0.005], [-0.01, -0.04, 0.0], [0.005, 0.0, 0.03]])
    u, pe = m.points @ (F - np.eye(3)).T, np.full(m.n_elements, p)

    def expected(s, t):
        return F @ (s * _neo_hookean_pk2(c10, F) + t) @ F.T / J + p * np.eye(3)

    law = NeoHookean(c10)
    plain = Problem(m, law)
    np.testing.assert_array_equal(post.problem_strain_stress(plain, u, pe)[1],
                                  post.nodal_strain_stress(m.points, m.cells, u, pe, law)[1])
    every = np.arange(m.n_elements)
    scaled = Problem(m, ScaledMaterial(law, np.full(m.n_elements, c)),
                     frozen_stresses=(FrozenStress(every, np.broadcast_to(T, (m.n_elements, 4, 3, 3))),))
    sigma = post.problem_strain_stress(scaled, u, pe)[1]
    np.testing.assert_allclose(sigma, np.broadcast_to(expected(c, T), sigma.shape), atol=1e-12)
    # the law on element 0 alone: a node of element 0 shared with k others takes s = (c + k)/(k + 1)
    one = np.array([0])
    factor = np.ones(m.n_elements)
    factor[0] = c
    part = Problem(m, ScaledMaterial(law, factor), frozen_stresses=(FrozenStress(one, np.broadcast_to(T, (1, 4, 3, 3))),))
    sigma = post.problem_strain_stress(part, u, pe)[1]
    held = np.bincount(m.cells.ravel(), minlength=m.n_nodes)  # (n_nodes,) elements per node
    for node in range(m.n_nodes):
        w = 1.0 / held[node] if node in m.cells[0] else 0.0
        np.testing.assert_allclose(sigma[node], expected(1 + w * (c - 1), w * T), atol=1e-12)
    assert np.abs(sigma[m.cells[0]] - expected(1.0, 0 * T)).max() > 1e-3  # element 0's nodes do feel the law
    # a frozen stress given at the nodes is the one used
    nodal = np.zeros((m.n_nodes, 3, 3))
    nodal[m.cells[0]] = T
    given = Problem(m, law, frozen_stresses=(FrozenStress(one, np.zeros((1, 4, 3, 3)), nodal=nodal),))
    sigma = post.problem_strain_stress(given, u, pe)[1]
    np.testing.assert_allclose(sigma[m.cells[0]], np.broadcast_to(expected(1.0, T), (10, 3, 3)), atol=1e-12)


@pytest.mark.parametrize("degree", [2, 3])
def test_frozen_stress_at_nodes_is_exact_for_a_linear_field(degree):
    """A frozen stress linear in X, T(X) = A + X_k B_k, known at the points of a tet rule, goes to the
    nodes of straight-sided elements exactly (the linear fit through the points); a rule of fewer
    than 4 points is refused."""
    from fem.problem import FrozenStress
    from fem.quadrature import tet_rule

    m = MESHES["box"]
    rng = np.random.default_rng(5)
    A, B = rng.standard_normal((3, 3)), rng.standard_normal((3, 3, 3))
    A, B = A + A.T, B + np.swapaxes(B, -1, -2)

    def field(X):
        return A + np.einsum("...k,kij->...ij", X, B)  # (..., 3, 3)

    qp = tet_rule(degree).points
    Xq = np.einsum("qa,eai->eqi", element.shape_functions(qp), m.points[m.cells])  # (n_el, n_qp, 3)
    fs = FrozenStress(np.arange(m.n_elements), field(Xq))
    np.testing.assert_allclose(post.frozen_stress_at_nodes(m.cells, [fs], qp, m.n_nodes), field(m.points),
                               atol=1e-12)
    with pytest.raises(ValueError, match="at least 4"):
        post.quadrature_to_nodes(tet_rule(1).points)
