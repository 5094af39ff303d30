"""Verification of the TET10 element, its isoparametric mapping and the quadrature rules.

References
----------
* Zienkiewicz & Taylor, *The Finite Element Method*, vol. 1, §6.7: TET10 shape functions
  are interpolatory (N_a(ξ_b) = δ_ab), sum to one and reproduce quadratic polynomials.
* Closed-form simplex moments (e.g. Stroud 1971, §8.7): on the unit tetrahedron
  ∫ x^a y^b z^c dV = a! b! c! / (a + b + c + 3)!, on the unit triangle
  ∫ x^a y^b dA = a! b! / (a + b + 2)!.
* Volume of a tube sector: V = (θ/2)(r_out² − r_in²)·h.
"""

from __future__ import annotations

from math import factorial

import numpy as np
import pytest

from fem import element
from fem.mesh import volumes
from fem.meshgen import tube_sector_mesh
from fem.quadrature import tet_rule, tri_rule

RNG = np.random.default_rng(20240603)


def _random_tet_points(n: int) -> np.ndarray:
    """Uniform random points inside the reference tetrahedron, shape (n, 3)."""
    lam = RNG.dirichlet(np.ones(4), size=n)  # (n, 4) barycentric
    return lam[:, 1:]


def _random_tri_points(n: int) -> np.ndarray:
    lam = RNG.dirichlet(np.ones(3), size=n)  # (n, 3)
    return lam[:, 1:]


# --------------------------------------------------------------------------- shape functions
def test_tet10_shape_functions_are_nodal():
    """N_a(ξ_b) = δ_ab at the ten nodes (Zienkiewicz & Taylor vol. 1, §6.7)."""
    N = element.shape_functions(element.NODES)  # (10, 10)
    np.testing.assert_allclose(N, np.eye(10), atol=1e-15)


def test_tet10_partition_of_unity_and_gradients():
    """Σ_a N_a = 1 and Σ_a ∇N_a = 0 everywhere (rigid-body/partition-of-unity property)."""
    xi = _random_tet_points(200)
    N = element.shape_functions(xi)  # (200, 10)
    dN = element.shape_gradients(xi)  # (200, 10, 3)
    np.testing.assert_allclose(N.sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(dN.sum(axis=1), 0.0, atol=1e-13)


def test_tet10_reproduces_quadratics():
    """Σ_a N_a(ξ) q(ξ_a) = q(ξ) for every complete quadratic q (P2 completeness)."""
    xi = _random_tet_points(100)
    N = element.shape_functions(xi)
    X = element.NODES

    def q(p):
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        return 0.3 - 1.1 * x + 0.7 * y + 2.0 * z + x * x - 0.4 * y * y + 1.3 * z * z + 0.5 * x * y - 0.9 * y * z + 0.2 * x * z

    np.testing.assert_allclose(N @ q(X), q(xi), atol=1e-13)


def test_tet10_gradients_match_finite_differences():
    """shape_gradients = central differences of shape_functions (error O(h²) ≈ 1e-12)."""
    xi = _random_tet_points(20)
    dN = element.shape_gradients(xi)
    h = 1e-6
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        fd = (element.shape_functions(xi + e) - element.shape_functions(xi - e)) / (2 * h)
        np.testing.assert_allclose(dN[:, :, j], fd, atol=1e-8)


def test_tri6_shape_functions_nodal_unity_gradients():
    """TRI6: N_a(s_b) = δ_ab, Σ N_a = 1, gradients match central differences."""
    np.testing.assert_allclose(element.tri6_shape_functions(element.TRI6_NODES), np.eye(6), atol=1e-15)
    s = _random_tri_points(50)
    np.testing.assert_allclose(element.tri6_shape_functions(s).sum(axis=1), 1.0, atol=1e-14)
    dN = element.tri6_shape_gradients(s)
    h = 1e-6
    for j in range(2):
        e = np.zeros(2)
        e[j] = h
        fd = (element.tri6_shape_functions(s + e) - element.tri6_shape_functions(s - e)) / (2 * h)
        np.testing.assert_allclose(dN[:, :, j], fd, atol=1e-8)


def test_faces_are_outward_and_consistent_with_tri6():
    """Each of FACES (Abaqus S1..S4) has (x_b − x_a)×(x_c − x_a) pointing away from the opposite vertex,
    and its mid-edge nodes are the midpoints of (ab, bc, ca) as the TRI6 node order requires."""
    X = element.NODES
    for f in element.FACES:
        a, b, c = X[f[0]], X[f[1]], X[f[2]]
        n = np.cross(b - a, c - a)
        opposite = [v for v in range(4) if v not in f[:3]][0]
        assert np.dot(n, X[opposite] - a) < 0
        np.testing.assert_allclose(X[f[3:]], 0.5 * (X[f[[0, 1, 2]]] + X[f[[1, 2, 0]]]), atol=0)


# --------------------------------------------------------------------------- quadrature
def _tet_moment(a: int, b: int, c: int) -> float:
    """∫_T x^a y^b z^c dV = a! b! c! / (a+b+c+3)! on the unit tetrahedron."""
    return factorial(a) * factorial(b) * factorial(c) / factorial(a + b + c + 3)


def _tri_moment(a: int, b: int) -> float:
    """∫_T x^a y^b dA = a! b! / (a+b+2)! on the unit triangle."""
    return factorial(a) * factorial(b) / factorial(a + b + 2)


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5, 6, 8])
def test_tet_rule_exact_for_monomials(degree):
    """tet_rule(d) integrates every monomial of total degree ≤ d exactly (simplex moment formula)."""
    rule = tet_rule(degree)
    assert rule.degree >= degree
    assert np.all(rule.weights > 0)
    assert np.all(element.barycentric(rule.points) >= -1e-14)  # points inside the tet
    x, y, z = rule.points.T
    for a in range(degree + 1):
        for b in range(degree + 1 - a):
            for c in range(degree + 1 - a - b):
                exact = _tet_moment(a, b, c)
                got = np.dot(rule.weights, x**a * y**b * z**c)
                assert abs(got - exact) <= 1e-13 * max(exact, 1e-3), (a, b, c, got, exact)


