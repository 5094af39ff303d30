"""Sparse direct solvers for the (non-symmetric, indefinite) Newton systems.

``pardiso`` (Intel MKL PARDISO via pypardiso, real non-symmetric, mtype 11) is the
default, several times faster per factorisation than SuperLU and more so on larger meshes
(``benchmarks/performance/bench_fem.py``; the figures: ``benchmarks/results/bench_fem.md``,
"Figures moved from the FE core's docstrings and comments"). The symbolic analysis (reordering,
phase 11) is done once per sparsity pattern and reused by every numerical factorisation (phase 22).
The saddle-point systems of the mixed u–p formulation have zero diagonal blocks when
D1 = 0; PARDISO handles them with weighted matching (2×2 pivots), falling back to
pivot perturbation, and each solve is followed by iterative refinement on the true
residual until ‖A x − b‖ ≤ 1e-9 ‖b‖.

``superlu`` (scipy) is a last-resort fallback and warns.

Every solver follows :class:`LinearSolver` (``factorize``, ``solve``, ``release``, a ``name``
and a ``stats`` dict) and is registered by name in :data:`SOLVERS`; :func:`make_solver` builds
one by name and :data:`SOLVER_NAMES` (``auto`` first) is what a run file's
``fidelity.linear_solver`` accepts. Another solver (an iterative one, say) is one class that
follows the protocol plus one entry in :data:`SOLVERS`; ``solve`` must raise
:class:`LinearSolverError` rather than return an inaccurate solution.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import time
import warnings
from types import MappingProxyType
from typing import Callable, Iterator, Mapping, Protocol, runtime_checkable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

logger = logging.getLogger(__name__)


class LinearSolverError(RuntimeError):
    """The factorisation failed or the solve did not reach the requested accuracy."""


@runtime_checkable
class LinearSolver(Protocol):
    """What the Newton solver needs of a linear solver.

    Attributes
    ----------
    name : str
        Its key in :data:`SOLVERS`.
    stats : dict
        Seconds and counts, at least ``factorize``, ``solve`` and ``n_factorize``.
    """

    name: str
    stats: dict

    def factorize(self, A: sp.csr_matrix, symmetric: bool | None = None) -> None:
        """Prepare solves with ``A`` (``symmetric``: a hint; None lets the solver decide)."""

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with A x = b for the last factorised A; :class:`LinearSolverError` when it cannot."""

    def release(self) -> None:
        """Free the factors; the solver can factorise again afterwards."""


