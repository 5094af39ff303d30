"""Convergence numerics shared by the benchmark scripts: observed order, Richardson
extrapolation and Pareto fronts of run time against error.

Every refinement study of ``benchmarks/`` fits the model q(h) = q∞ + C hᵖ to its three finest
levels h₁ > h₂ > h₃: the observed order p solves

    (q₁ − q₂)/(q₂ − q₃) = (h₁ᵖ − h₂ᵖ)/(h₂ᵖ − h₃ᵖ)

(non-uniform refinement ratios solved exactly) and the Richardson value is
q∞ = q₃ − (q₂ − q₃) h₃ᵖ/(h₂ᵖ − h₃ᵖ).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq


def observed_order(h, q, bracket: tuple[float, float] = (0.1, 8.0)) -> float:
    """Observed order p of the last three values ``q`` at sizes ``h`` (h decreasing).

    Parameters
    ----------
    h, q : sequence of float
        Sizes and values; the last three are used.
    bracket : (float, float)
        Range searched for p.

    Returns
    -------
    float
        p, or NaN when the differences change sign or vanish (no asymptotic range) or no p in
        ``bracket`` fits.
    """
    (h1, h2, h3), (q1, q2, q3) = [float(x) for x in h[-3:]], [float(x) for x in q[-3:]]
    d1, d2 = q1 - q2, q2 - q3
    if not (math.isfinite(d1) and math.isfinite(d2)) or d1 * d2 <= 0:
        return math.nan
    target = d1 / d2

    def g(p):
        return (h1**p - h2**p) / (h2**p - h3**p) - target

    lo, hi = bracket
    if g(lo) * g(hi) > 0:
        return math.nan
    return float(brentq(g, lo, hi, xtol=1e-12))


def extrapolate(h, q, p: float) -> float:
    """Richardson value q∞ of the last two values ``q`` at sizes ``h`` for the order ``p``."""
    (h2, h3), (q2, q3) = [float(x) for x in h[-2:]], [float(x) for x in q[-2:]]
    return q3 - (q2 - q3) * h3**p / (h2**p - h3**p)


def richardson(h, q, bracket: tuple[float, float] = (0.1, 8.0)) -> tuple[float, float]:
    """Observed order p and Richardson value q∞ of the last three values ``q`` at sizes ``h``.

    Returns
    -------
    (float, float)
        (p, q∞), or (NaN, NaN) where :func:`observed_order` finds no order in ``bracket``.
    """
    p = observed_order(h, q, bracket)
    return (p, extrapolate(h, q, p)) if math.isfinite(p) else (math.nan, math.nan)


def richardson_or_p2(h, q) -> tuple[float, float, str]:
    """Extrapolate q(h) → h = 0 from the three finest levels (h decreasing).

    The observed order (:func:`observed_order`, p ∈ [0.25, 8]); when the differences change sign
    or no p fits, or only two levels are given, p = 2 (the P2 rate) from the two finest levels.

    Returns
    -------
    q_ref : float
    p : float
    note : str
        'observed' or 'assumed p=2'.
    """
    h, q = list(h)[-3:], list(q)[-3:]
    if len(h) < 2:
        raise ValueError(f"h: {len(h)} levels given, at least 2 needed")
    if len(h) == 3:
        p = observed_order(h, q, bracket=(0.25, 8.0))
        if math.isfinite(p):
            return extrapolate(h, q, p), p, "observed"
    return extrapolate(h, q, 2.0), 2.0, "assumed p=2"


def pareto(times, errors) -> np.ndarray:
    """Boolean mask of the non-dominated points (no other point is at least as fast and as accurate, one strictly)."""
    t, e = np.asarray(times, float), np.asarray(errors, float)
    mask = np.ones(len(t), bool)
    for i in range(len(t)):
        better = (t <= t[i]) & (e <= e[i]) & ((t < t[i]) | (e < e[i]))
        mask[i] = not better.any()
    return mask


def front_ratio(times, errors, i) -> float:
    """Error of point i over the best error reached in no more time by any point (1 = on the front)."""
    t, e = np.asarray(times, float), np.asarray(errors, float)
    best = e[t <= t[i]].min()
    return float(e[i] / best) if best > 0 else (1.0 if e[i] == 0 else float("inf"))
