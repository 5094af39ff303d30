"""Elastic surface support (fem.support): energy, residual, tangent and a bar on normal springs.

References: Π_s = ½ ∫ [k_n (u·n0)² + k_t |u − (u·n0) n0|²] dA (docstring of fem.support); the tangent is
the exact Jacobian of the residual and the residual the gradient of the energy, checked by central
differences (≤ 1e-6 relative, as tests/test_fem_tangent.py). A prismatic bar whose end face x = 0 rests on
normal springs k_n and whose other end carries a force F along its axis is in uniaxial stress σ = F/A, so its
end face moves by F/(k_n A) and its far end by F L/(E A) + F/(k_n A) (small strain, E = 9Kμ/(3K + μ)).
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.assembly import Assembler, support_forces
from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.mesh import boundary_faces
from fem.meshgen import box_mesh
from fem.problem import DeadTraction, Dirichlet, ElasticSupport, Problem, ProblemError
from fem.state import State
from fem.support import SupportKernel
from tests.test_fem_tangent import _distorted, _fd_jacobian, _state, energy_gradient_fd

TOL = 1e-6


def _faces_at(mesh, axis: int, value: float) -> np.ndarray:
    _, _, f6 = boundary_faces(mesh.cells)
    return f6[np.all(np.isclose(mesh.points[f6][:, :, axis], value), axis=1)]


@pytest.fixture(scope="module")
def curved():
    """Distorted (curved-face) 1×1×2-cell box with springs on its (curved) faces z ≈ 0 and y ≈ 0."""
    flat = box_mesh(1.0, 1.0, 2.0, 1, 1, 2)
    faces = np.concatenate([_faces_at(flat, 2, 0.0), _faces_at(flat, 1, 0.0)])
    return _distorted(flat), faces


def test_flat_face_energy_is_the_closed_form():
    """On the flat face x = 0 of a box (area 2 × 3): a uniform u stores ½ A [k_n u_x² + k_t (u_y² + u_z²)],
    and u = (g y, 0, 0) stores ½ k_n g² ∫ y² dA = ½ k_n g² · 3 · 2³/3 (the rule integrates it exactly)."""
    mesh = box_mesh(1.0, 2.0, 3.0, 1, 2, 3)
    sk = SupportKernel(mesh.points, _faces_at(mesh, 0, 0.0))
    assert sk.area.sum() == pytest.approx(6.0, rel=1e-13)
    k_n, k_t = 2.5, 0.7
    u = np.tile([0.3, -0.2, 0.5], (mesh.n_nodes, 1))
    assert sk.energy(u, k_n, k_t) == pytest.approx(0.5 * 6.0 * (k_n * 0.09 + k_t * 0.29), rel=1e-13)
    np.testing.assert_allclose(sk.force(u, k_n, k_t), [-6.0 * k_n * 0.3, 6.0 * k_t * 0.2, -6.0 * k_t * 0.5],
                               rtol=1e-13)
    g = 0.4
    u = np.zeros_like(mesh.points)
    u[:, 0] = g * mesh.points[:, 1]
    assert sk.energy(u, k_n, k_t) == pytest.approx(0.5 * k_n * g**2 * 3.0 * 8.0 / 3.0, rel=1e-13)


@pytest.mark.parametrize("kernel", ["auto", "numpy"])
def test_support_tangent_matches_fd(curved, kernel):
    """The support's tangent blocks equal the central-difference Jacobian of its residual (curved faces,
    random state), the assembled problem's too, with either element kernel; the support part alone is what
    the support adds."""
    mesh, faces = curved
    mat = NeoHookean(0.5, 0.2)
    bare = Problem(mesh, mat)
    prob = Problem(mesh, mat, supports=(ElasticSupport(faces, 3.0, 0.8),))
    u, p = _state(prob, seed=7)
    asm, asm0 = Assembler(prob, kernel), Assembler(bare, kernel)
    x = np.concatenate([u.ravel(), p])
    n_u = prob.n_u

    def res(v):
        return asm.evaluate(v[:n_u].reshape(-1, 3), v[n_u:], (), False)[0]

    R, data, _ = asm.evaluate(u, p, (), True)
    K = asm.pattern.matrix(data).toarray()
    Kfd = _fd_jacobian(res, x)
    assert np.abs(K - Kfd).max() <= TOL * np.abs(K).max()
    K0 = asm0.pattern.matrix(asm0.evaluate(u, p, (), True)[1]).toarray()
    Ks = K - K0
    assert np.abs(Ks).max() > 0.1 * np.abs(K).max()  # the support part is not negligible in the check
    np.testing.assert_allclose(Ks[:n_u, :n_u] @ u.ravel(), R[:n_u] - asm0.evaluate(u, p, (), False)[0][:n_u],
                               rtol=0, atol=1e-12 * np.abs(R).max())
    assert np.abs(Ks - Ks.T).max() <= 1e-14 * np.abs(Ks).max()


def test_residual_is_support_energy_gradient(curved):
    """R = ∂Π/∂x with Π including ½ ∫ [k_n (u·n0)² + k_t |u_t|²] dA (Assembler.energy), by central FD."""
    mesh, faces = curved
    prob = Problem(mesh, NeoHookean(0.5, 0.2), supports=(ElasticSupport(faces, 3.0, 0.8),))
    asm = Assembler(prob)
    u, p = _state(prob, seed=5)
    R = asm.evaluate(u, p, (), False)[0]
    g = energy_gradient_fd(asm, u, p)
    assert np.abs(g - R).max() <= TOL * np.abs(R).max()


def test_support_refuses_bad_input():
    faces = np.zeros((1, 6), np.int64)
    with pytest.raises(ProblemError, match=r"ElasticSupport\(support\)\.k_n=-1\.0: must be finite and >= 0"):
        ElasticSupport(faces, -1.0, 0.0)
    with pytest.raises(ProblemError, match=r"ElasticSupport\(base\)\.faces: shape \(2, 3\)"):
        ElasticSupport(np.zeros((2, 3)), 1.0, 1.0, "base")
    mesh = box_mesh(1.0, 1.0, 1.0, 1, 1, 1)
    with pytest.raises(ProblemError, match="node index outside"):
        Problem(mesh, NeoHookean(0.5), supports=(ElasticSupport(faces + mesh.n_nodes, 1.0, 1.0),))


def test_bar_on_normal_springs_extends_by_the_closed_form():
    """L × b × b bar (L = 4, b = 1), end x = 0 on normal springs k_n = 2 N/mm³ (k_t = 0), the symmetry planes
    y = b/2 and z = b/2 held (no rigid motion left but the springs' axial one), dead axial force F on x = L.
    Compressible neo-Hookean μ = 1, K = 10 (E = 9Kμ/(3K + μ) = 2.903), F = 1e-4 N (strain 3e-5):
    base u_x = F/(k_n A) (exact: σ = F/A at every load) and tip u_x = F L/(E A) + F/(k_n A) within the
    strain's order (1e-4 relative) of small-strain theory."""
    L, b, k_n, mu, K = 4.0, 1.0, 2.0, 1.0, 10.0
    mesh = box_mesh(L, b, b, 4, 2, 2)
    X = mesh.points
    sym_y = np.nonzero(np.isclose(X[:, 1], b / 2))[0]
    sym_z = np.nonzero(np.isclose(X[:, 2], b / 2))[0]
    prob = Problem(mesh, NeoHookean(mu / 2, 2.0 / K),
                   dirichlet=(Dirichlet(sym_y, (1,), "sym y"), Dirichlet(sym_z, (2,), "sym z")),
                   tractions=(DeadTraction(_faces_at(mesh, 0, L), "pull"),),
                   supports=(ElasticSupport(_faces_at(mesh, 0, 0.0), k_n, 0.0, "springs"),))
    F, A = 1e-4, b * b
    load = LoadState((), (0.0, 0.0), (np.array([F / A, 0.0, 0.0]),))
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob), load, fractions=(1.0,))
    u = states[-1].u
    E = 9 * K * mu / (3 * K + mu)
    base, tip = np.isclose(X[:, 0], 0.0), np.isclose(X[:, 0], L)
    np.testing.assert_allclose(u[base, 0], F / (k_n * A), rtol=1e-8)
    expected = F * L / (E * A) + F / (k_n * A)
    np.testing.assert_allclose(u[tip, 0], expected, rtol=1e-4)
    # the springs' resultant balances the pull
    np.testing.assert_allclose(support_forces(prob, u)[0], [-F, 0.0, 0.0], atol=1e-9 * F)
