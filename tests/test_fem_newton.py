"""The Newton increment's acceptance rules (fem.newton), each on the case that needs it.

* ``energy``: a residual tolerance below the residual's round-off floor (rtol = 1e-16, atol = 0)
  on a stretched block still ends, at the floor, once the energy has converged.
* ``residual``: a residual 1000 times below its tolerance ends the increment one iteration
  before the energy ratio reaches etol (uniaxial stretch 0.3 of a block: 4 iterations, not 5).
* ``residual_floor``: tests/test_fibre_cell.py (a tiny prescribed increment of a fibre cell).
* The rules' boundaries exactly as the module docstring states them.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import fem.newton as newton_module
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.meshgen import box_mesh
from fem.newton import ACCEPTANCE_RULES, Iterate, NewtonSolver, SolveOptions, acceptance_rule
from fem.problem import Dirichlet, Problem
from fem.state import State


def _block(d1: float) -> Problem:
    """A distorted 2×2×2 unit block on symmetry supports, its face x = 1 moved along x."""
    m = box_mesh(1.0, 1.0, 1.0, 2, 2, 2, distort=0.2, seed=3)
    X = m.points

    def on(axis, value):
        return np.nonzero(np.isclose(X[:, axis], value, atol=1e-12))[0]

    sets = (Dirichlet(on(0, 0.0), (0,)), Dirichlet(on(1, 0.0), (1,)), Dirichlet(on(2, 0.0), (2,)),
            Dirichlet(on(0, 1.0), (0,)))
    return Problem(m, NeoHookean(0.5, d1), dirichlet=sets)


def _stretch(prob: Problem, u: float, opts: SolveOptions):
    x0 = State.zero(prob).as_vector().astype(float)
    timer = SimpleNamespace(time_assembly=0.0, time_factorize=0.0, time_solve=0.0)
    return NewtonSolver(prob, "auto").solve(x0, LoadState((), (0.0, 0.0, 0.0, u)).check(prob), opts, timer)


@pytest.mark.parametrize("d1", [0.0, 0.5])
def test_energy_rule_ends_an_increment_whose_tolerance_is_below_the_round_off_floor(d1):
    x, inc = _stretch(_block(d1), 0.3, SolveOptions(rtol=1e-16, atol=0.0, near_solution_energy=0.0))
    assert inc.converged and inc.rule == "energy" and inc.iterations == 5
    # the floor: no residual below 1e-16, which rtol = 1e-16 would ask of a force scale above 1
    assert 1e-16 < inc.residuals[-1] < 1e-15 and inc.energies[-1] < 1e-20


@pytest.mark.parametrize("d1, residuals", [(0.0, 1.2e-13), (0.5, 5.2e-16)])
def test_residual_rule_saves_the_iteration_the_energy_ratio_needs(d1, residuals):
    x, inc = _stretch(_block(d1), 0.3, SolveOptions(near_solution_energy=0.0))  # factorised every iteration
    assert inc.converged and inc.rule == "residual" and inc.iterations == 4
    assert inc.residuals[-1] == pytest.approx(residuals, rel=0.5)
    assert inc.energies[-1] > SolveOptions().etol  # the energy criterion alone would need a fifth


def test_without_the_energy_or_residual_rule_those_increments_take_longer_or_fail(monkeypatch):
    """The two tests above fail with the rule taken out (what justifies each rule)."""
    real = newton_module.acceptance_rule

    def without(name):
        def rule(m, opts, volume):
            got = real(m, opts, volume)
            if got != name:
                return got
            return "residual_floor" if (m.rp <= opts.vtol * volume and m.ru <= opts.rtol * m.f_ref + opts.atol
                                        and m.iteration >= 2 and m.ratio > 0.1) else ""
        return rule

    monkeypatch.setattr(newton_module, "acceptance_rule", without("energy"))
    _, inc = _stretch(_block(0.0), 0.3, SolveOptions(rtol=1e-16, atol=0.0))
    assert not inc.converged and "no convergence" in inc.reason
    monkeypatch.setattr(newton_module, "acceptance_rule", without("residual"))
    _, inc = _stretch(_block(0.0), 0.3, SolveOptions())
    assert inc.converged and inc.iterations == 5


def _it(**kw) -> Iterate:
    base = dict(iteration=2, ru=1.0, rp=0.0, energy=1.0, e0=1.0, ratio=0.01, f_ref=1e8)
    return Iterate(**{**base, **kw})


@pytest.mark.parametrize("m, rule", [
    # tol = rtol · F_ref = 1 with rtol = 1e-8, F_ref = 1e8; atol = 1e-12; etol = 1e-12; vtol · V = 1e-10
    (_it(ru=1000.0, energy=1e-12), "energy"),              # energy converged, residual 1000 tol: accepted
    (_it(ru=1000.1, energy=1e-12), ""),                    # ... just above 1000 tol: not
    (_it(ru=10.0, energy=1e-31, e0=1e-300), "energy"),     # an energy below 1e-30 counts as converged
    (_it(ru=10.0, energy=1e-12, rp=1.0), "energy"),        # the energy rule does not check the volume
    (_it(ru=1e-3, energy=0.5), "residual"),                # residual 1000 times below tol
    (_it(ru=1e-3, energy=0.5, rp=1e-9), ""),               # ... but the volume residual above vtol · V
    (_it(ru=0.9, energy=0.5, ratio=0.2), "residual_floor"),  # within tol, reduced by less than 10
    (_it(ru=0.9, energy=0.5, ratio=0.09), ""),             # ... reduced by more than 10: keep iterating
    (_it(ru=0.9, energy=0.5, ratio=0.2, iteration=1), ""),   # ... never on the first iteration
    (_it(ru=1.1, energy=0.5, ratio=0.9), ""),              # above tol
])
def test_rules_exactly_as_documented(m, rule):
    assert acceptance_rule(m, SolveOptions(), volume=1.0) == rule
    assert rule in ACCEPTANCE_RULES + ("",)


def test_unknown_linear_solver_is_refused():
    with pytest.raises(ValueError, match="'auto', 'pardiso', 'superlu'"):
        SolveOptions(linear_solver="cg")


@pytest.mark.parametrize("d1", [0.0, 0.5])
def test_factorisation_kept_near_the_solution_reaches_full_newtons_answer(d1):
    """Keeping the factorisation once the step energy is small (near_solution_energy) saves
    factorisations and converges to the state of full Newton within the solver tolerance."""
    full, inc_f = _stretch(_block(d1), 0.3, SolveOptions(near_solution_energy=0.0))
    prob = _block(d1)  # its own linear solver, so only this solve's factorisations count
    solver = NewtonSolver(prob, "auto")
    n0 = solver.linear.stats["n_factorize"]
    timer = SimpleNamespace(time_assembly=0.0, time_factorize=0.0, time_solve=0.0)
    x0 = State.zero(prob).as_vector().astype(float)
    kept, inc_k = solver.solve(x0, LoadState((), (0.0, 0.0, 0.0, 0.3)).check(prob),
                               SolveOptions(near_solution_energy=0.1), timer)
    assert inc_f.converged and inc_k.converged
    assert solver.linear.stats["n_factorize"] - n0 < inc_k.iterations
    assert np.abs(kept - full).max() <= 1e-8 * np.abs(full).max()


@pytest.mark.parametrize("d1", [0.0, 0.5])
def test_path_states_carry_the_residual_of_their_own_evaluation(d1):
    """The residual a converged state carries (State.residual, the Newton solve's last evaluation) is
    R at that state under its load, as the assembler evaluates it afresh: the same numbers to round-off,
    at the prescribed DOFs the supports' reactions (nonzero), at the free ones below the tolerance."""
    from fem.assembly import Assembler
    from fem.loadpath import solve_path

    prob = _block(d1)
    states, _ = solve_path(prob, State.zero(prob), LoadState((), (0.0, 0.0, 0.0, 0.0)),
                           LoadState((), (0.0, 0.0, 0.0, 0.3)), fractions=(0.5, 1.0))
    asm = Assembler(prob)
    face = prob.dirichlet[3].nodes
    for st in states:
        fresh = asm.evaluate(st.u, st.p, (), need_tangent=False)[0]
        assert st.residual is not None
        assert np.array_equal(st.residual, fresh)
        assert abs(st.residual[3 * face].sum()) > 1e-3  # the pull on the moved face
