"""The three gauge readings of one evaluation on a swept mesh level: the line reading (the
default), the centroid reading and the chord reading (from displacements only), with f1 and
the readings at δ = 5 mm of each (the designs and mesh levels of
:mod:`benchmarks.mesh_study`).

Shared by ``benchmarks.accuracy.gauge_readings`` and ``benchmarks.studies.fibre_models``.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.interpolate import CubicSpline

from benchmarks.common import design_from_genes, preset_spec
from benchmarks.mesh_study import DESIGNS, Q_I, TRIM, mesh_level
from fem.query import positions_at
from geometry.locate import PointLocator
from whisker_opt.experiment import objective
from whisker_opt.optimise.evaluator import SceneEvaluator
from whisker_opt.experiment.scene import run_scene

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
    alpha, l, t = DESIGNS[design_name]
    cfg = mesh_level(level)
    ev = SceneEvaluator(preset_spec(design_from_genes(alpha, l, t), cfg.preset, fibre_model=fibre_model,
                                   **cfg.overrides), trim=TRIM)
    specs = dict(zip(("i", "c"), ev.specs({"alpha": alpha, "l": l, "t": t, "Q_i": Q_I})))
    t0 = time.perf_counter()
    res = {k: run_scene(s, keep_states=True) for k, s in specs.items()}
    row = {"design": design_name, "level": level, "elements": res["i"].mesh.mesh.n_elements,
           "time_s": round(time.perf_counter() - t0, 1), "dl_mm": res["i"].delta_l}
    delta = ev.samples()
    for var in VARIANTS:
        cur = {}
        for k, s in specs.items():
            r = res[k]
            y = r.eps.get(var)
            cur[k] = _curve(r.delta, chord_reading(r, s.design, s.calibration) if y is None else y, delta)
        row.update({f"f1_{var}": objective.f1(cur["i"], cur["c"]), f"eps_i_{var}": float(cur["i"][-1]),
                    f"eps_c_{var}": float(cur["c"][-1])})
    return row
