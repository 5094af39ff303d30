"""The weighted least-squares fit of model parameters to observations, and its uncertainties.

With parameters θ (run-file keys, :mod:`~whisker_opt.calibration.parameters`), observations y_k of
stated uncertainty σ_k and file weight w_k, and the model's values m_k(θ)
(:func:`~whisker_opt.calibration.forward.predict`), the fit minimises

    C(θ) = ½ Σ_k r_k²,   r_k = w_k (m_k(θ) − y_k) / σ_k,   lower ≤ θ ≤ upper,

by ``scipy.optimize.least_squares`` (trust-region reflective, bounds) over the normalised parameters
u = (θ − lower)/(upper − lower) ∈ [0, 1]^n, with a forward-difference Jacobian of step h = ``diff_step``
in u (a fixed fraction of each range; backward where u + h would leave [0, 1]),
∂r/∂u_i ≈ (r(u + h e_i) − r(u))/h (:meth:`Problem.jacobian`). A restore observation's residual is in
MPa: m_k is the matching pressure the model predicts (a root search), so its σ_k is an uncertainty of
pressure.

Uncertainties (linearised at the optimum; Press et al., Numerical Recipes, §15.4–15.5): with J the
Jacobian of r in θ and J = U S Vᵀ its singular value decomposition,

    Cov(θ) = (JᵀJ)⁻¹ = V S⁻² Vᵀ,   std_i = √Cov_ii,   corr_ij = Cov_ij/(std_i std_j),

valid when the stated σ_k are the measurements' standard deviations (``std``). ``std_scaled`` multiplies
by √(χ²/ν), χ² = 2C, ν = m − n, as when the σ_k only fix relative weights. A singular value below
1e-8 of the largest marks a direction the data do not determine: a parameter with a component along
it has an infinite std (``null`` in JSON), stated as "not determined by these observations".

A parameter is *determined* by the observations when its uncertainty u_i (``std_scaled`` when χ²/ν > 1,
else ``std``: the larger) is finite and at most :data:`DETERMINED_FRACTION` of its range, so that
θ̂_i ± 2u_i (≈ 95 %) spans no more than the box the fit was given (:func:`determined`, the one rule for
every model); otherwise the data leave it where the fit stopped, and it is not calibrated.

Before the local fit, the cost is evaluated on a coarse deterministic scan of the box
(:mod:`~whisker_opt.calibration.starts`); a second local fit starts at the scan's best point when it
beats the start, the fit of lower final cost is the result, and two fits ending apart are reported
as a start-dependent result.

Held-out observations take no part in C; they are predicted with the start and the fitted values and
their miss m_k(θ̂) − y_k reported, with the prediction's own uncertainty from the parameters' (linear
propagation, the same Numerical Recipes §15.5): with g = ∂m_k/∂θ at θ̂ (forward differences of step
``diff_step`` of each range) and Cov(θ) scaled by max(1, χ²/ν) as :func:`uncertainty` scales the std,

    σ_pred,k = √(gᵀ Cov(θ) g),   z_k = (m_k(θ̂) − y_k) / √(σ_k² + σ_pred,k²),

so |z_k| ≲ 2 is a held-out observation the calibrated model predicts within both uncertainties.

Status of a fit (:attr:`FitOutcome.state`): ``converged`` when ``least_squares`` met its tolerance
(``ftol``, ``xtol`` or ``gtol``); ``budget exhausted`` when it stopped at its evaluation budget first;
``not moved`` when, in addition, no parameter left its start by more than the tolerance. Only a
converged fit that determines at least one parameter is a calibrated model (of the parameters it
determines). ``evaluations`` and the budget ``max_evaluations`` are those of the chosen local fit;
``total_evaluations`` adds the scan's and the other fit's. A parameter is *at a bound* when it lies
within ``tolerance`` × (upper − lower) of it, the nearer one: the rule by which ``least_squares`` (trust-region
reflective) declares a bound active (``xtol`` in the normalised u, whose bounds are 0 and 1). Its
iterates stay strictly inside the bounds (a step covers at most 99.5 % of the distance to a bound),
so a parameter pressed against a bound ends a small fraction of the range inside it, not on it.
χ²/ν is flagged above the 99th percentile of its distribution for ν degrees of freedom
(:func:`chi2_limit`: 6.63 for ν = 1, 3.02 for ν = 5, 1.88 for ν = 20, → 1 as ν grows): the stated
σ_k are then very unlikely to account for the misfit (a model that cannot reach the data, or
uncertainties stated too small), and ``std`` is too small; ``std_scaled`` allows for it.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from scipy import optimize

from fem.newton import SolveFailed
from geometry.design import InvalidDesignError
from whisker_opt.calibration.forward import Prediction, RestoreSearch, Simulator, predict
from whisker_opt.calibration.measurements import Observation
from whisker_opt.calibration.parameters import ModelParameter, configure
from whisker_opt.calibration.propagation import prediction_std
from whisker_opt.calibration.starts import FROM_SCAN, FROM_START, LocalFit, disagree, scan_points, scan_size
from whisker_opt.config.model import ConfigError, WhiskerConfig

logger = logging.getLogger(__name__)

#: Singular values of J below this fraction of the largest are taken as zero (undetermined directions).
RCOND = 1e-8
#: χ²/ν is flagged above this quantile of its distribution for ν degrees of freedom (:func:`chi2_limit`).
CHI2_QUANTILE = 0.99
#: :attr:`FitOutcome.state` of a fit that is a calibrated model.
CONVERGED = "converged"
BUDGET_EXHAUSTED = "budget exhausted"
NOT_MOVED = "not moved"
#: :attr:`FitOutcome.state` of a converged fit that determines no parameter.
NOT_DETERMINED = "no parameter determined"
#: A parameter is determined when its uncertainty is at most this fraction of its range (:func:`determined`).
DETERMINED_FRACTION = 0.25
#: What the model raises at a parameter set it cannot solve (a scanned point is then skipped).
UNSOLVABLE = (SolveFailed, FloatingPointError, InvalidDesignError, ConfigError)


def chi2_limit(dof: int, quantile: float = CHI2_QUANTILE) -> float:
    """The largest χ²/ν not flagged: the ``quantile`` of χ²_ν / ν (nan for ν ≤ 0).

    Parameters
    ----------
    dof : int
        ν = observations − parameters.
    quantile : float

    Returns
    -------
    float
    """
    from scipy.stats import chi2

    return float(chi2.ppf(quantile, dof) / dof) if dof > 0 else math.nan


def bounds_reached(values, parameters: Sequence[ModelParameter], rtol: float) -> tuple:
    """'lower' / 'upper' where a value lies within ``rtol`` × (upper − lower) of that bound (the
    nearer one), else None: ``least_squares``' active-set rule with ``xtol = rtol`` (module docstring).

    Parameters
    ----------
    values : sequence of float, shape (n,)
    parameters : sequence of ModelParameter
    rtol : float

    Returns
    -------
    tuple of str or None
    """
    out = []
    for v, p in zip(np.asarray(values, dtype=float), parameters):
        near = rtol * (p.upper - p.lower)
        lo, up = v - p.lower, p.upper - v
        out.append("lower" if lo <= min(up, near) else ("upper" if up <= min(lo, near) else None))
    return tuple(out)


def uncertainty(std, std_scaled) -> np.ndarray:
    """u_i: ``std_scaled`` where it is the larger (χ²/ν > 1), else ``std``; ``std`` where ν ≤ 0.

    Parameters
    ----------
    std, std_scaled : array_like, shape (n,)

    Returns
    -------
    ndarray, shape (n,)
    """
    std, scaled = np.asarray(std, dtype=float), np.asarray(std_scaled, dtype=float)
    return np.where(np.isnan(scaled), std, np.fmax(std, scaled))


def determined(std, std_scaled, parameters: Sequence[ModelParameter]) -> tuple[bool, ...]:
    """Whether the observations determine each parameter: u_i (:func:`uncertainty`) finite and at most
    :data:`DETERMINED_FRACTION` × (upper − lower) (the module docstring).

    Parameters
    ----------
    std, std_scaled : array_like, shape (n,)
    parameters : sequence of ModelParameter

    Returns
    -------
    tuple of bool
    """
    u = uncertainty(std, std_scaled)
    return tuple(bool(np.isfinite(v) and v <= DETERMINED_FRACTION * (p.upper - p.lower))
                 for v, p in zip(u, parameters))


@dataclass(frozen=True)
class Weighted:
    """An observation with the weight of its file."""

    observation: Observation
    weight: float = 1.0


@dataclass(frozen=True)
class ObservationResult:
    """One observation beside the model's value at the start and at the fitted parameters.

    ``residual`` is w (m − y)/σ at the fitted values; ``miss`` is m − y in the observation's unit.
    """

    name: str
    kind: str
    where: str
    unit: str
    measured: float
    sigma: float
    weight: float
    held_out: bool
    start: Prediction
    fitted: Prediction
    #: The uncertainty of the fitted model's value from the parameters' (held-out observations; nan otherwise).
    predicted_std: float = math.nan
    #: How many specimens the observation compares (1 or 2, its file's ``specimens`` column).
    specimens: int = 1

    @property
    def miss(self) -> float:
        return self.fitted.value - self.measured

    @property
    def start_miss(self) -> float:
        return self.start.value - self.measured

    @property
    def residual(self) -> float:
        return self.weight * self.miss / self.sigma

    @property
    def z(self) -> float:
        """The miss over √(σ² + σ_pred²): nan when the prediction's uncertainty is unknown."""
        return self.miss / math.hypot(self.sigma, self.predicted_std)