class PardisoSolver:
    """MKL PARDISO with the analysis reused across numerical factorisations.

    Two matrix types, chosen per factorisation by a cheap symmetry probe
    (‖K v − Kᵀ v‖ ≤ 1e-11 ‖K v‖ for a random v):

    * symmetric indefinite (mtype −2, Bunch–Kaufman pivoting, upper triangle only):
      material + fibre tangents, and follower pressure on closed cavities;
    * real non-symmetric (mtype 11) otherwise.

    Three pivoting strategies (:attr:`strategies`); ``matching`` first when the matrix has a
    zero diagonal entry, ``perturb`` first otherwise, then the others in turn when a refined
    solve fails:

    * ``matching``: weighted matching (iparm(13)=1), which pairs each zero-diagonal
      pressure unknown of the mixed u–p system with a displacement unknown into a
      2×2 pivot. On the whisker scene's D1 = 0 tangent it perturbs no pivot and the
      first solve is accurate, where without matching thousands of pivots are perturbed
      and every solve needs refinement sweeps (the figures: ``benchmarks/results/bench_fem.md``,
      "Figures moved from the FE core's docstrings and comments").
    * ``perturb``: no matching, pivot perturbation 1e-8 (iparm(10)=8). Matching gave
      useless factors on some clamped D1 = 0 meshes (Cook, cantilever: residuals up to
      1e32 in the solver verification) where this strategy converges in ≤ 4 sweeps.
    * ``scaled``: weighted matching with symmetric scaling and pivot perturbation 1e-8
      (iparm(13)=1, iparm(11)=1, iparm(10)=8), the last resort. Fibres 10⁵ times stiffer
      than the rubber (a wall cell with embedded fibre rings, ``benchmarks/studies/fibre_cell.py``)
      left both strategies above at |Ax − b|/|b| ≈ 5e-5 and 4e6 after refinement; these
      factors solve it (matching and scaling with the 1e-13 perturbation did not: 3e2).

    Every solve is refined on the true residual until ‖A x − b‖ ≤ ``tol`` ‖b‖. When
    the first strategy's factors cannot reach that, the matrix is refactorised with each
    other strategy in the order above (a pattern where ``matching`` failed is remembered, so
    later factorisations start with ``perturb``, and one that only ``scaled`` solved starts
    with ``scaled``); when none can, :class:`LinearSolverError` is raised (never a silent
    garbage update).
    """

    name = "pardiso"
    #: (name, iparm(10) pivot perturbation 10^-k, iparm(11) scaling, iparm(13) weighted matching)
    strategies = (("matching", 13, 0, 1), ("perturb", 8, 0, 0), ("scaled", 8, 1, 1))

    def __init__(self, tol: float = 1e-9) -> None:
        _mkl_rt_name()  # before the import: pypardiso searches for MKL at import time
        import pypardiso  # noqa: F401  (ImportError -> the next solver of AUTO_ORDER)

        self.tol = tol
        self._solvers: dict[tuple, object] = {}
        self._analysed: dict[tuple, tuple] = {}
        self._upper_cache = None  # (indptr, indices, mask, upper indices, upper indptr)
        self._start = None  # (indptr, indices, strategy): a pattern's first strategy, learnt from fallbacks
        self._A = None
        self._Af = None
        self._key = None
        self._rng = np.random.default_rng(12345)
        self.stats = {"analyse": 0.0, "factorize": 0.0, "solve": 0.0, "n_analyse": 0, "n_factorize": 0,
                      "n_symmetric": 0, "n_sweeps": 0, "n_fallback": 0}

    def _solver(self, mtype: int, strategy: str):
        key = (mtype, strategy)
        s = self._solvers.get(key)
        if s is None:
            import pypardiso

            _mkl_rt_name()  # exports PYPARDISO_MKL_RT: no per-instance library search (~0.8 s each)
            s = pypardiso.PyPardisoSolver(mtype=mtype)
            s.set_statistical_info_off()
            s.iparm[:] = 0
            s.set_iparm(1, 1)  # use the values below, not MKL defaults
            s.set_iparm(2, 2)  # nested-dissection (METIS) ordering
            s.set_iparm(8, 0)  # refinement done here, on the true residual
            perturbation, scaling, matching = next(st[1:] for st in self.strategies if st[0] == strategy)
            s.set_iparm(10, perturbation)  # pivot perturbation 10^-perturbation
            s.set_iparm(11, scaling)  # symmetric scaling (with the matching)
            s.set_iparm(13, matching)  # weighted matching: 2×2 pivots for the zero pressure diagonal
            if mtype == -2:
                s.set_iparm(21, 1)  # Bunch–Kaufman pivoting
            self._solvers[key] = s
        return s

    @staticmethod
    def _same_pattern(A: sp.csr_matrix, indptr: np.ndarray, indices: np.ndarray) -> bool:
        """Exact structure comparison (O(nnz); scipy copies index arrays, so ids lie)."""
        return (A.indptr.shape == indptr.shape and A.indices.shape == indices.shape
                and np.array_equal(A.indptr, indptr) and np.array_equal(A.indices, indices))

    def _upper(self, A: sp.csr_matrix):
        """Upper-triangle structure and data mask of A's pattern (cached while the pattern is unchanged)."""
        c = self._upper_cache
        if c is None or not self._same_pattern(A, c[0], c[1]):
            rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
            mask = A.indices >= rows
            indptr = np.concatenate([[0], np.cumsum(np.bincount(rows[mask], minlength=A.shape[0]))])
            indptr = indptr.astype(A.indptr.dtype)
            c = self._upper_cache = (A.indptr.copy(), A.indices.copy(), mask, A.indices[mask], indptr)
        return c[2], c[3], c[4]

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
        if symmetric:
            mask, ind_u, ptr_u = self._upper(A)
            Af = sp.csr_matrix((A.data[mask], ind_u, ptr_u), shape=A.shape)
            Af.has_sorted_indices = True
            self.stats["n_symmetric"] += 1
        else:
            Af = A
        # weighted matching exists for zero diagonal entries (the mixed D1 = 0 pressure block);
        # without any it only costs analysis time (0.23 -> 0.14 s at 24k unknowns, bench_fem)
        zero_diag = bool(np.any(A.diagonal() == 0.0))
        st = self._start
        if st is not None and self._same_pattern(A, st[0], st[1]):
            strategy = st[2]
        else:
            strategy = "matching" if zero_diag else "perturb"
        self._A, self._Af = A, Af
        self._factor(mtype, strategy)

    def _factor(self, mtype: int, strategy: str) -> None:
        Af = self._Af
        s = self._solver(mtype, strategy)
        key = (mtype, strategy)
        s._check_A(Af)
        b = np.zeros((Af.shape[0], 1))
        # symbolic analysis (ordering + matching, phase 11) only when this solver's
        # structure changed: compared by content, since scipy copies index arrays.
        # With matching, MKL computes the matching from the values in phase 11; later
        # matrices of the same pattern reuse it (still a valid pivot order; the checked
        # refinement and the fallback catch a matching that no longer fits).
        done = self._analysed.get(key)
        if done is None or not self._same_pattern(Af, done[0], done[1]):
            t = time.perf_counter()
            s.set_phase(11)
            s._call_pardiso(Af, b)
            self._analysed[key] = (Af.indptr.copy(), Af.indices.copy())
            self.stats["analyse"] += time.perf_counter() - t
            self.stats["n_analyse"] += 1
        t = time.perf_counter()
        s.set_phase(22)
        s._call_pardiso(Af, b)
        self.stats["factorize"] += time.perf_counter() - t
        self.stats["n_factorize"] += 1
        self._key = key

    def _refined(self, b: np.ndarray) -> tuple[np.ndarray, float]:
        s = self._solvers[self._key]
        s.set_phase(33)
        A = self._A
        x = s._call_pardiso(self._Af, np.asfortranarray(b.reshape(-1, 1))).ravel()
        nb = max(np.linalg.norm(b), 1e-300)
        rel = np.inf
        for _ in range(7):
            if not np.all(np.isfinite(x)):
                return x, np.inf
            r = b - A @ x
            rel = np.linalg.norm(r) / nb
            if rel <= self.tol:
                break
            self.stats["n_sweeps"] += 1
            x = x + s._call_pardiso(self._Af, np.asfortranarray(r.reshape(-1, 1))).ravel()
        return x, rel

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve with the last factorisation, refining on the true residual.

        Raises
        ------
        LinearSolverError
            If ‖A x − b‖ > tol ‖b‖ after the refinement sweeps with every strategy,
            or x is not finite.
        """
        t = time.perf_counter()
        try:
            x, rel = self._refined(b)
            if rel > self.tol:
                for nxt in (st[0] for st in self.strategies if st[0] != self._key[1]):
                    logger.debug("PARDISO %s factors reached only %.3g; refactorising with %s", self._key[1], rel, nxt)
                    self.stats["n_fallback"] += 1
                    if nxt == "perturb":  # matching failed on this pattern: start without it next time
                        self._start = (self._A.indptr.copy(), self._A.indices.copy(), nxt)
                    self._factor(self._key[0], nxt)
                    x, rel = self._refined(b)
                    if rel <= self.tol:
                        if nxt == "scaled":  # only the last resort solved it: start there next time
                            self._start = (self._A.indptr.copy(), self._A.indices.copy(), nxt)
                        break
        finally:
            self.stats["solve"] += time.perf_counter() - t
        if not np.isfinite(rel):
            raise LinearSolverError("PARDISO returned non-finite values (singular system?)")
        if rel > self.tol:
            raise LinearSolverError(f"PARDISO (mtype {self._key[0]}) solve inaccurate: |Ax-b|/|b| = {rel:.3g}")
        return x

    def release(self) -> None:
        """Free MKL's factors and analysis (PARDISO phase −1); the solver can be used again."""
        for s in self._solvers.values():
            try:
                s.free_memory(everything=True)
            except Exception:  # pragma: no cover - best effort
                pass
        self._solvers.clear()
        self._analysed.clear()

    def __del__(self) -> None:
        # MKL keeps the factors in its own memory, which pypardiso never frees on garbage
        # collection: without this, every scene leaked its factorisation (the GA workers'
        # growth: benchmarks/results/bench_case.md, the first attempt at case 1).
        try:
            self.release()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass


