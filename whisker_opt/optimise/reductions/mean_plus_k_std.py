"""``mean_plus_k_std``: mean + k·std of the variant set's estimates
(:func:`whisker_opt.optimise.robust.robust_objective`, docs/physics.md §10)."""

from __future__ import annotations

NAME = "mean_plus_k_std"
ORDER = 2  # place in the registry


def reduce(spread, k: float, worse: float) -> float:
    """``spread.mean + k · spread.std``; ``worse`` is not read."""
    from whisker_opt.optimise.robust import robust_objective

    return float(robust_objective(spread.mean, spread.std, k))
