"""Automatic load stepping along a load path, with cut-backs.

Loads (pressures, prescribed displacements) are interpolated linearly between two
:class:`fem.loads.LoadState` along a load parameter s ∈ [0, 1]. Each requested
fraction is reached by one or more increments, each a Newton solve of one load level
(:class:`fem.newton.NewtonSolver`). An increment that diverges, inverts an element or
exceeds the iteration limit is retried from the last converged state with half the
step (cut-back); easy increments (at most 4 iterations) let the step grow by 1.5.
Increments after the first may start from the secant extrapolation of the last two
converged states.

:func:`follow_path` steps any :class:`fem.system.NonlinearSystem` (state vectors in, state vectors
out); :func:`solve_path` is the 3-D solid's front (:class:`fem.state.State` in and out).
A failed path raises :class:`fem.newton.SolveFailed` carrying the step reports; a
non-converged or non-finite state is never returned.
"""

from __future__ import annotations

import logging
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from fem.loads import LoadState
from fem.newton import NewtonSolver, SolveFailed, SolveOptions
from fem.problem import Problem
from fem.state import State

logger = logging.getLogger(__name__)


@dataclass
class StepReport:
    """Everything that happened while reaching one requested fraction of the load path."""

    fraction: float
    increments: list = field(default_factory=list)
    n_cutbacks: int = 0
    min_j: float = float("nan")
    time_assembly: float = 0.0
    time_factorize: float = 0.0
    time_solve: float = 0.0
    time_total: float = 0.0
    linear_solver: str = ""

    @property
    def iterations(self) -> int:
        return sum(i.iterations for i in self.increments)

    @property
    def n_increments(self) -> int:
        return sum(1 for i in self.increments if i.converged)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["iterations"] = self.iterations
        d["n_increments"] = self.n_increments
        return d

    def summary(self) -> str:
        return (f"s={self.fraction:.4g}: {self.n_increments} increments, {self.iterations} iterations, "
                f"{self.n_cutbacks} cut-backs, min J={self.min_j:.4g}")


def solve_path(problem: Problem, state0: State, load0: LoadState, load1: LoadState,
               fractions=(1.0,), options: SolveOptions = SolveOptions(), callback=None):
    """Follow the load path load0 → load1 from ``state0`` and return the states at ``fractions``.

    Parameters
    ----------
    problem : Problem
    state0 : State
        Converged state under ``load0`` (its prescribed DOFs are overwritten by load0's values).
    load0, load1 : LoadState
    fractions : sequence of float
        Increasing values in (0, 1] at which states are returned (and ``callback`` called).
    options : SolveOptions
    callback : callable(fraction, State) or None

    Returns
    -------
    states : list of State
    reports : list of StepReport

    Raises
    ------
    fem.newton.SolveFailed
        When an increment cannot converge within the cut-back limits.
    """
    _check_fractions(fractions)
    load0 = load0.check(problem)
    load1 = load1.check(problem)
    newton = NewtonSolver(problem, options.linear_solver)
    states = []

    def reached(target: float, x: np.ndarray, residual: np.ndarray | None) -> None:
        st = State.from_vector(x, problem.mesh.n_nodes, residual)
        states.append(st)
        if callback is not None:
            callback(target, st)

    _, reports, _ = follow_path(newton, state0.as_vector(), load0, load1, fractions, options, reached)
    return states, reports


def _check_fractions(fractions) -> list[float]:
    fr = [float(f) for f in fractions]
    if not fr or any(not (0.0 < f <= 1.0) for f in fr) or any(b <= a for a, b in zip(fr, fr[1:])):
        raise ValueError(f"solve_path: fractions={fractions!r} must be increasing values in (0, 1]")
    return fr


