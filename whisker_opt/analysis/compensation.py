"""Morphological compensation: the vent pressure that makes a trimmed whisker read as the intact one.

The intact whisker runs at Q_i. After a trim Δ the gauge reads more per millimetre of
deflection; lowering the chamber pressure to some Q ∈ [0, Q_i] brings it back.

Analytic compensation
    Q such that the compensator's (trimmed design at Q) ε/δ equals the target's (intact
    design at Q_i), both from the beam model at a = 1, δ = 1 mm; a root of
    ``S_c(Q) - S_t`` by Brent's method. If no root lies in [0, Q_i], Q is clipped to the
    endpoint with the smaller mismatch and the result says so.

Response-based ("FE") compensation
    With any response function ``response(design, Q, deltas) -> ε(δ)`` (the FE scene, or
    :class:`whisker_opt.analysis.beam.BeamResponse` as a stand-in), Q minimises the mean gap

        g(Q) = mean_k |ε_trim(Q, δ_k) - ε_o(δ_k)|,   ε_o = ε_intact(Q_i)

    over Q ∈ [0, Q_i] (bounded Brent, ``scipy.optimize.minimize_scalar``; the end points
    are evaluated too, so a clipped optimum is found exactly). g is the same measure as
    the GA's objective f1. A cheaper variant (``method='root'``) brackets the
    root of the signed mean difference instead.

Measures
    recovery rate (%)       = (1 - |(ε_c - ε_o) / (ε_b - ε_o)|) · 100
    compensation error (%)  = |(ε_after - ε_target) / (ε_before - ε_target)| · 100
    with ε_o = ε_target the intact response at Q_i, ε_b = ε_before the trimmed response
    left at Q_i (uncompensated), ε_c = ε_after the trimmed response at the chosen Q.
    The thesis does not say which scalar ε of a curve ε(δ) is meant; ``scalar`` chooses:
    'mean' (default) the mean of the curve over the δ samples, 'last' its value at the
    last (largest) δ, 'gap' the mean absolute gap itself (recovery = 1 - g(Q)/g(Q_i)).
    With one scalar both measures are complementary: recovery = 100 - error
    whenever the error is <= 100 %.

Resolution of the recovery rate
    The rate is a ratio of two absolute gaps of the chosen scalar, the trim's effect
    |ε_b − ε_o| and what is left after venting |ε_c − ε_o|: recovery = (1 − left/effect)·100.
    When the trim's effect lies below the preset's f1 resolution (the smallest gap between two
    curves the mesh resolves, :func:`whisker_opt.experiment.fidelity.f1_resolution`, in the
    same calibrated strain) the ratio divides by mesh error: −2982 % then says only that the vent
    moves the reading much more than the trim did. :func:`recovery` is the one rule: such a
    rate is reported as "trim effect below resolution" with the two gaps instead of a
    percentage, and the vent restores the reading when what is left is itself within the
    resolution (:meth:`Recovery.restores`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Callable, Literal

import numpy as np
from scipy import optimize

from geometry.design import WhiskerDesign
from whisker_opt.analysis.beam import DEFAULT_MODEL, BeamModel, _check_range, sensitivity, sensitivity_grid
from whisker_opt.experiment.objective import f1

logger = logging.getLogger(__name__)

ResponseFn = Callable[[WhiskerDesign, float, np.ndarray], np.ndarray]
SensitivityFn = Callable[[WhiskerDesign, float, float], float]
Scalar = Literal["mean", "last", "gap"]

#: Default deflection samples [mm]: 0.5 … 5 (δ = 0 reads 0 by construction).
DEFAULT_DELTAS = np.linspace(0.5, 5.0, 10)


# --------------------------------------------------------------------------- measures
def recovery_rate(eps_o: float, eps_b: float, eps_c: float) -> float:
    """Recovery rate [%] = (1 - |(ε_c - ε_o)/(ε_b - ε_o)|)·100.

    Parameters
    ----------
    eps_o, eps_b, eps_c : float
        Original (intact), broken (uncompensated) and compensated responses.

    Returns
    -------
    float
        NaN when ε_b = ε_o (nothing to recover).
    """
    den = float(eps_b) - float(eps_o)
    if den == 0.0:
        return float("nan")
    return (1.0 - abs((float(eps_c) - float(eps_o)) / den)) * 100.0


def compensation_error(eps_target: float, eps_before: float, eps_after: float) -> float:
    """Compensation error [%] = |(ε_after - ε_target)/(ε_before - ε_target)|·100.

    NaN when ε_before = ε_target.
    """
    den = float(eps_before) - float(eps_target)
    if den == 0.0:
        return float("nan")
    return abs((float(eps_after) - float(eps_target)) / den) * 100.0


def trim_and_vent_gaps(eps_o, eps_b, eps_c, scalar: Scalar = "mean") -> tuple[float, float]:
    """The two absolute gaps the recovery rate is the ratio of: the trim's effect |ε_b − ε_o| and what
    is left after venting |ε_c − ε_o|, of the scalar ``scalar`` of three curves (module docstring; for
    'gap' the mean absolute gaps f1(ε_b, ε_o) and f1(ε_c, ε_o)), in the curves' strain."""
    o, b, c = (np.asarray(v, dtype=float) for v in (eps_o, eps_b, eps_c))
    if scalar == "mean":
        so, sb, sc = o.mean(), b.mean(), c.mean()
    elif scalar == "last":
        so, sb, sc = o[-1], b[-1], c[-1]
    elif scalar == "gap":
        return float(f1(b, o)), float(f1(c, o))
    else:
        raise ValueError(f"scalar = {scalar!r}: allowed 'mean', 'last', 'gap'")
    return abs(float(sb) - float(so)), abs(float(sc) - float(so))


