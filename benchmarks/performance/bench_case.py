"""Full reference case benchmark: run a case config and print what the run cost.

Prints wall time, evaluations, cache hits, failures, generations, the stopping rule that
fired and the best design with f1 and F_p. Target for ``configs/case1_trim5.yaml`` with the
default preset: under 1 hour on this 2-core machine.

Usage::

    python3 -m benchmarks.performance.bench_case [configs/case1_trim5.yaml] [--set KEY=VALUE ...] [--out DIR]

``--set`` changes a run-file key as ``whisker-opt run --set`` does, e.g. the whole 50 generations of
case 1 with ``--set optimiser.stopping.target_fp=0`` (the thesis' F_p rule otherwise stops it early).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from whisker_opt import wiring
from whisker_opt.config.model import dump_config, load_config
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.optimise.runner import check_new_run_dir, run_optimisation


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config", type=Path, nargs="?", default=Path("configs/case1_trim5.yaml"))
    ap.add_argument("--set", dest="settings", action="append", default=[], metavar="KEY=VALUE",
                    help="set a run-file key over the file (repeatable), e.g. optimiser.stopping.target_fp=0")
    ap.add_argument("--out", type=Path, default=None, help="run directory (default benchmarks/out/<stem>-<time>)")
    args = ap.parse_args()
    cfg = load_config(args.config, settings=args.settings)
    opt = cfg.optimiser or OptimiserConfig()
    out = args.out or Path("benchmarks/out") / f"{args.config.stem}-{time.strftime('%Y%m%d-%H%M%S')}"
    check_new_run_dir(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.yaml").write_text(dump_config(cfg))  # as `whisker-opt run`: report, view and verify read it
    t = time.perf_counter()
    s = run_optimisation(opt, out, wiring.evaluator(cfg), opt.resolve_seed(cfg.seed), progress=True)
    wall = time.perf_counter() - t
    best = s.best or {}
    print(f"case            {args.config} {' '.join('--set ' + x for x in args.settings)} "
          f"(preset {cfg.fidelity.preset}, trim {opt.trim} mm, {opt.executor.n_workers} workers)")
    print(f"wall time       {wall:.1f} s ({wall / 3600:.2f} h; target < 1 h)")
    print(f"evaluations     {s.n_evaluations} solved, {s.n_cache_hits} cache hits, {s.n_failures} failed")
    print(f"generations     {s.generations}, stopping rule: {s.stop_reason}")
    print(f"best design     {best.get('genes')}")
    print(f"best f1, F_p    {best.get('f1')}, {best.get('F_p')}")
    print(f"run directory   {out}")


if __name__ == "__main__":
    main()
