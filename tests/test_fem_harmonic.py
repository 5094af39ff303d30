"""The axisymmetric + Fourier-harmonic solid (fem.axisym.harmonic) against closed forms and finite differences.

References
----------
* Thick tube, plane strain, incompressible neo-Hookean (Rivlin): P = μ[ln(λa/λb) + (λb⁻² − λa⁻²)/2] with
  λb² − 1 = (A/B)²(λa² − 1) (VERIFICATION's thick-walled tube with λz = 1).
* Closed-end tube: the same kinematics with an axial stretch λ set by the end thrust P π a² (Ogden,
  *Non-linear Elastic Deformations*, §5.3), evaluated by quadrature here; its maximum over λa is the limit
  pressure.
* Pure bending of the unloaded tube: EI = 3μ π (r_o⁴ − r_i⁴)/4 (E = 3μ, Timoshenko & Gere).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from fem.axisym.harmonic import HarmonicSolid, HoopFibre, Region
from fem.axisym.harmonic_solve import (PATH_OPTIONS, AxisymmetricPath, AxisymmetricSystem, Control, EndThrust, Reduction,
                                      harmonic_response)
from fem.axisym.meshgen2d import grid_mesh, inclusion_mesh
from fem.material import NeoHookean, Yeoh
from fem.newton import SolveFailed
from tests.tube_closed_form import closed_end_tube

MU = 1.0
A, B = 1.0, 2.0


def _tube(n_r=4, n_z=1, h=0.5, law=None, pressure=True, level=1):
    m = grid_mesh([A, B], [0.0, h], [n_r], [n_z], level=level)
    edges = m.edges_where(lambda P: np.abs(P[:, 0] - A) < 1e-12) if pressure else None
    solid = HarmonicSolid(m.points, m.cells, [Region(np.arange(m.n_elements), law or NeoHookean(MU / 2))],
                          pressure_edges=edges)
    return m, solid


def _node(m, r, z):
    return int(np.argmin(np.hypot(m.points[:, 0] - r, m.points[:, 1] - z)))


@pytest.mark.parametrize("lam_a", [1.1, 1.5, 2.0])
def test_plane_strain_tube_inflates_as_rivlin(lam_a):
    """Pressure at a prescribed cavity stretch: the exact P(λa) within 2e-5 on 8 Q9 elements across the wall."""
    m, solid = _tube(n_r=8)
    path = AxisymmetricPath(solid, Reduction(solid.n_u0 + 3 * solid.n_el, 2 * np.arange(m.n_nodes) + 1))
    y, Q, _ = path.solve(np.zeros(path.n_red), 0.0, control=(2 * _node(m, A, 0.0), lam_a - 1.0))
    lam_b = math.sqrt(1 + (A / B) ** 2 * (lam_a**2 - 1))
    exact = MU * (math.log(lam_a / lam_b) + (lam_b**-2 - lam_a**-2) / 2)
    assert Q == pytest.approx(exact, rel=2e-5)


def test_closed_tube_reaches_its_limit_pressure():
    """A closed-end tube driven past its maximum pressure: P(λa) and λ against the exact solution, and the
    limit pressure as the largest P over the path."""
    m, solid = _tube(n_r=8)
    P = m.points
    bottom = np.nonzero(P[:, 1] < 1e-12)[0]
    top = np.nonzero(np.abs(P[:, 1] - 0.5) < 1e-12)[0]
    red = Reduction(solid.n_u0 + 3 * solid.n_el, 2 * bottom + 1, ties=(2 * top + 1,))
    path = AxisymmetricPath(solid, red, EndThrust(0, A, 2 * _node(m, A, 0.5), current=True))
    y, Q = np.zeros(path.n_red), 0.0
    fe, ex = [], []
    for lam_a in np.linspace(1.1, 3.0, 20):
        y, Q, _ = path.solve(y, Q, control=(2 * _node(m, A, 0.0), lam_a - 1.0))
        P_exact, lam = closed_end_tube(lam_a, A, B, MU)
        assert Q == pytest.approx(P_exact, rel=1e-4)
        assert 1 + path.full(y)[2 * top[0] + 1] / 0.5 == pytest.approx(lam, rel=1e-4)
        fe.append(Q)
        ex.append(P_exact)
    assert int(np.argmax(fe)) == int(np.argmax(ex)) not in (0, len(ex) - 1)  # a true maximum inside the path
    assert max(fe) == pytest.approx(max(ex), rel=1e-4)


def _closed_tube_path():
    m, solid = _tube(n_r=8)
    P = m.points
    bottom = np.nonzero(P[:, 1] < 1e-12)[0]
    top = np.nonzero(np.abs(P[:, 1] - 0.5) < 1e-12)[0]
    red = Reduction(solid.n_u0 + 3 * solid.n_el, 2 * bottom + 1, ties=(2 * top + 1,))
    return m, solid, red, EndThrust(0, A, 2 * _node(m, A, 0.5), current=True)


def test_pressure_past_the_limit_fails_as_the_3d_solver_does():
    """Load control of the closed-end tube: 0.97 of the exact limit pressure is reached (the cavity stretch
    as the exact solution's on its rising branch), 1.03 of it is not, and the path fails with the 3-D solver's
    SolveFailed after its cut-backs."""
    m, solid, red, thrust = _closed_tube_path()
    lam = np.linspace(1.5, 2.5, 41)
    P = np.array([closed_end_tube(v, A, B, MU)[0] for v in lam])
    p_max = P.max()
    path = AxisymmetricPath(solid, red, thrust, replace(PATH_OPTIONS, max_cutbacks=2))  # fails sooner
    y, Q, prev = path.follow(np.zeros(path.n_red), 0.0, 0.97 * p_max, 8)
    rising = lam[: int(np.argmax(P)) + 1]
    lam_a = 1 + path.full(y)[2 * _node(m, A, 0.0)] / A
    assert closed_end_tube(lam_a, A, B, MU)[0] == pytest.approx(0.97 * p_max, rel=1e-4) and lam_a < rising[-1]
    with pytest.raises(SolveFailed, match="3 cut-backs"):  # the limit exceeded
        path.follow(y, Q, 1.03 * p_max, 1, previous=prev)


@pytest.mark.parametrize("control", [None, "cavity"])
def test_axisymmetric_system_tangent_is_the_derivative_of_its_residual(control):
    """The bordered tangent of (y, Q) (two laws, a hoop fibre, follower pressure, the current end thrust) times
    random directions against central differences of the residual, in every row but the prescribed slot,
    under load control and with the cavity's radial displacement prescribed (its equation in Q's slot)."""
    m, solid = _mixed_mesh()
    P = m.points
    bottom = np.nonzero(P[:, 1] < 1e-12)[0]
    top = np.nonzero(np.abs(P[:, 1] - 0.6) < 1e-12)[0]
    red = Reduction(solid.n_u0 + 3 * solid.n_el, 2 * bottom + 1, ties=(2 * top + 1,))
    thrust = EndThrust(0, A, 2 * _node(m, A, 0.6), current=True)
    e = None
    if control == "cavity":
        e = int(Reduction.matrix(red).getrow(2 * _node(m, A, 0.3)).indices[0])
    system = AxisymmetricSystem(solid, red, thrust, control=e)
    rng = np.random.default_rng(5)
    x = _random_state(solid, rng)
    z = np.append(system.T.T @ x, 0.3)  # the reduced unknowns of a random state, Q = 0.3
    R, A_z, _ = system.evaluate(z, Control(0.0), True)
    rows = ~system.constrained
    h = 1e-6
    for _ in range(4):
        v = rng.standard_normal(len(z))
        fd = (system.evaluate(z + h * v, Control(0.0), False)[0] - system.evaluate(z - h * v, Control(0.0), False)[0])
        assert np.allclose(system.matvec(A_z, v)[rows], fd[rows] / (2 * h), rtol=1e-6,
                           atol=1e-7 * np.abs(fd[rows] / (2 * h)).max())


def _bend(m, solid, x, Q, plane_r):
    P = m.points
    bottom = np.nonzero(P[:, 1] < 1e-12)[0]
    top = np.nonzero(np.abs(P[:, 1] - P[:, 1].max()) < 1e-12)[0]
    pin = _node(m, P[:, 0].min(), 0.0)
    fixed = np.concatenate([3 * bottom + 1, 3 * top + 1, [3 * pin + 2]])
    y, f, _ = harmonic_response(solid, 1, x, Q, fixed, np.concatenate([0 * bottom, plane_r(top), [0.0]]))
    return P[:, 1].max() * float(f[3 * top + 1] @ plane_r(top))


@pytest.mark.parametrize("law", [NeoHookean(MU / 2), Yeoh((MU / 2, 0.3))])
def test_unloaded_tube_bends_as_beam_theory(law):
    """n = 1 about the unloaded state: EI = 3μ π (r_o⁴ − r_i⁴)/4 to round-off (the field is quadratic)."""
    m, solid = _tube(n_r=3, n_z=2, h=0.7, law=law, pressure=False)
    ei = _bend(m, solid, np.zeros(solid.n_u0 + 3 * solid.n_el), 0.0, lambda nodes: m.points[nodes, 0])
    assert ei == pytest.approx(3 * MU * math.pi * (B**4 - A**4) / 4, rel=1e-10)


def _random_state(solid, rng, amp=0.01):
    x = np.zeros(solid.n_u0 + 3 * solid.n_el)
    x[: solid.n_u0] = amp * rng.standard_normal(solid.n_u0)
    x[solid.n_u0:] = 0.1 * rng.standard_normal(3 * solid.n_el)
    return x


def _mixed_mesh():
    """Two regions (incompressible Yeoh, compressible neo-Hookean) and a hoop fibre on part of the mesh."""
    m = grid_mesh([A, B], [0.0, 0.6], [2], [2])
    soft = NeoHookean(0.4, 0.5)
    solid = HarmonicSolid(m.points, m.cells, [Region(np.array([0, 1]), Yeoh((0.5, 0.2, 0.01))),
                                              Region(np.array([2, 3]), soft)],
                          hoop_fibres=(HoopFibre(np.array([1, 3]), 30.0),),
                          pressure_edges=m.edges_where(lambda P: np.abs(P[:, 0] - A) < 1e-12))
    return m, solid


def test_axisymmetric_tangent_matches_finite_differences():
    """K of the axisymmetric state (two laws, a hoop fibre, follower pressure) against central differences."""
    m, solid = _mixed_mesh()
    rng = np.random.default_rng(3)
    x = _random_state(solid, rng)
    _, K = solid.axisymmetric(x, 0.3)
    K = K.toarray()
    h = 1e-6
    for j in rng.choice(len(x), 12, replace=False):
        e = np.zeros_like(x)
        e[j] = h
        fd = (solid.axisymmetric(x + e, 0.3, False)[0] - solid.axisymmetric(x - e, 0.3, False)[0]) / (2 * h)
        assert np.allclose(K[:, j], fd, rtol=1e-6, atol=1e-7 * np.abs(K).max())


def _energy_3d(solid, x, amp, theta_pts, eps):
    """∫∫ [W_iso + p(J − 1) − D1/4 p² + ½ k Ē²] R dA dΘ of the axisymmetric state plus ε × the harmonic-1 field
    (amplitudes ``amp`` = (n_nodes, 3) and element pressures (n_el, 3)), by a trapezoidal rule in Θ."""
    from fem.axisym.quad9 import gauss_square, pressure_basis
    u, p = x[: solid.n_u0].reshape(-1, 2), x[solid.n_u0:].reshape(-1, 3)
    a, q = amp
    xi, w = gauss_square(3)
    Np = pressure_basis(xi)
    F0 = solid.deformation_gradient(u)  # (n_el, n_qp, 3, 3)
    ae = a[solid.cells]  # (n_el, 9, 3)
    dA = np.einsum("eqaJ,eak->eqkJ", solid.dNdX, ae)  # (n_el, n_qp, 3, 2) ∂(a, b, c)/∂(R, Z)
    Na = np.einsum("eqa,eak->eqk", solid.N, ae)  # (n_el, n_qp, 3)
    R = solid.Rq
    total = 0.0
    for th in theta_pts:
        cs, sn = math.cos(th), math.sin(th)
        G = np.zeros_like(F0)
        G[..., 0, 0], G[..., 0, 1] = dA[..., 0, 0] * cs, dA[..., 0, 1] * cs
        G[..., 1, 0], G[..., 1, 1] = dA[..., 1, 0] * cs, dA[..., 1, 1] * cs
        G[..., 2, 0], G[..., 2, 1] = dA[..., 2, 0] * sn, dA[..., 2, 1] * sn
        G[..., 0, 2] = -(Na[..., 0] + Na[..., 2]) / R * sn
        G[..., 1, 2] = -Na[..., 1] / R * sn
        G[..., 2, 2] = (Na[..., 2] + Na[..., 0]) / R * cs
        F = F0 + eps * G
        J = np.linalg.det(F)
        pq = np.einsum("qj,ej->eq", Np, p + eps * q * cs)
        W = np.zeros_like(J)
        for k, reg in enumerate(solid.regions):
            sel = solid.laws == k
            W[sel] = reg.law.energy(F[sel])
        W += pq * (J - 1) - 0.25 * solid.d1[:, None] * pq**2
        total += float(np.sum(solid.wR * W))
        for hf in solid.hoop:
            c = solid.wR[hf.elements] * hf.stiffness
            E = 0.5 * (np.einsum("eqi,eqi->eq", F[hf.elements][..., :, 2], F[hf.elements][..., :, 2]) - 1)
            Eb = np.sum(c * E, 1) / c.sum(1)
            total += 0.5 * float(np.sum(c.sum(1) * Eb**2))
    return total * 2 * math.pi / len(theta_pts)


def test_harmonic_tangent_is_the_second_variation_of_the_3d_energy():
    """yᵀ K₁ y (no pressure) equals d²/dε² of the 3-D energy of the state plus ε × the n = 1 field, the
    energy integrated around the axis numerically: checks the amplitudes' gradient, the π factor and the
    parity argument that decouples cos- and sin-type components."""
    m, solid = _mixed_mesh()
    rng = np.random.default_rng(7)
    x = _random_state(solid, rng)
    a = 0.3 * rng.standard_normal((m.n_nodes, 3))
    q = 0.2 * rng.standard_normal((m.n_el if hasattr(m, "n_el") else m.n_elements, 3))
    K = solid.harmonic_tangent(1, x, 0.0)
    y = np.concatenate([a.ravel(), q.ravel()])
    th = np.linspace(0, 2 * math.pi, 48, endpoint=False)
    h = 1e-3
    e = [_energy_3d(solid, x, (a, q), th, s * h) for s in (-1, 0, 1)]
    second = (e[0] - 2 * e[1] + e[2]) / h**2
    assert y @ (K @ y) == pytest.approx(second, rel=1e-5)


def test_n1_bending_of_a_pressurised_tube_matches_the_3d_solver():
    """A rubber tube of the chamber wall's size under Q = 0.05 MPa and its closed-end thrust, bent by rotating
    its end plane: EI from the n = 1 harmonic against the 3-D P2 solver's central difference of the moment
    work-conjugate to the rotation (the 3-D mesh's own error is about 0.1 %, measured by refining it)."""
    from peers import wall_cell3d as fc

    cell = fc.Cell.default()
    Q = 0.05
    r, z = fc.uniform_grids(cell, 2)
    mesh = fc.cell_mesh(cell, r, z, 16)
    prob, top = fc.cell_problem(cell, mesh)
    run = fc.CellRun(cell, prob, top)
    U = run.pressurise(Q, 0.0)
    ei3 = 2 * run.bending_stiffness(Q, U)[1]  # half tube -> whole tube
    m = grid_mesh([cell.r_i, cell.r_o], [0.0, cell.s], [4], [2], level=2)
    solid = HarmonicSolid(m.points, m.cells, [Region(np.arange(m.n_elements), NeoHookean(cell.c10))],
                          pressure_edges=m.edges_where(lambda P: np.abs(P[:, 0] - cell.r_i) < 1e-9))
    P = m.points
    bottom = np.nonzero(P[:, 1] < 1e-12)[0]
    topn = np.nonzero(np.abs(P[:, 1] - cell.s) < 1e-12)[0]
    red = Reduction(solid.n_u0 + 3 * solid.n_el, 2 * bottom + 1, ties=(2 * topn + 1,))
    path = AxisymmetricPath(solid, red, EndThrust(0, cell.r_i, 2 * _node(m, cell.r_i, cell.s), current=False))
    y, _, _ = path.follow(np.zeros(path.n_red), 0.0, Q, 4)
    x = path.full(y)
    assert x[2 * topn[0] + 1] == pytest.approx(U, rel=1e-2)
    ei2 = _bend(m, solid, x, Q, lambda nodes: m.points[nodes, 0])
    assert ei2 == pytest.approx(ei3, rel=2e-3)
    assert ei2 < 0.99 * 3 * cell.c10 * 2 * math.pi * (cell.r_o**4 - cell.r_i**4) / 4  # pressure softens the bare tube


def test_inclusion_mesh_converges_to_the_circle():
    """The area of the meshed inclusion approaches π a² at the rate of quadratic (isoparametric) arcs."""
    from fem.axisym.quad9 import gauss_square, shape_gradients
    xi, w = gauss_square(3)
    dN = shape_gradients(xi)
    errs = []
    for level in (1, 2, 4):
        m = inclusion_mesh(1.0, 3.0, 2.0, 2.0, 0.4, level=level)
        el = m.elements_of("inclusion")
        J = np.einsum("qak,eai->eqik", dN, m.points[m.cells[el]])
        errs.append(abs(float(np.sum(w * np.linalg.det(J))) - math.pi * 0.4**2))
        assert float(np.sum(w * np.linalg.det(np.einsum("qak,eai->eqik", dN, m.points[m.cells])))) == \
            pytest.approx(2.0 * 2.0, rel=1e-12)  # the rectangle is exact
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 3.5)
