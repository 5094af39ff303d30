"""Mesh-convergence tables of the FE solver against exact / published references.

Prints three tables (the heavy refinements that the pytest suite leaves out):

1. Thick-walled tube inflation, incompressible, plane strain (exact): error of the
   inner radius stretch λa and of the deformed radius field r(R) = √(R² + a² − A²) at P(λa = 1.5),
   with observed convergence rates (P2/P0: O(h²) expected for displacements).
2. Cantilever under a dead tip load, D1 = 0, L/h = 10 and 20: Euler–Bernoulli (k = 0.01) and
   elastica (k = 0.5, 1, 2) tip deflection/shortening errors on refined meshes.
3. Cook's membrane, small-load limit: u(48, 52) vs 16.4326 with the rate of convergence, and the
   locking table u(ν) at fixed G on several meshes.

Usage::

    python3 -m benchmarks.accuracy.fem_convergence [--quick] [--solver auto|pardiso|superlu] [--only tube,cantilever,cook]

The problem set-ups are those of tests/test_fem_tube.py, tests/test_fem_cantilever.py and
tests/test_fem_cook.py (imported, so the tables and the tests cannot drift apart).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from fem.linsolve import SOLVER_NAMES
from fem.meshgen import box_mesh
from fem.newton import SolveFailed, SolveOptions
from tests.test_fem_cantilever import cantilever, elastica
from tests.test_fem_cook import G, LAME, U_REF, cook_displacement, d1_for
from tests.test_fem_tube import A, inflate, tube_problem


def _rates(errs):
    return ["" if i == 0 else f"{np.log2(errs[i - 1] / errs[i]):.2f}" for i in range(len(errs))]


def tube_table(opts: SolveOptions, quick: bool) -> None:
    print("\n== Thick-walled tube, plane strain, D1 = 0, A = 1, B = 2, mu = 1, at P(lambda_a = 1.5) ==")
    print(f"{'n_r x n_th':>11} {'DOFs':>7} {'time s':>7} {'max|la-1.5|/1.5':>16} {'rate':>5} "
          f"{'mean la err':>12} {'max|r-r_ex|':>12} {'rate':>5}")
    meshes = [(1, 2), (2, 4), (4, 8), (8, 16)] + ([] if quick else [(16, 32)])
    e_in, e_r, rows = [], [], []
    for n_r, n_t in meshes:
        prob, inner = tube_problem(n_r, n_t, height=0.5 / n_r)
        t = time.perf_counter()
        st = inflate(prob, [1.1, 1.3, 1.5], opts)[-1]
        dt = time.perf_counter() - t
        X = prob.mesh.points
        x = X + st.u
        R = np.hypot(X[:, 0], X[:, 1])
        r = np.hypot(x[:, 0], x[:, 1])
        lam = r[inner] / A
        e_in.append(np.abs(lam - 1.5).max() / 1.5)
        e_r.append(np.abs(r - np.sqrt(R**2 + (1.5**2 - 1.0) * A**2)).max())
        rows.append((f"{n_r} x {n_t}", prob.n_dofs, dt, abs(lam.mean() - 1.5) / 1.5))
    for row, a, ra, b, rb in zip(rows, e_in, _rates(e_in), e_r, _rates(e_r)):
        print(f"{row[0]:>11} {row[1]:>7d} {row[2]:>7.2f} {a:>16.3e} {ra:>5} {row[3]:>12.3e} {b:>12.3e} {rb:>5}")


def cantilever_table(opts: SolveOptions, quick: bool) -> None:
    ks = (0.01, 0.5, 1.0, 2.0)
    ref = {k: elastica(k) for k in ks}
    print("\n== Cantilever, dead tip load, D1 = 0, mu = 1: relative errors vs Euler-Bernoulli (k=0.01) "
          "and the elastica ==")
    print(f"{'L/h':>4} {'cells':>10} {'DOFs':>7} {'time s':>7} {'EB k=.01':>9} "
          + " ".join(f"{'dy k=' + str(k):>10} {'dx k=' + str(k):>10}" for k in ks[1:]))
    cases = [(10, 20, 2), (10, 30, 3), (10, 40, 4)] + ([] if quick else [(10, 60, 6), (20, 40, 2), (20, 60, 3)])
    for slender, nx, nyz in cases:
        t = time.perf_counter()
        try:
            res = cantilever(float(slender), 1.0, nx, nyz, ks, options=opts)
        except SolveFailed as exc:
            print(f"{slender:>4} {nx}x{nyz}x{nyz}: SolveFailed: {exc}")
            continue
        dt = time.perf_counter() - t
        m = box_mesh(float(slender), 1.0, 1.0, nx, nyz, nyz)
        n_dofs = 3 * m.n_nodes + m.n_elements
        eb = (res[0][0] - ks[0] / 3) / (ks[0] / 3)
        cols = []
        for k, (dy, dx) in zip(ks[1:], res[1:]):
            cols.append(f"{(dy - ref[k][0]) / ref[k][0]:>+10.2e} {(dx - ref[k][1]) / ref[k][1]:>+10.2e}")
        print(f"{slender:>4} {f'{nx}x{nyz}x{nyz}':>10} {n_dofs:>7d} {dt:>7.1f} {eb:>+9.2e} " + " ".join(cols))
    print("(Timoshenko shear correction of the beam theory: +0.9 % at L/h = 10, +0.2 % at L/h = 20)")


def cook_table(opts: SolveOptions, quick: bool) -> None:
    nu_ref = LAME / (2 * (LAME + G))
    print(f"\n== Cook's membrane, small-load limit, G = {G}, lambda = {LAME} (nu = {nu_ref:.6f}): u(48, 52) ==")
    print(f"{'n x n':>7} {'time s':>7} {'u':>9} {'rel err':>10} {'rate':>5}")
    ns = [2, 4, 8, 16, 32] + ([] if quick else [48])
    us, times = [], []
    for n in ns:
        t = time.perf_counter()
        us.append(cook_displacement(n, d1_for(nu_ref), options=opts))
        times.append(time.perf_counter() - t)
    errs = [abs(u - U_REF) / U_REF for u in us]
    for n, dt, u, e, r in zip(ns, times, us, errs, _rates(errs)):
        print(f"{n:>7} {dt:>7.2f} {u:>9.4f} {e:>10.2e} {r:>5}")
    print("\n-- locking table: u(48, 52) at fixed G as nu -> 0.5 (D1 = 0 is nu = 0.5) --")
    nus = [0.3, 0.4, 0.49, 0.499, 0.4999, nu_ref, 0.5]
    mesh_ns = [4, 8, 16] + ([] if quick else [32])
    print(f"{'nu':>9} " + " ".join(f"{'n=' + str(n):>9}" for n in mesh_ns))
    for nu in nus:
        vals = []
        for n in mesh_ns:
            try:
                vals.append(f"{cook_displacement(n, d1_for(nu), options=opts):>9.4f}")
            except SolveFailed:
                vals.append(f"{'FAILED':>9}")
        print(f"{nu:>9.5f} " + " ".join(vals))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="skip the largest meshes")
    ap.add_argument("--solver", default="auto", choices=SOLVER_NAMES)
    ap.add_argument("--only", default="tube,cantilever,cook", help="comma-separated subset of tables")
    args = ap.parse_args(argv)
    opts = SolveOptions(linear_solver=args.solver)
    tables = {"tube": tube_table, "cantilever": cantilever_table, "cook": cook_table}
    for name in args.only.split(","):
        t = time.perf_counter()
        tables[name.strip()](opts, args.quick)
        print(f"[{name}: {time.perf_counter() - t:.1f} s]")


if __name__ == "__main__":
    main()