def curve_measures(eps_o, eps_b, eps_c, scalar: Scalar = "mean") -> tuple[float, float]:
    """(recovery rate %, compensation error %) of three response curves ε(δ).

    Parameters
    ----------
    eps_o, eps_b, eps_c : array_like, shape (n_delta,)
        Intact at Q_i, trimmed at Q_i, trimmed at the compensation pressure.
    scalar : {'mean', 'last', 'gap'}
        How a curve becomes the scalar ε of the measures (see module docstring).
    """
    effect, left = trim_and_vent_gaps(eps_o, eps_b, eps_c, scalar)
    if effect == 0.0:
        return float("nan"), float("nan")
    return (1.0 - left / effect) * 100.0, left / effect * 100.0


@dataclass(frozen=True)
class Recovery:
    """The recovery rate of a vent with the two gaps it is the ratio of (module docstring, "Resolution").

    Attributes
    ----------
    rate : float
        (1 − vent_gap/trim_effect)·100 [%], NaN when the trim changes nothing.
    trim_effect, vent_gap : float
        |ε_b − ε_o| and |ε_c − ε_o| of the scalar [calibrated strain].
    resolution : float
        The smallest gap the mesh resolves [calibrated strain]; NaN when unknown (then every rate is shown).
    """

    rate: float
    trim_effect: float
    vent_gap: float
    resolution: float = float("nan")

    @property
    def resolved(self) -> bool:
        """Whether the trim's effect reaches the resolution, so that the percentage means something."""
        return not (self.resolution > 0.0 and self.trim_effect < self.resolution)

    @property
    def shown_rate(self) -> float:
        """The rate when :attr:`resolved`, else NaN (what a table or a CSV reports)."""
        return self.rate if self.resolved else float("nan")

    def restores(self, threshold: float) -> bool:
        """The vent restores the reading: the rate is at least ``threshold`` [%] when resolved, else what is
        left after venting lies within the resolution."""
        if self.resolved:
            return bool(self.rate >= threshold)
        return bool(self.vent_gap <= self.resolution)

    def text(self) -> str:
        """``recovery 82.6 %``, or ``trim effect below resolution (1.3e-3 < 2e-3), vent gap 4.0e-2``."""
        if self.resolved:
            return f"recovery {self.rate:.1f} %"
        return (f"trim effect below resolution ({self.trim_effect:.2g} < {self.resolution:.2g}), "
                f"vent gap {self.vent_gap:.2g}")


def recovery(eps_o, eps_b, eps_c, scalar: Scalar = "mean", resolution: float = float("nan")) -> Recovery:
    """:class:`Recovery` of three response curves (intact at Q_i, trimmed at Q_i, trimmed and vented)
    against the preset's f1 ``resolution`` in the curves' strain (the one rule of the module docstring)."""
    effect, left = trim_and_vent_gaps(eps_o, eps_b, eps_c, scalar)
    rate = (1.0 - left / effect) * 100.0 if effect > 0.0 else float("nan")
    return Recovery(float(rate), effect, left, float(resolution))


