"""Where the gauge reading's mesh error lives, and which reading of the same solution converges.

One scene per row (the intact one at Q_i or the trimmed, vented one, as one GA evaluation solves them, the
`default` preset's increments) on swept meshes that refine one thing at a time: the sectors everywhere, the
sectors at the gauge only (``MeshSizing.theta_grading``: the same element count, the sectors at the gauge
narrowed by 1 − β), the wall layers and the chamber layers. From the same solution, at δ = 5 mm:

- ``line``: the line reading of docs/physics.md §3 (ξ times the mean log stretch along the gauge's generator);
- ``foot_w``: the same over the gauge's footprint, length e times an arc of width w on the outer surface
  (16 × 8 Gauss points);
- ``dkappa``: the change of the section curvature over the gauge, (φ(x_ss + e) − φ(x_ss)) / s, with φ the tilt
  about z of the plane fitted to the deformed wall section and s the arc between the two sections' centroids
  (the ``section`` reading's curvature, :mod:`whisker_opt.experiment.readings.section`): a section integral, as
  the contact force is;
- ``transfer``: line / (ξ r_o Δκ), r_o the reference outer radius at the gauge centre: how much surface strain
  the section's curvature gives, which the periodic wall cell (docs/physics.md §14) gives converged as
  G(Q) = g(Q) (1 + ε_z(Q)) (its g is per reference length; ``cell_G`` below, bonded wall, no log correction).

Commands: ``python3 -m benchmarks.accuracy.reading_locality run --design default --csv results/locality.csv``
(then ``--design case1``), ``python3 -m benchmarks.accuracy.reading_locality report --csv results/locality.csv``.
Figures in benchmarks/results/f1_convergence.md ("Where the reading's error lives: at the gauge").
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from benchmarks.common import append_csv, design_from_genes, markdown_table, preset_spec, read_csv
from fem.query import deformation_gradient_at
from geometry.locate import PointLocator
from geometry.mesh import build_mesh
from geometry.sizing import MeshSizing
from whisker_opt.experiment.gauge import locate_gauge
from whisker_opt.experiment.readings import section
from whisker_opt.experiment.scene import run_scene
from whisker_opt.optimise.evaluator import SceneEvaluator
from whisker_opt.wall.law import mid_chamber_x
from whisker_opt.wall.table import WallTable

#: (alpha [deg], l [mm], t [mm], Q_i [MPa])
DESIGNS = {"default": (2.862, 15.0, 3.0, 0.2), "case1": (4.0515, 11.069, 2.6521, 0.19986)}
TRIM = 5.0
WIDTHS = (1.5, 3.0)
#: (label, n_theta, theta_grading, wall layers, chamber layer / pitch)
MESHES = (
    ("s8", 8, 0.0, 1, 0.5), ("s16", 16, 0.0, 1, 0.5), ("s24", 24, 0.0, 1, 0.5), ("s32", 32, 0.0, 1, 0.5),
    ("g8b.5", 8, 0.5, 1, 0.5), ("g16b.5", 16, 0.5, 1, 0.5), ("g16b.7", 16, 0.7, 1, 0.5), ("g24b.5", 24, 0.5, 1, 0.5),
    ("s8w2", 8, 0.0, 2, 0.5), ("s8w3", 8, 0.0, 3, 0.5), ("g16b.7w2", 16, 0.7, 2, 0.5), ("g16b.7w3", 16, 0.7, 3, 0.5),
    ("g16b.7w2a.25", 16, 0.7, 2, 0.25), ("g16b.7w3a.25", 16, 0.7, 3, 0.25),
)
FIELDS = ["design", "scene", "mesh", "n_theta", "grading", "layers", "axial", "elements", "time_s", "force5",
          "line", *[f"foot_{w:g}" for w in WIDTHS], "dkappa", "transfer", "cell_G"]


def _locate(mesh, pts: np.ndarray):
    loc = PointLocator(mesh.points, mesh.cells).locate(pts, tol=0.05)
    if not np.all(loc.inside):
        raise RuntimeError("sampling points outside the mesh")
    return loc


def footprint_reading(res, design, width: float, calibration: float, nx: int = 16, nt: int = 8) -> float:
    """ξ × the mean log stretch along the generators over the footprint e × width (Gauss–Legendre)."""
    mesh = res.mesh.mesh
    sx, wx = np.polynomial.legendre.leggauss(nx)
    st, wt = np.polynomial.legendre.leggauss(nt)
    x = design.x_ss + 0.5 * design.e * (sx + 1.0)  # (nx,)
    ro = np.array([design.r_outer(v) for v in x])  # (nx,)
    th = (0.5 * width / ro)[:, None] * st[None, :]  # (nx, nt)
    pts = np.stack([np.repeat(x, nt), (ro[:, None] * np.cos(th)).ravel(), (ro[:, None] * np.sin(th)).ravel()], 1)
    ta = math.tan(math.radians(design.alpha))
    tan = np.stack([np.ones(th.size), -ta * np.cos(th).ravel(), -ta * np.sin(th).ravel()], 1)  # (n, 3)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    w = np.outer(wx, wt).ravel()
    w /= w.sum()
    loc = _locate(mesh, pts)

    def stretch(u):
        F = deformation_gradient_at(mesh, u, loc.host_elements, loc.local_coords)  # (n, 3, 3)
        return np.linalg.norm(np.einsum("nij,nj->ni", F, tan), axis=1)  # (n,)

    lam0, lam = stretch(res.states["pressurised"].u), stretch(res.states["deflected"].u)
    return calibration * float(w @ np.log(lam / lam0))


def curvature_change(res, design) -> float:
    """Δκ over the gauge between onset and the last solved deflection [1/mm]: the section reading's own
    curvature (:func:`whisker_opt.experiment.readings.section.state`) of the two kept states."""
    gauge = locate_gauge(res.mesh, design)
    k0, k1 = (section.state(res.mesh.mesh, res.states[key].u, gauge) for key in ("pressurised", "deflected"))
    return k1 - k0


def cell_transfer(design, Q: float) -> float:
    """G(Q) = g(Q) (1 + ε_z(Q)) of the stored bonded wall cell at the design's mid-chamber wall."""
    table = WallTable.load()
    ri = design.r_inner(mid_chamber_x(design))
    g = table.lookup("bonded", "g", ri, design.t)
    ez = table.lookup("bonded", "ez", ri, design.t)
    return float(np.interp(Q, table.pressures, g) * (1.0 + np.interp(Q, table.pressures, ez)))


