"""Numbers written short for messages, reports and plot labels (a leaf: imports nothing of ``whisker_opt``)."""

from __future__ import annotations

import math


def short_float(x: float | None, digits: int = 1) -> str:
    """``x`` in short scientific notation: ``2e-3``, ``1.16e-3`` (``digits`` after the point at most)."""
    if x is None or not math.isfinite(float(x)):
        return "nan"
    if x == 0:
        return "0"
    mant, exp = f"{float(x):.{digits}e}".split("e")
    mant = mant.rstrip("0").rstrip(".") if "." in mant else mant
    return f"{mant}e{int(exp)}"
