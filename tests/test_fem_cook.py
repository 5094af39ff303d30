"""Cook's membrane, nearly incompressible, in the small-load (linear) limit: accuracy and no locking.

Reference: Cook's membrane (Cook 1974) — tapered panel with corners (0,0), (48,44),
(48,60), (0,44), left edge clamped, uniform shear on the right edge, plane strain, linear
elastic G = 0.375, λ = 7500 (ν ≈ 0.49998), total vertical force F = 1: converged vertical
displacement at (48, 52) = 16.4326 (Richardson-extrapolated, FinEALE). Required: within 1 % on
a moderate mesh, and no locking (the displacement does not fall as ν → 0.5).

Model: box_mesh(1, 1, t) mapped bilinearly onto the panel, one element layer with u_z = 0 at
every node (plane strain). Neo-Hookean W = C10(Ī1 − 3) + (J − 1)²/D1 linearises to isotropic
elasticity with G = 2 C10 and bulk modulus K = 2/D1 (K = λ + 2G/3). The shear is a dead
traction F/(16 t) on the right face; with F = 1e-5 geometric and material nonlinearity are
O(1e-6) relative, so u/F is the linear-elastic displacement for F = 1.
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.mesh import TetMesh, boundary_faces
from fem.meshgen import box_mesh, map_mesh
from fem.newton import SolveOptions
from fem.problem import DeadTraction, Dirichlet, Problem
from fem.state import State

U_REF = 16.4326  # VERIFICATION.md (FinEALE)
G = 0.375
LAME = 7500.0
F_SMALL = 1e-5  # total shear force; the answer is scaled back to F = 1


def cook_mesh(n: int, t: float = 1.0) -> TetMesh:
    """n × n × 1 cells of box_mesh(1, 1, t) mapped onto the panel:
    x = 48 s, y = 44 s + η (44 − 28 s) (straight panel edges; interior edges slightly curved)."""
    return map_mesh(box_mesh(1.0, 1.0, t, n, n, 1),
                    lambda p: np.stack([48.0 * p[:, 0], 44.0 * p[:, 0] + p[:, 1] * (44.0 - 28.0 * p[:, 0]), p[:, 2]], 1))


def d1_for(nu: float) -> float:
    """D1 = 2/K with K = 2G(1 + ν)/(3(1 − 2ν)) at fixed G; ν = 0.5 → D1 = 0."""
    return 0.0 if nu == 0.5 else 3.0 * (1.0 - 2.0 * nu) / (G * (1.0 + nu))


def cook_displacement(n: int, d1: float, t: float = 1.0, options: SolveOptions = SolveOptions()) -> float:
    """Vertical displacement at (48, 52) per unit total shear force (small-load limit)."""
    mesh = cook_mesh(n, t)
    X = mesh.points
    left = np.nonzero(np.isclose(X[:, 0], 0.0))[0]
    rest = np.setdiff1d(np.arange(mesh.n_nodes), left)
    _, _, f6 = boundary_faces(mesh.cells)
    right = f6[np.all(np.isclose(X[f6][:, :, 0], 48.0), axis=1)]
    prob = Problem(mesh, NeoHookean(G / 2.0, d1),
                   dirichlet=(Dirichlet(left, (0, 1, 2), "clamp"), Dirichlet(rest, (2,), "plane strain")),
                   tractions=(DeadTraction(right, "shear"),))
    load = LoadState((), (0.0, 0.0), (np.array([0.0, F_SMALL / (16.0 * t), 0.0]),))
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob), load, options=options)
    pt = np.nonzero(np.isclose(X[:, 0], 48.0) & np.isclose(X[:, 1], 52.0))[0]
    assert len(pt) >= 2  # the right-edge midpoint through the thickness (front, back, mid-edge)
    return float(states[-1].u[pt, 1].mean() / F_SMALL)


def test_material_constants_match_reference():
    """C10 = G/2 and D1 = 2/(λ + 2G/3) reproduce the reference's ν = λ/(2(λ + G)) ≈ 0.49998."""
    nu = LAME / (2 * (LAME + G))
    assert abs(nu - 0.49998) < 1e-5
    np.testing.assert_allclose(d1_for(nu), 2.0 / (LAME + 2.0 * G / 3.0), rtol=1e-12)


@pytest.fixture(scope="module")
def cook_16():
    """u(48, 52) on the 16 × 16 mesh for ν = 0.4, 0.49, 0.4999 and the reference ν ≈ 0.49998."""
    nus = [0.4, 0.49, 0.4999, LAME / (2 * (LAME + G))]
    return {nu: cook_displacement(16, d1_for(nu)) for nu in nus}


def test_cook_within_one_percent(cook_16):
    """16 × 16 mesh (11k DOFs), λ = 7500: u(48, 52) within 1 % of 16.4326."""
    u = cook_16[LAME / (2 * (LAME + G))]
    err = (u - U_REF) / U_REF
    print(f"Cook 16x16, nu=0.49998: u = {u:.4f} (ref {U_REF}), rel err {err:+.2e}")
    assert abs(err) <= 0.01


def test_cook_no_locking(cook_16):
    """The displacement levels off as ν → 0.5 (a locking element's would fall ∝ 1/K, i.e. 5× between
    ν = 0.4999 and 0.49998): u(0.49998) ≥ 0.999 u(0.4999), and u decreases monotonically with ν at
    fixed G, as the converged linear-elastic solution does (stiffer bulk)."""
    nus = sorted(cook_16)
    us = [cook_16[nu] for nu in nus]
    print("Cook 16x16: " + ", ".join(f"nu={nu:.5f}: {u:.4f}" for nu, u in zip(nus, us)))
    assert all(a > b for a, b in zip(us, us[1:]))
    assert us[-1] >= 0.999 * us[-2]
    assert us[-1] >= 0.99 * U_REF


def test_cook_fully_incompressible(cook_16):
    """D1 = 0 (ν = 0.5 exactly, the thesis material): the mixed u–p element still gives the
    nearly-incompressible answer: within 1 % of 16.4326 on the 16 × 16 mesh, and equal to the
    ν = 0.49998 result to 0.1 %."""
    u0 = cook_displacement(16, 0.0)
    u1 = cook_16[LAME / (2 * (LAME + G))]
    print(f"Cook 16x16: D1=0 u = {u0:.4f}, nu=0.49998 u = {u1:.4f}")
    assert abs(u0 - U_REF) <= 0.01 * U_REF
    assert abs(u0 - u1) <= 1e-3 * u1
