"""Sparse direct solvers for the (non-symmetric, indefinite) Newton systems.

``pardiso`` (Intel MKL PARDISO via pypardiso, real non-symmetric, mtype 11) is the
default: measured 0.77 / 4.3 / 26 s per factorisation at 19k / 58k / 146k P2 DOFs on
this machine kind, against 9.9 / 154 s for SuperLU (see issue #3 and
``benchmarks/bench_fem.py``). The symbolic analysis (reordering, phase 11) is done
once per sparsity pattern and reused by every numerical factorisation (phase 22).
The saddle-point systems of the mixed u–p formulation have zero diagonal blocks when
D1 = 0; PARDISO handles them with weighted matching and pivot perturbation, so each
solve is followed by iterative refinement on the true residual until
‖A x − b‖ ≤ 1e-10 ‖b‖.

``superlu`` (scipy) is a last-resort fallback and warns.
"""

from __future__ import annotations

import logging
import time
import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

logger = logging.getLogger(__name__)


class LinearSolverError(RuntimeError):
    """The factorisation failed or the solve did not reach the requested accuracy."""


class PardisoSolver:
    """MKL PARDISO with analysis reused across numerical factorisations."""

    name = "pardiso"

    def __init__(self) -> None:
        import pypardiso

        self._s = pypardiso.PyPardisoSolver(mtype=11)
        self._analysed_pattern = None
        self._A = None
        self.stats = {"analyse": 0.0, "factorize": 0.0, "solve": 0.0, "n_factorize": 0}

    def _pattern_id(self, A: sp.csr_matrix):
        return (A.shape, A.nnz, id(A.indices))

    def factorize(self, A: sp.csr_matrix) -> None:
        """Numerical factorisation (analysis only when the pattern changed)."""
        A = A if A.format == "csr" else A.tocsr()
        s = self._s
        s._check_A(A)
        b = np.zeros((A.shape[0], 1))
        pid = self._pattern_id(A)
        if self._analysed_pattern != pid:
            t = time.perf_counter()
            s.set_phase(11)
            s._call_pardiso(A, b)
            self._analysed_pattern = pid
            self.stats["analyse"] += time.perf_counter() - t
        t = time.perf_counter()
        s.set_phase(22)
        s._call_pardiso(A, b)
        self.stats["factorize"] += time.perf_counter() - t
        self.stats["n_factorize"] += 1
        self._A = A

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation (plus iterative refinement)."""
        t = time.perf_counter()
        s = self._s
        A = self._A
        s.set_phase(33)
        bb = np.asfortranarray(b.reshape(-1, 1))
        x = s._call_pardiso(A, bb).ravel()
        nb = np.linalg.norm(b)
        for _ in range(4):
            r = b - A @ x
            if not np.all(np.isfinite(x)):
                raise LinearSolverError("PARDISO returned non-finite values (singular system?)")
            if np.linalg.norm(r) <= 1e-10 * max(nb, 1e-300):
                break
            x = x + s._call_pardiso(A, np.asfortranarray(r.reshape(-1, 1))).ravel()
        self.stats["solve"] += time.perf_counter() - t
        return x

    def release(self) -> None:
        """Free MKL memory (phase −1)."""
        try:
            self._s.free_memory(everything=True)
        except Exception:  # pragma: no cover - best effort
            pass


class SuperLUSolver:
    """scipy SuperLU: slow for 3-D P2 problems (issue #3 measurements); fallback only."""

    name = "superlu"

    def __init__(self) -> None:
        self._lu = None
        self.stats = {"analyse": 0.0, "factorize": 0.0, "solve": 0.0, "n_factorize": 0}

    def factorize(self, A: sp.csr_matrix) -> None:
        t = time.perf_counter()
        self._lu = spla.splu(A.tocsc(), permc_spec="COLAMD")
        self.stats["factorize"] += time.perf_counter() - t
        self.stats["n_factorize"] += 1

    def solve(self, b: np.ndarray) -> np.ndarray:
        t = time.perf_counter()
        x = self._lu.solve(b)
        self.stats["solve"] += time.perf_counter() - t
        return x

    def release(self) -> None:
        self._lu = None


def make_solver(name: str = "auto"):
    """A linear solver by name: 'auto' (PARDISO if importable), 'pardiso' or 'superlu'."""
    if name not in ("auto", "pardiso", "superlu"):
        raise ValueError(f"linear_solver={name!r}: allowed 'auto', 'pardiso', 'superlu'")
    if name in ("auto", "pardiso"):
        try:
            return PardisoSolver()
        except Exception as exc:  # ImportError, or MKL failing to load
            if name == "pardiso":
                raise
            warnings.warn(
                f"PARDISO unavailable ({exc}); falling back to scipy SuperLU, which is 10-40x slower "
                "on 3-D P2 problems. Install pypardiso (pip install pypardiso).",
                RuntimeWarning,
                stacklevel=2,
            )
    return SuperLUSolver()
