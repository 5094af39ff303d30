"""Bonded membrane (fem.membrane): energy, residual, tangent, rigid motions and a bar with a bonded strip.

References: Π_m = ∫ t W(E_s) dA0 with the plane-stress Saint Venant–Kirchhoff W (docstring of fem.membrane);
the residual is checked against central differences of the energy and the tangent against central
differences of the residual (≤ 1e-6 relative, as tests/test_fem_tangent.py) on the curved outer faces of a
tube sector.

The bar: a prismatic L × b × h rubber bar (Young's modulus E_r, Poisson ratio ν_r, section A = b h) with a
sheet of thickness t, modulus E_p and Poisson ratio ν_p bonded over its whole face z = h (width w = b), its
ends pulled apart by a uniform axial displacement δ. The homogeneous strain ε = δ/L along x is an exact
solution when the sheet's lateral strain and the bar's agree:

* free lateral contraction: the bar contracts by −ν_r ε across, so the sheet is in uniaxial stress only when
  ν_p = ν_r; then σ_p = E_p ε and the axial force is the rule of mixtures N = (E_r A + E_p t w) ε;
* laterally constrained (u_y = 0 everywhere: plane strain across the width): the bar carries
  σ_x = E_r ε/(1 − ν_r²) (σ_z = 0) and the sheet, held at ε_y = 0, σ_x = E_p ε/(1 − ν_p²), so
  N = (E_r A/(1 − ν_r²) + E_p t w/(1 − ν_p²)) ε for any ν_p: the plane-stress modulus applies when the
  strip cannot contract sideways.

Between the two (ν_p ≠ ν_r, free lateral contraction) the homogeneous state is no solution: the sheet pulls
its face sideways against the bar and neither modulus is exact. At ε = 1e-5 the nonlinear solution matches
the small-strain forces to O(ε).
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.assembly import Assembler
from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.membrane import MembraneKernel
from fem.mesh import boundary_faces
from fem.meshgen import box_mesh, tube_sector_mesh
from fem.problem import Dirichlet, Membrane, Problem, ProblemError
from fem.state import State
from tests.test_fem_tangent import _fd_jacobian, energy_gradient_fd

TOL = 1e-6


def _outer_faces(mesh, r_out: float) -> np.ndarray:
    _, _, f6 = boundary_faces(mesh.cells)
    r = np.linalg.norm(mesh.points[f6][:, :, :2], axis=2)
    return f6[np.all(np.isclose(r, r_out), axis=1)]


@pytest.fixture(scope="module")
def sector():
    """A quarter tube sector (r 1 to 1.5, height 1) and its curved outer faces r = 1.5."""
    mesh = tube_sector_mesh(1.0, 1.5, 1.0, 1, 2, 2)
    return mesh, _outer_faces(mesh, 1.5)


def _thickness(kernel: MembraneKernel) -> np.ndarray:
    """A thickness that varies over the faces' quadrature points (and vanishes at some)."""
    z = kernel.points[..., 2]  # (n_f, n_qp)
    return 0.05 * np.where(z > 0.8, 0.0, 1.0 + z)


def _random(n: int, seed: int, scale: float) -> np.ndarray:
    return scale * np.random.default_rng(seed).standard_normal((n, 3))


def test_rigid_motion_stores_nothing(sector):
    """x = Q X + c (a finite rotation of 0.7 rad about a skew axis): E_s = 0, Π_m = 0 and R = 0 to round-off,
    while a stretch of 1 % stores t A0 W of the uniform strain on the flat limit's order."""
    mesh, faces = sector
    mk = MembraneKernel(mesh.points, faces)
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    Kx = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    Q = np.eye(3) + np.sin(0.7) * Kx + (1 - np.cos(0.7)) * Kx @ Kx
    x = mesh.points @ Q.T + np.array([0.3, -1.0, 2.0])
    t, Y, nu = 0.05, 200.0, 0.3
    assert np.abs(mk.strain(x)).max() < 1e-13
    assert abs(mk.energy(x, t, Y, nu)) < 1e-25
    R, _ = mk.evaluate(x, t, Y, nu, False)
    assert np.abs(R).max() < 1e-12 * Y * t
    # uniform dilation x = 1.01 X: E_s = ½ (1.01² − 1) I_2 on every face, W = (μ + λ̂) (tr E_s)²/2 · ... closed form
    e = 0.5 * (1.01**2 - 1.0)
    lam, mu = Y * nu / (1 - nu**2), Y / (2 * (1 + nu))
    W = mu * 2 * e**2 + 0.5 * lam * (2 * e) ** 2
    area = mk.wdA.sum()
    np.testing.assert_allclose(mk.strain(1.01 * mesh.points), np.broadcast_to(e * np.eye(2), (*mk.wdA.shape, 2, 2)),
                               atol=1e-14)
    assert mk.energy(1.01 * mesh.points, t, Y, nu) == pytest.approx(t * area * W, rel=1e-12)
    assert area == pytest.approx(0.5 * np.pi * 1.5 * 1.0, rel=1e-3)  # quarter of the cylinder r = 1.5, height 1


