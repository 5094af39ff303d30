"""The base mechanisms, one module each, registered by name in :mod:`whisker_opt.experiment.base_supports`;
:class:`BaseHold` is what each returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class BaseHold:
    """What holds the base on one mesh.

    Attributes
    ----------
    dirichlet : tuple of fem.problem.Dirichlet
        Displacement components prescribed to zero, in the order the load states list their values.
    supports : tuple of fem.problem.ElasticSupport
        Elastic supports (springs on faces).
    nodes : ndarray of int
        The held nodes: the base reaction is the sum of the residual over them (their prescribed components
        carry the reactions, the free ones are zero at equilibrium) plus the supports' forces.
    """

    dirichlet: tuple
    supports: tuple = ()
    nodes: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