def _check_inputs(design: WhiskerDesign, Q_i: float, trim: float) -> tuple[WhiskerDesign, WhiskerDesign, float]:
    Q_i = _check_range("Q_i", Q_i, 0.0, None, lo_open=True)
    _check_range("trim", trim, 0.0, None)
    intact = design.trimmed(0.0).validate()
    trimmed = design.trimmed(float(trim)).validate()
    return intact, trimmed, Q_i


# --------------------------------------------------------------------------- analytic
@dataclass(frozen=True)
class AnalyticCompensation:
    """Result of :func:`analytic_compensation`.

    Attributes
    ----------
    trim, Q_i, Q : float
        Trim Δ [mm], intact pressure and compensation pressure [MPa].
    target_sensitivity : float
        ε/δ of the intact design at Q_i [1/mm].
    sensitivity : float
        ε/δ of the trimmed design at Q.
    sensitivity_range : tuple[float, float]
        ε/δ of the trimmed design at Q = 0 and Q = Q_i.
    root_found : bool
        False if no Q in [0, Q_i] matches and Q was clipped to an end point.
    message : str
    """

    trim: float
    Q_i: float
    Q: float
    target_sensitivity: float
    sensitivity: float
    sensitivity_range: tuple[float, float]
    root_found: bool
    message: str


def analytic_compensation(design: WhiskerDesign, Q_i: float, trim: float, model: BeamModel | None = None,
                          *, a: float = 1.0, delta: float = 1.0, xtol: float = 1e-12) -> AnalyticCompensation:
    """Beam-model compensation pressure: S_trimmed(Q) = S_intact(Q_i) at a = 1, δ = 1 mm.

    Parameters
    ----------
    design : WhiskerDesign
        The whisker; its intact form (``trim = 0``) is the target, ``design.trimmed(trim)``
        the compensator.
    Q_i : float
        Intact operating pressure [MPa], > 0.
    trim : float
        Δ [mm].
    model : BeamModel, optional
    a, delta : float
        Contact ratio and deflection; the beam model is linear, so ε(δ)/δ does not depend on δ.
    xtol : float
        Absolute tolerance of Brent's method on Q [MPa].

    Returns
    -------
    AnalyticCompensation
    """
    model = DEFAULT_MODEL if model is None else model
    intact, trimmed, Q_i = _check_inputs(design, Q_i, trim)
    _check_range("delta", delta, 0.0, None, lo_open=True)
    s_t = sensitivity(intact, a, Q_i, model)  # ε(δ)/δ, the same at every δ (linear model)

    def f(q: float) -> float:
        return sensitivity(trimmed, a, q, model) - s_t

    f0, f1 = f(0.0), f(Q_i)
    s0, s1 = f0 + s_t, f1 + s_t
    if f0 == 0.0 or f1 == 0.0:
        q = 0.0 if f0 == 0.0 else Q_i
        found, msg = True, f"exact match at the end point Q = {q:g} MPa"
    elif f0 * f1 < 0.0:
        q = float(optimize.brentq(f, 0.0, Q_i, xtol=xtol, rtol=4 * np.finfo(float).eps))
        found, msg = True, f"root Q = {q:.6g} MPa in [0, {Q_i:g}]"
    else:
        q = 0.0 if abs(f0) <= abs(f1) else Q_i
        found = False
        msg = (
            f"no Q in [0, {Q_i:g}] MPa matches: trimmed (Δ = {trim:g} mm) ε/δ spans [{min(s0, s1):.6g}, "
            f"{max(s0, s1):.6g}] 1/mm, target {s_t:.6g}; clipped to Q = {q:g} MPa"
        )
        logger.warning("analytic compensation: %s", msg)
    s_q = s0 if q == 0.0 else (s1 if q == Q_i else f(q) + s_t)
    logger.info("analytic compensation Δ=%g Q_i=%g: %s", trim, Q_i, msg)
    return AnalyticCompensation(
        trim=float(trim), Q_i=Q_i, Q=q, target_sensitivity=s_t, sensitivity=s_q,
        sensitivity_range=(s0, s1), root_found=found, message=msg,
    )