@dataclass(frozen=True)
class FitOutcome:
    """What :func:`fit` found.

    Attributes
    ----------
    parameters : tuple of ModelParameter
    values : ndarray, shape (n,)
        Fitted values θ̂.
    std, std_scaled : ndarray, shape (n,)
        Standard uncertainties from the Jacobian (inf where undetermined; see the module docstring).
    correlation : ndarray, shape (n, n)
    at_bound : tuple of str or None
        'lower' / 'upper' where θ̂ is at a bound (:func:`bounds_reached`), else None.
    cost_start, cost : float
        C at the start and at θ̂.
    chi2, dof : float, int
        χ² = 2C and ν = m − n.
    observations : tuple of ObservationResult
        The fitted ones, then the held-out ones, each in the order given.
    evaluations : int
        Model evaluations (each predicts every fitted observation), the Jacobian's included.
    scenes : int
        Scenes solved (or beam evaluations).
    status : int
    message : str
        ``least_squares``' status and message.
    seconds : float
    singular_values : ndarray
    max_evaluations : int
        The evaluation budget of a local fit.
    tolerance : float
        ``ftol`` and ``xtol`` of the fit; also the at-bound and moved tolerance (a fraction of the range).
    starts : tuple of LocalFit
        The local fits, the one from the run file's start first (:mod:`~whisker_opt.calibration.starts`).
    scan : tuple of (ndarray, float)
        The scanned parameter sets and their cost (nan where the model gave no value).
    fit_start : ndarray, shape (n,)
        Where the chosen local fit started.
    total_evaluations : int
        Distinct parameter sets evaluated: the scan, every local fit and the start.
    """

    parameters: tuple[ModelParameter, ...]
    values: np.ndarray
    std: np.ndarray
    std_scaled: np.ndarray
    correlation: np.ndarray
    at_bound: tuple
    cost_start: float
    cost: float
    chi2: float
    dof: int
    observations: tuple[ObservationResult, ...]
    evaluations: int
    scenes: int
    status: int
    message: str
    seconds: float
    singular_values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    max_evaluations: int = 0
    tolerance: float = 1e-3
    starts: tuple[LocalFit, ...] = ()
    scan: tuple = ()
    fit_start: np.ndarray | None = None
    total_evaluations: int = 0

    @property
    def start(self) -> np.ndarray:
        return np.array([p.start for p in self.parameters])

    @property
    def width(self) -> np.ndarray:
        return np.array([p.upper - p.lower for p in self.parameters])

    @property
    def moved(self) -> bool:
        """Some parameter left the chosen local fit's start by more than ``tolerance`` × its range."""
        start = self.start if self.fit_start is None else self.fit_start
        return bool(np.any(np.abs(self.values - start) > self.tolerance * self.width))

    @property
    def uncertainty(self) -> np.ndarray:
        """u_i of each parameter (:func:`uncertainty`)."""
        return uncertainty(self.std, self.std_scaled)

    @property
    def determined(self) -> tuple[bool, ...]:
        """Whether the observations determine each parameter (:func:`determined`)."""
        return determined(self.std, self.std_scaled, self.parameters)

    @property
    def start_dependent(self) -> bool:
        """The local fits ended apart in cost or in a determined parameter
        (:func:`~whisker_opt.calibration.starts.disagree`)."""
        return disagree(self.starts, self.width, self.tolerance, self.determined)

    @property
    def state(self) -> str:
        """:data:`CONVERGED`, :data:`NOT_DETERMINED`, :data:`BUDGET_EXHAUSTED` or :data:`NOT_MOVED`."""
        if self.status > 0:
            return CONVERGED if any(self.determined) else NOT_DETERMINED
        return BUDGET_EXHAUSTED if self.moved else NOT_MOVED

    @property
    def calibrated(self) -> bool:
        """The fit converged and determined at least one parameter: those are a calibrated model."""
        return self.state == CONVERGED

    @property
    def chi2_per_dof(self) -> float:
        """χ²/ν (nan for ν ≤ 0)."""
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    @property
    def chi2_high(self) -> bool:
        """χ²/ν above :func:`chi2_limit`."""
        return self.dof > 0 and self.chi2_per_dof > chi2_limit(self.dof)

    def warnings(self) -> list[str]:
        """One sentence per reason not to trust the fit as it is: not converged, a parameter at a
        bound, χ²/ν above its limit, a parameter the observations do not determine."""
        out = []
        if self.state == NOT_DETERMINED:
            out.append("not calibrated: the observations determine none of the parameters (each one's uncertainty "
                       f"is more than {DETERMINED_FRACTION:g} of its range, or infinite)")
        elif self.state != CONVERGED:
            what = ("no parameter moved from its start by more than "
                    f"{self.tolerance:g} of its range" if self.state == NOT_MOVED else "it had not converged")
            out.append(f"not calibrated: the fit used its budget of {self.max_evaluations} model evaluations and "
                       f"stopped ({what}); raise calibration.max_evaluations (done: {self.evaluations})")
        if self.start_dependent:
            out.append("the result depends on where the fit starts: " + "; ".join(
                f"from {f.origin} ({self._describe(f.start)}) it ended at {self._describe(f.values)}, cost "
                f"{f.cost:.5g}" for f in self.starts) + "; the end of lower cost is reported")
        for p, v, b in zip(self.parameters, self.values, self.at_bound):
            if b:
                out.append(f"{p.path} = {v:.6g} is at its {b} bound {getattr(p, b):g} (within {self.tolerance:g} "
                           "of the range): the data push it beyond; widen the bound or question the model")
        if self.chi2_high:
            out.append(f"chi2/dof = {self.chi2_per_dof:.3g} is above {chi2_limit(self.dof):.3g} (the "
                       f"{100 * CHI2_QUANTILE:g}th percentile for {self.dof} degrees of freedom): the stated "
                       "uncertainties do not account for the misfit; std is too small (see std_scaled)")
        for p, u, ok in zip(self.parameters, self.uncertainty, self.determined):
            if not ok:
                unit = "" if p.unit in ("", "-") else f" {p.unit}"
                why = (f"its uncertainty {u:.3g}{unit} is more than {DETERMINED_FRACTION:g} of its range "
                       f"[{p.lower:g}, {p.upper:g}]" if math.isfinite(u) else "no combination of them moves it")
                out.append(f"{p.path} is not determined by these observations ({why}): its value is where the fit "
                           "stopped, not a calibration")
        return out

    def _describe(self, theta) -> str:
        return ", ".join(f"{p.path} = {v:.4g}" for p, v in zip(self.parameters, theta))

    @property
    def fitted(self) -> tuple[ObservationResult, ...]:
        return tuple(o for o in self.observations if not o.held_out)

    @property
    def held_out(self) -> tuple[ObservationResult, ...]:
        return tuple(o for o in self.observations if o.held_out)


