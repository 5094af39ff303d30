"""Which fibre model does a wall with resolved fibres follow? A periodic cell of the chamber wall.

The cell, its loads and the fibre models are described in :mod:`peers.wall_cell3d`
(``resolved``, ``resolved-rigid``, ``weak-ring``, ``band``, ``embedded``, ``smeared``, ``none``).

Printed per model and mesh: the axial strain of the wall U/s at Q = 0.1 and 0.2 MPa (the chamber's
extension per unit length, Δl/(l − c) of a whisker), the bending stiffness EI at Q = 0 and its ratio
EI(Q)/EI(0) (the thesis' prototypes: k(Q) = −1.337 Q + 0.9958, 0.862 at 0.1 and 0.728 at 0.2 MPa,
inferred from their gauge signals). Usage::

    OMP_NUM_THREADS=1 python3 -m benchmarks.studies.fibre_cell [--models resolved,embedded,smeared,none]
        [--levels 1,2] [--n-phi 16]

On one core: resolved level 1 (9 216 tets) about 5 min, level 2 (36 864 tets) 90 min; embedded and
smeared up to 12 wall layers under 2.5 min each. Measured figures: ``benchmarks/results/fibre_cell.md``.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys

from benchmarks.common import markdown_table
from peers.wall_cell3d import PRESSURES, Cell, measure
from whisker_opt.analysis.beam import LinearSoftening

#: The thesis' prototypes' effective modulus of the chamber region, k(Q) of the beam model's softening law.
PROTOTYPE_K = {Q: LinearSoftening()(Q) for Q in PRESSURES}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default="resolved,resolved-rigid,embedded,smeared,none")
    ap.add_argument("--levels", default=None, help="resolved: 1,2 (fibre cut into 2k × 2k); others: wall layers "
                                                   "(default 1,2,3,4,6,8)")
    ap.add_argument("--n-phi", type=int, default=16, help="cells around the half tube (even)")
    ap.add_argument("--smeared-scale", type=float, default=1.0,
                    help="factor on the smeared model's stiffness (1 = as in the product)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="  %(message)s", stream=sys.stderr)  # the cell's progress
    if not args.smeared_scale > 0:
        ap.error(f"--smeared-scale={args.smeared_scale}: must be > 0")
    if args.n_phi < 2 or args.n_phi % 2:
        ap.error(f"--n-phi={args.n_phi}: must be an even integer >= 2 (a node row at 90° carries the pin)")
    cell = Cell.default()
    print(f"cell: r_i = {cell.r_i:.3f} mm, t = {cell.t} mm, r_f = {cell.r_f:.3f} mm, s = {cell.s} mm, "
          f"fibre square {cell.side:.4f} mm, E_f A_f = {cell.E_f * cell.A_f:.0f} N; n_phi = {args.n_phi}")
    rows = []
    for model in args.models.split(","):
        default = "1,2" if model.startswith("resolved") else "1,2,3,4,6,8"
        for level in (int(v) for v in (args.levels or default).split(",")):
            row = measure(cell, model, level, args.n_phi, args.smeared_scale)
            rows.append(row)
            print(markdown_table([row], list(row)), flush=True)
    ref = [r for r in rows if r["model"] == "resolved"]
    cols = ["model", "level", "n_el", "n_r", "n_z"] + [f"ez_{Q}" for Q in PRESSURES] + ["EI0"] + \
        [f"EIr_{Q}" for Q in PRESSURES] + [f"EIw_{Q}" for Q in PRESSURES] + ["t_s"]
    print()
    print(markdown_table(rows, cols))
    print("prototype k(Q): " + ", ".join(f"{Q}: {k:.3f}" for Q, k in PROTOTYPE_K.items()))
    if ref:
        r = ref[-1]
        print("relative to resolved level", r["level"])
        rel = [{"model": x["model"], "level": x["level"],
                **{c: x.get(c, math.nan) / r[c] for c in cols if c.startswith(("ez_", "EI"))}} for x in rows]
        print(markdown_table(rel, ["model", "level"] + [c for c in cols if c.startswith(("ez_", "EI"))]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
