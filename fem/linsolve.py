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
    """MKL PARDISO with the analysis reused across numerical factorisations.

    Two matrix types, chosen per factorisation by a cheap symmetry probe
    (‖K v − Kᵀ v‖ ≤ 1e-11 ‖K v‖ for a random v):

    * symmetric indefinite (mtype −2, Bunch–Kaufman pivoting, upper triangle only):
      material + fibre tangents, and follower pressure on closed cavities;
    * real non-symmetric (mtype 11) otherwise.

    Both run *without* MKL's default weighted matching and with pivot perturbation
    1e-8 (iparm(13)=0, iparm(10)=8): with matching, the zero pressure block of the
    D1 = 0 saddle-point system gave useless factors (relative residuals up to 1e32
    on clamped Cook/cantilever meshes, measured in issue #3's verification), while
    these settings reach ‖A x − b‖/‖b‖ ≈ 1e-12 after ≤ 2 refinement sweeps. A solve
    that does not reach ``tol`` raises :class:`LinearSolverError` (never a silent
    garbage update).
    """

    name = "pardiso"

    def __init__(self, tol: float = 1e-9) -> None:
        import pypardiso  # noqa: F401  (ImportError -> fallback in make_solver)

        self.tol = tol
        self._solvers: dict[int, object] = {}
        self._analysed: dict[int, object] = {}
        self._upper_cache = None
        self._A = None
        self._Af = None
        self._mtype = None
        self._rng = np.random.default_rng(12345)
        self.stats = {"analyse": 0.0, "factorize": 0.0, "solve": 0.0, "n_factorize": 0, "n_symmetric": 0}

    def _solver(self, mtype: int):
        s = self._solvers.get(mtype)
        if s is None:
            import pypardiso

            if self._solvers:  # reuse the MKL library found by the first instance (its search globs sys.prefix: ~0.8 s)
                first = next(iter(self._solvers.values()))
                s = pypardiso.PyPardisoSolver.__new__(pypardiso.PyPardisoSolver)
                _init_like(s, first, mtype)
            else:
                s = pypardiso.PyPardisoSolver(mtype=mtype)
            s.set_statistical_info_off()
            s.iparm[:] = 0
            s.set_iparm(1, 1)  # use the values below, not MKL defaults
            s.set_iparm(2, 2)  # nested-dissection (METIS) ordering
            s.set_iparm(8, 0)  # refinement done here, on the true residual
            s.set_iparm(10, 8)  # pivot perturbation 1e-8
            s.set_iparm(11, 0)  # no scaling
            s.set_iparm(13, 0)  # no weighted matching
            if mtype == -2:
                s.set_iparm(21, 1)  # Bunch–Kaufman pivoting
            self._solvers[mtype] = s
        return s

    def _upper(self, A: sp.csr_matrix):
        """Upper-triangle CSR structure and data mask of A's pattern (cached per pattern)."""
        key = (A.shape, A.nnz, id(A.indices))
        if self._upper_cache is None or self._upper_cache[0] != key:
            rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
            mask = A.indices >= rows
            indptr = np.concatenate([[0], np.cumsum(np.bincount(rows[mask], minlength=A.shape[0]))])
            self._upper_cache = (key, mask, A.indices[mask], indptr, A.indices)
        return self._upper_cache

    def is_symmetric(self, A: sp.csr_matrix) -> bool:
        """Cheap probe: ‖A v − Aᵀ v‖ ≤ 1e-11 ‖A v‖ for a random v."""
        v = self._rng.standard_normal(A.shape[0])
        av = A @ v
        atv = A.T @ v
        return bool(np.linalg.norm(av - atv) <= 1e-11 * np.linalg.norm(av))

    def factorize(self, A: sp.csr_matrix, symmetric: bool | None = None) -> None:
        """Numerical factorisation (analysis only when the pattern or matrix type changed)."""
        A = A if A.format == "csr" else A.tocsr()
        if not A.has_sorted_indices:
            A.sort_indices()
        if symmetric is None:
            symmetric = self.is_symmetric(A)
        mtype = -2 if symmetric else 11
        s = self._solver(mtype)
        if symmetric:
            key, mask, ind_u, ptr_u, keep = self._upper(A)
            Af = sp.csr_matrix((A.data[mask], ind_u, ptr_u), shape=A.shape)
            Af.has_sorted_indices = True
            pid = ("u",) + key
            self.stats["n_symmetric"] += 1
        else:
            Af = A
            pid = ("f", A.shape, A.nnz, id(A.indices))
        s._check_A(Af)
        b = np.zeros((A.shape[0], 1))
        if self._analysed.get(mtype) != pid:
            t = time.perf_counter()
            s.set_phase(11)
            s._call_pardiso(Af, b)
            self._analysed[mtype] = pid
            self.stats["analyse"] += time.perf_counter() - t
        t = time.perf_counter()
        s.set_phase(22)
        s._call_pardiso(Af, b)
        self.stats["factorize"] += time.perf_counter() - t
        self.stats["n_factorize"] += 1
        self._A, self._Af, self._mtype = A, Af, mtype

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation, refining on the true residual.

        Raises
        ------
        LinearSolverError
            If ‖A x − b‖ > tol ‖b‖ after 6 refinement sweeps or x is not finite.
        """
        t = time.perf_counter()
        s = self._solvers[self._mtype]
        s.set_phase(33)
        A = self._A
        x = s._call_pardiso(self._Af, np.asfortranarray(b.reshape(-1, 1))).ravel()
        nb = max(np.linalg.norm(b), 1e-300)
        rel = np.inf
        for _ in range(7):
            if not np.all(np.isfinite(x)):
                raise LinearSolverError("PARDISO returned non-finite values (singular system?)")
            r = b - A @ x
            rel = np.linalg.norm(r) / nb
            if rel <= 0.01 * self.tol:
                break
            x = x + s._call_pardiso(self._Af, np.asfortranarray(r.reshape(-1, 1))).ravel()
        self.stats["solve"] += time.perf_counter() - t
        if rel > self.tol:
            raise LinearSolverError(f"PARDISO (mtype {self._mtype}) solve inaccurate: |Ax-b|/|b| = {rel:.3g}")
        return x

    def release(self) -> None:
        """Free MKL memory."""
        for s in self._solvers.values():
            try:
                s.free_memory(everything=True)
            except Exception:  # pragma: no cover - best effort
                pass


def _init_like(s, first, mtype: int) -> None:
    """Initialise a PyPardisoSolver ``s`` sharing ``first``'s loaded MKL library."""
    import os

    name = getattr(first.libmkl, "_name", None)
    old = os.environ.get("PYPARDISO_MKL_RT")
    try:
        if name:
            os.environ["PYPARDISO_MKL_RT"] = name
        type(s).__init__(s, mtype=mtype)
    finally:
        if old is None:
            os.environ.pop("PYPARDISO_MKL_RT", None)
        else:
            os.environ["PYPARDISO_MKL_RT"] = old


class SuperLUSolver:
    """scipy SuperLU: slow for 3-D P2 problems (issue #3 measurements); fallback only."""

    name = "superlu"

    def __init__(self) -> None:
        self._lu = None
        self.stats = {"analyse": 0.0, "factorize": 0.0, "solve": 0.0, "n_factorize": 0}

    def factorize(self, A: sp.csr_matrix, symmetric: bool | None = None) -> None:
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
