"""Propagation of fabrication tolerances to a design's figures: pure estimators, no finite elements.

A design is evaluated at its nominal parameters x0 and at deviated ones x0 + x, where each
deviation x_j is an independent random variable of half-width h_j (the stated tolerance
"± h_j"). The function under study, ``f(x) -> y``, maps a deviation vector (d,) to a vector of
outputs (m,) (for a whisker: f1 and the recovery rate); it is given by the caller, so this
module knows nothing of whiskers and is tested on closed-form functions.

Distributions (docs/physics.md §10)
    ``uniform``: x_j ~ U(−h_j, h_j), standard deviation σ_j = h_j/√3.
    ``normal``:  x_j ~ N(0, σ_j²) with σ_j = h_j/s, the tolerance being s standard deviations
    (s = ``sigmas``, 3 by default: 99.73 % of the parts lie within ± h_j).

Estimator (a): a seeded sample (:func:`draw`, :func:`sample_estimate`)
    N points by Latin hypercube (each variable's N strata of probability 1/N hit once, in a
    random order; McKay, Beckman & Conover 1979; ``scipy.stats.qmc.LatinHypercube``) or plain
    Monte Carlo, mapped through the inverse distribution function. Mean and standard deviation
    (ddof = 1) of each output over the sample, worst case the worst sampled value, and
    sensitivities from the least-squares linear fit y ≈ b0 + Σ_j b_j x_j.

Estimator (b): a first-order expansion (:func:`expansion_estimate`)
    Central finite differences with the step s_j = ``step``·h_j,

        g_j = (f(x0 + s_j e_j) − f(x0 − s_j e_j)) / (2 s_j),

    2n + 1 evaluations for n toleranced parameters (a zero tolerance costs nothing). Then
    (first-order second-moment method)

        mean ≈ f(x0),    std ≈ sqrt(Σ_j (g_j σ_j)²),

    and the worst case is f evaluated at the corner x_j = ±h_j whose signs follow the
    gradient: sign(g_j) where larger is worse (f1), −sign(g_j) where smaller is worse (the
    recovery rate). It is exact for a linear f; where f is not smooth (e.g. an absolute value
    through zero, as f1 = mean|ε_i − ε_c| near a perfect match) the central difference sees the
    two sides cancel and the expansion underestimates both the mean and the spread.

The robust objective of a design is mean + k·std (:func:`robust_objective`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist
from typing import Callable, Literal, Sequence

import numpy as np

Distribution = Literal["uniform", "normal"]
Sampling = Literal["lhs", "monte_carlo"]
#: ``f(x) -> y``: deviation vector (d,) to outputs (m,).
PointFunction = Callable[[np.ndarray], Sequence[float]]

DISTRIBUTIONS: tuple[str, ...] = ("uniform", "normal")
SAMPLINGS: tuple[str, ...] = ("lhs", "monte_carlo")


def _check_half_widths(half_widths: Sequence[float]) -> np.ndarray:
    h = np.asarray(half_widths, dtype=float)
    if h.ndim != 1 or h.size == 0:
        raise ValueError(f"half_widths: expected a non-empty vector, got shape {h.shape}")
    bad = [float(v) for v in h if not (math.isfinite(v) and v >= 0.0)]
    if bad:
        raise ValueError(f"half_widths: {bad} outside the allowed range [0, inf)")
    return h


def _check_choice(name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValueError(f"{name}: {value!r} is not one of {', '.join(map(repr, allowed))}")


def standard_deviations(half_widths: Sequence[float], distribution: Distribution = "uniform",
                        sigmas: float = 3.0) -> np.ndarray:
    """σ_j of each deviation: h_j/√3 (uniform on [−h_j, h_j]) or h_j/s (normal, ± h_j = s·σ_j).

    Parameters
    ----------
    half_widths : sequence of float, shape (d,)
        Tolerances h_j ≥ 0.
    distribution : {'uniform', 'normal'}
    sigmas : float
        s > 0, standard deviations per tolerance of the normal distribution.

    Returns
    -------
    ndarray, shape (d,)
    """
    h = _check_half_widths(half_widths)
    _check_choice("distribution", distribution, DISTRIBUTIONS)
    if distribution == "uniform":
        return h / math.sqrt(3.0)
    if not (math.isfinite(sigmas) and sigmas > 0):
        raise ValueError(f"sigmas: {sigmas!r} outside the allowed range (0, inf)")
    return h / float(sigmas)


def _unit_sample(n: int, d: int, sampling: Sampling, rng: np.random.Generator) -> np.ndarray:
    """(n, d) points in the open unit cube: Latin hypercube (scipy.stats.qmc, one point in each of the n
    strata of every variable, strata shuffled per column) or plain uniform draws, both from ``rng``."""
    if sampling == "monte_carlo":
        u = rng.random((n, d))
    else:
        from scipy.stats import qmc  # here: importing this module stays numpy only

        u = qmc.LatinHypercube(d, rng=rng).random(n)
    return np.clip(u, 1e-12, 1.0 - 1e-12)  # the normal's inverse needs 0 < u < 1


def draw(n: int, half_widths: Sequence[float], distribution: Distribution = "uniform",
         sampling: Sampling = "lhs", seed: int = 0, sigmas: float = 3.0) -> np.ndarray:
    """A seeded sample of deviation vectors.

    Parameters
    ----------
    n : int
        Number of points, ≥ 2.
    half_widths : sequence of float, shape (d,)
    distribution, sigmas
        See :func:`standard_deviations`.
    sampling : {'lhs', 'monte_carlo'}
    seed : int
        The same seed gives the same sample (``numpy.random.default_rng``).

    Returns
    -------
    ndarray, shape (n, d)
        x_j = −h_j + 2 h_j u (uniform) or σ_j Φ⁻¹(u) (normal) for u of the unit sample; a
        zero tolerance gives a zero column.
    """
    h = _check_half_widths(half_widths)
    _check_choice("distribution", distribution, DISTRIBUTIONS)
    _check_choice("sampling", sampling, SAMPLINGS)
    if int(n) != n or n < 2:
        raise ValueError(f"n: {n!r} outside the allowed range 2..inf")
    u = _unit_sample(int(n), h.size, sampling, np.random.default_rng(int(seed)))
    if distribution == "uniform":
        return (2.0 * u - 1.0) * h  # (n, d)
    sigma = standard_deviations(h, "normal", sigmas)
    z = np.vectorize(NormalDist().inv_cdf)(u)  # (n, d)
    return z * sigma


def robust_objective(mean, std, k: float):
    """mean + k·std (the objective of a robust design, docs/physics.md §10)."""
    return np.asarray(mean, dtype=float) + float(k) * np.asarray(std, dtype=float)


def _worst_index(values: np.ndarray, worse: float) -> int:
    """Index of the worst finite value: the largest for ``worse`` > 0, the smallest otherwise."""
    v = np.where(np.isfinite(values), values, np.nan)
    if np.all(np.isnan(v)):
        return -1
    return int(np.nanargmax(v) if worse > 0 else np.nanargmin(v))


def _worse_signs(worse: Sequence[float] | None, m: int) -> np.ndarray:
    w = np.ones(m) if worse is None else np.sign(np.asarray(worse, dtype=float))
    if w.shape != (m,) or np.any(w == 0):
        raise ValueError(f"worse: expected {m} signs (+1: larger is worse, -1: smaller is worse), got {worse!r}")
    return w


@dataclass(frozen=True)
class SampleEstimate:
    """Statistics of the outputs over a sample of deviations (estimator a).

    Attributes
    ----------
    points : ndarray, shape (n, d)
        The deviations.
    values : ndarray, shape (n, m)
        f at each point.
    mean, std : ndarray, shape (m,)
        Sample mean and standard deviation (ddof = 1), NaN values left out.
    worst : ndarray, shape (m,)
        The worst sampled value of each output.
    worst_point : ndarray, shape (m, d)
        Where it was found.
    slopes : ndarray, shape (m, d)
        b_j of the least-squares fit y ≈ b0 + Σ_j b_j x_j (0 for a zero tolerance): the sample's
        sensitivities.
    """

    points: np.ndarray
    values: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    worst: np.ndarray
    worst_point: np.ndarray
    slopes: np.ndarray

    @property
    def n_evaluations(self) -> int:
        return int(self.points.shape[0])


def linear_fit_slopes(points: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Slopes b (m, d) of the least-squares fit values ≈ b0 + points·bᵀ over the rows without NaN.

    Columns of ``points`` that are constant (a zero tolerance) get slope 0.
    """
    x = np.asarray(points, dtype=float)  # (n, d)
    y = np.asarray(values, dtype=float)  # (n, m)
    m, d = y.shape[1], x.shape[1]
    out = np.full((m, d), np.nan)
    live = np.ptp(x, axis=0) > 0  # (d,)
    for i in range(m):
        ok = np.isfinite(y[:, i])
        if ok.sum() <= live.sum():  # not enough points for the fit
            continue
        a = np.column_stack([np.ones(ok.sum()), x[ok][:, live]])  # (n_ok, 1 + d_live)
        coef = np.linalg.lstsq(a, y[ok, i], rcond=None)[0]
        out[i] = 0.0
        out[i, live] = coef[1:]
    return out


