"""CAD model of the whisker (cadquery / OpenCascade): the solid and the fibre wires.

The solid is one revolve, no booleans: the meridian half-section in the (x, y >= 0)
plane is the simple polygon

    (0, 0) -> (0, D/2) -> (L', r_o(L')) -> (L', 0) -> (l, 0) -> (l, r_i(l))
           -> (c, r_i(c)) -> (c, 0) -> back to (0, 0),          L' = L - trim,

whose edges on the axis collapse when it is revolved 360 deg about x; this gives the
cap, the conical cavity with two flat ends and the solid body at once (faces: base
plane, outer cone, tip plane, cavity end planes at x = c and x = l, cavity cone).

Fibres are wires, never solids (no helical sweeps): each helix is an interpolating
B-spline through the helix points of :func:`geometry.fibres.sample_helix` (spacing
0.2 mm by default), which reproduces the closed-form conical-helix length to ~1e-9.

cadquery is imported lazily: importing it costs seconds and the meshing fast path
does not need it.
"""

from __future__ import annotations

import logging
from pathlib import Path

from geometry.design import WhiskerDesign
from geometry.fibres import fibre_phases, sample_helix

logger = logging.getLogger(__name__)


def meridian_polygon(design: WhiskerDesign) -> list[tuple[float, float]]:
    """The half-section polygon (x, r) revolved into the solid (see module docstring)."""
    d = design
    Lt = d.length
    return [
        (0.0, 0.0),
        (0.0, d.r_outer(0.0)),
        (Lt, d.r_outer(Lt)),
        (Lt, 0.0),
        (d.l, 0.0),
        (d.l, d.r_inner(d.l)),
        (d.c, d.r_inner(d.c)),
        (d.c, 0.0),
    ]


def build_solid(design: WhiskerDesign):
    """Build the whisker solid by revolving the meridian polygon about the x axis.

    Parameters
    ----------
    design : WhiskerDesign
        Validated first (raises :class:`geometry.design.InvalidDesignError`).

    Returns
    -------
    cadquery.Solid
    """
    import cadquery as cq

    design.validate()
    wp = cq.Workplane("XY").polyline(meridian_polygon(design)).close().revolve(360.0, (0, 0, 0), (1, 0, 0))
    solid = wp.val()
    if not solid.isValid():  # pragma: no cover - OCC failure
        raise RuntimeError(f"cadquery produced an invalid solid for {design.describe()}")
    logger.debug("built solid of %s, volume %.6g", design.describe(), solid.Volume())
    return solid


def build_cavity(design: WhiskerDesign):
    """The cavity alone as a solid (revolved trapezoid (c,0)-(c,r_i(c))-(l,r_i(l))-(l,0)).

    For checks and visualisation: its volume and area are the cavity's.
    """
    import cadquery as cq

    design.validate()
    d = design
    poly = [(d.c, 0.0), (d.c, d.r_inner(d.c)), (d.l, d.r_inner(d.l)), (d.l, 0.0)]
    return cq.Workplane("XY").polyline(poly).close().revolve(360.0, (0, 0, 0), (1, 0, 0)).val()


def build_fibre_wires(design: WhiskerDesign, spacing: float = 0.2) -> list:
    """The fibre helices as cadquery wires (B-splines through helix points ``spacing`` apart).

    Returns
    -------
    list[cadquery.Wire]
        One wire per fibre, phases ``2 pi k / n_fibres``.
    """
    import cadquery as cq

    design.validate()
    wires = []
    for phase in fibre_phases(design):
        pts = sample_helix(design, phase, spacing)
        edge = cq.Edge.makeSpline([cq.Vector(*map(float, p)) for p in pts])
        wires.append(cq.Wire.assembleEdges([edge]))
    return wires


def export_step(shape, path: str | Path, fibres: list | None = None) -> Path:
    """Write the solid (and optionally fibre wires) as STEP.

    Parameters
    ----------
    shape : cadquery.Shape
        Typically the result of :func:`build_solid`.
    path : str or Path
    fibres : list of cadquery.Wire, optional
        Added to the same file as a compound.
    """
    import cadquery as cq

    path = Path(path)
    obj = shape if not fibres else cq.Compound.makeCompound([shape, *fibres])
    cq.exporters.export(obj, str(path), exportType="STEP")
    logger.info("wrote STEP %s", path)
    return path


def export_stl(shape, path: str | Path, tolerance: float = 0.01, angular_tolerance: float = 0.1) -> Path:
    """Write the solid as a triangulated STL (chordal ``tolerance`` in mm)."""
    import cadquery as cq

    path = Path(path)
    cq.exporters.export(
        shape, str(path), exportType="STL", tolerance=tolerance, angularTolerance=angular_tolerance
    )
    logger.info("wrote STL %s", path)
    return path
