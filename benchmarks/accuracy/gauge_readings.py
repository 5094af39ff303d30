"""Does the way the gauge is read decide how f1 converges? Three readings over a mesh refinement.

For the three designs of ``time_vs_error.py`` (intact at Q_i = 0.2 MPa, trimmed 5 mm and
vented, contact at the tip, δ to 5 mm) on its swept mesh levels k (``wall_layers = k``),
f1 and the readings at δ = 5 mm are computed from the same solved scenes with

``line``
    the default: mean over the gauge's Gauss points of ln(λ(δ)/λ(0)), λ = |F T| (element-wise F);
``centroid``
    the axial Eulerian log strain at the centroid of the element under the gauge centre;
``chord``
    from displacements only: ln(ℓ(δ)/ℓ(0)) of the chord between the gauge's end points, the
    elongation of the gauge's material line that a bonded gauge measures.

If the line reading converged slowly because F is discontinuous between elements, the chord
reading (continuous displacements, no derivative) would converge differently. All readings
are calibrated (× ξ). Usage::

    python3 -m benchmarks.accuracy.gauge_readings [--designs default,slim-thin,stout-thick] [--levels 1,2,3]
"""

from __future__ import annotations

import argparse

from benchmarks.common import markdown_table
from benchmarks.mesh_study import DESIGNS
from benchmarks.readings import VARIANTS, measure


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--designs", default=",".join(DESIGNS),
                    help="comma-separated names of benchmarks.mesh_study.DESIGNS")
    ap.add_argument("--levels", default="1,2,3", help="swept mesh levels (4 takes 500-800 s per evaluation)")
    ap.add_argument("--fibre-model", default="embedded", choices=("embedded", "smeared"),
                    help="SceneSpec.fibre_model of every scene")
    args = ap.parse_args()
    rows = [measure(d, int(k), args.fibre_model) for d in args.designs.split(",") for k in args.levels.split(",")]
    cols = ["design", "level", "elements", "time_s", "dl_mm"] + [f"{q}_{v}" for v in VARIANTS for q in
                                                                ("f1", "eps_i", "eps_c")]
    print(markdown_table(rows, cols))


if __name__ == "__main__":
    main()
