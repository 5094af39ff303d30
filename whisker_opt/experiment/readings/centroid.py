"""``centroid`` (the thesis' reading): the axial Eulerian log strain at the centroid of the gauge's element.

The axial component of ``ln V = ½ ln(F Fᵀ)`` at the centroid of the element under the gauge centre
(:attr:`whisker_opt.experiment.gauge.GaugeGeometry.centroid_element`), relative to contact onset, times ξ
(docs/physics.md §3): what Abaqus reports as LE11 for the element under the gauge.
"""

from __future__ import annotations

import numpy as np

NAME = "centroid"
ORDER = 1  # place in the registry (the default reading first)
DESCRIPTION = ("axial Eulerian log strain at the centroid of the element under the gauge centre, relative to "
               "contact onset, times ξ (the thesis' readout)")


def state(mesh, u: np.ndarray, gauge) -> float:
    """``(½ ln F Fᵀ)_xx`` at the centroid of the gauge's element for displacement ``u``."""
    from fem.query import deformation_gradient_at

    F = deformation_gradient_at(
        mesh, u, np.array([gauge.centroid_element]), np.full((1, 3), 0.25)
    )[0]  # (3, 3)
    b = F @ F.T
    lam2, vec = np.linalg.eigh(b)
    ln_v = 0.5 * (vec * np.log(lam2)) @ vec.T
    return float(ln_v[0, 0])


def relative(now: float, onset: float, gauge, context=None) -> float:
    """The uncalibrated reading: the axial log strain ``now`` less that at ``onset``."""
    return now - onset
