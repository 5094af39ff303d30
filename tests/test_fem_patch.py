"""Patch tests: homogeneous deformations of a distorted, curved P2 patch reproduce exact neo-Hookean stresses.

Reference: closed-form homogeneous deformations (μ = 2 C10):

* incompressible uniaxial stretch λ:   σ11 = μ(λ² − 1/λ),  nominal P11 = μ(λ − 1/λ²);
* incompressible equibiaxial stretch λ: σ11 = σ22 = μ(λ² − λ⁻⁴);
* simple shear γ:                       σ12 = μγ,  σ11 − σ22 = μγ²;
* compressible W = C10(Ī1 − 3) + (J − 1)²/D1 (Abaqus form): Cauchy stress
  σ = (2 C10/J) (B̄ − (Ī1/3) I) + (2/D1)(J − 1) I with B̄ = J^{-2/3} F Fᵀ
  (Holzapfel 2000, eq. 6.105 with the volumetric derivative of (J − 1)²/D1); the
  free lateral stretch follows from the zero-traction condition, solved with scipy.

A homogeneous deformation u = (F − I)X lies in the P2 space of any (curved) isoparametric
mesh and its constant stress satisfies the weak equilibrium equations exactly, so the
discrete solution must reproduce it to round-off: ≤ 1e-8 relative.
Stresses are checked both as recovered quadrature-point stresses (P_iso + p J F⁻ᵀ) and
as reaction forces (the residual at prescribed DOFs).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from fem.assembly import Assembler
from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.mesh import TetMesh
from fem.meshgen import box_mesh
from fem.problem import Dirichlet, Problem
from fem.state import State

TOL = 1e-8  # patch-test stresses, relative
C10 = 0.5
MU = 2 * C10
D1 = 0.5  # K = 2/D1 = 4 MPa, ν ≈ 0.38 for the compressible cases


@pytest.fixture(scope="module")
def patch() -> TetMesh:
    """3×3×3-cell box with randomly moved interior vertices (straight-edged, distorted tets)."""
    return box_mesh(1.0, 1.0, 1.0, 3, 3, 3, distort=0.3, seed=7)


@pytest.fixture(scope="module")
def curved_patch() -> TetMesh:
    """The distorted patch with its interior mid-edge nodes also moved randomly: curved tets.

    For curved tets the integrand ∇_ξN · adj(∂X/∂ξ) of the weak equilibrium of a constant
    stress is a cubic polynomial in ξ, so the patch test is passed exactly only with a
    quadrature rule of degree ≥ 3 (the default 4-point rule, degree 2, leaves an O(1e-4)
    consistency error on this patch).
    """
    m = box_mesh(1.0, 1.0, 1.0, 3, 3, 3, distort=0.3, seed=7)
    X = m.points.copy()
    interior = np.all((X > 1e-9) & (X < 1 - 1e-9), axis=1)
    n_vert = int(m.cells[:, :4].max()) + 1
    mid = interior & (np.arange(len(X)) >= n_vert)
    rng = np.random.default_rng(3)
    X[mid] += 0.02 * rng.uniform(-1, 1, size=(int(mid.sum()), 3))
    return TetMesh(X, m.cells)


def _on(X, axis, value):
    return np.nonzero(np.isclose(X[:, axis], value, atol=1e-12))[0]


def _cauchy_exact(F: np.ndarray, c10: float, d1: float) -> np.ndarray:
    """σ = (2C10/J)(B̄ − Ī1/3 I) + (2/D1)(J − 1) I for compressible neo-Hookean."""
    J = np.linalg.det(F)
    Bbar = J ** (-2.0 / 3.0) * F @ F.T
    return 2 * c10 / J * (Bbar - np.trace(Bbar) / 3 * np.eye(3)) + 2.0 / d1 * (J - 1.0) * np.eye(3)


def _recovered_cauchy(problem: Problem, state: State) -> np.ndarray:
    """Cauchy stress P Fᵀ/J with P = P_iso + p J F⁻ᵀ at every quadrature point, shape (n_el, n_qp, 3, 3)."""
    asm = Assembler(problem)
    F, J, G = asm.deformation(state.u)
    P_iso, _ = problem.material.stress_tangent(F, G, J, need_tangent=False)
    P = P_iso + (state.p[:, None] * J)[..., None, None] * np.swapaxes(G, -1, -2)  # (n_el, n_qp, 3, 3)
    return np.einsum("eqiJ,eqkJ->eqik", P, F) / J[..., None, None]


def _solve(problem: Problem, values: tuple) -> State:
    states, _ = solve_path(problem, State.zero(problem), LoadState.zero(problem),
                           LoadState((), tuple(values)), fractions=(0.5, 1.0))
    return states[-1]


def _check(problem, state, F, sigma_ref, label):
    """FE nodal field = (F − I)X and recovered σ = σ_ref to TOL (relative to max|σ_ref|)."""
    X = problem.mesh.points
    u_ref = X @ (F - np.eye(3)).T
    du = np.abs(state.u - u_ref).max() / np.abs(u_ref).max()
    sig = _recovered_cauchy(problem, state)
    ds = np.abs(sig - sigma_ref).max() / np.abs(sigma_ref).max()
    print(f"{label}: max rel displacement error {du:.2e}, max rel stress error {ds:.2e}")
    assert du <= TOL
    assert ds <= TOL


def _reaction(problem, state, nodes, comp):
    """Σ of the residual (internal force) over prescribed DOFs = reaction force on that face."""
    R = Assembler(problem).evaluate(state.u, state.p, (), False)[0]
    return R[3 * nodes + comp].sum()


def _uniaxial_problem(mesh, material):
    X = mesh.points
    x1 = _on(X, 0, 1.0)
    sets = (Dirichlet(_on(X, 0, 0.0), (0,)), Dirichlet(_on(X, 1, 0.0), (1,)), Dirichlet(_on(X, 2, 0.0), (2,)),
            Dirichlet(x1, (0,)))
    return Problem(mesh, material, dirichlet=sets), x1


@pytest.mark.parametrize("lam", [1.5, 0.7])
def test_uniaxial_incompressible(patch, lam):
    """Uniaxial stretch λ, D1 = 0, symmetry BCs, free lateral faces: σ11 = μ(λ² − 1/λ),
    reaction on the unit end face = nominal stress μ(λ − 1/λ²) (VERIFICATION.md)."""
    prob, x1 = _uniaxial_problem(patch, NeoHookean(C10, 0.0))
    st = _solve(prob, (0.0, 0.0, 0.0, lam - 1.0))
    F = np.diag([lam, lam**-0.5, lam**-0.5])
    sigma = np.diag([MU * (lam**2 - 1 / lam), 0.0, 0.0])
    _check(prob, st, F, sigma, f"uniaxial incompressible λ={lam}")
    nominal = MU * (lam - lam**-2)
    assert abs(_reaction(prob, st, x1, 0) - nominal) <= TOL * abs(nominal)


@pytest.mark.parametrize("lam", [1.5, 0.7])
def test_uniaxial_compressible(patch, lam):
    """Uniaxial stretch λ, D1 > 0, free lateral faces: lateral stretch a from σ22(λ, a, a) = 0
    (brentq on the closed-form Cauchy stress), then σ11 and the nominal end force J σ11 / λ."""
    prob, x1 = _uniaxial_problem(patch, NeoHookean(C10, D1))
    a = brentq(lambda a: _cauchy_exact(np.diag([lam, a, a]), C10, D1)[1, 1], 0.3, 1.5, xtol=1e-15, rtol=1e-15)
    F = np.diag([lam, a, a])
    sigma = _cauchy_exact(F, C10, D1)
    assert abs(sigma[1, 1]) < 1e-13 and abs(a - lam**-0.5) > 1e-2  # genuinely compressible
    st = _solve(prob, (0.0, 0.0, 0.0, lam - 1.0))
    _check(prob, st, F, sigma, f"uniaxial compressible λ={lam} (a={a:.6f})")
    nominal = np.linalg.det(F) * sigma[0, 0] / lam
    assert abs(_reaction(prob, st, x1, 0) - nominal) <= TOL * abs(nominal)
    # element pressures are the volumetric stress 2(J − 1)/D1 (fem.state.State docstring)
    np.testing.assert_allclose(st.p, 2 * (np.linalg.det(F) - 1) / D1, rtol=TOL)


def _equibiaxial_problem(mesh, material):
    X = mesh.points
    x1, y1 = _on(X, 0, 1.0), _on(X, 1, 1.0)
    sets = (Dirichlet(_on(X, 0, 0.0), (0,)), Dirichlet(_on(X, 1, 0.0), (1,)), Dirichlet(_on(X, 2, 0.0), (2,)),
            Dirichlet(x1, (0,)), Dirichlet(y1, (1,)))
    return Problem(mesh, material, dirichlet=sets), x1


def test_equibiaxial_incompressible(patch):
    """Equibiaxial stretch λ = 1.3, D1 = 0, face z = 1 free: σ11 = σ22 = μ(λ² − λ⁻⁴) (VERIFICATION.md)."""
    lam = 1.3
    prob, x1 = _equibiaxial_problem(patch, NeoHookean(C10, 0.0))
    st = _solve(prob, (0.0, 0.0, 0.0, lam - 1.0, lam - 1.0))
    F = np.diag([lam, lam, lam**-2])
    s = MU * (lam**2 - lam**-4)
    _check(prob, st, F, np.diag([s, s, 0.0]), "equibiaxial incompressible")
    nominal = s / lam  # J = 1, P11 = σ11/λ; reference area of the face = 1
    assert abs(_reaction(prob, st, x1, 0) - nominal) <= TOL * abs(nominal)


def test_equibiaxial_compressible(patch):
    """Equibiaxial stretch λ = 1.3, D1 > 0: thickness stretch c from σ33(λ, λ, c) = 0 (brentq)."""
    lam = 1.3
    prob, x1 = _equibiaxial_problem(patch, NeoHookean(C10, D1))
    c = brentq(lambda c: _cauchy_exact(np.diag([lam, lam, c]), C10, D1)[2, 2], 0.2, 1.5, xtol=1e-15, rtol=1e-15)
    F = np.diag([lam, lam, c])
    sigma = _cauchy_exact(F, C10, D1)
    st = _solve(prob, (0.0, 0.0, 0.0, lam - 1.0, lam - 1.0))
    _check(prob, st, F, sigma, f"equibiaxial compressible (c={c:.6f})")
    nominal = np.linalg.det(F) * sigma[0, 0] / lam
    assert abs(_reaction(prob, st, x1, 0) - nominal) <= TOL * abs(nominal)


def test_simple_shear_incompressible(patch):
    """Simple shear γ = 0.6, D1 = 0: displacement (γY, 0, 0) prescribed on all boundary nodes except
    the interior of face z = 1, which is traction-free in the exact solution (σ·e3 = 0) and fixes
    the hydrostatic pressure. Exact: σ = μ(B − I): σ12 = μγ, σ11 − σ22 = μγ², σ22 = σ33 = 0."""
    g = 0.6
    X = patch.points
    on_bnd = np.any(np.isclose(X, 0.0, atol=1e-12) | np.isclose(X, 1.0, atol=1e-12), axis=1)
    top_only = np.isclose(X[:, 2], 1.0) & ~np.any(np.isclose(X[:, :2], 0.0) | np.isclose(X[:, :2], 1.0), axis=1)
    nodes = np.nonzero(on_bnd & ~top_only)[0]
    prob = Problem(patch, NeoHookean(C10, 0.0), dirichlet=(Dirichlet(nodes, (0, 1, 2)),))
    F = np.eye(3)
    F[0, 1] = g
    vals = X[prob.dirichlet[0].nodes] @ (F - np.eye(3)).T
    st = _solve(prob, (vals,))
    sigma = MU * np.array([[g**2, g, 0.0], [g, 0.0, 0.0], [0.0, 0.0, 0.0]])
    assert sigma[0, 1] == MU * g and sigma[0, 0] - sigma[1, 1] == MU * g**2
    _check(prob, st, F, sigma, "simple shear incompressible")


def test_simple_shear_compressible(patch):
    """Simple shear γ = 0.6, D1 > 0, all boundary nodes prescribed: J = 1 so p = 0 and
    σ = μ dev(B): σ12 = μγ, σ11 − σ22 = μγ² (VERIFICATION.md), σ33 = −μγ²/3."""
    g = 0.6
    X = patch.points
    nodes = np.nonzero(np.any(np.isclose(X, 0.0, atol=1e-12) | np.isclose(X, 1.0, atol=1e-12), axis=1))[0]
    prob = Problem(patch, NeoHookean(C10, D1), dirichlet=(Dirichlet(nodes, (0, 1, 2)),))
    F = np.eye(3)
    F[0, 1] = g
    st = _solve(prob, (X[prob.dirichlet[0].nodes] @ (F - np.eye(3)).T,))
    sigma = _cauchy_exact(F, C10, D1)
    np.testing.assert_allclose([sigma[0, 1], sigma[0, 0] - sigma[1, 1]], [MU * g, MU * g**2], rtol=1e-14)
    _check(prob, st, F, sigma, "simple shear compressible")


def test_general_homogeneous_deformation_compressible(patch):
    """An arbitrary F (stretch + shear + rotation, det F ≠ 1) on all boundary nodes, D1 > 0:
    σ equals the closed form and is objective (a superposed rotation rotates σ)."""
    X = patch.points
    nodes = np.nonzero(np.any(np.isclose(X, 0.0, atol=1e-12) | np.isclose(X, 1.0, atol=1e-12), axis=1))[0]
    prob = Problem(patch, NeoHookean(C10, D1), dirichlet=(Dirichlet(nodes, (0, 1, 2)),))
    U = np.array([[1.2, 0.1, -0.05], [0.1, 0.9, 0.08], [-0.05, 0.08, 1.1]])
    t = 0.7
    Rz = np.array([[np.cos(t), -np.sin(t), 0.0], [np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]])
    F = Rz @ U
    st = _solve(prob, (X[prob.dirichlet[0].nodes] @ (F - np.eye(3)).T,))
    sigma = _cauchy_exact(F, C10, D1)
    np.testing.assert_allclose(sigma, Rz @ _cauchy_exact(U, C10, D1) @ Rz.T, atol=1e-14)
    _check(prob, st, F, sigma, "general F compressible")


@pytest.mark.parametrize("degree", [3, 4])
def test_curved_patch_with_exact_quadrature(curved_patch, degree):
    """Curved P2 patch, quadrature of degree ≥ 3: uniaxial incompressible (λ = 1.5, σ11 = μ(λ² − 1/λ))
    and compressible simple shear (σ = closed form) reproduced to 1e-8 (see ``curved_patch``)."""
    X = curved_patch.points
    x1 = _on(X, 0, 1.0)
    sets = (Dirichlet(_on(X, 0, 0.0), (0,)), Dirichlet(_on(X, 1, 0.0), (1,)), Dirichlet(_on(X, 2, 0.0), (2,)),
            Dirichlet(x1, (0,)))
    lam = 1.5
    prob = Problem(curved_patch, NeoHookean(C10, 0.0), dirichlet=sets, quadrature_degree=degree)
    st = _solve(prob, (0.0, 0.0, 0.0, lam - 1.0))
    _check(prob, st, np.diag([lam, lam**-0.5, lam**-0.5]), np.diag([MU * (lam**2 - 1 / lam), 0.0, 0.0]),
           f"curved uniaxial incompressible, degree {degree}")
    nodes = np.nonzero(np.any(np.isclose(X, 0.0, atol=1e-12) | np.isclose(X, 1.0, atol=1e-12), axis=1))[0]
    prob = Problem(curved_patch, NeoHookean(C10, D1), dirichlet=(Dirichlet(nodes, (0, 1, 2)),), quadrature_degree=degree)
    F = np.eye(3)
    F[0, 1] = 0.6
    st = _solve(prob, (X[prob.dirichlet[0].nodes] @ (F - np.eye(3)).T,))
    _check(prob, st, F, _cauchy_exact(F, C10, D1), f"curved simple shear compressible, degree {degree}")