def test_residual_is_membrane_energy_gradient(sector):
    """R = ∂Π/∂x with Π including ∫ t W(E_s) dA0 (Assembler.energy), by central differences, thickness varying
    over the quadrature points."""
    mesh, faces = sector
    t = _thickness(MembraneKernel(mesh.points, faces))
    prob = Problem(mesh, NeoHookean(0.5, 0.2), membranes=(Membrane(faces, t, 200.0, 0.3),))
    asm = Assembler(prob)
    u, p = _random(mesh.n_nodes, 5, 0.05), 0.3 * np.random.default_rng(6).standard_normal(mesh.n_elements)
    R = asm.evaluate(u, p, (), False)[0]
    g = energy_gradient_fd(asm, u, p)
    assert np.abs(g - R).max() <= TOL * np.abs(R).max()


@pytest.mark.parametrize("kernel", ["auto", "numpy"])
def test_membrane_tangent_matches_fd(sector, kernel):
    """The assembled tangent equals the central-difference Jacobian of the residual (curved faces, random
    state, both element kernels); the membrane's part is not negligible in the check and is symmetric."""
    mesh, faces = sector
    mat = NeoHookean(0.5, 0.2)
    t = _thickness(MembraneKernel(mesh.points, faces))
    prob = Problem(mesh, mat, membranes=(Membrane(faces, t, 5000.0, 0.3),))
    asm, asm0 = Assembler(prob, kernel), Assembler(Problem(mesh, mat), kernel)
    u, p = _random(mesh.n_nodes, 7, 0.05), 0.3 * np.random.default_rng(8).standard_normal(mesh.n_elements)
    x = np.concatenate([u.ravel(), p])
    n_u = prob.n_u

    def res(v):
        return asm.evaluate(v[:n_u].reshape(-1, 3), v[n_u:], (), False)[0]

    K = asm.pattern.matrix(asm.evaluate(u, p, (), True)[1]).toarray()
    Kfd = _fd_jacobian(res, x)
    assert np.abs(K - Kfd).max() <= TOL * np.abs(K).max()
    Km = K - asm0.pattern.matrix(asm0.evaluate(u, p, (), True)[1]).toarray()
    assert np.abs(Km).max() > 0.1 * np.abs(K).max()
    assert np.abs(Km - Km.T).max() <= 1e-12 * np.abs(Km).max()