def follow_path(newton: NewtonSolver, x0: np.ndarray, load0, load1, fractions=(1.0,),
                options: SolveOptions = SolveOptions(), callback=None, history: tuple | None = None):
    """Follow the load path load0 → load1 of ``newton``'s system from the state vector ``x0``.

    Parameters
    ----------
    newton : NewtonSolver
        The solver of the system (:class:`fem.system.NonlinearSystem`).
    x0 : ndarray
        Converged state under ``load0`` (copied; its prescribed unknowns are overwritten by load0's values).
    load0, load1 : load
        Checked loads of the system (``interpolate(other, s)``).
    fractions : sequence of float
        Increasing values in (0, 1] at which states are kept (and ``callback`` called).
    options : SolveOptions
    callback : callable(fraction, x, residual) or None
        ``residual``: R at ``x`` as the converged solve last evaluated it.
    history : tuple (x, s) or None
        A converged state before ``x0`` on the same path and its load parameter (s < 0), for the
        first increment's secant predictor.

    Returns
    -------
    reached : list of (x, residual)
        The states at ``fractions``.
    reports : list of StepReport
    history : tuple (x, s) or None
        The last converged state before the end and its load parameter, for a path that goes on.

    Raises
    ------
    fem.newton.SolveFailed
        When an increment cannot converge within the cut-back limits.
    """
    fr = _check_fractions(fractions)
    x = np.array(x0, dtype=float)
    cd, cv = newton.system.prescribed(load0)
    x[cd] = cv
    s = 0.0
    ds = min(options.initial_step, options.max_step)
    reached, reports = [], []
    n_cut_total = 0
    hist = history  # (x, s) of the previous converged state, for the secant predictor
    loose = options
    if options.intermediate_rtol is not None:
        loose = replace(options, rtol=options.intermediate_rtol, etol=max(options.etol, options.intermediate_rtol**2))
    for target in fr:
        rep = StepReport(fraction=target, linear_solver=newton.linear_solver_name)
        t_start = time.perf_counter()
        while s < target - 1e-12:
            s_new = min(target, s + ds)
            if target - s_new < 0.05 * ds:  # avoid a sliver increment
                s_new = target
            load_new = load0.interpolate(load1, s_new)
            x_start = x
            if options.extrapolate and hist is not None and s - hist[1] > 0:
                # secant predictor: continue the last converged increment's direction
                cand = x + (x - hist[0]) * ((s_new - s) / (s - hist[1]))
                if newton.min_jacobian(cand) > 0.05:
                    x_start = cand
            opts_inc = options if s_new >= target else loose
            x_new, inc = newton.solve(x_start, load_new, opts_inc, rep)
            if not inc.converged and x_start is not x:
                # the extrapolated start failed: retry this increment from the converged state
                x_new, inc2 = newton.solve(x, load_new, opts_inc, rep)
                inc2.reason = inc2.reason or inc.reason
                inc = inc2
            inc.s_start, inc.s_end = s, s_new
            rep.increments.append(inc)
            if inc.converged:
                hist = (x, s)
                x = x_new
                s = s_new
                rep.min_j = inc.min_j if np.isnan(rep.min_j) else min(rep.min_j, inc.min_j)
                if inc.iterations <= 4:
                    ds = min(options.max_step, ds * 1.5)
            else:
                rep.n_cutbacks += 1
                n_cut_total += 1
                ds = (s_new - s) * 0.5
                logger.debug("cut-back at s=%.4g: %s; new step %.3g", s, inc.reason, ds)
                if ds < options.min_step or n_cut_total > options.max_cutbacks:
                    rep.time_total = time.perf_counter() - t_start
                    reports.append(rep)
                    raise SolveFailed(
                        f"load path failed at s={s:.4g} (step {ds:.3g}, {n_cut_total} cut-backs): {inc.reason}",
                        reports, inc)
        rep.time_total = time.perf_counter() - t_start
        reports.append(rep)
        reached.append((x, newton.residual))
        if callback is not None:
            callback(target, x, newton.residual)
    return reached, reports, hist
