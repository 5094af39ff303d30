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
from types import MappingProxyType
from typing import Mapping

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
    radius : float
        Reference outer radius at the gauge centre [mm].
    sites : mapping
        Reading name -> :class:`Site`: the sampling points that a registered reading asks for with a
        ``points(design)`` function of its own module, located with the gauge.
    """

    host_elements: np.ndarray
    local_coords: np.ndarray
    weights: np.ndarray
    tangent: np.ndarray
    centroid_element: int
    radius: float
    sites: Mapping[str, "Site"]


@dataclass(frozen=True)
class Site:
    """A reading's own sampling points, located in the mesh.

    Attributes
    ----------
    host_elements : ndarray, shape (n,)
    local_coords : ndarray, shape (n, 3)
    data : object
        What the reading's ``points`` returned beside the points (weights, a layout), passed through.
    """

    host_elements: np.ndarray
    local_coords: np.ndarray
    data: object = None


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
    own = {name: r.points(design) for name, r in GAUGE_READINGS.items() if r.points is not None}  # name -> (pts, data)
    # Points on the exact cone lie up to the P2 surface-interpolation error outside the
    # mesh; a host whose local coordinates are slightly outside (barycentric >= -0.05)
    # with an exact inverse map is the right host (the field extends smoothly).
    loc = PointLocator(wm.mesh.points, wm.mesh.cells).locate(np.vstack([pts, centre, *(p for p, _ in own.values())]),
                                                              tol=0.05)
    if not np.all(loc.inside) or np.any(loc.residual > 1e-8 * (1.0 + design.D)):
        bad = int(np.sum(~np.asarray(loc.inside)) + np.sum(np.asarray(loc.residual) > 1e-8 * (1.0 + design.D)))
        raise ValueError(f"gauge points not located in the mesh: {bad} of {len(loc.inside)} sampling points "
                         f"(the gauge line, its centre and the readings' own: {', '.join(own) or 'none'})")
    elems, xi = loc.host_elements, loc.local_coords
    sites, k = {}, n + 1
    for name, (p, data) in own.items():
        sites[name] = Site(elems[k:k + len(p)], xi[k:k + len(p)], data)
        k += len(p)
    return GaugeGeometry(elems[:n], xi[:n], w, tangent, int(elems[n]), float(centre[0, 1]), MappingProxyType(sites))


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