def _bar_force(nu_p: float, constrained: bool) -> tuple[float, float, float, float]:
    """Axial force of the bar with its sheet at ε = 1e-5 and the two rule-of-mixture forces (E_p, E_p/(1−ν²))
    and the bare bar's force, for the module docstring's bar (L = 3, b = h = 1, μ = 1, K = 10; t = 0.002,
    E_p = 1000, so E_p t w = 2 against E_r A = 2.90)."""
    L, b, h, mu, K = 3.0, 1.0, 1.0, 1.0, 10.0
    t, Ep, eps = 0.002, 1000.0, 1e-5
    mesh = box_mesh(L, b, h, 3, 2, 2)
    X = mesh.points
    _, _, f6 = boundary_faces(mesh.cells)
    top = f6[np.all(np.isclose(X[f6][:, :, 2], h), axis=1)]
    left, right = np.nonzero(np.isclose(X[:, 0], 0.0))[0], np.nonzero(np.isclose(X[:, 0], L))[0]
    held_y = np.arange(mesh.n_nodes) if constrained else np.nonzero(np.isclose(X[:, 1], b / 2))[0]
    bottom = np.nonzero(np.isclose(X[:, 2], 0.0))[0]
    dirichlet = (Dirichlet(left, (0,), "left"), Dirichlet(right, (0,), "right"), Dirichlet(held_y, (1,), "y"),
                 Dirichlet(bottom, (2,), "z"))
    prob = Problem(mesh, NeoHookean(mu / 2, 2.0 / K), dirichlet=dirichlet,
                   membranes=(Membrane(top, t, Ep, nu_p, "strip"),))
    load = LoadState((), (0.0, eps * L, 0.0, 0.0))
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob), load, fractions=(1.0,))
    s = states[-1]
    R = Assembler(prob).evaluate(s.u, s.p, (), False)[0]
    N = float(R[3 * right].sum())
    Er = 9 * K * mu / (3 * K + mu)
    nu_r = (3 * K - 2 * mu) / (2 * (3 * K + mu))
    if constrained:
        return N, (Er * b * h / (1 - nu_r**2) + Ep * t * b / (1 - nu_p**2)) * eps, Ep * t * b * eps, nu_r
    return N, (Er * b * h + Ep * t * b) * eps, Er * b * h * eps, nu_r


def test_bar_with_bonded_strip_free_lateral_is_the_rule_of_mixtures():
    """ν_p = ν_r (= 14/31 for K/μ = 10), lateral contraction free: N = (E_r A + E_p t w) ε within 1e-4."""
    nu_r = (30.0 - 2.0) / (2 * 31.0)
    N, expected, bare, _ = _bar_force(nu_r, constrained=False)
    assert N == pytest.approx(expected, rel=1e-4)
    assert N > 1.5 * bare  # the strip carries 41 % of the force


def test_bar_with_bonded_strip_laterally_held_takes_the_plane_stress_modulus():
    """u_y = 0 everywhere, ν_p = 0.34: N = (E_r A/(1 − ν_r²) + E_p t w/(1 − ν_p²)) ε within 1e-4, which
    differs from the uniaxial E_p t w by 13 % of the strip's share, so the check tells the two apart."""
    N, expected, _, _ = _bar_force(0.34, constrained=True)
    assert N == pytest.approx(expected, rel=1e-4)
    uniaxial = expected - 2.0 * 1e-5 * (1.0 / (1 - 0.34**2) - 1.0)
    assert abs(N - uniaxial) > 50 * abs(N - expected)


def test_membrane_refuses_bad_input():
    faces = np.zeros((2, 6), np.int64)
    with pytest.raises(ProblemError, match=r"Membrane\(membrane\)\.poisson=0\.5: must be in \[0, 0\.5\)"):
        Membrane(faces, 0.01, 1000.0, 0.5)
    with pytest.raises(ProblemError, match=r"Membrane\(gauge\)\.youngs_modulus=0\.0: must be finite and > 0"):
        Membrane(faces, 0.01, 0.0, 0.3, "gauge")
    with pytest.raises(ProblemError, match=r"Membrane\(membrane\)\.thickness: must be finite and >= 0"):
        Membrane(faces, -0.01, 1000.0, 0.3)
    with pytest.raises(ProblemError, match=r"Membrane\(membrane\)\.thickness: shape \(3, 6\)"):
        Membrane(faces, np.ones((3, 6)), 1000.0, 0.3)
    mesh = box_mesh(1.0, 1.0, 1.0, 1, 1, 1)
    with pytest.raises(ProblemError, match="node index outside"):
        Problem(mesh, NeoHookean(0.5), membranes=(Membrane(faces + mesh.n_nodes, 0.01, 1000.0, 0.3),))
    _, _, f6 = boundary_faces(mesh.cells)
    with pytest.raises(ProblemError, match=r"thickness: 4 points per face, the triangle rule of degree 4 has 9"):
        Assembler(Problem(mesh, NeoHookean(0.5), membranes=(Membrane(f6[:2], np.ones((2, 4)), 1000.0, 0.3),)))
