"""The uncertainty of a calibrated model's prediction, propagated from its parameters' covariance.

Linear propagation at the fitted values θ̂ (Press et al., Numerical Recipes, §15.5; JCGM 100:2008, the GUM, §5.1):
with g = ∂m/∂θ, the prediction's gradient by forward differences in the fit's normalised parameters, and
Cov(θ) the fit's covariance (:func:`whisker_opt.calibration.fit.covariance`),

    σ_pred = √(gᵀ Cov(θ) g).

:func:`whisker_opt.calibration.fit.fit` gives each held-out observation this uncertainty and the z score of its
miss (docs/calibration.md).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = ["prediction_std"]


def prediction_std(problem, theta, observations: Sequence, at_theta: Sequence, cov: np.ndarray,
                   diff_step: float) -> list[float]:
    """σ_pred = √(gᵀ Cov g) of each observation's model value at θ (the module docstring).

    Parameters
    ----------
    problem : whisker_opt.calibration.fit.Problem
        Its ``u``, ``theta``, ``width`` and ``predictions(theta, observations)``.
    theta : array_like, shape (n,)
        The fitted values θ̂.
    observations : sequence of whisker_opt.calibration.fit.Weighted
    at_theta : sequence of whisker_opt.calibration.forward.Prediction
        Their values at θ̂.
    cov : ndarray, shape (n, n)
        Cov(θ) (inf along directions the fit does not determine).
    diff_step : float
        Forward-difference step in the normalised parameters (backward near the upper end).

    Returns
    -------
    list of float
        nan where a shifted prediction found no match; inf where g has a component along an undetermined
        direction.
    """
    u0 = problem.u(theta)
    m0 = np.array([p.value for p in at_theta])  # (k,)
    grad = np.empty((len(observations), u0.size))  # (k, n): ∂m/∂θ
    ok = np.array([p.matched for p in at_theta])
    for i in range(u0.size):
        h = diff_step if u0[i] + diff_step <= 1.0 else -diff_step
        v = u0.copy()
        v[i] += h
        preds = problem.predictions(problem.theta(v), observations)
        ok &= np.array([p.matched for p in preds])
        grad[:, i] = (np.array([p.value for p in preds]) - m0) / (h * problem.width[i])
    out = []
    for k in range(len(observations)):
        g = grad[k]
        if not ok[k]:
            out.append(math.nan)
            continue
        used = g != 0.0
        c = cov[np.ix_(used, used)]  # (n', n')
        out.append(math.inf if not np.all(np.isfinite(c)) else math.sqrt(max(0.0, float(g[used] @ c @ g[used]))))
    return out