def column_moments(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation (ddof = 1) of each column of ``values`` (n, m), NaN left out (NaN for a column
    with no finite value, std NaN with fewer than two)."""
    y = np.asarray(values, dtype=float)  # (n, m)
    with np.errstate(invalid="ignore"):
        mean = np.array([np.nanmean(c) if np.isfinite(c).any() else np.nan for c in y.T])
        std = np.array([np.nanstd(c, ddof=1) if np.isfinite(c).sum() > 1 else np.nan for c in y.T])
    return mean, std


def sample_estimate(f: PointFunction, points: np.ndarray, worse: Sequence[float] | None = None) -> SampleEstimate:
    """Estimator (a): evaluate ``f`` at every point of a sample and summarise.

    Parameters
    ----------
    f : callable
        ``f(x) -> y``, x of shape (d,), y of shape (m,).
    points : ndarray, shape (n, d)
        From :func:`draw`.
    worse : sequence of ±1, shape (m,), optional
        Per output, +1 when a larger value is worse (default), −1 when a smaller one is.

    Returns
    -------
    SampleEstimate
    """
    x = np.atleast_2d(np.asarray(points, dtype=float))  # (n, d)
    y = np.array([np.asarray(f(p), dtype=float).ravel() for p in x])  # (n, m)
    w = _worse_signs(worse, y.shape[1])
    mean, std = column_moments(y)
    idx = [_worst_index(y[:, i], w[i]) for i in range(y.shape[1])]
    worst = np.array([y[j, i] if j >= 0 else np.nan for i, j in enumerate(idx)])
    worst_point = np.array([x[j] if j >= 0 else np.full(x.shape[1], np.nan) for j in idx])
    return SampleEstimate(x, y, mean, std, worst, worst_point, linear_fit_slopes(x, y))


@dataclass(frozen=True)
class ExpansionEstimate:
    """The first-order expansion of the outputs about the nominal point (estimator b).

    Attributes
    ----------
    nominal : ndarray, shape (m,)
        f(x0), the expansion's mean.
    minus, plus : ndarray, shape (d, m)
        f(x0 − s_j e_j) and f(x0 + s_j e_j) (the nominal value where h_j = 0): the tornado.
    steps : ndarray, shape (d,)
        s_j.
    gradient : ndarray, shape (m, d)
        Central differences g_j.
    sigma : ndarray, shape (d,)
        σ_j of the deviations.
    std : ndarray, shape (m,)
        sqrt(Σ_j (g_j σ_j)²).
    corners : ndarray, shape (m, d)
        The worst corner of each output (x_j = ±h_j by the gradient's signs).
    worst : ndarray, shape (m,)
        f at that corner (NaN when corners were not evaluated).
    n_evaluations : int
        Calls of f made (distinct points only).
    """

    nominal: np.ndarray
    minus: np.ndarray
    plus: np.ndarray
    steps: np.ndarray
    gradient: np.ndarray
    sigma: np.ndarray
    std: np.ndarray
    corners: np.ndarray
    worst: np.ndarray
    n_evaluations: int

    @property
    def mean(self) -> np.ndarray:
        """The expansion's mean, f(x0)."""
        return self.nominal

    @property
    def contributions(self) -> np.ndarray:
        """g_j σ_j (m, d): each tolerance's share of the standard deviation (its square sums to std²)."""
        return self.gradient * self.sigma[None, :]


def expansion_estimate(f: PointFunction, half_widths: Sequence[float], distribution: Distribution = "uniform",
                       sigmas: float = 3.0, step: float = 1.0, worse: Sequence[float] | None = None,
                       corners: bool = True) -> ExpansionEstimate:
    """Estimator (b): central finite differences about x0 = 0, std from the gradient, worst corner evaluated.

    Parameters
    ----------
    f : callable
        ``f(x) -> y``, x of shape (d,), y of shape (m,).
    half_widths : sequence of float, shape (d,)
        Tolerances h_j.
    distribution, sigmas
        See :func:`standard_deviations`.
    step : float
        s_j = step·h_j, 0 < step ≤ 1 (1: the differences span the whole tolerance band).
    worse : sequence of ±1, shape (m,), optional
        As :func:`sample_estimate`; chooses each output's worst corner.
    corners : bool
        Evaluate the worst corners (one more call per distinct corner); otherwise ``worst`` is NaN.

    Returns
    -------
    ExpansionEstimate
    """
    h = _check_half_widths(half_widths)
    if not (math.isfinite(step) and 0.0 < step <= 1.0):
        raise ValueError(f"step: {step!r} outside the allowed range (0, 1]")
    sigma = standard_deviations(h, distribution, sigmas)
    d = h.size
    y0 = np.asarray(f(np.zeros(d)), dtype=float).ravel()  # (m,)
    m = y0.size
    w = _worse_signs(worse, m)
    calls = 1
    s = step * h
    minus = np.tile(y0, (d, 1))  # (d, m)
    plus = np.tile(y0, (d, 1))  # (d, m)
    grad = np.zeros((m, d))
    for j in np.flatnonzero(s > 0):
        e = np.zeros(d)
        e[j] = s[j]
        minus[j] = np.asarray(f(-e), dtype=float).ravel()
        plus[j] = np.asarray(f(e), dtype=float).ravel()
        calls += 2
        grad[:, j] = (plus[j] - minus[j]) / (2.0 * s[j])
    std = np.sqrt(np.sum((grad * sigma[None, :]) ** 2, axis=1))  # (m,)
    signs = np.where(grad * w[:, None] >= 0.0, 1.0, -1.0)  # (m, d): towards "worse"
    corner_pts = signs * h[None, :]  # (m, d)
    worst = np.full(m, np.nan)
    if corners:
        seen: dict[tuple, np.ndarray] = {}
        for i in range(m):
            key = tuple(corner_pts[i])
            if key not in seen:
                seen[key] = np.asarray(f(corner_pts[i]), dtype=float).ravel()
                calls += 1
            worst[i] = seen[key][i]
    return ExpansionEstimate(y0, minus, plus, s, grad, sigma, std, corner_pts, worst, calls)
