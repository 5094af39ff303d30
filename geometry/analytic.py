"""Closed forms of the whisker's volumes, areas and fibre lengths.

Truncated cone (frustum) of height h and end radii R1, R2 (Bronshtein, *Handbook of
Mathematics*, sec. 3.3.4)::

    V = pi h (R1^2 + R1 R2 + R2^2) / 3
    A_lateral = pi (R1 + R2) s,    s = sqrt(h^2 + (R1 - R2)^2)

Conical helix ``x -> (x, r(x) cos(theta), r(x) sin(theta))`` with ``theta = 2 pi x / p``
and ``r(x) = r0 - x tan(alpha)``. Its arc length element is
``sqrt(1 + r'^2 + (2 pi r / p)^2) dx``; with ``k = 2 pi / p`` and ``a^2 = 1 + tan^2 alpha``::

    int sqrt(a^2 + k^2 r^2) dr = (r/2) sqrt(a^2 + k^2 r^2) + a^2/(2k) asinh(k r / a)

so that for alpha > 0 the length over x in [x0, x1] is that antiderivative between
r(x1) and r(x0), divided by tan(alpha); for alpha = 0 it is ``(x1 - x0) sqrt(1 + k^2 r0^2)``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import quad

from geometry.design import WhiskerDesign


def frustum_volume(h: float, r1: float, r2: float) -> float:
    """``pi h (r1^2 + r1 r2 + r2^2) / 3``."""
    return math.pi * h * (r1 * r1 + r1 * r2 + r2 * r2) / 3.0


def frustum_lateral_area(h: float, r1: float, r2: float) -> float:
    """``pi (r1 + r2) sqrt(h^2 + (r1 - r2)^2)``."""
    return math.pi * (r1 + r2) * math.hypot(h, r1 - r2)


def cavity_volume(d: WhiskerDesign) -> float:
    """Volume of the cavity: frustum over ``[c, l]`` with radii ``r_i(c), r_i(l)``."""
    return frustum_volume(d.l - d.c, d.r_inner(d.c), d.r_inner(d.l))


def outer_volume(d: WhiskerDesign) -> float:
    """Volume enclosed by the outer surface: frustum over ``[0, L - trim]``."""
    return frustum_volume(d.length, d.r_outer(0.0), d.r_outer(d.length))


def solid_volume(d: WhiskerDesign) -> float:
    """Rubber volume = outer frustum - cavity frustum."""
    return outer_volume(d) - cavity_volume(d)


def cavity_area(d: WhiskerDesign) -> float:
    """Whole cavity surface: lateral cone plus the two flat end discs.

    ``A = pi (R_c + R_l) s + pi R_c^2 + pi R_l^2``, ``R_c = r_i(c)``, ``R_l = r_i(l)``.
    """
    rc, rl = d.r_inner(d.c), d.r_inner(d.l)
    return frustum_lateral_area(d.l - d.c, rc, rl) + math.pi * (rc * rc + rl * rl)


def outer_lateral_area(d: WhiskerDesign) -> float:
    """Lateral area of the outer cone over ``[0, L - trim]``."""
    return frustum_lateral_area(d.length, d.r_outer(0.0), d.r_outer(d.length))


def base_area(d: WhiskerDesign) -> float:
    """Base disc ``pi (D/2)^2``."""
    return math.pi * (d.D / 2.0) ** 2


def tip_area(d: WhiskerDesign) -> float:
    """Tip disc ``pi r_o(L - trim)^2``."""
    return math.pi * d.r_outer(d.length) ** 2


def helix_length(r0: float, tan_alpha: float, pitch: float, x0: float, x1: float) -> float:
    """Closed-form length of the conical helix ``r(x) = r0 - x tan(alpha)`` on ``[x0, x1]``.

    See the module docstring for the antiderivative.
    """
    k = 2.0 * math.pi / pitch
    if abs(tan_alpha) < 1e-14:
        return (x1 - x0) * math.sqrt(1.0 + (k * r0) ** 2)
    a2 = 1.0 + tan_alpha * tan_alpha
    a = math.sqrt(a2)

    def F(r: float) -> float:
        return 0.5 * r * math.sqrt(a2 + (k * r) ** 2) + a2 / (2.0 * k) * math.asinh(k * r / a)

    ra, rb = r0 - x0 * tan_alpha, r0 - x1 * tan_alpha
    return (F(ra) - F(rb)) / tan_alpha


def helix_length_quad(r0: float, tan_alpha: float, pitch: float, x0: float, x1: float) -> float:
    """Same length by adaptive quadrature of ``sqrt(1 + r'^2 + (2 pi r / p)^2)`` (independent check)."""
    k = 2.0 * math.pi / pitch

    def f(x: float) -> float:
        r = r0 - x * tan_alpha
        return math.sqrt(1.0 + tan_alpha**2 + (k * r) ** 2)

    val, _ = quad(f, x0, x1, epsabs=0.0, epsrel=1e-13, limit=200)
    return val


def fibre_length(d: WhiskerDesign) -> float:
    """Length of one fibre helix over the chamber region ``[c, l]`` (all fibres are equal)."""
    r0 = d.r_fibre(0.0)
    return helix_length(r0, d.tan_alpha, d.fibre_pitch, d.c, d.l)


def polyline_length(points: np.ndarray) -> float:
    """Sum of segment lengths of an ordered point list, shape (n, 3)."""
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
