"""``grip``: the holder grips the outer surface over a depth d from the base; the base face itself is free.

A socket of depth d = ``scene.base_grip_depth`` [mm] holds the outer surface at 0 ≤ x ≤ d rigidly (a press
fit that does not slip: every outer-surface node there fixed in x, y and z); the base face x = 0 is not held,
so the rubber inside the socket may bulge axially. A stiff holder makes it a clamp at x = d of the part beyond
(the cantilever of length L − d), softened by the gripped length's shear. The nodes are those of the outer
surface at x ≤ d (:func:`geometry.tagging.band_nodes`): on a mesh the grip ends at the last node station at or
before d, so d is resolved to the axial element size there.

Range of d (an estimate: the prototype's holder is undocumented): 1 to 6 mm for the default design, from a
lip of about one element (a thin printed collar) to the gauge's start x_ss = 6 mm (a deeper socket would cover
the gauge, which the prototype's photographs show exposed); default 2 mm, the cap's thickness c (the holder
grips the solid cap, not the chamber). The run file allows 0 ≤ d ≤ 100 mm and d below the whisker's length
(d = 0 holds only the rim of the base face); a grip beyond x_ss is logged as a warning.
"""

from __future__ import annotations

import logging

import numpy as np

NAME = "grip"
ORDER = 3
DESCRIPTION = "the outer surface at 0 ≤ x ≤ base_grip_depth fixed (a socket that grips), the base face free"
PARAMETERS: tuple[str, ...] = ("base_grip_depth",)
#: Default grip depth [mm] (the default design's cap thickness) and the estimated range of module docstring.
DEPTH_DEFAULT = 2.0
DEPTH_ESTIMATE: tuple[float, float] = (1.0, 6.0)

logger = logging.getLogger(__name__)


def hold(wm, spec):
    """One displacement set: the outer-surface nodes at x ≤ ``spec.base_grip_depth`` in x, y and z."""
    from fem.problem import Dirichlet
    from geometry.tagging import band_nodes
    from whisker_opt.experiment.bases import BaseHold

    d = spec.base_grip_depth
    if d > spec.design.x_ss:
        logger.warning("scene.base_grip_depth=%g mm reaches past the gauge's start x_ss=%g mm: the holder covers "
                       "the gauge", d, spec.design.x_ss)
    nodes = band_nodes(wm.mesh.points, wm.node_sets["outer"], d)
    return BaseHold((Dirichlet(nodes, (0, 1, 2), "base grip"),), (), nodes)
