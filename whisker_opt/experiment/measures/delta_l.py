"""``delta_l``: Δl [mm], the axial extension of the intact whisker's tip after pressurisation to Q_i (the mean
x-displacement of the tip face's nodes), ``extra["delta_l"]``."""

from __future__ import annotations

NAME = "delta_l"
ORDER = 2  # place in the registry
UNIT = "mm"
DESCRIPTION = "axial tip extension of the intact whisker after pressurisation to Q_i"


def read(outcome) -> float:
    """``extra["delta_l"]``."""
    return outcome.extra["delta_l"]
