"""``worst``: the worst value met over the variants, an unread variant (NaN) left out.

The largest value, or the smallest for a measure where smaller is worse
(:attr:`whisker_opt.experiment.measures.Measure.worse` < 0); NaN when no variant was read.
"""

from __future__ import annotations

import math

import numpy as np

NAME = "worst"
ORDER = 1  # place in the registry


def reduce(spread, k: float, worse: float) -> float:
    """max of the finite ``spread.values`` for ``worse`` > 0, else their min; ``k`` is not read."""
    v = np.asarray(spread.values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan
    return float(v.max() if worse > 0 else v.min())
