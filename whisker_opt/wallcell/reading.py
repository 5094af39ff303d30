"""What a wall law does to the gauge reading: the beam model of the whisker with the wall cell's chamber.

The whisker is the cantilever of :mod:`whisker_opt.analysis.beam` (Castigliano deflection, gauge strain
averaged over the gauge's material span), with the chamber taken from the wall cell instead of Hooke's law
on a thinned tube:

* rigidity per reference length B(ξ, Q) = EI_cell(Q) · EI_bare(ξ)/EI_bare(ξ_cell): the cell's bending
  stiffness at its station, carried along the cone by the bare tube's 3μπ(r_o⁴ − r_i⁴)/4;
* the chamber stretched uniformly by λ = 1 + ε_z(Q) (material point ξ at x = c + λ(ξ − c)), the
  tip beyond it shifted by (λ − 1)(l − c);
* the gauge strain g(Q) r_o κ, κ = M/B the curvature per reference length (:mod:`whisker_opt.wallcell.cell`).

So ε/δ follows from the cell's EI(Q), ε_z(Q) and g(Q) alone, with solid end regions of E = 3μ.

:func:`inferred_k` then asks the question the thesis answered on its prototypes: which modulus factor
k = E₂(Q)/E in the thesis' own beam model (thinning, extension, Hooke's gauge; §8) gives the same change
of ε/δ with Q? Its prototypes gave k(Q) = −1.337 Q + 0.9958 from their gauge signals, so this is the
like-for-like comparison of a wall law with the prototype.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq

from geometry.design import WhiskerDesign
from whisker_opt.analysis.beam import BeamModel, castigliano_deflection, mean_surface_strain


def _bare_ei(mu: float, r_o: float, t: float) -> float:
    return 3 * mu * math.pi * (r_o**4 - (r_o - t) ** 4) / 4


def cell_sensitivity(design: WhiskerDesign, EI: float, ez: float, g: float, x_cell: float, mu: float,
                     a: float = 1.0) -> float:
    """ε/δ [1/mm] at contact ratio a (of the pressurised length) with the chamber of one wall-cell reading.

    Parameters
    ----------
    design : WhiskerDesign
    EI, ez, g : float
        The cell's EI [N mm²], ε_z and gauge transfer at one pressure.
    x_cell : float
        Axial station of the cell [mm].
    mu : float
        Small-strain shear modulus of the rubber [MPa] (E = 3μ in the solid regions).
    a : float
        Contact ratio in (0, 1].
    """
    c, l, t = design.c, design.l, design.t
    lam = 1.0 + ez
    b_cell = EI / _bare_ei(mu, float(design.r_outer(x_cell)), t)

    def inside(xi):
        return c <= xi <= l

    def position(xi):
        return xi if xi < c else (c + lam * (xi - c) if xi <= l else xi + (lam - 1) * (l - c))

    def stretch(xi):
        return lam if inside(xi) else 1.0

    def rigidity(xi):  # per current length: λ B for the chamber, E I elsewhere
        ro = float(design.r_outer(xi))
        if inside(xi):
            return lam * b_cell * _bare_ei(mu, ro, t)
        return 3 * mu * math.pi * ro**4 / 4

    def y(xi):  # ε = y M / rigidity = g r_o M / B in the chamber
        return g * lam * float(design.r_outer(xi)) if inside(xi) else float(design.r_outer(xi))

    length = design.L + (lam - 1) * (l - c)
    x_p = a * length
    xi_p = x_p if x_p <= c else (c + (x_p - c) / lam if x_p <= c + lam * (l - c) else x_p - (lam - 1) * (l - c))
    delta = castigliano_deflection(x_p, rigidity, 1.0, breakpoints=(c, l), position=position, stretch=stretch,
                                   xi_load=xi_p, epsrel=1e-10)
    eps = mean_surface_strain(x_p, rigidity, y, (design.x_ss, design.x_ss + design.e), 1.0, position=position,
                              stretch=stretch, epsrel=1e-10)
    return eps / delta


def inferred_k(design: WhiskerDesign, ratio: float, Q: float, a: float = 1.0,
               model: BeamModel | None = None) -> float:
    """The k = E₂/E of the thesis' beam model whose ε/δ(Q)/ε/δ(0) equals ``ratio`` (NaN if none in [0.1, 10]).

    The model is :class:`whisker_opt.analysis.beam.BeamModel` with a constant k at Q (its default thinning
    and extension), against k = 1 at Q = 0. A soft chamber extends and thins without bound in that model, so
    k is searched from 1 outwards on a grid (where the model has a wall left) and refined by Brent's method
    in the first bracket.
    """
    model = model or BeamModel()
    base = replace(model, softening=lambda q: 1.0).sensitivity(design, a, 0.0)

    def f(k):
        try:
            return replace(model, softening=lambda q, k=k: k).sensitivity(design, a, Q) / base - ratio
        except ValueError:  # no wall left at this k (the model's thinning)
            return float("nan")

    for side in (np.geomspace(1.0, 0.1, 41), np.geomspace(1.0, 10.0, 41)):
        vals = [f(k) for k in side]
        for k0, k1, v0, v1 in zip(side, side[1:], vals, vals[1:]):
            if np.isfinite(v0) and np.isfinite(v1) and v0 * v1 <= 0:
                return float(brentq(f, min(k0, k1), max(k0, k1), xtol=1e-12))
    return float("nan")


def reading_ratios(design: WhiskerDesign, entry: dict, x_cell: float, mu: float, a_values) -> np.ndarray:
    """ε/δ(Q)/ε/δ(0) of a table entry at every pressure (columns) and contact ratio (rows)."""
    out = np.empty((len(a_values), len(entry["EI"])))
    for i, a in enumerate(a_values):
        s = [cell_sensitivity(design, ei, ez, g, x_cell, mu, a) for ei, ez, g in
             zip(entry["EI"], entry["ez"], entry["g"])]
        out[i] = np.array(s) / s[0]
    return out
