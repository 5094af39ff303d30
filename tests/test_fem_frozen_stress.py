"""A frozen second Piola–Kirchhoff stress and a scaled law: tangents, energy, and the stiffness they give.

References: the frozen stress's energy ½ T:(C − I) and its derivatives (fem/frozen_stress.py, Bonet &
Wood 2008 §5.5); checked against central finite differences of the residual and of the energy, as the
rest of the assembly (tests/test_fem_tangent.py). The scaled law with T = −(c − 1) S̄_p must keep the
stress of the state p (same residual) and multiply its incremental material stiffness by c (an
identity of the tangents at that state).
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.assembly import Assembler
from fem.material import ElementwiseMaterial, NeoHookean, ScaledMaterial, Yeoh
from fem.problem import FrozenStress, Problem, ProblemError

from tests.test_fem_tangent import _dense, _distorted, _fd_jacobian, _residual_fun, energy_gradient_fd
from fem.meshgen import box_mesh


@pytest.fixture(scope="module")
def mesh():
    return _distorted(box_mesh(1.0, 1.0, 2.0, 1, 1, 2))


def _sym_stress(n_sel, n_qp, seed=3):
    A = np.random.default_rng(seed).standard_normal((n_sel, n_qp, 3, 3))
    return 0.2 * (A + np.swapaxes(A, -1, -2))


def _state(mesh, seed=1):
    rng = np.random.default_rng(seed)
    return 0.05 * rng.standard_normal((mesh.n_nodes, 3)), 0.3 * rng.standard_normal(mesh.n_elements)


def test_frozen_stress_tangent_and_energy_against_fd(mesh):
    sel = np.array([0, 2, 3, 7, 11])
    prob = Problem(mesh, NeoHookean(c10=0.5, d1=0.01),
                   frozen_stresses=(FrozenStress(sel, _sym_stress(len(sel), 4)),))
    asm = Assembler(prob, kernel="numpy")
    u, p = _state(mesh)
    R, K = _dense(asm, u, p, ())
    x = np.concatenate([u.ravel(), p])
    Kfd = _fd_jacobian(_residual_fun(asm, ()), x)
    assert np.abs(K - Kfd).max() <= 1e-6 * np.abs(Kfd).max()
    g = energy_gradient_fd(asm, u, p)
    assert np.abs(R - g).max() <= 1e-6 * np.abs(g).max()
    # and the term is really there: the same problem without it differs
    R0, _ = _dense(Assembler(Problem(mesh, NeoHookean(c10=0.5, d1=0.01)), kernel="numpy"), u, p, ())
    assert np.abs(R - R0).max() > 1e-3 * np.abs(R0).max()


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
def test_scaled_law_tangent_against_fd(mesh, kernel):
    from fem import jit

    if kernel == "numba" and not jit.AVAILABLE:
        pytest.skip("numba not installed")
    s = np.linspace(0.4, 2.5, mesh.n_elements)
    base = ElementwiseMaterial((Yeoh(c=(0.4, -0.02, 0.003), d1=0.01), NeoHookean(c10=0.8, d1=0.01)),
                               np.arange(mesh.n_elements) % 2)
    asm = Assembler(Problem(mesh, ScaledMaterial(base, s)), kernel=kernel)
    u, p = _state(mesh, seed=4)
    R, K = _dense(asm, u, p, ())
    Kfd = _fd_jacobian(_residual_fun(asm, ()), np.concatenate([u.ravel(), p]))
    assert np.abs(K - Kfd).max() <= 1e-6 * np.abs(Kfd).max()


def test_scaled_law_with_frozen_stress_keeps_the_state_and_scales_the_material_stiffness(mesh):
    """c W̄ + ½ T:(C − I), T = −(c − 1) S̄_p: at the state p the same residual as W̄, and the
    isochoric tangent c K_mat + K_geo(S̄_p) where W̄ alone gives K_mat + K_geo(S̄_p)."""
    base = NeoHookean(c10=0.5, d1=0.0)
    u_p, _ = _state(mesh, seed=7)
    p0 = np.zeros(mesh.n_elements)  # element pressures 0: the tangent is the isochoric one alone
    plain = Assembler(Problem(mesh, base), kernel="numpy")
    F, J, G = plain.deformation(u_p)
    P_iso = base.stress_coefficients(F, G, J)[0]  # (n_el, n_qp, 3, 3)
    S_p = np.matmul(G, P_iso)  # (n_el, n_qp, 3, 3)  S̄ = F⁻¹ P̄
    S_p = 0.5 * (S_p + np.swapaxes(S_p, -1, -2))
    all_el = np.arange(mesh.n_elements)
    c = 1.7
    law = Problem(mesh, ScaledMaterial(base, np.full(mesh.n_elements, c)),
                  frozen_stresses=(FrozenStress(all_el, -(c - 1.0) * S_p),))
    geo = Problem(mesh, base, frozen_stresses=(FrozenStress(all_el, S_p),))
    R_plain, K_plain = _dense(plain, u_p, p0, ())
    R_law, K_law = _dense(Assembler(law, kernel="numpy"), u_p, p0, ())
    n_u = 3 * mesh.n_nodes
    assert np.abs(R_law - R_plain).max() <= 1e-12 * np.abs(R_plain).max()
    # K_geo(S̄_p): the frozen-stress tangent of S̄_p alone (a problem with it minus one without)
    K_geo = _dense(Assembler(geo, kernel="numpy"), u_p, p0, ())[1] - K_plain
    K_mat = K_plain - K_geo
    expect = c * K_mat + K_geo
    assert np.abs(K_law[:n_u, :n_u] - expect[:n_u, :n_u]).max() <= 1e-10 * np.abs(expect).max()
    assert np.abs(K_geo).max() > 1e-3 * np.abs(K_plain).max()  # the state is stressed


def test_frozen_stress_refuses_bad_shapes(mesh):
    with pytest.raises(ProblemError, match="shape"):
        FrozenStress(np.array([0, 1]), np.zeros((3, 4, 3, 3)))
    with pytest.raises(ProblemError, match="symmetric"):
        T = np.zeros((1, 4, 3, 3))
        T[0, :, 0, 1] = 1.0
        FrozenStress(np.array([0]), T)
    with pytest.raises(ProblemError, match="points per element"):
        Assembler(Problem(mesh, NeoHookean(c10=0.5, d1=0.01), frozen_stresses=(FrozenStress(np.array([0]), np.zeros((1, 5, 3, 3))),)))
    with pytest.raises(ValueError, match="factor"):
        ScaledMaterial(NeoHookean(c10=0.5, d1=0.01), np.array([1.0, 0.0]))
    with pytest.raises(ProblemError, match="nodal: shape"):
        FrozenStress(np.array([0]), np.zeros((1, 4, 3, 3)), nodal=np.zeros((mesh.n_nodes, 3)))
    with pytest.raises(ProblemError, match=f"nodal: {mesh.n_nodes + 1} nodes"):
        Problem(mesh, NeoHookean(c10=0.5, d1=0.01),
                frozen_stresses=(FrozenStress(np.array([0]), np.zeros((1, 4, 3, 3)), nodal=np.zeros((mesh.n_nodes + 1, 3, 3))),))
