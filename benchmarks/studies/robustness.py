"""The two tolerance estimators on one design: first-order expansion against a seeded sample.

For one genome (default: the case-1 reference optimum [4.0515°, 11.069, 2.6521, 0.19986]) at one
preset (default ``coarse``), propagates the default tolerances of the ``robustness`` section
(docs/physics.md §10) to f1 and the recovery rate by

- the first-order expansion (central differences over the whole tolerance, 2n+1 points, the
  calibration's free; plus the worst corners), and
- a Latin-hypercube sample of ``--samples`` points (and, with ``--mc``, a plain Monte Carlo
  sample of as many points with another seed, to show the sample's own scatter),

and prints a table: deviated designs solved, wall time, and mean, std and worst of each output.
Each deviated design is three FE scenes on one core.

    OMP_NUM_THREADS=1 python3 -m benchmarks.studies.robustness [--preset coarse] [--samples 32] [--mc]
        [--genes 4.0515,11.069,2.6521,0.19986]   (then the values of any gene optimiser.genes adds)
"""

from __future__ import annotations

import argparse
import time

from whisker_opt.config.model import load_config
from whisker_opt.genes import genes_dict, run_genome
from whisker_opt.robustness import StudyDesign, study_design

REFERENCE = (4.0515, 11.069, 2.6521, 0.19986)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default="configs/case1_trim5.yaml")
    ap.add_argument("--preset", default="coarse")
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--mc", action="store_true", help="also a plain Monte Carlo sample (seed + 1)")
    ap.add_argument("--genes", default=",".join(map(str, REFERENCE)))
    args = ap.parse_args()

    cfg = load_config(args.config, settings=(f"fidelity.preset={args.preset}", f"robustness.sample.n={args.samples}"))
    genes = genes_dict([float(v) for v in args.genes.split(",")], run_genome(cfg))  # in the config's genome order
    design = StudyDesign("bench", genes)
    rows = []
    t0 = time.perf_counter()
    res = study_design(cfg, design, ("expansion", "sample"))
    for method, est in res.estimates.items():
        rows.append((f"{method}" + (f" lhs n={args.samples}" if method == "sample" else ""), res.solves[method],
                     res.seconds[method], est))
    if args.mc:
        rob = cfg.robustness
        mc_cfg = cfg.model_copy(update={"robustness": rob.model_copy(update={"sample": rob.sample.model_copy(
            update={"design": "monte_carlo", "seed": rob.sample_seed(cfg.seed) + 1})})})
        mc = study_design(mc_cfg, design, ("sample",))
        rows.append((f"sample mc n={args.samples}", mc.solves["sample"] - 1, mc.seconds["sample"],
                     mc.estimates["sample"]))
    total = time.perf_counter() - t0
    print(f"design {genes} at preset {args.preset}; tolerances {cfg.robustness.tolerances.model_dump()} "
          f"({cfg.robustness.distribution}); nominal f1 = {res.nominal['f1']:.4g}, recovery = "
          f"{res.nominal['recovery_rate']:.3f} %")
    print(f"{'estimator':<20} {'solves':>6} {'time [s]':>8} {'f1 mean':>9} {'f1 std':>9} {'f1 worst':>9} "
          f"{'rec mean':>8} {'rec std':>8} {'rec worst':>9}")
    for name, solves, secs, est in rows:
        print(f"{name:<20} {solves:>6d} {secs:>8.0f} {est.mean[0]:>9.3g} {est.std[0]:>9.3g} {est.worst[0]:>9.3g} "
              f"{est.mean[1]:>8.2f} {est.std[1]:>8.2f} {est.worst[1]:>9.2f}")
    exp = res.estimates["expansion"]
    print("expansion tornado (f1 at -h / +h per tolerance, nominal "
          f"{res.nominal['f1']:.3g}): " + ", ".join(
              f"{k} {lo:.3g}/{hi:.3g}" for k, lo, hi in zip(cfg.robustness.tolerances.model_dump(), exp.minus[:, 0],
                                                          exp.plus[:, 0])))
    if res.failures:
        print("failed deviated designs:", *res.failures, sep="\n  ")
    print(f"total {total:.0f} s")


if __name__ == "__main__":
    main()
