"""The periodic wall cell of ``benchmarks/wall_cell3d.py`` (the cell of ``benchmarks/studies/fibre_cell.py``) and the solver paths it needs.

References
----------
* Bending of the bare rubber tube: EI = E I with E = 3μ (incompressible) and, for the half
  tube, I = π (r_o⁴ − r_i⁴)/8 (Timoshenko & Gere, pure bending of a hollow circular section).
* A stiff ring embedded in a cell of 4 wall layers (768 tets) leaves PARDISO's matching and
  perturbation factors at |Ax − b|/|b| ≈ 5e-5 and 4e6 after refinement; the scaled strategy
  (fem.linsolve) must solve it to the same answer as SuperLU.
* A prescribed-displacement increment of 1e-4 of the cell starts with an energy norm near
  round-off, so only the residual criterion can end it (fem.newton).
"""

from __future__ import annotations

import math

import pytest

from fem.linsolve import SOLVERS
from fem.loadpath import solve_path
from fem.newton import SolveOptions

from benchmarks import wall_cell3d as fc


@pytest.fixture(scope="module")
def cell():
    return fc.Cell.default()


def _run(cell, model_fields=(), trusses=(), n_r=2, n_phi=16):
    r, z = fc.uniform_grids(cell, n_r)
    mesh = fc.cell_mesh(cell, r, z, n_phi)
    prob, top = fc.cell_problem(cell, mesh, trusses=trusses(mesh) if callable(trusses) else trusses,
                                fields=model_fields)
    return fc.CellRun(cell, prob, top), mesh


def test_bare_tube_bends_as_beam_theory(cell):
    """EI of the rubber cell at Q = 0 against 3μ π (r_o⁴ − r_i⁴)/8 (measured 1464.0 against 1464.7)."""
    run, _ = _run(cell, n_r=2)
    exact = 3 * 2 * cell.c10 * math.pi * (cell.r_o**4 - cell.r_i**4) / 8
    assert run.bending_stiffness(0.0, 0.0)[1] == pytest.approx(exact, rel=2e-3)


def test_stiff_embedded_ring_solves_with_scaled_pardiso_factors(cell, monkeypatch):
    """The 4-layer cell with its ring: PARDISO falls back to the scaled factors and agrees with SuperLU."""
    pytest.importorskip("pypardiso")
    results = {}
    for solver in SOLVERS:  # every registered solver: the same answer
        run, mesh = _run(cell, trusses=lambda m: (fc.embedded_ring(cell, m, cell.t / 4),), n_r=4)
        opts = SolveOptions(linear_solver=solver)
        monkeypatch.setattr(fc, "solve_path", lambda *a, _o=opts, **k: solve_path(*a, options=_o, **k))
        results[solver] = run.bending_stiffness(0.0, 0.0)[1]
        if solver == "pardiso":
            lin = next(v for k, v in run.prob._cache.items() if isinstance(k, tuple) and k[0] == "linear_solver")
            assert lin._key[1] == "scaled"
    assert results["pardiso"] == pytest.approx(results["superlu"], rel=1e-8)


def test_tiny_prescribed_increment_converges(cell):
    """After pressurising the 1-layer cell with its ring, a move of U by 1e-4 s converges (the energy
    norm of such an increment is at round-off from its first iteration)."""
    run, _ = _run(cell, trusses=lambda m: (fc.embedded_ring(cell, m, cell.t),), n_r=1)
    U = run.pressurise(0.05, 0.0, n_levels=1)
    N0 = run.forces()[0]
    run.go(0.05, U + 1e-4 * cell.s)
    N1 = run.forces()[0]
    assert 0 < N1 - N0 < 1.0  # the wall's axial stiffness (≈ 50 N/mm) times 1.5e-4 mm