def _check_stored(stored: Any, n: int, path: Path, key: str) -> None:
    """Refuse the stored predictions of one parameter set that are not ``n`` predictions (a value, whether it
    matched, a note) and a count of scenes (:class:`whisker_opt.output.journal.JournalError`, one line)."""
    from whisker_opt.output.journal import JournalError

    preds = stored.get("predictions") if isinstance(stored, dict) else None
    scenes = stored.get("scenes") if isinstance(stored, dict) else None
    ok = (isinstance(preds, list) and len(preds) == n and isinstance(scenes, int) and not isinstance(scenes, bool)
          and scenes >= 0 and all(isinstance(p, dict) and set(p) == {"value", "matched", "note"}
                                  and isinstance(p["value"], (int, float)) and not isinstance(p["value"], bool)
                                  and isinstance(p["matched"], bool) and isinstance(p["note"], str) for p in preds))
    if not ok:
        raise JournalError(f"{path}: the predictions stored for {key[:80]!r} are not {n} predictions of the "
                           f"observations asked for, so they are not believed: delete {path} to start the calibration "
                           "from the beginning")


class Problem:
    """The residual function of a calibration: run file + parameters + observations + a simulator.

    Parameters
    ----------
    data : dict
        The run file's content (the parameters are set over it, :func:`configure`).
    parameters : sequence of ModelParameter
    observations : sequence of Weighted
        Those to fit (held-out ones are predicted apart, :func:`fit`).
    sim : Simulator
    search : RestoreSearch
    source : str
        Names the run file in messages.
    """

    def __init__(self, data: dict, parameters: Sequence[ModelParameter], observations: Sequence[Weighted],
                 sim: Simulator, search: RestoreSearch = RestoreSearch(), source: str = "calibration") -> None:
        if not parameters:
            raise ValueError("a fit needs at least one parameter")
        if not observations:
            raise ValueError("a fit needs at least one observation that is not held out")
        self.data, self.parameters, self.observations = data, tuple(parameters), tuple(observations)
        self.sim, self.search, self.source = sim, search, source
        self.lower = np.array([p.lower for p in self.parameters])
        self.width = np.array([p.upper - p.lower for p in self.parameters])
        self.evaluations = 0
        self._memo: dict[tuple, np.ndarray] = {}
        #: Counts the evaluations when set (:func:`fit`): a progress line each.
        self.progress = None
        #: The predictions of a stopped fit (:class:`whisker_opt.output.journal.StudyJournal`), when set.
        self.journal = None
        #: Scenes the predictions read back from :attr:`journal` cost when they were made.
        self.replayed_scenes = 0
        self._replayed: set[str] = set()
        #: The parameter sets asked for since it was last set to an empty set (a local fit's), when set.
        self.requested: set | None = None

    def theta(self, u) -> np.ndarray:
        """θ = lower + u·(upper − lower)."""
        return self.lower + np.asarray(u, dtype=float) * self.width

    def u(self, theta) -> np.ndarray:
        return (np.asarray(theta, dtype=float) - self.lower) / self.width

    def config(self, theta) -> WhiskerConfig:
        """The run file at parameter values θ."""
        return configure(self.data, self.parameters, theta, self.source)

    def predictions(self, theta, observations: Sequence[Weighted] | None = None) -> list[Prediction]:
        """The model's value of each observation (default the fitted ones) at θ; read back from
        :attr:`journal` when a stopped fit made them, recorded there otherwise."""
        obs = self.observations if observations is None else observations
        key = None
        if self.journal is not None:
            which = "fitted" if observations is None else repr([w.observation.name for w in obs])
            key = f"{np.asarray(theta, dtype=float).tolist()!r} {which}"
            stored = self.journal.get(key)
            if stored is not None:
                _check_stored(stored, len(obs), self.journal.path, key)
                if key not in self._replayed:
                    self._replayed.add(key)
                    self.replayed_scenes += int(stored["scenes"])
                return [Prediction(**p) for p in stored["predictions"]]
        solved = int(getattr(self.sim, "solved", 0))
        cfg = self.config(theta)
        preds = [predict(w.observation, cfg, self.sim, self.search) for w in obs]
        if key is not None:
            self.journal.record(key, {"predictions": [dataclasses.asdict(p) for p in preds],
                                      "scenes": int(getattr(self.sim, "solved", 0)) - solved})
        return preds

    def residuals_at(self, theta) -> np.ndarray:
        """r(θ), shape (m,): w (m − y)/σ of every fitted observation."""
        key = tuple(np.round(np.asarray(theta, dtype=float), 15))
        if self.requested is not None:
            self.requested.add(key)
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        self.evaluations += 1
        preds = self.predictions(theta)
        r = np.array([w.weight * (p.value - w.observation.value) / w.observation.sigma
                      for w, p in zip(self.observations, preds)])  # (m,)
        if not np.all(np.isfinite(r)):
            bad = [w.observation.name for w, v in zip(self.observations, r) if not math.isfinite(v)]
            raise FloatingPointError(f"the model gives no value for {', '.join(bad)} at {self._describe(theta)}")
        if self.progress is not None:
            self.progress.step(f"(cost {0.5 * float(r @ r):.6g} at {self._describe(theta)})")
        else:
            logger.info("calibration: evaluation %d at %s: cost %.6g", self.evaluations, self._describe(theta),
                        0.5 * float(r @ r))
        self._memo[key] = r
        return r

    def _describe(self, theta) -> str:
        return ", ".join(f"{p.path} = {v:.6g}" for p, v in zip(self.parameters, np.asarray(theta, dtype=float)))

    def residuals(self, u) -> np.ndarray:
        """r as a function of the normalised parameters u (what ``least_squares`` sees)."""
        return self.residuals_at(self.theta(np.clip(u, 0.0, 1.0)))

    def jacobian(self, u, step: float) -> np.ndarray:
        """∂r/∂u by forward differences of step ``step`` in u (backward near the upper end), shape (m, n)."""
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        r0 = self.residuals(u)
        jac = np.empty((r0.size, u.size))  # (m, n)
        for i in range(u.size):
            h = step if u[i] + step <= 1.0 else -step
            v = u.copy()
            v[i] += h
            jac[:, i] = (self.residuals(v) - r0) / h
        return jac