def measure(design_name: str, scene: str, mesh: tuple) -> dict:
    """One scene on one mesh: its row."""
    label, n_theta, beta, layers, axial = mesh
    alpha, l, t, q_i = DESIGNS[design_name]  # noqa: E741
    sizing = MeshSizing(wall_layers=float(layers), n_theta=n_theta, theta_grading=beta, axial_pitch_fraction=axial,
                        h_body=10.0, name=label)
    base = preset_spec(design_from_genes(alpha, l, t), "default", sizing=sizing, mesh_method="swept")
    ev = SceneEvaluator(base, trim=TRIM)
    intact, trimmed = ev.specs({"alpha": alpha, "l": l, "t": t, "Q_i": q_i})
    spec = intact if scene == "intact" else trimmed
    t0 = time.perf_counter()
    wm = build_mesh(spec.design, spec.sizing, method="swept", num_threads=1)
    res = run_scene(spec, wm, keep_states=True)
    xi = spec.calibration
    d = spec.design
    dk = curvature_change(res, d)
    line = float(res.eps["line"][-1])
    ro = d.r_outer(d.x_ss + 0.5 * d.e)
    row = {"design": design_name, "scene": scene, "mesh": label, "n_theta": n_theta, "grading": beta,
           "layers": layers, "axial": axial, "elements": wm.mesh.n_elements, "force5": f"{res.contact_force[-1]:.6f}",
           "line": f"{line:.6f}", "dkappa": f"{dk:.6e}", "transfer": f"{line / (xi * ro * dk):.5f}",
           "cell_G": f"{cell_transfer(d, spec.Q):.5f}"}
    for w in WIDTHS:
        row[f"foot_{w:g}"] = f"{footprint_reading(res, d, w, xi):.6f}"
    row["time_s"] = f"{time.perf_counter() - t0:.1f}"
    return row


def report(rows: list[dict]) -> str:
    """Markdown tables, one per design and scene, with each column's spread (max − min) / mean."""
    out = []
    for name in dict.fromkeys(r["design"] for r in rows):
        for scene in ("intact", "trimmed"):
            sub = [r for r in rows if r["design"] == name and r["scene"] == scene]
            if not sub:
                continue
            out.append(f"**{name}, {scene}**\n\n" + markdown_table(sub, ["mesh", "elements", "force5", "line",
                       *[f"foot_{w:g}" for w in WIDTHS], "dkappa", "transfer", "cell_G", "time_s"]))
            spread = []
            for col in ("force5", "line", *[f"foot_{w:g}" for w in WIDTHS], "dkappa", "transfer"):
                v = np.array([float(r[col]) for r in sub])
                spread.append(f"{col} {100 * (v.max() - v.min()) / abs(v.mean()):.2f} %")
            out.append("Spread over the meshes, (max − min)/mean: " + ", ".join(spread) + "\n")
    return "\n\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    run = sub.add_parser("run", help="solve the scenes and append rows to the CSV")
    run.add_argument("--design", choices=sorted(DESIGNS), default="default")
    run.add_argument("--scenes", default="intact,trimmed")
    run.add_argument("--meshes", default=",".join(m[0] for m in MESHES), help="labels of MESHES, comma-separated")
    run.add_argument("--csv", type=Path, required=True)
    rep = sub.add_parser("report", help="print the tables of a CSV")
    rep.add_argument("--csv", type=Path, required=True)
    args = ap.parse_args(argv)
    if args.cmd == "report":
        print(report(read_csv(args.csv)))
        return 0
    by_label = {m[0]: m for m in MESHES}
    for label in args.meshes.split(","):
        for scene in args.scenes.split(","):
            row = measure(args.design, scene, by_label[label])
            append_csv(args.csv, row, FIELDS)
            print(" ".join(f"{k}={row[k]}" for k in FIELDS if k in row), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
