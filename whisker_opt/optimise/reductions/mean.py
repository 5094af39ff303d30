"""``mean``: the variant set's mean of the measure (the sample's mean, the expansion's f(x0), the mean over laws)."""

from __future__ import annotations

NAME = "mean"
ORDER = 0  # place in the registry


def reduce(spread, k: float, worse: float) -> float:
    """The variant set's estimate of the mean, ``spread.mean``; ``k`` and ``worse`` are not read."""
    return float(spread.mean)