def test_tet_rule_degree2_is_not_degree3():
    """The 4-point rule is exactly degree 2: it misses ∫ x³ (sanity check that the test can fail)."""
    rule = tet_rule(2)
    x = rule.points[:, 0]
    assert abs(np.dot(rule.weights, x**3) - _tet_moment(3, 0, 0)) > 1e-5


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5, 6, 8])
def test_tri_rule_exact_for_monomials(degree):
    """tri_rule(d) integrates every monomial of total degree ≤ d exactly (simplex moment formula)."""
    rule = tri_rule(degree)
    assert np.all(rule.weights > 0)
    x, y = rule.points.T
    for a in range(degree + 1):
        for b in range(degree + 1 - a):
            exact = _tri_moment(a, b)
            got = np.dot(rule.weights, x**a * y**b)
            assert abs(got - exact) <= 1e-13 * max(exact, 1e-3), (a, b, got, exact)


# --------------------------------------------------------------------------- isoparametric mapping
def test_curved_tube_sector_volume_converges():
    """Volume of a curved P2 tube sector → (θ/2)(r_out² − r_in²) h at the isoparametric rate.

    With the mid-edge nodes on the circular arcs, the quadratic interpolation of a
    circle of chord angle Δφ has a radial error O(Δφ⁴) (the P2 geometric error), so
    halving Δφ should cut the volume error by ≈ 16; the mapping is curved (the P2
    volume differs from the straight-edged one) and exactly integrated by
    ``volumes`` (det J is a cubic polynomial, degree-3 rule).
    """
    r_in, r_out, h, theta = 1.0, 2.0, 0.5, np.pi / 2
    exact = 0.5 * theta * (r_out**2 - r_in**2) * h
    errs = []
    for n_t in (2, 4, 8):
        m = tube_sector_mesh(r_in, r_out, h, 2, n_t, 1, theta)
        v = volumes(m.points, m.cells)
        assert np.all(v > 0)
        errs.append(abs(v.sum() - exact) / exact)
        # the straight-edged volume (vertices only) has an O(Δφ²) error, much larger
        x = m.points[m.cells[:, :4]]
        v_lin = np.linalg.det(x[:, 1:] - x[:, :1]).sum() / 6.0
        assert abs(v_lin - exact) / exact > 10 * errs[-1]
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert errs[-1] < 1e-5
    assert np.all(rates > 3.5), (errs, rates)


def test_curved_element_mapping_matches_exact_map():
    """Σ N_a(ξ) X_a of a curved sector element lies on the exact cylindrical map to O(Δφ³).

    Reference: the box-space point mapped by r = r_in + (r_out − r_in)p₁, φ = θp₂.
    The interpolant of a smooth map by P2 is third-order accurate in the element size.
    """
    from fem.meshgen import box_mesh

    r_in, r_out, h, theta = 1.0, 2.0, 1.0, np.pi / 2
    errs = []
    for n in (2, 4, 8):
        base = box_mesh(1.0, 1.0, 1.0, n, n, n)
        m = tube_sector_mesh(r_in, r_out, h, n, n, n, theta)
        xi = _random_tet_points(5)
        N = element.shape_functions(xi)  # (5, 10)
        pb = np.einsum("qa,eai->eqi", N, base.points[base.cells]).reshape(-1, 3)  # box-space points
        xm = np.einsum("qa,eai->eqi", N, m.points[m.cells]).reshape(-1, 3)
        r = r_in + (r_out - r_in) * pb[:, 0]
        phi = theta * pb[:, 1]
        xe = np.stack([r * np.cos(phi), r * np.sin(phi), h * pb[:, 2]], axis=1)
        errs.append(np.abs(xm - xe).max())
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 2.7), (errs, rates)
