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

    python3 benchmarks/gauge_readings.py [--designs default,slim-thin,stout-thick] [--levels 1,2,3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

sys.path.insert(0, str(Path(__file__).resolve().parent))

import time_vs_error as tv  # noqa: E402
from _bench_common import design_from_genes, markdown_table, preset_spec  # noqa: E402

from fem.query import positions_at  # noqa: E402
from geometry.locate import PointLocator  # noqa: E402
from whisker_opt.experiment import objective  # noqa: E402
from whisker_opt.experiment.evaluator import SceneEvaluator  # noqa: E402
from whisker_opt.experiment.scene import run_scene  # noqa: E402

VARIANTS = ("line", "centroid", "chord")


def chord_reading(res, design, calibration: float) -> np.ndarray:
    """ξ ln(ℓ/ℓ_0) of the chord between the gauge's end points at every solved state (onset first)."""
    mesh = res.mesh.mesh
    xa, xb = design.x_ss, design.x_ss + design.e
    ends = np.array([[xa, design.r_outer(xa), 0.0], [xb, design.r_outer(xb), 0.0]])
    loc = PointLocator(mesh.points, mesh.cells).locate(ends, tol=0.05)
    states = [res.states["pressurised"]] + [res.states[k] for k in sorted(
        (k for k in res.states if k.startswith("delta_")), key=lambda k: float(k[6:]))]
    if res.states["deflected"] is not states[-1]:
        states.append(res.states["deflected"])
    length = np.array([np.linalg.norm(np.diff(positions_at(mesh, s.u, loc.host_elements, loc.local_coords), axis=0))
                       for s in states])
    return calibration * np.log(length / length[0])


def _curve(delta_solved, y, delta):
    return CubicSpline(delta_solved, y)(delta) if len(delta_solved) >= 4 else np.interp(delta, delta_solved, y)


def measure(design_name: str, level: int, fibre_model: str = "embedded") -> dict:
    """One evaluation of a design on mesh level ``level``: Δl, and f1, ε_i(5), ε_c(5) per reading."""
    alpha, l, t = tv.DESIGNS[design_name]
    cfg = tv.mesh_level(level)
    ev = SceneEvaluator(preset_spec(design_from_genes(alpha, l, t), cfg.preset, fibre_model=fibre_model,
                                   **cfg.overrides), trim=tv.TRIM)
    specs = dict(zip(("i", "c"), ev.specs({"alpha": alpha, "l": l, "t": t, "Q_i": tv.Q_I})))
    t0 = time.perf_counter()
    res = {k: run_scene(s, keep_states=True) for k, s in specs.items()}
    row = {"design": design_name, "level": level, "elements": res["i"].mesh.mesh.n_elements,
           "time_s": round(time.perf_counter() - t0, 1), "dl_mm": res["i"].delta_l}
    delta = ev.samples()
    for var in VARIANTS:
        cur = {}
        for k, s in specs.items():
            r = res[k]
            y = {"line": r.eps_line, "centroid": r.eps_centroid}.get(var)
            cur[k] = _curve(r.delta, chord_reading(r, s.design, s.calibration) if y is None else y, delta)
        row.update({f"f1_{var}": objective.f1(cur["i"], cur["c"]), f"eps_i_{var}": float(cur["i"][-1]),
                    f"eps_c_{var}": float(cur["c"][-1])})
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--designs", default=",".join(tv.DESIGNS), help="comma-separated names of time_vs_error.DESIGNS")
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
