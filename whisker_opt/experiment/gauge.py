"""The strain gauge: where it sits on the whisker and in its mesh, and how it is read.

Two readings are offered.

``line`` (default)
    The gauge is a material line of length ``e`` on the +y generator of the outer cone,
    from x = x_ss to x = x_ss + e. Its unit tangent in the reference configuration is
    ``T = (1, -tan α, 0) / sqrt(1 + tan² α)``. At ``n`` Gauss-Legendre points along it the
    local stretch is ``λ = |F T|``; the reading is the length-weighted mean of the
    logarithmic strain relative to contact onset,
    ``ε = ξ · Σ_k w_k ln(λ_k(δ) / λ_k(0))``, with ``Σ w_k = 1`` and ξ the calibration
    factor. Relative to onset, because the gauge is zeroed when contact begins.

``centroid`` (the thesis' variant)
    The axial component of the Eulerian logarithmic strain ``ln V = ½ ln(F Fᵀ)`` at the
    centroid of the element under the gauge centre, relative to onset, times ξ. That is
    what Abaqus reports as LE11 for the element under the gauge.

The gauge's host elements depend on the mesh only: they are located once per mesh
(:func:`locate_gauge`) and travel with it as a :class:`GaugedMesh`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.query import deformation_gradient_at
from geometry.design import WhiskerDesign
from geometry.locate import PointLocator
from geometry.mesh import WhiskerMesh

@dataclass(frozen=True)
class GaugeGeometry:
    """Sampling points of the gauge in the reference configuration.

    Attributes
    ----------
    host_elements : ndarray, shape (n,)
        Host elements of the Gauss points along the gauge line.
    local_coords : ndarray, shape (n, 3)
    weights : ndarray, shape (n,)
        Gauss weights normalised to sum 1 (the mean over the gauge length).
    tangent : ndarray, shape (3,)
        Unit reference tangent of the line.
    centroid_element : int
        Element under the gauge centre (the thesis' readout).
    """

    host_elements: np.ndarray
    local_coords: np.ndarray
    weights: np.ndarray
    tangent: np.ndarray
    centroid_element: int


def gauge_points(x_ss: float, e: float, r_outer, alpha: float, n: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference Gauss points on the +y generator, their weights (sum 1) and the tangent.

    Parameters
    ----------
    x_ss, e : float
        Gauge start and length [mm].
    r_outer : callable
        Outer radius r_o(x) [mm].
    alpha : float
        Cone half-angle [deg].
    n : int
        Number of Gauss-Legendre points.
    """
    s, w = np.polynomial.legendre.leggauss(n)
    x = x_ss + 0.5 * e * (s + 1.0)
    pts = np.stack([x, np.array([r_outer(xi) for xi in x]), np.zeros(n)], axis=1)
    ta = np.tan(np.radians(alpha))
    tangent = np.array([1.0, -ta, 0.0]) / np.hypot(1.0, ta)
    return pts, w / w.sum(), tangent


def locate_gauge(wm: WhiskerMesh, design: WhiskerDesign, n: int = 16) -> GaugeGeometry:
    """Host elements and local coordinates of the gauge's Gauss points and its centre.

    ``n`` Gauss–Legendre points along the gauge: the axial strain is piecewise
    polynomial and discontinuous across the elements the gauge crosses, so few points
    integrate it poorly; 16 points read as 64 do to a small fraction of the mesh's own error
    (``benchmarks/results/gauge_readings.md``, "Gauss points along the gauge").
    """
    pts, w, tangent = gauge_points(design.x_ss, design.e, design.r_outer, design.alpha, n)
    centre = np.array([[design.x_ss + 0.5 * design.e, design.r_outer(design.x_ss + 0.5 * design.e), 0.0]])
    # Points on the exact cone lie up to the P2 surface-interpolation error outside the
    # mesh; a host whose local coordinates are slightly outside (barycentric >= -0.05)
    # with an exact inverse map is the right host (the field extends smoothly).
    loc = PointLocator(wm.mesh.points, wm.mesh.cells).locate(np.vstack([pts, centre]), tol=0.05)
    if not np.all(loc.inside) or np.any(loc.residual > 1e-8 * (1.0 + design.D)):
        raise ValueError(f"gauge points not located in the mesh (inside {loc.inside}, residuals {loc.residual})")
    elems, xi = loc.host_elements, loc.local_coords
    return GaugeGeometry(elems[:n], xi[:n], w, tangent, int(elems[n]))


@dataclass(frozen=True, eq=False)
class GaugedMesh:
    """A whisker mesh with its gauge located in it: the pair a scene runs on.

    Attributes
    ----------
    wm : WhiskerMesh
    gauge : GaugeGeometry
        :func:`locate_gauge` of ``wm`` for the design it was built from.
    """

    wm: WhiskerMesh
    gauge: GaugeGeometry

    @classmethod
    def locate(cls, wm: WhiskerMesh, design: WhiskerDesign) -> GaugedMesh:
        """Pair ``wm`` with the gauge of ``design`` located in it."""
        return cls(wm, locate_gauge(wm, design))


def line_stretch(mesh, u: np.ndarray, gauge: GaugeGeometry) -> np.ndarray:
    """Local stretches ``λ_k = |F_k T|`` at the gauge points, shape (n,)."""
    F = deformation_gradient_at(mesh, u, gauge.host_elements, gauge.local_coords)  # (n, 3, 3)
    return np.linalg.norm(F @ gauge.tangent, axis=1)  # (n,)


def centroid_log_strain_xx(mesh, u: np.ndarray, gauge: GaugeGeometry) -> float:
    """Axial Eulerian log strain ``(½ ln F Fᵀ)_xx`` at the centroid of the gauge's element."""
    F = deformation_gradient_at(
        mesh, u, np.array([gauge.centroid_element]), np.full((1, 3), 0.25)
    )[0]  # (3, 3)
    b = F @ F.T
    lam2, vec = np.linalg.eigh(b)
    ln_v = 0.5 * (vec * np.log(lam2)) @ vec.T
    return float(ln_v[0, 0])


@dataclass
class GaugeReader:
    """Stateful reader: remembers the onset state and returns calibrated readings.

    Call :meth:`zero` at contact onset, then :meth:`read` at each deflection.
    """

    mesh: object
    gauge: GaugeGeometry
    calibration: float

    def zero(self, u: np.ndarray) -> None:
        self._lam0 = line_stretch(self.mesh, u, self.gauge)
        self._c0 = centroid_log_strain_xx(self.mesh, u, self.gauge)

    def read(self, u: np.ndarray) -> tuple[float, float]:
        """Return ``(line reading, centroid reading)`` (the order of :data:`GAUGE_VARIANTS`), both times the
        calibration factor."""
        lam = line_stretch(self.mesh, u, self.gauge)
        line = float(self.gauge.weights @ np.log(lam / self._lam0))
        cen = centroid_log_strain_xx(self.mesh, u, self.gauge) - self._c0
        return self.calibration * line, self.calibration * cen
