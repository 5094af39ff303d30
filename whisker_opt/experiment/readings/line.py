"""``line`` (the default reading): the mean logarithmic strain along the gauge line.

The gauge is a material line of length ``e`` on the +y generator of the outer cone, from x = x_ss to
x = x_ss + e, with unit reference tangent ``T = (1, -tan α, 0) / sqrt(1 + tan² α)``
(:class:`whisker_opt.experiment.gauge.GaugeGeometry`). At its Gauss-Legendre points the local stretch is
``λ_k = |F_k T|``; the reading is the length-weighted mean of the logarithmic strain relative to contact onset
(docs/physics.md §3),

    ε = ξ · Σ_k w_k ln(λ_k(δ) / λ_k(0)),   Σ w_k = 1,

ξ the calibration factor (applied by :class:`whisker_opt.experiment.gauge.GaugeReader`).
"""

from __future__ import annotations

import numpy as np

NAME = "line"
ORDER = 0  # place in the registry (the default reading first)
DESCRIPTION = "mean logarithmic strain along the gauge line, relative to contact onset, times ξ"


def state(mesh, u: np.ndarray, gauge) -> np.ndarray:
    """The local stretches ``λ_k = |F_k T|`` at the gauge points of displacement ``u``, shape (n,)."""
    from fem.query import deformation_gradient_at

    F = deformation_gradient_at(mesh, u, gauge.host_elements, gauge.local_coords)  # (n, 3, 3)
    return np.linalg.norm(F @ gauge.tangent, axis=1)  # (n,)


def relative(now: np.ndarray, onset: np.ndarray, gauge, context=None) -> float:
    """Σ_k w_k ln(λ_k / λ_k⁰): the uncalibrated reading of the stretches ``now`` relative to those at ``onset``."""
    return float(gauge.weights @ np.log(now / onset))
