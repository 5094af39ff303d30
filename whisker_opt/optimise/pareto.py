"""Pareto dominance, non-dominated filtering and the hypervolume indicator (minimisation).

Dominance
    a dominates b (a ≺ b) when a_k <= b_k for every objective k and a_k < b_k for at least
    one (Deb 2001, Def. 2.5). A point set's non-dominated subset (its Pareto front) holds the
    points no other point of the set dominates; equal points do not dominate each other, so
    duplicates are either all kept or all dropped.

Non-dominated sorting
    Front 0 is the non-dominated subset, front r the non-dominated subset of what is left
    after fronts 0..r−1 are removed (Deb et al. 2002, NSGA-II, §III-A). NSGA-II itself uses
    DEAP's ``tools.sortNondominated``; :func:`front_ranks` is the plain O(M N²) version that
    the archive and the tests use.

Hypervolume
    HV(P, r) = λ(∪_{p∈P, p ≺ r} [p_1, r_1] × … × [p_m, r_m]), the Lebesgue measure of the
    region the points dominate up to the reference point r (Zitzler & Thiele 1999). Points
    that do not strictly dominate r in every objective add nothing. In two objectives the
    front sorted by f_1 gives HV = Σ_i (r_1 − a_i)(b_{i−1} − b_i) with b_0 = r_2 (a sweep);
    in more objectives the points are sliced along the last objective and the (m−1)-volume
    of each slab is computed recursively (hypervolume by slicing objectives, While et al.
    2006), exact and fast enough for fronts of a few hundred points in up to five objectives.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np


def dominates(a: Sequence[float], b: Sequence[float]) -> bool:
    """True when ``a`` Pareto-dominates ``b`` (minimisation): no worse anywhere, better somewhere."""
    a_ = np.asarray(a, dtype=float)
    b_ = np.asarray(b, dtype=float)
    return bool(np.all(a_ <= b_) and np.any(a_ < b_))


def _dominated_mask(points: np.ndarray) -> np.ndarray:
    """``mask[i]`` is True when some point of ``points`` (n, m) dominates point i."""
    n = len(points)
    mask = np.zeros(n, dtype=bool)
    for i in range(n):
        le = np.all(points <= points[i], axis=1)  # (n,)
        lt = np.any(points < points[i], axis=1)  # (n,)
        mask[i] = bool(np.any(le & lt))
    return mask


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
    pts = np.asarray(points, dtype=float)
    if pts.size == 0:
        return []
    pts = pts.reshape(len(pts), -1)
    return [int(i) for i in np.flatnonzero(~_dominated_mask(pts))]


def front_ranks(points: Sequence[Sequence[float]]) -> list[int]:
    """Non-domination rank of each point: 0 for the Pareto front, 1 for the next front, ..."""
    pts = np.asarray(points, dtype=float)
    n = len(pts)
    ranks = [-1] * n
    left = list(range(n))
    rank = 0
    while left:
        sub = pts[left].reshape(len(left), -1)
        dom = _dominated_mask(sub)
        for j, i in enumerate(left):
            if not dom[j]:
                ranks[i] = rank
        left = [i for j, i in enumerate(left) if dom[j]]
        rank += 1
    return ranks


def _hv2(points: np.ndarray, ref: np.ndarray) -> float:
    """Two-objective sweep: points sorted by f_1, each adds (r_1 − a)(b_prev − b)."""
    order = np.lexsort((points[:, 1], points[:, 0]))
    hv = 0.0
    b_prev = ref[1]
    for a, b in points[order]:
        if b < b_prev:
            hv += (ref[0] - a) * (b_prev - b)
            b_prev = b
    return float(hv)


def _hv(points: np.ndarray, ref: np.ndarray) -> float:
    """Hypervolume of points that all strictly dominate ``ref`` (slicing along the last objective)."""
    n, m = points.shape
    if n == 0:
        return 0.0
    if m == 1:
        return float(ref[0] - points[:, 0].min())
    if m == 2:
        return _hv2(points, ref)
    order = np.argsort(points[:, -1], kind="stable")
    pts = points[order]
    hv = 0.0
    for k in range(n):
        top = pts[k + 1, -1] if k + 1 < n else ref[-1]
        depth = top - pts[k, -1]
        if depth <= 0.0:
            continue
        # the slab between this point's last objective and the next one's: points 0..k dominate it
        base = pts[: k + 1, :-1]
        base = base[non_dominated(base)]
        hv += depth * _hv(base, ref[:-1])
    return float(hv)


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
    pts = np.asarray(points, dtype=float)
    if pts.size == 0:
        return 0.0
    pts = pts.reshape(len(pts), -1)
    if pts.shape[1] != r.size:
        raise ValueError(f"hypervolume: points have {pts.shape[1]} objectives, the reference point {r.size}")
    pts = pts[np.all(pts < r, axis=1)]
    if len(pts) == 0:
        return 0.0
    pts = np.unique(pts, axis=0)
    pts = pts[non_dominated(pts)]
    return _hv(pts, r)
