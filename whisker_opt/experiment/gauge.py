"""The strain gauge: where it sits on the whisker and in its mesh, and how it is read.

The readings are registered by name in :mod:`whisker_opt.experiment.gauge_variants`, one module each in
:mod:`whisker_opt.experiment.readings`: ``line`` (default), the mean logarithmic strain along the gauge line,
and ``centroid`` (the thesis' variant), the axial Eulerian log strain at the centroid of the element under the
gauge centre. :class:`GaugeReader` zeroes every one at contact onset and returns them relative to it, times
the calibration factor ξ (the gauge is zeroed when contact begins).

The gauge's host elements depend on the mesh only: they are located once per mesh
(:func:`locate_gauge`) and travel with it as a :class:`GaugedMesh`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.design import WhiskerDesign
from geometry.locate import PointLocator
from geometry.mesh import WhiskerMesh
from whisker_opt.experiment.gauge_variants import GAUGE_READINGS


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
    section_elements : ndarray, shape (2, m)
        Host elements of the sampling points of the wall's cross-sections at the gauge's two ends
        (:func:`section_points`; the ``section`` reading).
    section_coords : ndarray, shape (2, m, 3)
    section_weights : ndarray, shape (m,)
        Area weights of those points, normalised to sum 1.
    radius : float
        Reference outer radius at the gauge centre [mm].
    """

    host_elements: np.ndarray
    local_coords: np.ndarray
    weights: np.ndarray
    tangent: np.ndarray
    centroid_element: int
    section_elements: np.ndarray
    section_coords: np.ndarray
    section_weights: np.ndarray
    radius: float


@dataclass(frozen=True)
class ReadingContext:
    """What a reading may know of its scene beyond the mesh and the gauge.

    Attributes
    ----------
    wall_transfer : float
        G(Q) = g(Q) (1 + ε_z(Q)) of the stored wall cell at the scene's chamber pressure and wall
        (:meth:`whisker_opt.wall.law.WallLaw.gauge_transfer`; NaN when the wall lies outside the table).
    """

    wall_transfer: float = 1.0


def section_points(design: WhiskerDesign, x: float, n_r: int = 4, n_theta: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Sampling points of the wall's cross-section at ``x`` (r_i … r_o, Gauss–Legendre in r, equal angles
    offset by half a step) and their area weights r w_r (normalised to sum 1), shapes (n_r n_theta, 3), (n_r n_theta,)."""
    s, w = np.polynomial.legendre.leggauss(n_r)
    ri, ro = design.r_inner(x), design.r_outer(x)
    r = ri + 0.5 * (ro - ri) * (s + 1.0)  # (n_r,)
    th = 2.0 * np.pi * (np.arange(n_theta) + 0.5) / n_theta  # (n_theta,)
    R, T = np.meshgrid(r, th, indexing="ij")  # (n_r, n_theta)
    pts = np.stack([np.full(R.size, float(x)), (R * np.cos(T)).ravel(), (R * np.sin(T)).ravel()], axis=1)
    wt = np.repeat(w * r, n_theta)
    return pts, wt / wt.sum()


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
    sec = [section_points(design, x) for x in (design.x_ss, design.x_ss + design.e)]
    m = len(sec[0][1])
    # Points on the exact cone lie up to the P2 surface-interpolation error outside the
    # mesh; a host whose local coordinates are slightly outside (barycentric >= -0.05)
    # with an exact inverse map is the right host (the field extends smoothly).
    loc = PointLocator(wm.mesh.points, wm.mesh.cells).locate(np.vstack([pts, centre, sec[0][0], sec[1][0]]), tol=0.05)
    if not np.all(loc.inside) or np.any(loc.residual > 1e-8 * (1.0 + design.D)):
        bad = int(np.sum(~np.asarray(loc.inside)) + np.sum(np.asarray(loc.residual) > 1e-8 * (1.0 + design.D)))
        raise ValueError(f"gauge points not located in the mesh: {bad} of {len(loc.inside)} sampling points "
                         f"(gauge line, centre, the wall sections at its ends)")
    elems, xi = loc.host_elements, loc.local_coords
    return GaugeGeometry(elems[:n], xi[:n], w, tangent, int(elems[n]), elems[n + 1:].reshape(2, m),
                         xi[n + 1:].reshape(2, m, 3), sec[0][1], float(centre[0, 1]))


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


@dataclass
class GaugeReader:
    """Stateful reader: remembers the onset state and returns calibrated readings.

    Call :meth:`zero` at contact onset, then :meth:`read` at each deflection.
    """

    mesh: object
    gauge: GaugeGeometry
    calibration: float
    context: ReadingContext = ReadingContext()

    def zero(self, u: np.ndarray) -> None:
        """Keep what every registered reading needs of the onset state ``u``."""
        self._onset = {n: r.state(self.mesh, u, self.gauge) for n, r in GAUGE_READINGS.items()}

    def read(self, u: np.ndarray) -> dict[str, float]:
        """Every registered reading (:data:`GAUGE_READINGS`, in its order) of ``u`` relative to onset, times the
        calibration factor."""
        return {n: self.calibration * r.relative(r.state(self.mesh, u, self.gauge), self._onset[n], self.gauge,
                                                 self.context)
                for n, r in GAUGE_READINGS.items()}
