"""``sliding``: the base face held axially, only its inner half also held radially.

Every base node is held in x; the nodes with r ≤ D/4 (the inner half of the base's radius) also in y and z, so
the outer half of the base face may slide radially on the holder (a frictionless holder floor with a central
peg or adhesive spot). No parameters (D is the design's base diameter).
"""

from __future__ import annotations

import numpy as np

NAME = "sliding"
ORDER = 1
DESCRIPTION = "every base node held axially, only the nodes within r ≤ D/4 also held in y and z"
PARAMETERS: tuple[str, ...] = ()


def hold(wm, spec):
    """Two displacement sets: every base node in x, then the nodes with r ≤ D/4 in y and z."""
    from fem.problem import Dirichlet
    from whisker_opt.experiment.bases import BaseHold

    base = np.asarray(wm.node_sets["base"], dtype=np.int64)
    r = np.linalg.norm(wm.mesh.points[base, 1:], axis=1)  # (n_base,)
    inner = base[r <= 0.25 * spec.design.D + 1e-9]
    return BaseHold((Dirichlet(base, (0,), "base"), Dirichlet(inner, (1, 2), "base inner")), (), base)
