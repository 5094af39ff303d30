"""Pareto dominance, non-dominated filtering and the hypervolume indicator (minimisation).

The filtering, the ranks and the hypervolume are moocore's (the multi-objective core library
DEAP itself depends on for its hypervolume); this module fixes their conventions for the
project and handles the empty set.

Dominance
    a dominates b (a ≺ b) when a_k <= b_k for every objective k and a_k < b_k for at least
    one (Deb 2001, Def. 2.5). A point set's non-dominated subset (its Pareto front) holds the
    points no other point of the set dominates; equal points do not dominate each other, so
    duplicates are either all kept or all dropped (moocore's ``keep_weakly=True``).

Non-dominated sorting
    Front 0 is the non-dominated subset, front r the non-dominated subset of what is left
    after fronts 0..r−1 are removed (Deb et al. 2002, NSGA-II, §III-A): moocore's
    ``pareto_rank``. NSGA-II itself uses DEAP's ``tools.sortNondominated`` on its individuals;
    :func:`front_ranks` serves the archive and the tests.

Hypervolume
    HV(P, r) = λ(∪_{p∈P, p ≺ r} [p_1, r_1] × … × [p_m, r_m]), the Lebesgue measure of the
    region the points dominate up to the reference point r (Zitzler & Thiele 1999). Points
    that do not strictly dominate r in every objective add nothing. Computed exactly by
    moocore's ``hypervolume``.
"""

from __future__ import annotations

from typing import Sequence

import moocore
import numpy as np


def dominates(a: Sequence[float], b: Sequence[float]) -> bool:
    """True when ``a`` Pareto-dominates ``b`` (minimisation): no worse anywhere, better somewhere."""
    a_ = np.asarray(a, dtype=float)
    b_ = np.asarray(b, dtype=float)
    return bool(np.all(a_ <= b_) and np.any(a_ < b_))


def _as_points(points: Sequence[Sequence[float]]) -> np.ndarray:
    """``points`` as an (n, m) float array ((0, 0) when empty)."""
    pts = np.asarray(points, dtype=float)
    return pts.reshape(len(pts), -1) if pts.size else np.empty((0, 0))


def non_dominated(points: Sequence[Sequence[float]]) -> list[int]:
    """Indices (ascending) of the points no other point dominates.

    Parameters
    ----------
    points : sequence of sequence of float
        n points of m objectives, all minimised, finite.

    Returns
    -------
    list of int
    """
    pts = _as_points(points)
    if pts.size == 0:
        return []
    return [int(i) for i in np.flatnonzero(moocore.is_nondominated(pts, keep_weakly=True))]


def front_ranks(points: Sequence[Sequence[float]]) -> list[int]:
    """Non-domination rank of each point: 0 for the Pareto front, 1 for the next front, ..."""
    pts = _as_points(points)
    if pts.size == 0:
        return []
    return [int(r) for r in moocore.pareto_rank(pts)]


def hypervolume(points: Sequence[Sequence[float]], ref: Sequence[float]) -> float:
    """Hypervolume dominated by ``points`` up to the reference point ``ref`` (minimisation).

    Parameters
    ----------
    points : sequence of sequence of float
        n points of m objectives (any n >= 0; dominated points and duplicates are allowed).
    ref : sequence of float
        Reference point r (m values); only points with p_k < r_k for every k count.

    Returns
    -------
    float
        HV >= 0 (see the module docstring for the formula).
    """
    r = np.asarray(ref, dtype=float)
    pts = _as_points(points)
    if pts.size == 0:
        return 0.0
    if pts.shape[1] != r.size:
        raise ValueError(f"hypervolume: points have {pts.shape[1]} objectives, the reference point {r.size}")
    pts = pts[np.all(pts < r, axis=1)]
    if len(pts) == 0:
        return 0.0
    return float(moocore.hypervolume(pts, ref=r))
