"""``tied``: the cap shares its nodes with the body, a perfect bond (the default; the thesis' FE tied the cap to
the body as a separate part, and the cap is moulded onto the chamber end)."""

from __future__ import annotations

from typing import Mapping

NAME = "tied"
ORDER = 0
DESCRIPTION = "the cap tied to the body (shared nodes, a perfect bond)"
PARAMETERS: tuple[str, ...] = ()


def factor(values: Mapping[str, float], c: float, mu: float) -> float:
    """No joint compliance: the cap's law as it is."""
    return 1.0
