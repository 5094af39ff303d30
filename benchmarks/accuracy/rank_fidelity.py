"""Does the GA's fidelity rank designs as a finer one does? f1 of random designs at two presets.

Draws ``--n`` designs uniformly from the GA box of ``configs/case1_trim5.yaml`` (seeded),
evaluates each with the GA's evaluator at ``--low`` and ``--high`` presets and prints f1 at
both, their ratio, and the Spearman rank correlation of the two f1 columns (1 = same order).
Failed evaluations are listed and left out of the correlation.

Usage::

    python3 -m benchmarks.accuracy.rank_fidelity [--n 8] [--low default] [--high fine] [--seed 1]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from scipy import stats

from whisker_opt.config.model import load_config
from whisker_opt import wiring
from whisker_opt.experiment.fidelity import PRESET_NAMES
from whisker_opt.genes import GENE_NAMES


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", type=Path, default=Path("configs/case1_trim5.yaml"))
    ap.add_argument("--n", type=int, default=8, help="number of random designs")
    ap.add_argument("--low", default="default", choices=PRESET_NAMES)
    ap.add_argument("--high", default="fine", choices=PRESET_NAMES)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    cfg = load_config(args.config)
    opt = wiring.optimiser_of(cfg)
    bounds = dict(zip(GENE_NAMES, opt.genes.bounds()))
    rng = np.random.default_rng(args.seed)
    evs = {p: wiring.evaluator(wiring.with_preset(cfg, p)) for p in (args.low, args.high)}
    print(f"{'alpha':>7} {'l':>7} {'t':>6} {'Q_i':>7} {'f1 ' + args.low:>12} {'f1 ' + args.high:>12} {'ratio':>7} "
          f"{'t_low':>6} {'t_high':>7}")
    rows = []
    for _ in range(args.n):
        genes = {g: float(rng.uniform(lo, hi)) for g, (lo, hi) in bounds.items()}
        out = {}
        for p, ev in evs.items():
            t = time.perf_counter()
            out[p] = (ev(genes), time.perf_counter() - t)
        lo_, hi_ = out[args.low][0], out[args.high][0]
        if lo_.ok and hi_.ok:
            rows.append((lo_.f1, hi_.f1))
            print(f"{genes['alpha']:>7.3f} {genes['l']:>7.3f} {genes['t']:>6.3f} {genes['Q_i']:>7.4f} {lo_.f1:>12.4e} "
                  f"{hi_.f1:>12.4e} {hi_.f1 / lo_.f1:>7.3f} {out[args.low][1]:>6.1f} {out[args.high][1]:>7.1f}",
                  flush=True)
        else:
            print(f"{genes}: {args.low} {lo_.status} {lo_.reason}; {args.high} {hi_.status} {hi_.reason}", flush=True)
    if len(rows) >= 3:
        a = np.array(rows)
        rho = stats.spearmanr(a[:, 0], a[:, 1]).statistic
        print(f"Spearman rank correlation of f1 ({args.low} vs {args.high}) over {len(a)} designs: {rho:.3f}; "
              f"f1 ratio {args.high}/{args.low}: median {np.median(a[:, 1] / a[:, 0]):.3f}, "
              f"range {np.min(a[:, 1] / a[:, 0]):.3f}-{np.max(a[:, 1] / a[:, 0]):.3f}")


if __name__ == "__main__":
    main()
