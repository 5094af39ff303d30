"""``f1``: the compensation error mean_k |ε_i(δ_k) − ε_c(δ_k)| (:mod:`whisker_opt.experiment.objective`),
the outcome's own ``f1``."""

from __future__ import annotations

NAME = "f1"
ORDER = 0  # place in the registry (f1 first)
UNIT = "-"
DESCRIPTION = "compensation error mean |eps_i - eps_c| over the deflection samples"
CALIBRATED = True


def read(outcome) -> float:
    """``outcome.f1``."""
    return outcome.f1