@functools.lru_cache(maxsize=1)
def _mkl_rt_name() -> str | None:
    """Path of the MKL runtime for pypardiso, found once per process.

    pypardiso searches ``sys.prefix`` recursively when ``find_library`` fails, and does
    so at import (it builds a module-level solver), a second or so per process
    (``benchmarks/results/bench_fem.md``, "Figures moved from the FE core's docstrings and comments"). The pip
    layout (``<prefix>/lib/libmkl_rt.so*``) is tried first, non-recursively, and
    exported as pypardiso's documented ``PYPARDISO_MKL_RT`` (unless the user set it)
    so the import skips the search.
    """
    import ctypes
    import glob
    import os
    import sys

    if os.environ.get("PYPARDISO_MKL_RT"):
        return os.environ["PYPARDISO_MKL_RT"]
    for path in sorted(glob.glob(f"{sys.prefix}/lib/libmkl_rt.so*"), key=len):
        try:
            ctypes.CDLL(path)
        except OSError:  # pragma: no cover - broken install
            continue
        os.environ["PYPARDISO_MKL_RT"] = path
        return path
    import pypardiso  # pragma: no cover - other layouts: pypardiso's own search

    name = getattr(pypardiso.PyPardisoSolver().libmkl, "_name", None)  # pragma: no cover
    if name:  # pragma: no cover
        os.environ["PYPARDISO_MKL_RT"] = name
    return name  # pragma: no cover


