"""Newton–Raphson solve of one load level, with line search, full or modified Newton.

One *increment* drives the state from the last converged load level to the next one
(:class:`NewtonSolver`). Its first iteration applies the prescribed-displacement
increment through the tangent (a consistent linear predictor), so the previous
converged state is the warm start. The solver knows its problem only as a
:class:`fem.system.NonlinearSystem` (residual, tangent, prescribed unknowns, norms): the 3-D
solid (:class:`fem.system.SolidSystem`) and the axisymmetric state of a body of revolution
(:class:`fem.axisym.harmonic_solve.AxisymmetricSystem`) go through the same iterations, rules,
line search and load stepping.

Measures of an iteration (:class:`Iterate`; Wriggers 2008, §5.1; Abaqus' criteria): the
residual ‖R_u‖ on the free DOFs after the step, the force scale F_ref (the largest of the
increment's first residual and the reaction norms so far), the volume residual ‖R_p‖ against
V (the mesh volume), and the energy |Δx · R| of the step against the largest of the increment
(the first iteration of a displacement-driven increment has no free residual, so its energy is
0). With tol = rtol · F_ref, an iteration ends the increment by the first of these rules
(:func:`acceptance_rule`; the name is kept in :attr:`IncrementReport.rule`):

``energy``
    |Δx · R| ≤ etol · max |Δx · R| (or ≤ 1e-30) and ‖R_u‖ ≤ 1000 · tol; ‖R_p‖ is not checked.
    The rule that ends most increments: Newton's energy converges quadratically, and the
    residual may stop a little above tol where round-off sets its floor (stiff fibres put it
    near 1e-16 times the fibre force scale; scene tests end increments at 3.6 tol). Without it
    an increment whose tol lies below the floor never ends (``tests/test_fem_newton.py``).
``residual``
    ‖R_u‖ ≤ 1e-3 · tol + atol and ‖R_p‖ ≤ vtol · V: the residual far below its tolerance, whatever
    the energy ratio (still far from etol one step after a large first step). Without it such
    increments take one more iteration: an assembly and a linear solve (``tests/test_fem_newton.py``).
``residual_floor``
    ‖R_u‖ ≤ tol + atol, ‖R_p‖ ≤ vtol · V, from the second iteration on, and the last iteration
    reduced ‖R_u‖ by less than a factor of 10: the residual at its round-off floor (Newton's
    quadratic rate would reduce it by far more). A small increment (a secant correction of a
    prescribed displacement) starts with an energy near round-off, so its energy ratio cannot
    reach etol; without the rule it fails (``tests/test_fibre_cell.py``, the tiny increment).

The two criteria together (‖R_u‖ ≤ tol + atol, ‖R_p‖ ≤ vtol · V and the energy) are not a rule
of their own: ``energy`` and ``residual`` accept everything they accept except residuals in
(1e-3 · tol + atol, tol + atol] that also exceed 1000 · tol, a band that exists only when
atol > 999 tol and is narrower than tol.

An increment that diverges (a residual above 1000 times the first, from the third iteration
on), inverts an element along the whole Newton step, fails its linear solve or exceeds the
iteration limit returns its start state with an unconverged :class:`IncrementReport`; the load
stepping (:mod:`fem.loadpath`) then cuts back, and raises :class:`SolveFailed` when it cannot.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from fem.assembly import InvertedElements
from fem.linsolve import SOLVER_NAMES, LinearSolverError
from fem.loads import LoadState
from fem.problem import Problem
from fem.system import NonlinearSystem, SolidSystem


@dataclass(frozen=True)
class SolveOptions:
    """Newton and stepping controls.

    Parameters
    ----------
    rtol : float
        Relative residual tolerance (0, 1).
    atol : float
        Absolute residual floor [N].
    etol : float
        Relative energy-norm tolerance.
    vtol : float
        Volume-constraint tolerance relative to the mesh volume.
    max_iterations : int
        Newton iterations per increment before a cut-back.
    initial_step, min_step, max_step : float
        Increment sizes as fractions of the whole path.
    max_cutbacks : int
        Cut-backs allowed over the whole path.
    line_search : bool
        Backtracking on the residual norm (and on inverted elements).
    linear_solver : str
        One of :data:`fem.linsolve.SOLVER_NAMES` ('auto', then the registered solvers).
    reuse_tangent : float
        0 = full Newton (factorise every iteration). r in (0, 1): modified Newton that
        keeps the last factorisation, across iterations and increments, as long as each
        iteration reduces the residual by at least the factor r; otherwise the tangent
        is re-assembled and re-factorised. Fewer factorisations for mildly nonlinear
        paths (the deflection step), same converged answer (same residual criteria).
    extrapolate : bool
        Start each increment after the first from the secant extrapolation of the last
        two converged states (falls back to the last converged state if that start
        inverts elements or fails to converge).
    intermediate_rtol : float or None
        Residual tolerance for increments that end *between* requested fractions (their
        states are never returned; the next increment's Newton iterations remove what
        is left). The energy tolerance becomes its square. None: ``rtol`` everywhere.
        Requested fractions are always converged to ``rtol``/``etol``.
    first_line_search : bool
        Also search along the first iteration's step of a load-driven increment (one whose
        prescribed displacements do not change, e.g. a pressure step): the linear predictor
        of a large pressure step overshoots, and without the search Newton then wanders for
        several iterations. A displacement-driven first step is always taken whole.
    near_solution_energy : float
        Full Newton only (``reuse_tangent`` = 0): once an iteration's step energy |Δx · R| is at
        most this fraction of the increment's largest, the following iterations keep the last
        factorisation (modified Newton near the solution, where the tangent changes little) while
        each reduces ‖R_u‖ by at least ``near_solution_ratio``; otherwise the tangent is
        re-assembled and re-factorised. 0: factorise every iteration.
    near_solution_ratio : float
        The residual reduction per iteration that keeps the factorisation near the solution.
    """

    rtol: float = 1e-8
    atol: float = 1e-12
    etol: float = 1e-12
    vtol: float = 1e-10
    max_iterations: int = 20
    initial_step: float = 1.0
    min_step: float = 1e-4
    max_step: float = 1.0
    max_cutbacks: int = 20
    line_search: bool = True
    linear_solver: str = "auto"
    reuse_tangent: float = 0.0
    extrapolate: bool = True
    intermediate_rtol: float | None = None
    first_line_search: bool = True
    near_solution_energy: float = 1e-2
    near_solution_ratio: float = 0.1

    def __post_init__(self) -> None:
        checks = [("rtol", self.rtol, 0.0, 1.0), ("atol", self.atol, 0.0, 1e6), ("etol", self.etol, 0.0, 1.0),
                  ("vtol", self.vtol, 0.0, 1.0), ("max_iterations", self.max_iterations, 1, 1000),
                  ("initial_step", self.initial_step, 1e-9, 1.0), ("min_step", self.min_step, 1e-12, 1.0),
                  ("max_step", self.max_step, 1e-9, 1.0), ("max_cutbacks", self.max_cutbacks, 0, 1000),
                  ("reuse_tangent", self.reuse_tangent, 0.0, 0.99),
                  ("near_solution_energy", self.near_solution_energy, 0.0, 1.0),
                  ("near_solution_ratio", self.near_solution_ratio, 0.0, 0.99)]
        for name, v, lo, hi in checks:
            if not (lo <= v <= hi):
                raise ValueError(f"SolveOptions.{name}={v!r} outside the allowed range [{lo}, {hi}]")
        if self.linear_solver not in SOLVER_NAMES:
            raise ValueError(f"SolveOptions.linear_solver={self.linear_solver!r}: allowed "
                             f"{', '.join(repr(n) for n in SOLVER_NAMES)}")
        if self.intermediate_rtol is not None and not (self.rtol <= self.intermediate_rtol < 1.0):
            raise ValueError(f"SolveOptions.intermediate_rtol={self.intermediate_rtol!r} outside the allowed "
                             f"range [rtol={self.rtol}, 1)")


@dataclass
class IncrementReport:
    """One increment: load parameter interval, iterations, residual history and the acceptance ``rule``
    (one of :data:`ACCEPTANCE_RULES`; ``''`` when not converged)."""

    s_start: float
    s_end: float
    converged: bool
    iterations: int = 0
    residuals: list = field(default_factory=list)
    energies: list = field(default_factory=list)
    min_j: float = float("nan")
    reason: str = ""
    rule: str = ""


class SolveFailed(RuntimeError):
    """The load path could not be followed.

    Attributes
    ----------
    reports : list of fem.loadpath.StepReport
        The step reports so far (the last one is the failed step).
    last : IncrementReport or None
        The increment that failed.
    """

    def __init__(self, message: str, reports: list, last: IncrementReport | None = None):
        super().__init__(message)
        self.reports = reports
        self.last = last


class NewtonSolver:
    """Newton solves of one system's load levels.

    Holds what the increments of one load path share: the system (:class:`fem.system.NonlinearSystem`:
    residual, tangent, prescribed unknowns, norms), the linear solver (the system's, so systems sharing a
    sparsity pattern share its analysis) and, for modified Newton, the last factorisation.

    Parameters
    ----------
    problem : Problem or NonlinearSystem
        A 3-D :class:`fem.problem.Problem` (solved as a :class:`fem.system.SolidSystem`) or any system.
    linear_solver : str
        One of :data:`fem.linsolve.SOLVER_NAMES` (see :func:`fem.linsolve.make_solver`).
    """

    def __init__(self, problem: Problem | NonlinearSystem, linear_solver: str = "auto") -> None:
        self.system = SolidSystem(problem) if isinstance(problem, Problem) else problem
        self.linear = self.system.linear_solver(linear_solver)
        self.volume = float(self.system.volume)
        self._fact = {"valid": False, "data": None}  # factorisation state (modified Newton)
        #: R at the state the last converged :meth:`solve` returned (its last evaluation), else None
        self.residual: np.ndarray | None = None

    @property
    def linear_solver_name(self) -> str:
        return getattr(self.linear, "name", "?")

    def min_jacobian(self, x: np.ndarray) -> float:
        """Smallest det F of the state vector ``x`` (displacements first)."""
        return self.system.min_jacobian(x)

    def solve(self, x0: np.ndarray, load: LoadState, opts: SolveOptions, timer) -> tuple[np.ndarray, IncrementReport]:
        """Newton iterations from ``x0`` to equilibrium under ``load``.

        Each iteration: a Newton step (:meth:`_newton_step`: factorise when full Newton, when the
        last factorisation is stale or when the last iteration reduced the residual by less than
        ``opts.reuse_tangent``; the first iteration also applies the prescribed-displacement
        increment), a line search along it (:meth:`_line_search`), then the acceptance test
        (:func:`acceptance_rule`, the rules of the module docstring, first match wins, recorded
        in ``report.rule``). The increment fails when an iteration's residual exceeds 1000 times
        the first iteration's (from iteration 3 on) or after ``opts.max_iterations`` iterations.

        Parameters
        ----------
        x0 : ndarray, shape (n_dofs,)
            Start state (displacements, then element pressures); its prescribed DOFs hold
            the previous load level's values.
        load : LoadState or the system's load
            The load level to reach (its prescribed values by :meth:`fem.system.NonlinearSystem.prescribed`).
        opts : SolveOptions
        timer : object
            Has float attributes ``time_assembly``, ``time_factorize`` and ``time_solve``
            that the seconds spent are added to (a :class:`fem.loadpath.StepReport`).

        Returns
        -------
        x : ndarray
            The converged state, or ``x0`` when the increment failed.
        report : IncrementReport
            ``converged``, the acceptance ``rule`` and, on failure, ``reason``.
        """
        inc = IncrementReport(0.0, 0.0, False)
        self.residual = None
        try:
            x = self._iterate(x0, load, opts, timer, inc)
        except _IncrementFailed as exc:
            inc.reason = exc.reason
            if exc.stale:
                self._fact["valid"] = False
            return x0, inc
        inc.converged = True
        return x, inc

    def _iterate(self, x0: np.ndarray, load: LoadState, opts: SolveOptions, timer, inc: IncrementReport) -> np.ndarray:
        """The Newton loop of :meth:`solve`: the converged state, filling ``inc``; raises :class:`_IncrementFailed`."""
        system, fact = self.system, self._fact
        modified = opts.reuse_tangent > 0
        cd, cv_new = system.prescribed(load)
        x = x0.copy()
        du_c = np.zeros(len(x))
        du_c[cd] = cv_new - x0[cd]
        try:
            R, data, min_j = self._evaluate(x, load, not (modified and fact["valid"]), timer)
        except InvertedElements as exc:
            raise _IncrementFailed(f"start state: {exc}", stale=False) from None
        ru0, _, rc0 = system.norms(R)
        f_ref = max(ru0, rc0, 1e-300)
        e0 = None
        ratio = 0.0
        ru_prev = ru0
        keep = modified  # keep the factorisation while it converges (modified Newton)
        keep_ratio = opts.reuse_tangent if modified else opts.near_solution_ratio
        for it in range(1, opts.max_iterations + 1):
            inc.iterations = it
            refactor = (not keep) or (not fact["valid"]) or ratio > keep_ratio
            if refactor and data is None:
                try:
                    R, data, min_j = self._evaluate(x, load, True, timer)
                except InvertedElements as exc:  # pragma: no cover - x was evaluated before
                    raise _IncrementFailed(f"iteration {it}: {exc}") from None
            dx = self._newton_step(it, R, data, refactor, du_c, timer)
            energy = abs(float(np.dot(dx, np.where(system.constrained, 0.0, R))))
            # reference energy: the largest seen in this increment (the first iteration of a
            # displacement-driven increment has no free residual, so its energy is 0)
            e0 = max(energy, 1e-300) if e0 is None else max(e0, energy)
            # full Newton near the solution: the next iterations keep this factorisation
            keep = keep or (it > 1 and energy <= opts.near_solution_energy * e0)
            x, R, data, min_j = self._line_search(x, dx, R, it, load, opts, timer, keep, it == 1 and bool(np.any(du_c)))
            ru, rp, rc = system.norms(R)
            ratio = ru / max(ru_prev, 1e-300)
            ru_prev = ru
            f_ref = max(f_ref, rc)
            inc.residuals.append(ru)
            inc.energies.append(energy / e0)
            inc.min_j = min_j
            inc.rule = acceptance_rule(Iterate(it, ru, rp, energy, e0, ratio, f_ref), opts, self.volume)
            if inc.rule:
                self.residual = R
                return x
            if it >= 3 and inc.residuals[-1] > 1e3 * inc.residuals[0]:
                raise _IncrementFailed(f"iteration {it}: residual diverging ({inc.residuals[-1]:.3g})")
        raise _IncrementFailed(f"no convergence in {opts.max_iterations} iterations (residual {inc.residuals[-1]:.3g}, "
                               f"ref {f_ref:.3g})")

    def _evaluate(self, x: np.ndarray, load: LoadState, tangent: bool, timer):
        """(R, tangent data or None, min det F) at the state ``x``; raises :class:`InvertedElements`."""
        t = time.perf_counter()
        try:
            return self.system.evaluate(x, load, tangent)
        finally:
            timer.time_assembly += time.perf_counter() - t

    def _newton_step(self, it: int, R: np.ndarray, data, refactor: bool, du_c: np.ndarray, timer) -> np.ndarray:
        """Δx of K Δx = −R (with the prescribed increment ``du_c`` on the first iteration), factorising K
        first when ``refactor`` (else the last factorisation's K); raises :class:`_IncrementFailed`."""
        system, solver, fact = self.system, self.linear, self._fact
        rhs = -R
        if it == 1 and np.any(du_c):
            rhs = rhs - system.matvec(data if refactor else fact["data"], du_c)
        rhs = rhs.copy()
        rhs[system.constrained_dofs] = du_c[system.constrained_dofs] if it == 1 else 0.0
        t = time.perf_counter()
        try:
            if refactor:
                solver.factorize(system.matrix(data), symmetric=system.symmetric)
                fact["valid"], fact["data"] = True, data
                timer.time_factorize += time.perf_counter() - t
            t = time.perf_counter()
            dx = solver.solve(rhs)
            timer.time_solve += time.perf_counter() - t
        except (LinearSolverError, RuntimeError, ValueError) as exc:
            raise _IncrementFailed(f"linear solve failed: {exc}") from None
        if not np.all(np.isfinite(dx)):
            raise _IncrementFailed("non-finite Newton update", stale=False)
        return dx

    def _line_search(self, x: np.ndarray, dx: np.ndarray, R: np.ndarray, it: int, load: LoadState,
                     opts: SolveOptions, timer, keep: bool, prescribed: bool) -> tuple:
        """The state along ``x + α Δx`` that the iteration moves to: (x, R, data, min det F).

        Line search (Crisfield 1991, §9.3): accept the full step unless the directional
        derivative s(α) = Δx·R(x + αΔx) fails to drop below 0.8|s(0)|; then take the secant
        zero of s (at most two secant steps); always halve α away from inverted elements
        (down to 1e-3). The residual-norm backtracking it replaces stalled with stiff fibres
        (1e5 stiffness contrast). A first iteration that applies a ``prescribed`` displacement
        increment (or any first iteration without ``opts.first_line_search``), ``opts.line_search``
        False or an ascent direction (s(0) >= 0) take the first step without inverted elements.
        Trial states are evaluated without the tangent when the next iteration ``keep``s the
        factorisation. Raises :class:`_IncrementFailed` when every trial inverts an element.
        """
        system = self.system
        whole = prescribed or (it == 1 and not opts.first_line_search)
        free = ~system.constrained
        s0 = float(np.dot(dx[free], R[free]))
        alpha = 1.0
        best = None
        for trial in range(10):
            x_try = x + alpha * dx
            if it == 1 and alpha < 1.0:
                cdofs = system.constrained_dofs
                x_try[cdofs] = x[cdofs] + dx[cdofs]  # keep the prescribed values exact
            try:
                R_try, data_try, mj = self._evaluate(x_try, load, not keep, timer)
            except InvertedElements:
                alpha *= 0.5
                if alpha < 1e-3:
                    break
                continue
            best = (x_try, R_try, data_try, mj)
            if not opts.line_search or whole or s0 >= 0:
                break
            s1 = float(np.dot(dx[free], R_try[free]))
            if abs(s1) <= 0.8 * abs(s0) or trial >= 2:
                break
            # secant zero of s(α) between 0 and α, kept in [0.1, 1] of the current α
            alpha = alpha * min(1.0, max(0.1, s0 / (s0 - s1)))
        if best is None:
            raise _IncrementFailed(f"iteration {it}: inverted elements along the whole Newton step")
        return best


class _IncrementFailed(Exception):
    """An increment that cannot converge: ``reason``, and whether the kept factorisation is ``stale``."""

    def __init__(self, reason: str, stale: bool = True) -> None:
        super().__init__(reason)
        self.reason = reason
        self.stale = stale


@dataclass(frozen=True)
class Iterate:
    """The measures of one Newton iteration that decide acceptance.

    Attributes
    ----------
    iteration : int
        1 for the first iteration of the increment.
    ru, rp : float
        ‖R_u‖ on the free DOFs [N] and ‖R_p‖ (volume constraint) after the step.
    energy : float
        |Δx · R| of the step, with R before the step (free DOFs).
    e0 : float
        The increment's reference energy: the largest ``energy`` so far.
    ratio : float
        ``ru`` over the previous iteration's (the first iteration's: over the start residual).
    f_ref : float
        Force scale: the largest of the start residual and the reaction norms so far.
    """

    iteration: int
    ru: float
    rp: float
    energy: float
    e0: float
    ratio: float
    f_ref: float


def acceptance_rule(m: Iterate, opts: SolveOptions, volume: float) -> str:
    """The first acceptance rule of the module docstring that ``m`` meets, or ``''``.

    Parameters
    ----------
    m : Iterate
    opts : SolveOptions
        ``rtol``, ``atol``, ``etol`` and ``vtol``.
    volume : float
        Mesh volume V (the scale of ``vtol``).

    Returns
    -------
    str
        One of :data:`ACCEPTANCE_RULES`, or ``''`` when the iteration is not converged.
    """
    tol = opts.rtol * m.f_ref
    volume_ok = m.rp <= opts.vtol * volume
    if (m.energy / m.e0 <= opts.etol or m.energy <= 1e-30) and m.ru <= 1e3 * tol:
        return "energy"
    if volume_ok and m.ru <= 1e-3 * tol + opts.atol:
        return "residual"
    if volume_ok and m.ru <= tol + opts.atol and m.iteration >= 2 and m.ratio > 0.1:
        return "residual_floor"
    return ""


#: The acceptance rules in the order :func:`acceptance_rule` tries them (module docstring).
ACCEPTANCE_RULES: tuple[str, ...] = ("energy", "residual", "residual_floor")
