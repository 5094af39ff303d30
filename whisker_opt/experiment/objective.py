"""f1, the number the optimiser minimises: how far the compensated response lies from the intact one.

.. math::

    f_1 = \\frac{1}{N} \\sum_{k=1}^{N} \\left| \\varepsilon_i(\\delta_k) - \\varepsilon_c(\\delta_k) \\right|

with ε_i the gauge reading of the intact whisker at its initial pressure Q_i, ε_c that of the
trimmed, vented whisker, and δ_k = k·Δδ (k = 1 … N, N·Δδ = δ_max) the deflection samples
(``docs/physics.md``). Its unit is that of the readings: strain as simulated (uncalibrated),
or multiplied by the gauge factor ξ where the readings are calibrated. The same mean absolute
gap measures any two curves on common samples (for instance before and after compensation).
"""

from __future__ import annotations

import numpy as np


def f1(eps_a, eps_b) -> float:
    """Mean absolute gap between two gauge curves sampled at the same deflections.

    Parameters
    ----------
    eps_a, eps_b : array_like, shape (N,)
        Gauge readings at δ_1 … δ_N (not including δ = 0).

    Returns
    -------
    float
        ``mean |eps_a - eps_b|``.

    Raises
    ------
    ValueError
        Shapes differ or the curves are empty.
    """
    a = np.asarray(eps_a, dtype=float)
    b = np.asarray(eps_b, dtype=float)
    if a.shape != b.shape or a.size == 0:
        raise ValueError(f"gauge curves must have equal, non-empty shapes (got {a.shape}, {b.shape})")
    return float(np.mean(np.abs(a - b)))