@contextlib.contextmanager
def mkl_threads(n: int | None) -> Iterator[None]:
    """MKL's thread count (PARDISO's factorisations and solves) for the calling thread, restored after.

    ``MKL_Set_Num_Threads_Local``: a solve in a process whose MKL uses several threads (a serial
    GA run on all cores) and one in a worker started with one thread differ in round-off (about
    1e-12 of a reading); pinning both to the same count makes them bit-identical. No effect when
    ``n`` is None or MKL cannot be loaded.
    """
    import ctypes

    try:
        name = _mkl_rt_name() if n is not None else None
        fn = ctypes.CDLL(name).MKL_Set_Num_Threads_Local if name else None
    except (ImportError, OSError, AttributeError):  # no MKL: nothing to pin
        fn = None
    if fn is None:
        yield
        return
    fn.restype, fn.argtypes = ctypes.c_int, [ctypes.c_int]
    previous = fn(int(n))  # 0: the thread followed MKL's global setting
    try:
        yield
    finally:
        fn(previous)


class SuperLUSolver:
    """scipy SuperLU: slow for 3-D P2 problems (benchmarks/performance/bench_fem.py); fallback only."""

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


#: The linear solvers by name: name -> constructor (no arguments) of a :class:`LinearSolver`.
SOLVERS: Mapping[str, Callable[[], LinearSolver]] = MappingProxyType({
    PardisoSolver.name: PardisoSolver,
    SuperLUSolver.name: SuperLUSolver,
})
#: The solvers ``auto`` tries, in order: the first that can be built is used.
AUTO_ORDER: tuple[str, ...] = (PardisoSolver.name, SuperLUSolver.name)
#: Every name :func:`make_solver` accepts (the choices of ``fidelity.linear_solver``).
SOLVER_NAMES: tuple[str, ...] = ("auto",) + tuple(SOLVERS)


def make_solver(name: str = "auto") -> LinearSolver:
    """A linear solver by name.

    Parameters
    ----------
    name : str
        One of :data:`SOLVER_NAMES`: a key of :data:`SOLVERS`, or ``'auto'``: the first of
        :data:`AUTO_ORDER` that can be built (PARDISO when pypardiso and MKL load), with a
        ``RuntimeWarning`` when it is not the first.

    Returns
    -------
    LinearSolver

    Raises
    ------
    ValueError
        An unknown name (the message lists the allowed ones).
    """
    if name not in SOLVER_NAMES:
        allowed = ", ".join(repr(n) for n in SOLVER_NAMES)
        raise ValueError(f"linear_solver={name!r}: allowed {allowed}")
    if name != "auto":
        return SOLVERS[name]()
    failed = []
    for candidate in AUTO_ORDER:
        try:
            solver = SOLVERS[candidate]()
        except Exception as exc:  # ImportError, or MKL failing to load
            failed.append(f"{candidate} unavailable ({exc})")
            continue
        if failed:
            warnings.warn(f"{'; '.join(failed)}; falling back to {candidate}, which is 10-40x slower on 3-D P2 "
                          "problems than PARDISO. Install pypardiso (pip install pypardiso).",
                          RuntimeWarning, stacklevel=2)
        return solver
    raise LinearSolverError(f"no linear solver could be built: {'; '.join(failed)}")
