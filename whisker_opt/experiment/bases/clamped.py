"""``clamped`` (the default): every node of the base face x = 0 fixed in x, y and z.

The limit of a rigid holder bonded to the whole base face, or of a press fit that neither slips nor lets the
face tilt: the stiffest of the mechanisms (``compliant`` tends to it as its springs stiffen, ``grip`` as its
depth tends to 0 with the base face held too). No parameters.
"""

from __future__ import annotations

import numpy as np

NAME = "clamped"
ORDER = 0  # place in the registry (the default first)
DESCRIPTION = "every base node fixed in x, y and z"
PARAMETERS: tuple[str, ...] = ()


def hold(wm, spec):
    """One displacement set: the base face's nodes in x, y and z."""
    from fem.problem import Dirichlet
    from whisker_opt.experiment.bases import BaseHold

    base = np.asarray(wm.node_sets["base"], dtype=np.int64)
    return BaseHold((Dirichlet(base, (0, 1, 2), "base"),), (), base)
