"""``sensitivity``: S = ε_c(δ_max) / δ_max [1/mm].

The gauge reading of the trimmed, vented scene (the run's ``scene.gauge_variant``, relative to contact onset,
times ξ) at the largest deflection δ_max, per millimetre of that deflection of the contact: the secant slope of
the compensated response through the onset, ``extra["eps_c_max"] / extra["deflection"]``. Smaller is worse.
"""

from __future__ import annotations

NAME = "sensitivity"
ORDER = 1  # place in the registry
UNIT = "1/mm"
DESCRIPTION = ("gauge reading of the trimmed, vented scene at the largest deflection per mm of that deflection, "
               "eps_c(delta_max) / delta_max")
CALIBRATED = True
WORSE = -1.0


def read(outcome) -> float:
    """``extra["eps_c_max"] / extra["deflection"]``."""
    return outcome.extra["eps_c_max"] / outcome.extra["deflection"]
