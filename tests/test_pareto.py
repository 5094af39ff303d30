"""Dominance, non-dominated filtering, front ranks and the hypervolume, against brute force and closed forms."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from whisker_opt.optimise.pareto import dominates, front_ranks, hypervolume, non_dominated


def _brute_non_dominated(pts: np.ndarray) -> list[int]:
    out = []
    for i, p in enumerate(pts):
        if not any(np.all(q <= p) and np.any(q < p) for j, q in enumerate(pts) if j != i):
            out.append(i)
    return out


def _inclusion_exclusion_hv(pts: np.ndarray, ref: np.ndarray) -> float:
    """HV = Σ_{S ≠ ∅} (−1)^{|S|+1} Π_k (r_k − max_{p∈S} p_k)⁺: the measure of a union of boxes."""
    total = 0.0
    for size in range(1, len(pts) + 1):
        for sub in itertools.combinations(range(len(pts)), size):
            corner = pts[list(sub)].max(axis=0)
            total += (-1) ** (size + 1) * float(np.prod(np.clip(ref - corner, 0.0, None)))
    return total


def test_dominates_is_weak_everywhere_and_strict_somewhere():
    assert dominates([1, 2], [1, 3])
    assert dominates([0, 0, 0], [1, 1, 1])
    assert not dominates([1, 2], [1, 2])  # equal points do not dominate each other
    assert not dominates([1, 3], [2, 2]) and not dominates([2, 2], [1, 3])
    assert not dominates([2, 2], [1, 2])


@pytest.mark.parametrize("m", [2, 3, 4])
def test_non_dominated_equals_brute_force(m):
    rng = np.random.default_rng(m)
    for trial in range(20):
        pts = rng.integers(0, 6, size=(int(rng.integers(1, 30)), m)).astype(float)  # ties and duplicates
        assert non_dominated(pts) == _brute_non_dominated(pts), trial


def test_non_dominated_of_a_known_set():
    pts = [[1, 5], [2, 2], [3, 3], [5, 1], [2, 2], [4, 1]]
    assert non_dominated(pts) == [0, 1, 4, 5]  # [3,3] and [5,1] are dominated; the duplicate [2,2] stays
    assert non_dominated([]) == []


def test_front_ranks_peel_fronts():
    rng = np.random.default_rng(7)
    pts = rng.random((40, 3))
    ranks = front_ranks(pts)
    assert sorted(i for i, r in enumerate(ranks) if r == 0) == non_dominated(pts)
    for i, r in enumerate(ranks):
        same = [j for j, s in enumerate(ranks) if s == r]
        assert not any(dominates(pts[j], pts[i]) for j in same)
        if r > 0:  # dominated by a point of the front just above
            assert any(dominates(pts[j], pts[i]) for j, s in enumerate(ranks) if s == r - 1)


def test_hypervolume_of_a_staircase_in_two_objectives():
    # boxes [1,4]x[3,4], [2,4]x[2,4], [3,4]x[1,4]: union = 1·1 + 1·2 + 1·3 = 6
    assert hypervolume([[1, 3], [2, 2], [3, 1]], [4, 4]) == pytest.approx(6.0, rel=1e-15)
    assert hypervolume([[1, 3], [2, 2], [3, 1], [3, 3], [2, 2]], [4, 4]) == pytest.approx(6.0, rel=1e-15)
    assert hypervolume([[0.25, 0.5]], [1, 1]) == pytest.approx(0.75 * 0.5)
    assert hypervolume([], [1, 1]) == 0.0
    # points on or beyond the reference point add nothing
    assert hypervolume([[1, 4], [4, 1], [5, 0]], [4, 4]) == 0.0


@pytest.mark.parametrize("n", [1, 2, 5, 40])
def test_hypervolume_of_a_sampled_linear_front(n):
    # x_i = i/n, y_i = 1 − i/n, ref (1, 1): HV = Σ_{i=1..n} (1 − i/n)(1/n) = (n − 1)/(2n)
    pts = [[i / n, 1 - i / n] for i in range(n + 1)]
    assert hypervolume(pts, [1, 1]) == pytest.approx((n - 1) / (2 * n), rel=1e-12, abs=1e-15)


def test_hypervolume_of_a_box_corner_in_three_objectives():
    # a single point: a box; two points whose boxes nest: the larger box
    assert hypervolume([[0.5, 0.25, 0.0]], [1, 1, 1]) == pytest.approx(0.5 * 0.75 * 1.0)
    assert hypervolume([[0.5, 0.5, 0.5], [0.2, 0.2, 0.2]], [1, 1, 1]) == pytest.approx(0.8 ** 3)


@pytest.mark.parametrize("m", [2, 3, 4, 5])
def test_hypervolume_equals_inclusion_exclusion(m):
    rng = np.random.default_rng(10 + m)
    for _ in range(10):
        pts = rng.random((int(rng.integers(1, 8)), m))
        ref = np.full(m, 1.05)
        assert hypervolume(pts, ref) == pytest.approx(_inclusion_exclusion_hv(pts, ref), rel=1e-12, abs=1e-15)


def _grid_hv(pts: np.ndarray, ref: float, h: float) -> float:
    """HV of points on a grid of spacing h, by counting the dominated cells of [0, ref]^m."""
    m = pts.shape[1]
    k = int(round(ref / h))
    corners = np.stack(np.meshgrid(*[np.arange(k) * h] * m, indexing="ij"), axis=-1).reshape(-1, m)
    dominated = np.zeros(len(corners), dtype=bool)
    for p in pts:
        dominated |= np.all(corners >= p - 1e-12, axis=1)
    return float(dominated.sum()) * h**m


@pytest.mark.parametrize("m", [2, 3, 4])
def test_hypervolume_of_larger_sets_equals_a_cell_count(m):
    rng = np.random.default_rng(20 + m)
    h = 0.05
    pts = rng.integers(0, 20, size=(80, m)) * h  # on the grid, with ties and duplicates
    assert hypervolume(pts, [1.0] * m) == pytest.approx(_grid_hv(pts, 1.0, h), rel=1e-12)


@pytest.mark.parametrize("m", [1, 2, 3])
def test_front_ranks_with_ties_equal_peeling_by_brute_force(m):
    rng = np.random.default_rng(30 + m)
    pts = rng.integers(0, 4, size=(25, m)).astype(float)
    want = [-1] * len(pts)
    left = list(range(len(pts)))
    rank = 0
    while left:
        front = [left[j] for j in _brute_non_dominated(pts[left])]
        for i in front:
            want[i] = rank
        left = [i for i in left if i not in front]
        rank += 1
    assert front_ranks(pts) == want
    assert front_ranks([]) == []


def test_hypervolume_refuses_mismatched_dimensions():
    with pytest.raises(ValueError, match="objectives"):
        hypervolume([[1, 2, 3]], [4, 4])
