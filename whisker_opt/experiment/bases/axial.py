"""``axial``: the base face held only axially, on a frictionless rigid floor.

Every base node is held in x; of the three rigid motions left (translation in y and z, rotation about x) the
least that stops them: the base node nearest the axis (r = 0 on the whisker's meshes) held in y and z, and the
base node nearest the point (0, R, 0) of the base's rim (R the largest radius of a base node) held in z. That
rim node lies in the plane z = 0 in which the contact pushes (−y), so by the scene's mirror symmetry about it its
z reaction is zero up to the mesh's asymmetry; the axis node carries the whole in-plane reaction (the holder's
peg). The face may expand or contract radially and its rim may slide: the softest radial support of the
mechanisms short of ``compliant`` with small k_t. No parameters.
"""

from __future__ import annotations

import numpy as np

NAME = "axial"
ORDER = 2
DESCRIPTION = ("every base node held axially; the node on the axis also in y and z and the rim node at (0, R, 0) "
               "in z, against rigid motion")
PARAMETERS: tuple[str, ...] = ()


def hold(wm, spec):
    """Three displacement sets: every base node in x, the node nearest the axis in y and z, the rim node in z."""
    from fem.problem import Dirichlet
    from whisker_opt.experiment.bases import BaseHold

    base = np.asarray(wm.node_sets["base"], dtype=np.int64)
    yz = wm.mesh.points[base, 1:]  # (n_base, 2)
    r = np.linalg.norm(yz, axis=1)  # (n_base,)
    centre = base[np.argmin(r)]
    rim = base[np.argmin(np.linalg.norm(yz - [r.max(), 0.0], axis=1))]
    return BaseHold((Dirichlet(base, (0,), "base"), Dirichlet([centre], (1, 2), "base axis"),
                     Dirichlet([rim], (2,), "base rim")), (), base)
