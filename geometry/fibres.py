"""Fibre helices as 1-D polylines, for embedding as truss elements.

Fibre k of n (k = 0..n-1) is the conical helix over the chamber region ``c <= x <= l``::

    theta_k(x) = 2 pi (x - c) / p + 2 pi k / n
    X_k(x) = (x, r_f(x) cos theta_k, r_f(x) sin theta_k),   r_f(x) = r_i(x) + frac * t

(right-handed about +x; with n = 2 the second helix is the first rotated by 180 deg).
The polyline samples it uniformly in arc length with segments no longer than a
requested ``ds``; arc length is tabulated with the trapezoidal rule on a grid 32 times
finer than the output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from geometry.design import WhiskerDesign


@dataclass(frozen=True)
class FibrePath:
    """One fibre polyline located in a tet mesh.

    Attributes
    ----------
    points_ref : ndarray, shape (n, 3)
        Reference positions of the polyline points.
    host_elements : ndarray, shape (n,), int64
        Element containing each point.
    local_coords : ndarray, shape (n, 3)
        Local coordinates xi of each point in its host (``X(xi) = points_ref``).
    segments : ndarray, shape (n - 1, 2), int64
        Consecutive point pairs (truss elements).
    phase : float
        Helix phase ``2 pi k / n`` [rad].
    """

    points_ref: np.ndarray
    host_elements: np.ndarray
    local_coords: np.ndarray
    segments: np.ndarray
    phase: float = 0.0

    @property
    def length(self) -> float:
        """Polyline length ``sum |X_{i+1} - X_i|``."""
        return float(np.linalg.norm(np.diff(self.points_ref, axis=0), axis=1).sum())


def helix_xyz(design: WhiskerDesign, x: np.ndarray, phase: float) -> np.ndarray:
    """Points of the fibre helix at axial positions ``x`` (see module docstring), shape (n, 3)."""
    x = np.asarray(x, dtype=float)
    th = 2.0 * math.pi * (x - design.c) / design.fibre_pitch + phase
    r = design.r_fibre(x)
    return np.stack([x, r * np.cos(th), r * np.sin(th)], axis=1)


def helix_hoop_and_speed(design: WhiskerDesign, x):
    """``(2π r_f(x)/p, s)`` with ``s = √(1 + r_f'² + (2π r_f/p)²)``: the hoop component of the
    unnormalised helix tangent dX/dx and the helix's arc length per unit x (r_f' = −tan α)."""
    hoop = (2.0 * math.pi / design.fibre_pitch) * design.r_fibre(x)
    return hoop, np.sqrt(1.0 + design.tan_alpha**2 + hoop**2)


def fibre_phases(design: WhiskerDesign) -> list[float]:
    """``2 pi k / n`` for k = 0..n-1."""
    n = int(design.n_fibres)
    return [2.0 * math.pi * k / n for k in range(n)]


def sample_helix(design: WhiskerDesign, phase: float, ds: float) -> np.ndarray:
    """Polyline of one helix with (nearly) equal segments of length <= ``ds``.

    Parameters
    ----------
    design : WhiskerDesign
    phase : float
        Helix phase [rad].
    ds : float
        Maximum segment length [mm].

    Returns
    -------
    ndarray, shape (n, 3)
        Ordered from x = c to x = l (both ends included).
    """
    if ds <= 0:
        raise ValueError(f"sample_helix: ds={ds} must be > 0")
    x0, x1 = design.c, design.l
    # arc length per unit x (helix_hoop_and_speed), tabulated
    n_est = max(8, int(math.ceil(2.0 * math.pi * design.r_fibre(x0) * (x1 - x0) / design.fibre_pitch / ds)))
    xf = np.linspace(x0, x1, 32 * n_est + 1)
    _, speed = helix_hoop_and_speed(design, xf)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(xf))])
    n_seg = max(1, int(math.ceil(s[-1] / ds)))
    xs = np.interp(np.linspace(0.0, s[-1], n_seg + 1), s, xf)
    xs[0], xs[-1] = x0, x1
    return helix_xyz(design, xs, phase)