# --------------------------------------------------------------------------- response-based
@dataclass(frozen=True, eq=False)
class ResponseCompensation:
    """Result of :func:`fe_compensation`.

    Attributes
    ----------
    trim, Q_i, Q : float
        Δ [mm], intact pressure, chosen vent pressure [MPa].
    deltas : ndarray, shape (n,)
        Deflection samples [mm].
    eps_target, eps_broken, eps_compensated : ndarray, shape (n,)
        ε_o (intact, Q_i), ε_b (trimmed, Q_i), ε_c (trimmed, Q).
    gap_before, gap_after : float
        Mean |ε - ε_o| over δ, uncompensated and compensated.
    recovery_rate, compensation_error : float
        the measures [%] on the scalar ``scalar``.
    scalar : str
    at_bound : str or None
        'lower' (Q = 0) or 'upper' (Q = Q_i) when the optimum is an end point, else None.
    n_evaluations : int
        Calls of the response function (including the target).
    """

    trim: float
    Q_i: float
    Q: float
    deltas: np.ndarray
    eps_target: np.ndarray
    eps_broken: np.ndarray
    eps_compensated: np.ndarray
    gap_before: float
    gap_after: float
    recovery_rate: float
    compensation_error: float
    scalar: str
    at_bound: str | None
    n_evaluations: int


def fe_compensation(design: WhiskerDesign, Q_i: float, trim: float, response: ResponseFn,
                    deltas=None, *, scalar: Scalar = "mean", method: Literal["bounded", "root"] = "bounded",
                    xatol: float = 1e-4, maxiter: int = 60, eps_target=None) -> ResponseCompensation:
    """Vent pressure Q ∈ [0, Q_i] minimising the mean gap to the intact response.

    Parameters
    ----------
    design : WhiskerDesign
        Intact form (trim 0) = target; ``design.trimmed(trim)`` = compensator.
    Q_i : float
        Intact pressure [MPa] > 0.
    trim : float
        Δ [mm]; 0 returns Q = Q_i without solving.
    response : callable
        ``response(design, Q, deltas) -> ε`` (shape of deltas), the gauge reading at a = 1
        (FE scene, or :class:`whisker_opt.analysis.beam.BeamResponse`).
    deltas : array_like, optional
        Deflection samples [mm]; default :data:`DEFAULT_DELTAS`.
    scalar : {'mean', 'last', 'gap'}
        Scalar of a curve for the recovery/compensation measures.
    method : {'bounded', 'root'}
        'bounded' (default): bounded Brent minimisation of the mean gap g(Q) (about 15-20
        response calls at xatol = 1e-4 MPa). 'root': Brent root of the signed mean
        difference mean_k(ε_trim(Q, δ_k) - ε_o(δ_k)) bracketed by [0, Q_i] (about 6-9
        calls); the same Q as 'bounded' when ε_trim(Q) - ε_o keeps one sign over δ (the
        usual case: the curves do not cross), and the end point with the smaller gap when
        the bracket holds no sign change.
    xatol : float
        Absolute tolerance on Q [MPa] of the search.
    maxiter : int
        Maximum Brent iterations.
    eps_target : array_like, optional
        Precomputed intact response at Q_i on ``deltas`` (saves one response call).

    Returns
    -------
    ResponseCompensation
    """
    intact, trimmed, Q_i = _check_inputs(design, Q_i, trim)
    _check_range("xatol", xatol, 0.0, Q_i, lo_open=True)
    if scalar not in ("mean", "last", "gap"):
        raise ValueError(f"scalar = {scalar!r}: allowed 'mean', 'last', 'gap'")
    if method not in ("bounded", "root"):
        raise ValueError(f"method = {method!r}: allowed 'bounded', 'root'")
    ds = np.asarray(DEFAULT_DELTAS if deltas is None else deltas, dtype=float)
    if ds.ndim != 1 or ds.size == 0 or not np.all(np.isfinite(ds)):
        raise ValueError(f"deltas = {deltas!r}: need a non-empty 1-D array of finite deflections [mm]")

    n_eval = 0
    if eps_target is None:
        eps_o = np.asarray(response(intact, Q_i, ds), dtype=float)
        n_eval += 1
    else:
        eps_o = np.asarray(eps_target, dtype=float)
    if eps_o.shape != ds.shape:
        raise ValueError(f"eps_target shape {eps_o.shape} != deltas shape {ds.shape}")

    memo: dict[float, np.ndarray] = {}

    def curve(q: float) -> np.ndarray:
        nonlocal n_eval
        q = float(q)
        if q not in memo:
            memo[q] = np.asarray(response(trimmed, q, ds), dtype=float)
            n_eval += 1
        return memo[q]

    def gap(q: float) -> float:
        return f1(curve(q), eps_o)

    if trim == 0.0:
        eps_b = eps_o if eps_target is not None else curve(Q_i)
        return ResponseCompensation(
            trim=0.0, Q_i=Q_i, Q=Q_i, deltas=ds, eps_target=eps_o, eps_broken=eps_b, eps_compensated=eps_b,
            gap_before=f1(eps_b, eps_o), gap_after=f1(eps_b, eps_o), recovery_rate=float("nan"),
            compensation_error=float("nan"), scalar=scalar, at_bound="upper", n_evaluations=n_eval,
        )

    g_hi = gap(Q_i)
    g_best, q_best, bound = _best_vent_pressure(gap, lambda q: float(np.mean(curve(q) - eps_o)), Q_i, trim,
                                                method, xatol, maxiter)
    eps_b, eps_c = curve(Q_i), curve(q_best)
    rec, err = curve_measures(eps_o, eps_b, eps_c, scalar)
    if bound == "lower":
        logger.warning("fe_compensation Δ=%g: optimum at Q = 0 (vent fully): the pressure range cannot restore "
                       "the intact response (gap %.4g -> %.4g)", trim, g_hi, g_best)
    logger.info("fe_compensation Δ=%g Q_i=%g: Q=%.6g gap %.4g -> %.4g, recovery %.2f%%, error %.2f%% (%d responses)",
                trim, Q_i, q_best, g_hi, g_best, rec, err, n_eval)
    return ResponseCompensation(
        trim=float(trim), Q_i=Q_i, Q=q_best, deltas=ds, eps_target=eps_o, eps_broken=eps_b, eps_compensated=eps_c,
        gap_before=g_hi, gap_after=g_best, recovery_rate=rec, compensation_error=err, scalar=scalar,
        at_bound=bound, n_evaluations=n_eval,
    )


