"""``von_mises_max``: the largest nodal von Mises stress [MPa] of the two deflected states (intact at Q_i and
trimmed, vented, both at δ_max; :func:`whisker_opt.experiment.scene.peak_von_mises`), the max of
``extra["von_mises_max"]``."""

from __future__ import annotations

NAME = "von_mises_max"
ORDER = 3  # place in the registry
UNIT = "MPa"
DESCRIPTION = "largest nodal von Mises stress of the intact and the trimmed scene at the largest deflection"


def read(outcome) -> float:
    """max of ``extra["von_mises_max"]`` over the scenes."""
    return max(outcome.extra["von_mises_max"].values())
