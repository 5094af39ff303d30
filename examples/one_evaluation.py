"""Evaluate one genome [α, l, t, Q_i] as the GA does; print f1 and the timings.

Usage: python3 examples/one_evaluation.py [OUTDIR]
An evaluation writes no files: OUTDIR is accepted like in the other examples, and unused.
"""
import sys

import whisker_opt as wo

cfg = wo.load_config({
    "fidelity": {"preset": "coarse"},
    "scene": {"deflection": 5.0},
    "optimiser": {"trim": 5.0},  # the trimmed whisker is 5 mm shorter and vented
})
genes = {"alpha": 4.0, "l": 12.0, "t": 3.0, "Q_i": 0.1}  # deg, mm, mm, MPa
res = wo.evaluate(cfg, genes)

print("genes", genes)
print(f"status = {res.status} {res.reason}")
if not res.ok:
    sys.exit(1)
print(f"f1 = {res.f1:.6g}")
for stage, seconds in res.timings.items():
    print(f"  {stage:<22} {seconds:8.3f} s")
