"""Do Δl, ε and f1 converge under mesh refinement? The embedded and the smeared fibre model side by side.

For each design of ``time_vs_error.py`` and each fibre model (``SceneSpec.fibre_model``), one evaluation
(intact at 0.2 MPa, trimmed 5 mm and vented, a = 1, δ to 5 mm, line reading) on the swept mesh levels
k (nominal size h = 1/k, ``time_vs_error.mesh_level``), then, over the last three levels, whether each
quantity changes monotonically, its observed order p and the Richardson value. Usage::

    OMP_NUM_THREADS=1 python3 -m benchmarks.studies.fibre_models [--designs default,slim-thin,stout-thick]
        [--levels 1,2,3] [--models embedded,smeared]

Levels 1-3 take about 5 min per design and model on one core; level 4 500-800 s per evaluation.
"""

from __future__ import annotations

import argparse
import math

from benchmarks.common import markdown_table
from benchmarks.numerics import richardson
from benchmarks.readings import measure

QUANTITIES = (("dl_mm", "Δl"), ("eps_i_line", "ε_i(5)"), ("eps_c_line", "ε_c(5)"), ("f1_line", "f1"))


def summarise(rows: list[dict]) -> list[dict]:
    """One row per (design, model, quantity): the values per level, monotone, p, q∞, error of level 1."""
    out = []
    keys = sorted({(r["design"], r["model"]) for r in rows}, key=lambda k: (k[0], k[1]))
    for design, model in keys:
        rs = sorted((r for r in rows if r["design"] == design and r["model"] == model), key=lambda r: r["level"])
        for key, label in QUANTITIES:
            vals = [r[key] for r in rs]
            row = {"design": design, "model": model, "quantity": label,
                   "values": " / ".join(f"{v:.5g}" for v in vals)}
            if len(rs) >= 3:
                h = tuple(1.0 / r["level"] for r in rs[-3:])
                diffs = [b - a for a, b in zip(vals, vals[1:])]
                p, qinf = richardson(h, vals[-3:], bracket=(0.1, 10.0))
                row.update(monotone="yes" if all(d * diffs[0] > 0 for d in diffs) else "no",
                           p=f"{p:.2f}" if math.isfinite(p) else "-",
                           richardson=f"{qinf:.5g}" if math.isfinite(qinf) else "-",
                           err_first=f"{(vals[0] - qinf) / qinf:+.1%}" if math.isfinite(qinf) else "-")
            out.append(row)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--designs", default="default,slim-thin,stout-thick")
    ap.add_argument("--levels", default="1,2,3")
    ap.add_argument("--models", default="embedded,smeared")
    args = ap.parse_args()
    rows = []
    for d in args.designs.split(","):
        for m in args.models.split(","):
            for k in args.levels.split(","):
                r = measure(d, int(k), m)
                r["model"] = m
                rows.append(r)
                print(f"# {d} {m} level {k}: {r['elements']} elements, {r['time_s']} s, Δl {r['dl_mm']:.5g} mm, "
                      f"ε_i {r['eps_i_line']:.5g}, ε_c {r['eps_c_line']:.5g}, f1 {r['f1_line']:.5g}", flush=True)
    print(markdown_table(rows, ["design", "model", "level", "elements", "time_s", "dl_mm", "eps_i_line",
                                "eps_c_line", "f1_line"]))
    print()
    print(markdown_table(summarise(rows), ["design", "model", "quantity", "values", "monotone", "p", "richardson",
                                           "err_first"]))


if __name__ == "__main__":
    main()