def covariance(jac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(JᵀJ)⁻¹ by the SVD of J, with undetermined directions as infinite variances; and the singular values.

    Parameters
    ----------
    jac : ndarray, shape (m, n)
        Jacobian of the weighted residuals in the parameters.

    Returns
    -------
    cov : ndarray, shape (n, n)
    s : ndarray, shape (min(m, n),)
    """
    _, s, vt = np.linalg.svd(jac, full_matrices=False)  # (m, k), (k,), (k, n)
    n = jac.shape[1]
    keep = s > RCOND * (s[0] if s.size and s[0] > 0 else 1.0)
    v = vt[keep].T  # (n, k_kept)
    cov = (v / s[keep] ** 2) @ v.T  # (n, n)
    # directions the data do not reach: the null space of J (with its rank-deficient part)
    null = np.eye(n) - v @ v.T  # (n, n) projector onto them
    undetermined = np.diag(null) > 1e-6
    cov[undetermined, :] = np.inf
    cov[:, undetermined] = np.inf
    return cov, s


def fit(problem: Problem, held_out: Sequence[Weighted] = (), *, max_evaluations: int = 40, diff_step: float = 0.02,
        tolerance: float = 1e-3, progress: bool = False) -> FitOutcome:
    """Fit the problem's parameters (see the module docstring) and predict the held-out observations.

    Parameters
    ----------
    problem : Problem
    held_out : sequence of Weighted
        Observations left out of the fit, predicted at the start and at the fitted values.
    max_evaluations : int
        Budget of model evaluations of each local fit, the finite-difference Jacobian's included:
        ``least_squares`` gets ``max_nfev = max(1, max_evaluations // (n + 1))`` (each of its evaluations
        costs n more for the Jacobian; a Jacobian at a point already evaluated reuses it). The scan
        adds :func:`~whisker_opt.calibration.starts.scan_size` evaluations.
    diff_step : float
        Finite-difference step h in the normalised parameters (a fraction of each range).
    tolerance : float
        ``ftol`` and ``xtol`` of ``least_squares``; also the at-bound and moved tolerance
        (:func:`bounds_reached`, :attr:`FitOutcome.moved`).
    progress : bool
        A bar over the model evaluations on a terminal; a progress line per evaluation (elapsed
        time, ETA against the budget) is logged either way (:class:`whisker_opt.output.progress.Progress`).

    Returns
    -------
    FitOutcome
    """
    from whisker_opt.output.progress import Progress

    t0 = time.perf_counter()
    params = problem.parameters
    n = len(params)
    theta0 = np.array([p.start for p in params])
    u0 = problem.u(theta0)
    problem.progress = Progress(scan_size(n) + 2 * max_evaluations + 1, "calibrate", "model evaluation", progress,
                                at_most=True)
    local = dict(max_evaluations=max_evaluations, diff_step=diff_step, tolerance=tolerance)
    try:
        r0 = problem.residuals(u0)
        start_preds = problem.predictions(theta0)  # memoised scenes: no new solves
        scan = _scan(problem)
        fits = [_local_fit(problem, u0, FROM_START, **local)]
        best = min((c, k) for k, (_, c) in enumerate(scan) if math.isfinite(c)) if scan else None
        if best is not None and best[0] < 0.5 * float(r0 @ r0):
            try:
                fits.append(_local_fit(problem, problem.u(scan[best[1]][0]), FROM_SCAN, **local))
            except UNSOLVABLE as exc:  # a region the model cannot solve: the start's fit stands
                logger.warning("calibration: the fit from %s stopped: %s", FROM_SCAN, exc)
    finally:
        problem.progress.close()
        problem.progress = None
    chosen, res = min(fits, key=lambda f: f[0].cost)
    theta = chosen.values
    r = problem.residuals_at(theta)
    jac_theta = np.asarray(res.jac, dtype=float) / problem.width  # (m, n): dr/dθ = dr/du / (upper - lower)
    std, std_scaled, corr, s, chi2, dof, cov = _uncertainties(jac_theta, r)
    fitted_preds = problem.predictions(theta)
    held_start = problem.predictions(theta0, held_out) if held_out else []
    held_fit = problem.predictions(theta, held_out) if held_out else []
    held_std = prediction_std(problem, theta, held_out, held_fit, cov * max(1.0, chi2 / dof if dof > 0 else 1.0),
                              diff_step) if held_out else []
    results = [_result(w, p0, p1, False) for w, p0, p1 in zip(problem.observations, start_preds, fitted_preds)]
    results += [_result(w, p0, p1, True, sd) for w, p0, p1, sd in zip(held_out, held_start, held_fit, held_std)]
    outcome = FitOutcome(
        parameters=params, values=theta, std=std, std_scaled=std_scaled, correlation=corr,
        at_bound=bounds_reached(theta, params, tolerance), cost_start=0.5 * float(r0 @ r0), cost=0.5 * chi2,
        chi2=chi2, dof=dof, observations=tuple(results), evaluations=chosen.evaluations,
        scenes=int(getattr(problem.sim, "solved", 0)) + problem.replayed_scenes, status=chosen.status,
        message=chosen.message, seconds=time.perf_counter() - t0, singular_values=s,
        max_evaluations=int(max_evaluations), tolerance=float(tolerance), starts=tuple(f for f, _ in fits),
        scan=tuple(scan), fit_start=chosen.start, total_evaluations=problem.evaluations,
    )
    logger.info("calibration: %s (%s) after %d evaluations (%d in all): cost %.6g -> %.6g", outcome.state,
                chosen.message, chosen.evaluations, problem.evaluations, outcome.cost_start, outcome.cost)
    return outcome


def _scan(problem: Problem) -> list[tuple[np.ndarray, float]]:
    """The cost at each point of the scan (:func:`~whisker_opt.calibration.starts.scan_points`); nan
    where the model gives no value (logged)."""
    out = []
    for u in scan_points(len(problem.parameters)):
        theta = problem.theta(u)
        try:
            r = problem.residuals_at(theta)
            out.append((theta, 0.5 * float(r @ r)))
        except UNSOLVABLE as exc:
            logger.info("calibration: scan: no model value at %s: %s", problem._describe(theta), exc)
            out.append((theta, math.nan))
    return out


def _local_fit(problem: Problem, u0: np.ndarray, origin: str, *, max_evaluations: int, diff_step: float,
               tolerance: float) -> tuple[LocalFit, optimize.OptimizeResult]:
    """One ``least_squares`` fit from u0 (trust-region reflective, in the normalised parameters)."""
    n = u0.size
    problem.requested = set()
    try:
        res = optimize.least_squares(problem.residuals, u0, jac=lambda u: problem.jacobian(u, diff_step),
                                     bounds=(np.zeros(n), np.ones(n)), method="trf", x_scale=1.0, ftol=tolerance,
                                     xtol=tolerance, gtol=1e-10, max_nfev=max(1, max_evaluations // (n + 1)))
        evaluations = len(problem.requested)
    finally:
        problem.requested = None
    r0 = problem.residuals(u0)
    fitted = LocalFit(origin=origin, start=problem.theta(u0), values=problem.theta(np.clip(res.x, 0.0, 1.0)),
                      cost_start=0.5 * float(r0 @ r0), cost=float(res.cost), status=int(res.status),
                      message=str(res.message), evaluations=evaluations)
    logger.info("calibration: the fit from %s (%s) ended at %s: cost %.6g -> %.6g (%s)", origin,
                problem._describe(fitted.start), problem._describe(fitted.values), fitted.cost_start, fitted.cost,
                res.message)
    return fitted, res


def _uncertainties(jac_theta: np.ndarray, r: np.ndarray):
    """std, std_scaled, the correlation matrix, J's singular values, χ² and ν (the module docstring)."""
    n = jac_theta.shape[1]
    cov, s = covariance(jac_theta)
    with np.errstate(invalid="ignore"):
        std = np.sqrt(np.diag(cov))
        finite = np.isfinite(std) & (std > 0)
        corr = np.full((n, n), np.nan)
        corr[np.ix_(finite, finite)] = cov[np.ix_(finite, finite)] / np.outer(std[finite], std[finite])
    chi2 = float(r @ r)
    dof = r.size - n
    std_scaled = std * math.sqrt(chi2 / dof) if dof > 0 else np.full(n, np.nan)
    return std, std_scaled, corr, s, chi2, dof, cov


def _result(w: Weighted, start: Prediction, fitted: Prediction, held_out: bool,
            predicted_std: float = math.nan) -> ObservationResult:
    ob = w.observation
    return ObservationResult(name=ob.name, kind=ob.kind, where=ob.where, unit=ob.unit, measured=float(ob.value),
                             sigma=float(ob.sigma), weight=float(w.weight), held_out=held_out, start=start,
                             fitted=fitted, predicted_std=float(predicted_std),
                             specimens=int(getattr(ob, "specimens", 1)))
