"""Read a run directory back: the best design and the generation table.

Usage: python3 examples/read_a_run.py [RUN_DIR | OUTDIR]
A run directory (holding config.yaml) is read as it is; otherwise a tiny GA is run into
OUTDIR (default: a new temporary directory) first.
"""
import sys
import tempfile
from pathlib import Path

import whisker_opt as wo

arg = Path(sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="whisker-"))
if (arg / "config.yaml").is_file():
    run_dir = arg
else:
    cfg = wo.load_config({
        "fidelity": {"preset": "coarse"},
        "optimiser": {"ga": {"population": 4, "n_elite": 1}, "executor": {"kind": "serial"},
                      "stopping": {"max_generations": 1, "target_fp": 0.0}},
    })
    run_dir = wo.run(cfg, arg / "run").run_dir

res = wo.load_run(run_dir)
print(f"run {res.run_dir}: {len(res.evaluations)} evaluations, stopped by {res.stop_reason}")
print("best design", {k: round(v, 4) for k, v in res.best_genes.items()})
print(f"f1 = {res.best['f1']:.6g}  F_p = {res.best['F_p']:.6g}  (generation {res.best['generation_found']})")
print(f"{'gen':>4} {'evals':>6} {'fail':>5} {'best F_p':>11} {'mean F_p':>11} {'best f1':>11}")
for g in res.generations:
    print(f"{g['generation']:>4} {g['evals']:>6} {g['n_failures']:>5} {g['best_fp']:>11.4g} "
          f"{g['mean_fp']:>11.4g} {g['best_f1']:>11.4g}")
