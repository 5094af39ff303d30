"""PARDISO layer: accuracy on saddle-point and non-symmetric systems, analysis reuse, memory release.

References: scipy's SuperLU (independent direct solver) on the same small systems.
"""

import gc

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

pytest.importorskip("pypardiso")

from fem.linsolve import PardisoSolver  # noqa: E402


def saddle_point(n: int = 60, m: int = 20, seed: int = 0) -> sp.csr_matrix:
    """[[K, Bᵀ], [B, 0]] with K SPD: the structure of the D1 = 0 mixed u–p tangent."""
    rng = np.random.default_rng(seed)
    K = sp.random(n, n, density=0.1, random_state=rng)
    K = K @ K.T + sp.identity(n) * 5.0
    B = sp.random(m, n, density=0.2, random_state=rng) + sp.eye(m, n)
    Z = sp.csr_matrix((np.zeros(m), (np.arange(m), np.arange(m))), shape=(m, m))  # stored zero diagonal
    A = sp.bmat([[K, B.T], [B, Z]], format="csr")
    A.sort_indices()
    assert A.nnz == K.nnz + 2 * B.nnz + m
    return A


def test_saddle_point_solve_matches_superlu_and_reuses_analysis():
    A = saddle_point()
    b = np.arange(A.shape[0], dtype=float)
    S = PardisoSolver()
    S.factorize(A)
    x = S.solve(b)
    ref = spla.spsolve(A.tocsc(), b)
    assert np.linalg.norm(A @ x - b) <= 1e-9 * np.linalg.norm(b)
    assert np.allclose(x, ref, rtol=1e-8, atol=1e-10)
    assert S.stats["n_symmetric"] == 1
    # new values, same structure: no new symbolic analysis, still accurate
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    A2 = A.copy()
    A2.data = A.data * (1.0 + 0.1 * np.cos(rows + A.indices))  # symmetric change of the values
    S.factorize(A2)
    x2 = S.solve(b)
    assert np.linalg.norm(A2 @ x2 - b) <= 1e-9 * np.linalg.norm(b)
    assert S.stats["n_analyse"] == 1 and S.stats["n_factorize"] == 2


def test_matching_only_for_a_zero_diagonal():
    """Weighted matching is chosen for the saddle point (zero pressure diagonal) and skipped
    for a symmetric matrix without zero diagonal entries; both solves are accurate."""
    A = saddle_point()
    b = np.arange(A.shape[0], dtype=float)
    S = PardisoSolver()
    S.factorize(A)
    assert S._key == (-2, "matching")
    assert np.linalg.norm(A @ S.solve(b) - b) <= 1e-9 * np.linalg.norm(b)
    K = (A[:60, :60] + sp.identity(60)).tocsr()  # SPD block of the same kind
    K.sort_indices()
    S2 = PardisoSolver()
    S2.factorize(K)
    assert S2._key == (-2, "perturb")
    x = S2.solve(b[:60])
    assert np.allclose(x, spla.spsolve(K.tocsc(), b[:60]), rtol=1e-9, atol=1e-12)
    assert S2.stats["n_fallback"] == 0


def test_non_symmetric_system():
    rng = np.random.default_rng(1)
    A = (sp.random(80, 80, density=0.08, random_state=rng) + sp.identity(80) * 4.0).tocsr()
    A.sort_indices()
    b = rng.standard_normal(80)
    S = PardisoSolver()
    S.factorize(A)
    assert S.stats["n_symmetric"] == 0
    x = S.solve(b)
    assert np.allclose(x, spla.spsolve(A.tocsc(), b), rtol=1e-9, atol=1e-12)


def test_memory_released_when_the_solver_is_collected(monkeypatch):
    """MKL's factors live outside Python: a collected solver must free them (it leaked ~30 MB per scene)."""
    calls = []
    orig = PardisoSolver.release

    def spy(self):
        calls.append(1)
        orig(self)

    monkeypatch.setattr(PardisoSolver, "release", spy)
    S = PardisoSolver()
    S.factorize(saddle_point())
    del S
    gc.collect()
    assert calls
