"""Embedded truss fibres: exact axial fibre in a stretched block, and a hoop winding that stiffens a tube.

References
----------
* Fibre law (fem.truss, Bonet & Wood 2008 §7.2): Green–Lagrange strain E = (λ² − 1)/2 and
  axial force N = E_f A E λ (second Piola stress S = E_f E, pushed forward over the reference
  area A).
* Incompressible neo-Hookean uniaxial nominal stress μ(λ − 1/λ²) (closed form).
* Thick-walled tube: P(λa) (see tests/test_fem_tube.py); the requirement:
  "a rubber tube with a stiff embedded hoop winding under internal pressure grows far less
  radially than the bare tube, and an axial fibre carries the force its strain implies".
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fem.assembly import Assembler
from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.meshgen import box_mesh
from fem.problem import Dirichlet, EmbeddedTrusses, Problem
from fem.state import State
from fem.truss import TrussKernel
from tests.test_fem_tube import A, B, tube_pressure, tube_problem


def locate_affine(points: np.ndarray, cells: np.ndarray, q: np.ndarray):
    """Host element and local coordinates ξ of points in a straight-edged TET10 mesh (affine map).

    Returns (host_elements (n,), local_coords (n, 3)); asserts every point is inside a tet.
    """
    x = points[cells[:, :4]]  # (n_el, 4, 3)
    Jinv = np.linalg.inv(np.transpose(x[:, 1:] - x[:, :1], (0, 2, 1)))  # (n_el, 3, 3), columns = edges
    he = np.empty(len(q), dtype=np.int64)
    xi = np.empty((len(q), 3))
    for k, p in enumerate(q):
        s = np.einsum("eij,ej->ei", Jinv, p - x[:, 0])  # (n_el, 3)
        lam = np.concatenate([1.0 - s.sum(axis=1, keepdims=True), s], axis=1)
        e = int(np.argmax(lam.min(axis=1)))
        assert lam[e].min() > -1e-10, f"point {p} outside the mesh"
        he[k] = e
        xi[k] = s[e]
    return he, xi


# --------------------------------------------------------------------------- axial fibre, exact
@pytest.mark.parametrize("lam", [1.3, 0.85])
def test_axial_fibre_force_in_uniaxial_stretch(lam):
    """A straight axial fibre (E_f/μ = 1e5) in a block under uniaxial stretch λ with sliding ends.

    The homogeneous field u = (F − I)X with F = diag(λ, λ^-½, λ^-½) remains exact: the fibre's
    uniform axial force cancels at interior fibre points and its end forces act on the
    x-constrained end faces. Hence, to round-off:
    every fibre segment has E = (λ² − 1)/2, TrussKernel.axial_force = E_f A E λ, and the end
    reaction is μ(λ − 1/λ²)·(l_y l_z) + E_f A E λ.
    """
    lx, ly, lz = 2.0, 1.0, 1.0
    c10 = 0.5
    mu = 2 * c10
    Ef, Af = 1.0e5, 0.01
    mesh = box_mesh(lx, ly, lz, 4, 2, 2, distort=0.25, seed=11)
    X = mesh.points
    xs = np.concatenate([[0.0], np.sort(np.random.default_rng(5).uniform(0, lx, 7)), [lx]])
    q = np.stack([xs, np.full_like(xs, 0.37), np.full_like(xs, 0.61)], axis=1)  # off-grid line
    he, xi = locate_affine(X, mesh.cells, q)
    seg = np.stack([np.arange(len(xs) - 1), np.arange(1, len(xs))], axis=1)
    fib = EmbeddedTrusses(he, xi, seg, Ef, Af)
    on = lambda ax, v: np.nonzero(np.isclose(X[:, ax], v, atol=1e-12))[0]  # noqa: E731
    x1 = on(0, lx)
    prob = Problem(mesh, NeoHookean(c10, 0.0), trusses=(fib,),
                   dirichlet=(Dirichlet(on(0, 0.0), (0,)), Dirichlet(on(1, 0.0), (1,)), Dirichlet(on(2, 0.0), (2,)),
                              Dirichlet(x1, (0,))))
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob),
                           LoadState((), (0.0, 0.0, 0.0, (lam - 1.0) * lx)), fractions=(0.5, 1.0))
    st = states[-1]
    F = np.diag([lam, lam**-0.5, lam**-0.5])
    u_ref = X @ (F - np.eye(3)).T
    assert np.abs(st.u - u_ref).max() <= 1e-8 * np.abs(u_ref).max()

    tk = TrussKernel(X, mesh.cells, he, xi, seg, Ef, Af)
    x = X + st.u
    E_gl = 0.5 * (lam**2 - 1.0)
    N_ref = Ef * Af * E_gl * lam
    np.testing.assert_allclose(tk.L0.sum(), lx, rtol=1e-12)
    np.testing.assert_allclose(tk.strain(x), E_gl, rtol=1e-8)
    np.testing.assert_allclose(tk.axial_force(x), N_ref, rtol=1e-8)
    R = Assembler(prob).evaluate(st.u, st.p, (), False)[0]
    reaction = R[3 * x1].sum()
    ref = mu * (lam - lam**-2) * ly * lz + N_ref
    print(f"λ={lam}: fibre force {tk.axial_force(x).mean():.6g} (ref {N_ref:.6g}), "
          f"end reaction {reaction:.8g} (ref {ref:.8g}), fibre share {N_ref / ref:.4f}")
    assert abs(reaction - ref) <= 1e-8 * abs(ref)


# --------------------------------------------------------------------------- hoop winding
def _hoop_fibre(n_r, n_theta, r_f, n_pts):
    """Hoop polyline at radius r_f, mid-height, φ = 0 … π/2, located in the box space of the sector mesh.

    tube_sector_mesh maps box_mesh(1,1,1,n_r,n_θ,1) node by node, so an element's local
    coordinates are those of the box-space point ((r − A)/(B − A), φ/(π/2), ½).
    """
    base = box_mesh(1.0, 1.0, 1.0, n_r, n_theta, 1)
    t = np.linspace(0.0, 1.0, n_pts)
    qb = np.stack([np.full(n_pts, (r_f - A) / (B - A)), t, np.full(n_pts, 0.5)], axis=1)
    he, xi = locate_affine(base.points, base.cells, qb)
    seg = np.stack([np.arange(n_pts - 1), np.arange(1, n_pts)], axis=1)
    return he, xi, seg


def test_hoop_winding_limits_radial_growth():
    """Quarter tube (A = 1, B = 2 mm, μ = 0.3 MPa, plane-strain slab of height = pitch 0.5 mm) at the
    pressure that inflates the bare tube to λa = 1.5; a hoop fibre (E_f = 31067 MPa, d = 0.38 mm,
    thesis fibre; E_f/μ ≈ 1e5) at mid-wall r_f = 1.5 mm.

    Expected: the winding carries most of the hoop load. If the rubber inside the winding acted as a
    fluid the fibre force would be N = P r_f h (equilibrium of the quarter), i.e. a fibre strain of
    N/(E_f A_f) ≈ 3e-5; the remaining growth is the rubber bulging between turns. We require the
    inner radial growth to be at least 5× smaller than the bare tube's ("far less") and
    the fibre to be in tension carrying between half and all of P r_f h.
    """
    mu, Ef, df, r_f, h = 0.3, 31067.0, 0.38, 1.5, 0.5
    Af = np.pi * df**2 / 4
    n_r, n_t = 2, 8
    prob0, inner = tube_problem(n_r=n_r, n_theta=n_t, height=h, c10=mu / 2)
    he, xi, seg = _hoop_fibre(n_r, n_t, r_f, 33)
    prob1 = dataclasses.replace(prob0, trusses=(EmbeddedTrusses(he, xi, seg, Ef, Af, "winding"),), _cache={})
    P = tube_pressure(1.5, mu=mu)
    X = prob0.mesh.points
    growth = []
    for prob in (prob0, prob1):
        states, reps = solve_path(prob, State.zero(prob), LoadState.zero(prob), LoadState((P,), (0.0, 0.0, 0.0)),
                                  fractions=(0.5, 1.0))
        x = X + states[-1].u
        growth.append(np.hypot(x[inner, 0], x[inner, 1]).max() / A - 1.0)
    tk = Assembler(prob1).topo.truss_kernels[0]
    N = tk.axial_force(x)
    ratio = growth[1] / growth[0]
    share = N / (P * r_f * h)
    print(f"bare tube λa−1 = {growth[0]:.4f}, wound tube λa−1 = {growth[1]:.5f}, ratio {ratio:.4f}; "
          f"fibre force / (P r_f h) = {share.min():.3f}…{share.max():.3f}, fibre strain {tk.strain(x).max():.2e} "
          f"(fluid-core estimate {P * r_f * h / (Ef * Af):.2e})")
    assert abs(growth[0] - 0.5) <= 5e-3 * 1.5  # bare tube reproduces λa = 1.5 (tests/test_fem_tube.py)
    assert ratio <= 0.2
    assert np.all(share > 0.5) and np.all(share <= 1.0)
