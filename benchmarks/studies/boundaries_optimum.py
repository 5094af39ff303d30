"""What the prototype's boundary mechanisms would change in a reference case's optimum: f1 and the vent's
recovery rate of the case-1 optimum and of the thesis' default design, solved with the clamped base (the
default scene), the soft compliant base, and the soft base with the gauge's bonded backing at its calibrated
modulus (docs/physics.md §14.2; the mechanisms' settings are those of ``benchmarks.prototype.MECHANISMS``).

Each (design, mechanism) is :func:`whisker_opt.analysis.law_spread.law_spread` of the run file with the
mechanism's settings under its own wall law: the intact, uncompensated and trimmed scenes at the run file's
preset, f1 of the intact and trimmed curves, and the recovery rate of a full vent (docs/physics.md §7).

Usage::

    OMP_NUM_THREADS=1 python3 -m benchmarks.studies.boundaries_optimum [--config configs/case1_trim5.yaml]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from benchmarks.prototype import MECHANISMS
from whisker_opt.analysis.law_spread import law_spread
from whisker_opt.config.model import load_config

ROOT = Path(__file__).resolve().parents[2]
#: The designs: the case-1 optimum (benchmarks/results/bench_case.md) and the thesis' default design at Q_i = 0.2.
DESIGNS = {"case-1 optimum": {"alpha": 4.0515, "l": 11.069, "t": 2.6521, "Q_i": 0.19986},
           "thesis default": {"alpha": 2.862, "l": 15.0, "t": 3.0, "Q_i": 0.2}}
#: The mechanisms compared (names of ``boundaries.MECHANISMS``).
COMPARED = ("clamped (as before)", "compliant base (h = 10 mm)", "compliant base (h = 10) + bonded gauge (calibrated)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", type=Path, default=ROOT / "configs" / "case1_trim5.yaml")
    ap.add_argument("--preset", default=None, help="fidelity preset (default: the config's)")
    args = ap.parse_args(argv)
    base = (f"fidelity.preset={args.preset}",) if args.preset else ()
    print("| design | mechanism | f1 | recovery rate | trim effect | status | time [s] |")
    print("|---|---|---:|---:|---:|---|---:|")
    for name in COMPARED:
        cfg = load_config(args.config, settings=base + MECHANISMS[name])
        t0 = time.perf_counter()
        rows = law_spread(cfg, list(DESIGNS.values()), [cfg.material.wall_law])
        for design, r in zip(DESIGNS, rows):
            rate = f"{r['recovery_rate']:.1f} %" if r["recovery_rate"] == r["recovery_rate"] else "-"
            status = r["status"] if r["status"] == "ok" else f"{r['status']}: {r['reason'][:80]}"
            print(f"| {design} | {name} | {r['f1']:.3g} | {rate} | {r['trim_effect']:.3g} | {status} | "
                  f"{r['time_s']:.0f} |", flush=True)
        print(f"# {name}: {time.perf_counter() - t0:.0f} s, preset {cfg.fidelity.preset}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
