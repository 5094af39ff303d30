"""Smoke tests of the stability benchmark (benchmarks/reliability/stress_test.py) and of the convergence
numerics the benchmarks share (benchmarks/numerics.py).

Fast (< 30 s): the case list, the failure classification of designed-to-fail cases, one
converged coarse scene, and the Richardson / Pareto helpers on data with known answers.
"""

import math

import pytest

from benchmarks import numerics
from benchmarks.reliability import stress_test
from fem.newton import SolveOptions


def test_case_list_covers_box_corners_and_edge_midpoints():
    """48 box points (16 corners + 32 edge midpoints), 302 cases by default, unique ids."""
    pts = stress_test.box_points()
    assert len(pts) == 48
    corners = [p for p in pts if all(p[g] in stress_test.GENE_BOX[g] for g in p)]
    assert len(corners) == 16
    cases = stress_test.make_cases(110)
    assert len(cases) == 302 and len({c.case_id for c in cases}) == 302
    assert max(c.Q for c in cases) == pytest.approx(0.3) and max(c.delta_max for c in cases) == 8.0
    assert {c.contact_ratio for c in cases} == {0.5, 0.75, 1.0}
    assert sum(c.ga_scene for c in cases) >= 96  # all box/thesis cases + in-range random ones


def test_invalid_design_is_classified_with_a_reason():
    """α = 6°, l = 15, t = 7.5 leaves no cavity (r_i(l) = 7.42 − 7.5 < 0): invalid_geometry."""
    case = stress_test.Case("bad", "test", 6.0, 15.0, 7.5, 0.1, 0.0, 0.1, 5.0, 1.0, 0.0)
    row = stress_test.run_case(case, "coarse")
    assert row["status"] == "invalid_geometry" and not row["converged"]
    assert "InvalidDesignError" in row["reason"] and math.isnan(row["eps_max"])


def test_starved_solver_is_classified_solve_failed_and_timeout_is_timeout():
    """One Newton iteration and no cut-back cannot pressurise to 0.2 MPa: solve_failed, 1 cut-back."""
    case = stress_test.Case("starved", "test", 2.862, 15.0, 3.0, 0.2, 0.0, 0.2, 5.0, 1.0, 0.0)
    row = stress_test.run_case(case, "coarse", solve_options=SolveOptions(max_iterations=1, max_cutbacks=0))
    assert row["status"] == "solve_failed", row
    assert row["cutbacks"] == 1 and row["increments"] == 0 and "load path failed" in row["reason"]
    row = stress_test.run_case(case, "coarse", timeout_s=0.05)
    assert row["status"] == "timeout" and row["time_s"] < 5.0


def test_ga_scene_converges_with_finite_readings_at_coarse():
    """Default design, Q = 0.05, δ = 2 mm: converged, finite positive ε, 4 deflection increments at least."""
    case = stress_test.Case("ok", "test", 2.862, 15.0, 3.0, 0.05, 0.0, 0.05, 2.0, 1.0, 0.0)
    row = stress_test.run_case(case, "coarse")
    assert row["status"] == "ok" and row["converged"], row
    assert math.isfinite(row["eps_max"]) and row["eps_max"] > 0
    assert row["increments"] >= 4 and row["cutbacks"] == 0 and 0 < row["min_j"] < 1.5


def test_richardson_and_pareto_on_known_data():
    """q = 1 + 0.5 h^1.5 on h = 1/2, 1/3, 1/4 extrapolates to 1 with p = 1.5; Pareto mask by hand."""
    h = [1.0, 0.5, 1 / 3, 0.25]
    q_ref, p, note = numerics.richardson_or_p2(h, [1 + 0.5 * x**1.5 for x in h])
    assert q_ref == pytest.approx(1.0, abs=1e-12) and p == pytest.approx(1.5, abs=1e-9) and note == "observed"
    q_ref, p, note = numerics.richardson_or_p2(h, [1.0, 1.2, 1.1, 1.15])  # not monotone: p = 2 from two finest
    assert note == "assumed p=2" and q_ref == pytest.approx(1.15 + 0.05 * (1 / 16) / (1 / 9 - 1 / 16))
    mask = numerics.pareto([1, 2, 3, 4], [5, 1, 2, 0.5])
    assert mask.tolist() == [True, True, False, True]
    assert numerics.front_ratio([1, 2, 3, 4], [5, 1, 2, 0.5], 2) == 2.0


def test_observed_order_and_richardson_value_on_known_data():
    """q = 2 − 3 h^2.5 on non-uniform h: p = 2.5 and q∞ = 2 in any bracket holding 2.5; NaN (no asymptotic
    range) when the differences change sign, vanish, or p lies outside the bracket."""
    h = [1.0, 0.6, 0.45]
    q = [2 - 3 * x**2.5 for x in h]
    p, q_inf = numerics.richardson(h, q)
    assert p == pytest.approx(2.5, abs=1e-9) and q_inf == pytest.approx(2.0, abs=1e-9)
    assert numerics.observed_order([1 / k for k in (1, 2, 3)], [1 - 1 / k**3 for k in (1, 2, 3)],
                                   bracket=(0.05, 12.0)) == pytest.approx(3.0, abs=1e-9)
    assert math.isnan(numerics.observed_order(h, q, bracket=(0.1, 2.0)))
    assert all(math.isnan(v) for v in numerics.richardson(h, [1.0, 1.2, 1.1]))
    assert math.isnan(numerics.observed_order(h, [1.0, 1.0, 1.0]))
