"""Interleaved A/B timing of one GA evaluation between two checkouts of whisker-opt.

This machine's speed drifts by ±20 % within minutes, so a change's effect is measured as
alternating processes of the two code versions, each timing ``--n`` evaluations (intact
at 0.2 MPa + trimmed 5 mm vented, default preset, one thread) after one warm-up
evaluation; the table gives each round's medians and the median over rounds. ``--design``
names the design (α, l, t, Q_i): the three of ``time_vs_error.py`` and the case-1 optimum.

Usage::

    git worktree add /tmp/old <commit>
    python3 -m benchmarks.performance.ab_eval OLD_CHECKOUT . [--rounds 5] [--n 3] [--design default]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

CHILD = r"""
import statistics, sys, time
sys.path.insert(0, ".")
from geometry.design import WhiskerDesign
from geometry.mesh import MeshSizing, build_mesh
from whisker_opt.genes import design_from_genes
from whisker_opt.experiment.fidelity import PRESETS
from whisker_opt.experiment.scene import run_scene
from whisker_opt.experiment.spec import SceneSpec
p = PRESETS["default"]
def spec(d, Q):
    return SceneSpec(d, Q=Q, sizing=PRESETS["default"].sizing, n_pressure_steps=p.n_pressure_steps,
                     n_deflection_steps=p.n_deflection_steps)
a, l, t, Q = (float(v) for v in sys.argv[2:6])
d = design_from_genes(WhiskerDesign(), {"alpha": a, "l": l, "t": t}, trim=0.0)
def ev():
    s1, s2 = spec(d, Q), spec(d.trimmed(5.0), 0.0)
    return run_scene(s1, build_mesh(d, s1.sizing)), run_scene(s2, build_mesh(d.trimmed(5.0), s2.sizing))
ev()
ts = []
for _ in range(int(sys.argv[1])):
    t = time.perf_counter(); r1, r2 = ev(); ts.append(time.perf_counter() - t)
print(statistics.median(ts), repr(float(r1.eps["line"][-1])), repr(float(r2.eps["line"][-1])))
"""


#: (alpha [deg], l [mm], t [mm], Q_i [MPa]), as in f1_convergence.py
DESIGNS = {
    "default": (2.862, 15.0, 3.0, 0.2),
    "slim-thin": (6.0, 15.0, 2.0, 0.2),
    "stout-thick": (2.5, 10.0, 6.0, 0.2),
    "case1": (4.0515, 11.069, 2.6521, 0.19986),
}


def run(repo: Path, n: int, design: str) -> tuple[float, float, float]:
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", PYTHONPATH=str(repo))
    out = subprocess.run([sys.executable, "-c", CHILD, str(n), *map(str, DESIGNS[design])], cwd=repo, env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    return float(out[0]), float(out[1]), float(out[2])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old", type=Path, help="checkout A (the baseline)")
    ap.add_argument("new", type=Path, help="checkout B")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--n", type=int, default=3, help="timed evaluations per process")
    ap.add_argument("--design", choices=sorted(DESIGNS), default="default")
    args = ap.parse_args()
    a_all, b_all = [], []
    print(f"{'round':>5} {'A [s]':>8} {'B [s]':>8}")
    for k in range(1, args.rounds + 1):
        a, ea_i, ea_c = run(args.old.resolve(), args.n, args.design)
        b, eb_i, eb_c = run(args.new.resolve(), args.n, args.design)
        a_all.append(a)
        b_all.append(b)
        print(f"{k:>5} {a:>8.3f} {b:>8.3f}")
    ma, mb = statistics.median(a_all), statistics.median(b_all)
    rel = max(abs(eb_i - ea_i) / abs(ea_i), abs(eb_c - ea_c) / abs(ea_c))
    print(f"{args.design}: median {ma:.3f} s -> {mb:.3f} s (ratio {mb / ma:.3f}); readings eps_i(5) {ea_i:.12f} -> "
          f"{eb_i:.12f}, eps_c(5) {ea_c:.12f} -> {eb_c:.12f} (max relative difference {rel:.1e})")


if __name__ == "__main__":
    main()