def _best_vent_pressure(gap: Callable[[float], float], signed: Callable[[float], float], Q_i: float, trim: float,
                        method: str, xatol: float, maxiter: int) -> tuple[float, float, str | None]:
    """(gap, Q, bound) of the best vent pressure in [0, Q_i] (:func:`fe_compensation`'s search).

    The end points are candidates; ``bounded`` adds Brent's bounded minimum of ``gap``, ``root`` the
    Brent root of ``signed`` (the signed mean difference) when the end points bracket one. ``bound`` is
    ``'lower'`` or ``'upper'`` when an end point wins, else None.
    """
    cands = [(gap(0.0), 0.0, "lower"), (gap(Q_i), Q_i, "upper")]
    if method == "bounded":
        res = optimize.minimize_scalar(gap, bounds=(0.0, Q_i), method="bounded",
                                       options={"xatol": xatol, "maxiter": maxiter})
        if not res.success:
            logger.warning("fe_compensation Δ=%g: bounded search did not converge (%s)", trim, res.message)
        cands.append((float(res.fun), float(res.x), None))
    else:  # 'root': zero of the signed mean difference, bracketed by the end points
        s_lo, s_hi = signed(0.0), signed(Q_i)
        if s_lo * s_hi < 0.0:
            q_r = float(optimize.brentq(signed, 0.0, Q_i, xtol=xatol, maxiter=maxiter))
            cands.append((gap(q_r), q_r, None))
    return min(cands, key=lambda c: c[0])


