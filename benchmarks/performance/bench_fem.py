"""FE core performance: assembly, factorisation, Newton iteration, full solve vs CalculiX.

Problem: a clamped neo-Hookean block (C10 = 0.14 MPa, K/μ = 10) whose top face is
pushed sideways and down by prescribed displacements (a large, nonlinear shear), meshed
with P2 tets at about 10k / 30k / 100k displacement DOFs. The same mesh and loads run
through CalculiX (C3D10, NEO HOOKE, NLGEOM, same number of fixed increments, tightened
tolerances) and through whisker-opt with the same (displacement) formulation, so the
comparison is like for like; the agreement of the two answers is printed too.

Usage::

    python3 -m benchmarks.performance.bench_fem            # 10k and 30k DOFs (CalculiX on both)
    python3 -m benchmarks.performance.bench_fem --full     # also 100k DOFs
    python3 -m benchmarks.performance.bench_fem --no-ccx   # our solver only

Prints one table; speed-ups are ratios measured in the same run on the same machine.
``lin.sol.`` is our time in PARDISO (analysis, factorisations, refined solves) and
``ccx/lin`` CalculiX's time over it: the speed-up we would reach if assembly and all
other work were free.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from fem.assembly import Assembler
from peers.calculix import CcxCase, ccx_available, run_ccx
from fem.linsolve import make_solver
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.meshgen import box_mesh
from fem.problem import Dirichlet, Problem
from fem.state import State
from fem.loadpath import solve_path
from fem.newton import SolveOptions

C10 = 0.14
D1 = 2.0 / (10 * 2 * C10)
N_INC = 4


def make_case(n: int):
    mesh = box_mesh(1.0, 1.0, 2.0, n, n, 2 * n)
    P = mesh.points
    base = np.nonzero(np.isclose(P[:, 2], 0.0))[0]
    top = np.nonzero(np.isclose(P[:, 2], 2.0))[0]
    return mesh, base, top


def time_kernels(prob, reps=3):
    asm = Assembler(prob)
    u = np.zeros((prob.mesh.n_nodes, 3))
    u[:, 0] = 0.05 * prob.mesh.points[:, 2] ** 2
    p = np.zeros(prob.mesh.n_elements)
    t_asm = []
    for _ in range(reps):
        t = time.perf_counter()
        R, data, _ = asm.evaluate(u, p, ())
        t_asm.append(time.perf_counter() - t)
    solver = make_solver("auto")
    A = asm.pattern.matrix(data.copy())
    con = prob.constrained_dofs()
    d = data.copy()
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    mask = np.isin(rows, con) | np.isin(A.indices, con)
    d[mask] = 0.0
    d[asm.pattern.diag[con]] = 1.0
    A = asm.pattern.matrix(d)
    t = time.perf_counter()
    solver.factorize(A)
    t_first = time.perf_counter() - t
    t_fac = []
    for _ in range(reps):
        t = time.perf_counter()
        solver.factorize(A)
        t_fac.append(time.perf_counter() - t)
    t = time.perf_counter()
    solver.solve(np.ones(A.shape[0]))
    t_sol = time.perf_counter() - t
    return statistics.median(t_asm), t_first, statistics.median(t_fac), t_sol


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--full", action="store_true", help="include the ~100k-DOF mesh")
    ap.add_argument("--no-ccx", action="store_true", help="skip CalculiX")
    ap.add_argument("--threads", type=int, default=2, help="CalculiX threads (OMP_NUM_THREADS)")
    ap.add_argument("--reuse", type=float, default=0.3,
                    help="SolveOptions.reuse_tangent (0 = full Newton; default 0.3 = modified Newton)")
    args = ap.parse_args()
    sizes = [(7, "10k"), (10, "30k")] + ([(15, "100k")] if args.full else [])
    use_ccx = ccx_available() and not args.no_ccx
    print(f"{'mesh':>6} {'DOFs':>7} {'assemble':>9} {'analyse+fac':>11} {'factor':>8} {'solve':>7} "
          f"{'asm/iter':>8} {'iters':>5} {'ours [s]':>9} {'lin.sol.':>8} {'ccx [s]':>8} {'speed-up':>8} "
          f"{'ccx/lin':>7} {'|du|/|u|':>9}")
    for n, label in sizes:
        mesh, base, top = make_case(n)
        mat = NeoHookean(C10, D1)
        dirichlet = (Dirichlet(base), Dirichlet(top))
        prob = Problem(mesh, mat, dirichlet=dirichlet, formulation="displacement")
        t_asm, t_first, t_fac, t_sol = time_kernels(prob)
        top_val = np.tile([0.3, 0.0, -0.2], (len(top), 1))
        load1 = LoadState((), (np.zeros((len(base), 3)), top_val))
        fr = tuple(np.linspace(0, 1, N_INC + 1)[1:])
        prob = Problem(mesh, mat, dirichlet=dirichlet, formulation="displacement")
        t = time.perf_counter()
        states, reps = solve_path(prob, State.zero(prob), LoadState.zero(prob), load1, fractions=fr,
                                  options=SolveOptions(max_step=1.0 / N_INC, initial_step=1.0 / N_INC,
                                                      reuse_tangent=args.reuse))
        t_ours = time.perf_counter() - t
        iters = sum(r.iterations for r in reps)
        # linear-solver time (analysis + factorisations + refined solves): CalculiX's time over
        # it bounds the speed-up any faster assembly or Newton bookkeeping could give
        t_lin = sum(r.time_factorize + r.time_solve for r in reps)
        ccx_t, err = float("nan"), float("nan")
        if use_ccx:
            bc = tuple((base, k, 0.0) for k in range(3)) + tuple((top, k, float(top_val[0, k])) for k in range(3))
            res = run_ccx(CcxCase(mesh.points, mesh.cells, C10, D1, boundary=bc, n_increments=N_INC),
                          threads=args.threads, cleanup=True)
            ccx_t = res.wall_time
            u = states[-1].u
            err = float(np.abs(u - res.displacements).max() / np.abs(res.displacements).max())
        per_iter = (t_ours / max(iters, 1))
        print(f"{label:>6} {3 * mesh.n_nodes:>7d} {t_asm:>9.3f} {t_first:>11.3f} {t_fac:>8.3f} {t_sol:>7.3f} "
              f"{t_asm / per_iter:>8.1%} {iters:>5d} {t_ours:>9.2f} {t_lin:>8.2f} {ccx_t:>8.2f} {ccx_t / t_ours:>7.1f}x "
              f"{ccx_t / t_lin:>6.1f}x {err:>9.1e}")


if __name__ == "__main__":
    main()
