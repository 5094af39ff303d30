"""Which mesh setting buys accuracy where: one-at-a-time changes of the default preset's sizing.

Each variant is a swept mesh with the ``default`` preset's sizing and one or two settings
changed (sectors ``n_theta``, axial pitch, wall layers). Every variant runs one GA evaluation
(intact at Q_i = 0.2 MPa + trimmed 5 mm vented, see ``time_vs_error.py``) at the three
designs of ``time_vs_error.py`` and prints the time and the signed errors of Δl, ε(5 mm)
and f1 against that benchmark's Richardson references, read from its ``runs.csv`` (run
``time_vs_error.py`` first).

Usage::

    python3 -m benchmarks.accuracy.sizing_study [--variants base,th12,L2] [--runs results/benchmarks/time_vs_error/runs.csv]
"""

from __future__ import annotations

import argparse
import csv
import sys
from dataclasses import replace
from pathlib import Path

from benchmarks import mesh_study

#: variant name -> MeshSizing fields changed from the default preset
VARIANTS = {
    "base": {},
    "th12": dict(n_theta=12),
    "th16": dict(n_theta=16),
    "pitch.25": dict(axial_pitch_fraction=0.25),
    "L2": dict(wall_layers=2.0),
    "th12+pitch.25": dict(n_theta=12, axial_pitch_fraction=0.25),
    "L2+th12": dict(wall_layers=2.0, n_theta=12),
}


def main() -> None:
    from whisker_opt.experiment.fidelity import PRESETS

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated names from: " + ", ".join(VARIANTS))
    ap.add_argument("--runs", type=Path, default=Path("results/benchmarks/time_vs_error/runs.csv"),
                    help="runs.csv of time_vs_error.py (its mesh levels give the references)")
    args = ap.parse_args()
    names = args.variants.split(",")
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        ap.error(f"--variants: unknown {unknown}; allowed: {list(VARIANTS)}")
    if not args.runs.is_file():
        ap.error(f"--runs: {args.runs} does not exist; run benchmarks/accuracy/time_vs_error.py first")
    with args.runs.open() as fh:
        runs = [r for r in csv.DictReader(fh) if r["family"] == "mesh"]
    _, refs = mesh_study.analyse(runs)
    base = PRESETS["default"].sizing
    print(f"{'variant':14s} {'design':12s} {'elements':>8} {'time [s]':>8} {'err dl':>8} {'err eps5':>8} {'err f1':>8}")
    for name in names:
        for d in mesh_study.DESIGNS:
            if d not in refs:
                continue
            cfg = mesh_study.Config(name, "study",
                                    overrides={"sizing": replace(base, **VARIANTS[name]), "mesh_method": "swept"})
            r = mesh_study.evaluate(d, cfg)
            e = {q: (r[q] - refs[d][q][0]) / refs[d][q][0] for q in mesh_study.QUANTITIES}
            print(f"{name:14s} {d:12s} {r['n_elements']:>8d} {r['time_s']:>8.1f} {e['delta_l']:>+8.2%} "
                  f"{e['eps5']:>+8.2%} {e['f1']:>+8.1%}", flush=True)


if __name__ == "__main__":
    main()
