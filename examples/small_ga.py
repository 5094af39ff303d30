"""A small serial GA on the coarse preset: population 4, one generation; print the best design.

Usage: python3 examples/small_ga.py [OUTDIR]   (default: a new temporary directory)
"""
import sys
import tempfile
from pathlib import Path

import whisker_opt as wo

out = Path(sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="whisker-"))
cfg = wo.load_config({
    "fidelity": {"preset": "coarse"},
    "scene": {"deflection": 5.0},
    "optimiser": {
        "trim": 5.0,
        "ga": {"population": 4, "n_elite": 1},
        "stopping": {"max_generations": 1, "target_fp": 0.0},  # breed exactly one generation
        "executor": {"kind": "serial"},
    },
    "output": {"results_dir": str(out), "name": "small_ga"},
    "seed": 1,
})
summary = wo.run(cfg)  # into a new <OUTDIR>/small_ga-run-<time> directory

best = summary.best
print(f"run directory {summary.run_dir}")
print(f"stopped by {summary.stop_reason} after generation {summary.generations}, "
      f"{summary.n_evaluations} evaluations, {summary.n_failures} failed")
print("best design")
for name, value in best["genes"].items():
    print(f"  {name:<6} {value:.4f}")
print(f"f1 = {best['f1']:.6g}")
print(f"F_p = {best['F_p']:.6g}")