# --------------------------------------------------------------------------- table
@dataclass(frozen=True)
class CompensationRow:
    """One trim of a :class:`CompensationTable` (pressures in MPa, rates in %, gaps in strain)."""

    trim: float
    Q: float
    recovery_rate: float
    compensation_error: float
    gap_before: float
    gap_after: float
    at_bound: str | None
    Q_analytic: float = float("nan")
    analytic_root_found: bool | None = None
    eps_target: tuple[float, ...] = ()
    eps_broken: tuple[float, ...] = ()
    eps_compensated: tuple[float, ...] = ()

    @property
    def Q_difference(self) -> float:
        """Q - Q_analytic [MPa] (NaN without an analytic value)."""
        return self.Q - self.Q_analytic


@dataclass(frozen=True, eq=False)
class CompensationTable:
    """Δ → Q table of a design: what a robot would store.

    Attributes
    ----------
    design : WhiskerDesign
        Intact design.
    Q_i : float
        Intact pressure [MPa].
    rows : tuple of CompensationRow
        Increasing trims, first Δ = 0.
    deltas : ndarray
        Deflection samples used [mm].
    scalar : str
        Scalar of the recovery/compensation measures.
    """

    design: WhiskerDesign
    Q_i: float
    rows: tuple[CompensationRow, ...]
    deltas: np.ndarray
    scalar: str

    def column(self, name: str) -> np.ndarray:
        """One column as an array, e.g. ``column('Q')``."""
        return np.array([getattr(r, name) for r in self.rows], dtype=float)

    @property
    def trims(self) -> np.ndarray:
        return self.column("trim")

    @property
    def pressures(self) -> np.ndarray:
        return self.column("Q")

    def is_monotone(self, tol: float = 1e-6) -> bool:
        """Q non-increasing in Δ (larger trims need lower vent pressure), within ``tol`` [MPa]."""
        return bool(np.all(np.diff(self.pressures) <= tol))

    def curves(self, which: Literal["target", "broken", "compensated"]) -> np.ndarray:
        """ε(δ) of every row on :attr:`deltas`, shape (n_rows, n_delta) (NaN rows if not stored)."""
        out = np.full((len(self.rows), self.deltas.size), np.nan)
        for i, r in enumerate(self.rows):
            v = getattr(r, f"eps_{which}")
            if len(v) == self.deltas.size:
                out[i] = v
        return out

    def measures_at(self, delta: float) -> dict[str, np.ndarray]:
        """The recovery/compensation measures on the readings at one deflection δ (e.g. 1 mm, as the beam model uses).

        ``delta`` must be one of :attr:`deltas` (within 1e-9 mm). Returns arrays over the
        rows: ``eps_target``, ``eps_broken``, ``eps_compensated`` (ε at δ), ``recovery_rate``
        and ``compensation_error`` [%] (NaN where nothing is to recover, e.g. Δ = 0).
        """
        k = np.flatnonzero(np.abs(self.deltas - float(delta)) <= 1e-9)
        if k.size == 0:
            raise ValueError(f"measures_at: δ = {delta!r} mm is not a sample of the table "
                             f"(deltas = {np.array2string(self.deltas, precision=4)})")
        o, b, c = (self.curves(w)[:, k[0]] for w in ("target", "broken", "compensated"))
        rec = np.array([recovery_rate(*v) for v in zip(o, b, c)])
        err = np.array([compensation_error(*v) for v in zip(o, b, c)])
        return {"eps_target": o, "eps_broken": b, "eps_compensated": c, "recovery_rate": rec,
                "compensation_error": err}


