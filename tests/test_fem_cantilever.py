"""Incompressible solid cantilever under a dead tip load: Euler–Bernoulli and the Euler elastica.

Reference: the elastica of a cantilever under a dead tip load (Bisshopp & Drucker 1945):
EIθ'' = −P cos θ, θ(0) = 0, θ'(L) = 0, load parameter k = PL²/EI; tip deflection
δy/L = ∫₀¹ sin θ ds and shortening δx/L = 1 − ∫₀¹ cos θ ds. We compute the elastica by
shooting (scipy) and check it against the VERIFICATION.md table. For small k the 3-D beam
approaches Euler–Bernoulli δ = PL³/(3EI) with E = 3μ (incompressible).
Required: small load within 2 % of Euler–Bernoulli; k = 1, 2 within 2 % of the elastica.

Model: box 10 × 1 × 1 (L/h = 10; the Timoshenko shear correction 3EI/(κGAL²) ≈ 0.9 %),
30 × 3 × 3 cells, base x = 0 clamped, dead traction P/h² in +y on the tip face, D1 = 0,
μ = 1; tip displacement read at the centre of the tip face. Refinement table in
benchmarks/accuracy/fem_convergence.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.mesh import boundary_faces
from fem.meshgen import box_mesh
from fem.newton import SolveOptions
from fem.problem import DeadTraction, Dirichlet, Problem
from fem.state import State

TOL = 0.02  # relative, the solver's accepted error on the elastica


def elastica(k: float) -> tuple[float, float]:
    """(δy/L, δx/L) of the cantilever elastica θ'' = −k cos θ, θ(0) = 0, θ'(1) = 0, by shooting on θ'(0)."""

    def shoot(m):
        sol = solve_ivp(lambda s, y: [y[1], -k * np.cos(y[0]), np.sin(y[0]), np.cos(y[0])], (0.0, 1.0),
                        [0.0, m, 0.0, 0.0], rtol=1e-12, atol=1e-14)
        return sol.y[:, -1]

    m = brentq(lambda m: shoot(m)[1], 0.0, 1.01 * k, xtol=1e-14)  # θ'(0) ∈ (0, k]
    y = shoot(m)
    return float(y[2]), float(1.0 - y[3])


def test_elastica_reference_matches_table():
    """The shooting solution reproduces the Bisshopp–Drucker table of VERIFICATION.md to its 5 digits."""
    table = {0.5: (0.16214, 0.01592), 1.0: (0.30172, 0.05643), 2.0: (0.49346, 0.16064), 5.0: (0.71379, 0.38763)}
    for k, ref in table.items():
        np.testing.assert_allclose(elastica(k), ref, atol=6e-6)


def cantilever(L: float, h: float, nx: int, nyz: int, ks, mu: float = 1.0, d1: float = 0.0,
               options: SolveOptions = SolveOptions()):
    """Tip-centre (δy/L, δx/L) of a clamped L × h × h block under dead tip loads k = PL²/EI."""
    mesh = box_mesh(L, h, h, nx, nyz, nyz)
    X = mesh.points
    base = np.nonzero(np.isclose(X[:, 0], 0.0))[0]
    _, _, f6 = boundary_faces(mesh.cells)
    tip = f6[np.all(np.isclose(X[f6][:, :, 0], L), axis=1)]
    prob = Problem(mesh, NeoHookean(mu / 2.0, d1), dirichlet=(Dirichlet(base, (0, 1, 2), "clamp"),),
                   tractions=(DeadTraction(tip, "tip"),))
    EI = 3.0 * mu * h**4 / 12.0  # E = 3μ (incompressible), I = h⁴/12
    ks = np.asarray(ks, float)
    P = ks[-1] * EI / L**2
    load = LoadState((), (0.0,), (np.array([0.0, P / h**2, 0.0]),))
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob), load, fractions=tuple(ks / ks[-1]),
                           options=options)
    pt = np.nonzero(np.isclose(X[:, 0], L) & np.isclose(X[:, 1], h / 2) & np.isclose(X[:, 2], h / 2))[0]
    assert len(pt) == 1
    return [(st.u[pt[0], 1] / L, -st.u[pt[0], 0] / L) for st in states]


@pytest.fixture(scope="module")
def beam_results():
    ks = (0.01, 1.0, 2.0)
    return dict(zip(ks, cantilever(10.0, 1.0, 30, 3, ks)))


def test_small_load_euler_bernoulli(beam_results):
    """k = PL²/EI = 0.01: δy = PL³/(3EI), i.e. δy/L = k/3, within 2 % (elastica correction O(k²) ≈ 1e-5)."""
    dy, _ = beam_results[0.01]
    ref = 0.01 / 3.0
    err = (dy - ref) / ref
    print(f"cantilever k=0.01: dy/L = {dy:.6e} (EB {ref:.6e}), rel err {err:+.2e}")
    assert abs(err) <= TOL


@pytest.mark.parametrize("k", [1.0, 2.0])
def test_large_load_elastica(beam_results, k):
    """k = 1, 2: tip deflection and shortening within 2 % of the elastica (dead load, large rotation)."""
    dy, dx = beam_results[k]
    ry, rx = elastica(k)
    ey, ex = (dy - ry) / ry, (dx - rx) / rx
    print(f"cantilever k={k}: dy/L = {dy:.5f} (elastica {ry:.5f}, {ey:+.2e}), dx/L = {dx:.5f} "
          f"(elastica {rx:.5f}, {ex:+.2e})")
    assert abs(ey) <= TOL
    assert abs(ex) <= TOL