def compensation_table(design: WhiskerDesign, Q_i: float, trim_max: float, response: ResponseFn, *,
                       step: float = 1.0, deltas=None, scalar: Scalar = "mean", method: str = "bounded",
                       xatol: float = 1e-4, analytic_model: BeamModel | None = None,
                       maxiter: int = 60) -> CompensationTable:
    """Compensation pressure for trims Δ = 0, step, …, Δmax.

    Parameters
    ----------
    design : WhiskerDesign
        Intact design.
    Q_i : float
        Intact pressure [MPa].
    trim_max : float
        Largest trim [mm] (included; the last step may be shorter).
    response : callable
        ``response(design, Q, deltas) -> ε`` (see :func:`fe_compensation`).
    step : float
        Trim increment [mm] > 0.
    deltas, scalar, method, xatol, maxiter
        As in :func:`fe_compensation`.
    analytic_model : BeamModel, optional
        If given, each row also carries the analytic (beam) compensation pressure.

    Returns
    -------
    CompensationTable
    """
    dmax = _check_range("trim_max", trim_max, 0.0, None)
    step = _check_range("step", step, 0.0, None, lo_open=True)
    n = int(math.floor(dmax / step + 1e-9))
    trims = [i * step for i in range(n + 1)]
    if dmax - trims[-1] > 1e-9:
        trims.append(dmax)
    design.trimmed(dmax).validate()  # refuse early if the largest cut reaches the chamber
    ds = np.asarray(DEFAULT_DELTAS if deltas is None else deltas, dtype=float)
    eps_o = np.asarray(response(design.trimmed(0.0), Q_i, ds), dtype=float)
    rows = []
    for tr in trims:
        r = fe_compensation(design, Q_i, tr, response, ds, scalar=scalar, method=method, xatol=xatol,
                            maxiter=maxiter, eps_target=eps_o)
        qa, found = float("nan"), None
        if analytic_model is not None:
            if tr == 0.0:
                qa, found = Q_i, True
            else:
                ac = analytic_compensation(design, Q_i, tr, analytic_model)
                qa, found = ac.Q, ac.root_found
        rows.append(CompensationRow(trim=tr, Q=r.Q, recovery_rate=r.recovery_rate,
                                    compensation_error=r.compensation_error, gap_before=r.gap_before,
                                    gap_after=r.gap_after, at_bound=r.at_bound, Q_analytic=qa,
                                    analytic_root_found=found, eps_target=tuple(map(float, r.eps_target)),
                                    eps_broken=tuple(map(float, r.eps_broken)),
                                    eps_compensated=tuple(map(float, r.eps_compensated))))
    table = CompensationTable(design=design.trimmed(0.0), Q_i=float(Q_i), rows=tuple(rows), deltas=ds, scalar=scalar)
    if not table.is_monotone():
        logger.warning("compensation table not monotone in Δ: Q = %s", np.array2string(table.pressures, precision=5))
    return table


# --------------------------------------------------------------------------- beam vs FE
@dataclass(frozen=True, eq=False)
class SensitivityComparison:
    """Beam model vs FE gauge sensitivity on a grid a × Q.

    Attributes
    ----------
    design : WhiskerDesign
    a : ndarray, shape (n_a,)
    Q : ndarray, shape (n_Q,)
    beam, fe : ndarray, shape (n_a, n_Q)
        ε/δ [1/mm].
    """

    design: WhiskerDesign
    a: np.ndarray
    Q: np.ndarray
    beam: np.ndarray
    fe: np.ndarray

    @property
    def relative_difference(self) -> np.ndarray:
        """(beam - fe) / fe, shape (n_a, n_Q)."""
        return (self.beam - self.fe) / self.fe

    @property
    def max_abs_relative_difference(self) -> float:
        return float(np.max(np.abs(self.relative_difference)))


def compare_sensitivity(design: WhiskerDesign, fe_sensitivity: SensitivityFn, *, a_values=None, Q_values=None,
                        model: BeamModel | None = None) -> SensitivityComparison:
    """Beam model against a supplied FE sensitivity ``fe_sensitivity(design, a, Q) -> ε/δ``.

    Parameters
    ----------
    design : WhiskerDesign
    fe_sensitivity : callable
        FE gauge sensitivity [1/mm]; it must use the same calibration ξ as ``model.calibration``.
    a_values : array_like, optional
        Contact ratios; default 12 points on [0.45, 1].
    Q_values : array_like, optional
        Pressures [MPa]; default 5 points on [0, 0.2].
    model : BeamModel, optional

    Returns
    -------
    SensitivityComparison
    """
    a = np.asarray(np.linspace(0.45, 1.0, 12) if a_values is None else a_values, dtype=float)
    q = np.asarray(np.linspace(0.0, 0.2, 5) if Q_values is None else Q_values, dtype=float)
    beam = sensitivity_grid(design, a, q, model)  # (n_a, n_Q)
    fe = np.array([[float(fe_sensitivity(design, ai, qj)) for qj in q] for ai in a])  # (n_a, n_Q)
    cmp = SensitivityComparison(design=design, a=a, Q=q, beam=beam, fe=fe)
    logger.info("beam vs FE sensitivity: max |rel. diff| = %.3g over %d points", cmp.max_abs_relative_difference,
                beam.size)
    return cmp
