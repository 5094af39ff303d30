"""Run time against error of the whisker scene: what each setting and shortcut buys.

One *evaluation* is what the GA pays per design: the intact whisker at
Q_i = 0.2 MPa and the same design trimmed by 5 mm and vented, contact at the tip, δ to
5 mm. Its wall time (meshing included) is set against the relative errors of

(a) Δl, the axial extension at Q = 0.2 MPa (intact scene);
(b) ε(5 mm), the calibrated gauge reading (line variant) of the intact scene;
(c) f1 = mean over δ_k = 0.01 … 5 mm of |ε_i(δ_k) − ε_c(δ_k)| (the definition of
    :class:`whisker_opt.optimise.evaluator.SceneEvaluator`, curves by its spline);

against references extrapolated (Richardson) from the finest levels of a mesh study.

Configurations (families)
-------------------------
``mesh``
    Structured swept meshes (``mesh_method="swept"``), level k = 1 … 4:
    ``wall_layers = k``, ``n_theta = 8, 10, 12, 16``, ``axial_pitch_fraction = 0.5/k``,
    ``h_body = 10/k`` (nominal size h = 1/k), 10 deflection and 2 pressure steps, the
    default solver options. The reference of each quantity is the Richardson
    extrapolation of the three finest levels (observed order p from their ratio; p = 2,
    the P2 rate, from the two finest when the three are not monotone).
``preset``
    The fidelity presets coarse / default / fine (``whisker_opt.experiment.fidelity``; template
    meshes).
``increments``
    The default preset with 2, 5, 10, 20 deflection steps (3 is the preset).
``rtol``
    The default preset with Newton tolerance ``SolveOptions.rtol`` = 1e-4, 1e-6, 1e-10.
``shortcut``
    The default preset without one shortcut each: swept mesh instead of the mapped
    template; a fresh fTetWild mesh (1 thread; default design only unless
    ``--fresh-corners``); full Newton (``reuse_tangent = 0``)
    instead of the modified Newton; no secant predictor (``extrapolate = False``); and
    with one extra shortcut, loose intermediate increments (``intermediate_rtol = 1e-4``).
Element order is not a variable: the solver has the 10-node tetrahedron only.

``--ccx`` adds CalculiX on the default preset's mesh of the default design: CalculiX has
no embedded trusses and no hybrid elements, so both codes solve that mesh *without
fibres*, at Q = 0, D1 = 2/(1000 μ) (K/μ = 1000), tip face pushed 5 mm in 10 increments;
the row gives both times and the difference of ε(5 mm): our mixed P2/P0 formulation
against C3D10, and our solver in the same displacement (C3D10-like) formulation against
C3D10, which separates the codes' difference from the formulations'. Skipped when
``ccx`` is not on PATH.

Outputs (``--out``, default ``results/benchmarks/time_vs_error/``): ``runs.csv`` (one row
per evaluation, appended as it finishes), ``errors.csv`` and ``errors.md`` (errors against
the references, Pareto flags), ``time_vs_error.png`` (log–log, Pareto front as a line,
presets as stars). Printed: the table and whether the ``default`` preset is on or near
(error within 2× of the front at its run time) the Pareto front.

Usage::

    python3 -m benchmarks.accuracy.time_vs_error --quick      # default design, levels 1-3, ~8 min
    python3 -m benchmarks.accuracy.time_vs_error [--ccx]      # default design + 2 GA-box corners
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks.common import D1_K1000, append_csv, design_from_genes, markdown_table, preset_spec, read_csv
from benchmarks.mesh_study import DESIGNS, ERR_FLOOR, QUANTITIES, analyse, configs, evaluate


def plot(rows: list[dict], path: Path) -> None:
    """Log–log error against time, one row of panels per design, Pareto front as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    designs = list(dict.fromkeys(r["design"] for r in rows))
    fams = list(dict.fromkeys(r["family"] for r in rows))
    colours = dict(zip(fams, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    fig, axes = plt.subplots(len(designs), 3, figsize=(14, 4 * len(designs)), squeeze=False)
    titles = {"delta_l": "(a) Δl at Q = 0.2 MPa", "eps5": "(b) ε(5 mm)", "f1": "(c) f1 (intact 0.2 / trimmed 5)"}
    for i, dname in enumerate(designs):
        mine = [r for r in rows if r["design"] == dname]
        for j, q in enumerate(QUANTITIES):
            ax = axes[i, j]
            t = np.array([float(r["time_s"]) for r in mine])
            e = np.array([max(float(r[f"err_{q}"]), ERR_FLOOR) for r in mine])
            for fam in fams:
                sel = [k for k, r in enumerate(mine) if r["family"] == fam and fam != "preset"]
                if sel:
                    ax.scatter(t[sel], e[sel], color=colours[fam], label=fam, s=22)
            front = sorted(k for k, r in enumerate(mine) if r[f"front_{q}"])
            front.sort(key=lambda k: t[k])
            ax.step(t[front], e[front], where="post", color="k", lw=1, alpha=0.6, label="Pareto front")
            for k, r in enumerate(mine):
                if r["family"] == "preset":
                    ax.scatter(t[k], e[k], marker="*", s=160, color=colours["preset"], edgecolor="k", zorder=5)
                    ax.annotate(r["config"], (t[k], e[k]), textcoords="offset points", xytext=(5, 5), fontsize=8)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("evaluation wall time [s]")
            ax.set_ylabel("relative error")
            ax.set_title(f"{dname}: {titles[q]}", fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ----------------------------------------------------------------------------- CalculiX
def ccx_point() -> dict | None:
    """Our solver and CalculiX on the default preset's mesh of the default design, no fibres."""
    from peers.calculix import CcxCase, ccx_available, run_ccx
    from geometry.mesh import build_mesh
    from whisker_opt.experiment.gauge import GaugeReader
    from whisker_opt.experiment.gauge import locate_gauge
    from whisker_opt.experiment.scene import run_scene

    if not ccx_available():
        print("ccx not on PATH: CalculiX point skipped")
        return None
    design = design_from_genes(*DESIGNS["default"], n_fibres=0)
    spec = preset_spec(design, "default", Q=0.0, d1=D1_K1000, n_deflection_steps=10)
    wm = build_mesh(design, spec.sizing, method=spec.mesh_method)
    t = time.perf_counter()
    ours = run_scene(spec, wm)
    t_ours = time.perf_counter() - t
    base, tip = wm.node_sets["base"], wm.node_sets["tip"]
    # peers.calculix writes repr(float): a coordinate like -1.4473103847089728e-15 exceeds CalculiX's
    # 20-character field ("*ERROR reading *NODE"); rounding to 1e-12 mm keeps every field short
    case = CcxCase(np.round(wm.mesh.points, 12), wm.mesh.cells, spec.c10, spec.d1,
                   boundary=tuple((base, k, 0.0) for k in range(3)) + ((tip, 1, -spec.deflection),),
                   n_increments=10, direct=False, print_reactions=False)
    try:
        res = run_ccx(case, threads=1, cleanup=True, timeout=1800)
    except Exception as exc:  # noqa: BLE001 - a CalculiX failure is reported, not fatal
        print(f"CalculiX failed: {exc}")
        return {"t_ours": t_ours, "t_ccx": float("nan"), "eps_ours": float(ours.eps["line"][-1]),
                "eps_ccx": float("nan"), "rel_diff": float("nan"), "n_elements": wm.mesh.n_elements}
    reader = GaugeReader(wm.mesh, locate_gauge(wm, design), spec.calibration)
    reader.zero(np.zeros_like(res.displacements))
    eps_ccx = float(reader.read(res.displacements)["line"])
    eps = float(ours.eps["line"][-1])
    # the same (displacement, C3D10-like) formulation through our solver: separates the
    # solver's difference from the formulation's (C3D10 locks on this coarse mesh)
    t = time.perf_counter()
    disp = run_scene(replace(spec, formulation="displacement"), wm)
    t_disp = time.perf_counter() - t
    eps_d = float(disp.eps["line"][-1])
    return {"t_ours": t_ours, "t_ccx": res.wall_time, "eps_ours": eps, "eps_ccx": eps_ccx,
            "rel_diff": (eps - eps_ccx) / eps_ccx, "t_ours_displacement": t_disp, "eps_ours_displacement": eps_d,
            "rel_diff_same_formulation": (eps_d - eps_ccx) / eps_ccx, "n_elements": wm.mesh.n_elements}


# ----------------------------------------------------------------------------- main
RUN_FIELDS = ["design", "config", "family", "level", "n_elements", "time_s", "time_intact_s", "iterations",
              "increments", "delta_l", "eps5", "f1"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="default design, mesh levels 1-3, a few variations")
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/time_vs_error"))
    ap.add_argument("--ccx", action="store_true", help="add the CalculiX comparison point")
    ap.add_argument("--fresh", action="store_true", help="discard the rows of an earlier run in --out")
    ap.add_argument("--fresh-corners", action="store_true",
                    help="also run the 'fresh mesh' shortcut at the two box corners (hours: 48k-64k-element "
                         "fTetWild meshes of the thin-walled corner)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "runs.csv"
    if args.fresh:
        path.unlink(missing_ok=True)
    designs = ["default"] if args.quick else list(DESIGNS)
    cfgs = configs(args.quick)
    done = {(r["design"], r["config"]) for r in read_csv(path)}
    # a fresh 3-layer fTetWild mesh of the thin-walled corner has ~61k elements (bench_mesh.py);
    # one evaluation on it at one thread ran > 56 min before it was stopped (2026-11-23)
    pairs = [(d, c) for d in designs for c in cfgs
             if not (c.name == "fresh mesh" and d != "default" and not args.fresh_corners)]
    todo = [(d, c) for d, c in pairs if (d, c.name) not in done]
    print(f"{len(pairs)} evaluations ({len(todo)} to run) -> {path}")
    t0 = time.perf_counter()
    for i, (d, c) in enumerate(todo, 1):
        row = evaluate(d, c)
        append_csv(path, row, RUN_FIELDS)
        print(f"[{i:>2}/{len(todo)}] {d:<12} {c.name:<18} {row['n_elements']:>6} el {row['time_s']:7.1f} s  "
              f"dl {row['delta_l']:.6f}  eps5 {row['eps5']:.6f}  f1 {row['f1']:.6e}  "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    wanted = {(d, c.name) for d, c in pairs}
    rows = [r for r in read_csv(path) if (r["design"], r["config"]) in wanted]
    table, refs = analyse(rows)
    cols = ["design", "config", "n_elements", "time_s", "err_delta_l", "err_eps5", "err_f1",
            "front_delta_l", "front_eps5", "front_f1"]
    lines = ["# Run time against error", "", "References (Richardson, three finest mesh levels):", ""]
    for dname, ref in refs.items():
        lines.append(f"- {dname}: " + "; ".join(f"{q} = {v:.7g} (p = {p:.2f}, {note})" for q, (v, p, note) in ref.items()))
    lines += ["", markdown_table(table, cols), ""]
    verdicts = []
    for r in table:
        if r["config"] == "default":
            for q in QUANTITIES:
                ratio = r[f"ratio_{q}"]
                state = "on the front" if r[f"front_{q}"] else ("near the front" if ratio <= 2 else "OFF the front")
                verdicts.append(f"- {r['design']}, {q}: default preset {state} (error {r[f'err_{q}']:.2e}, "
                                f"{ratio:.2f}x the best error reached in ≤ {float(r['time_s']):.1f} s)")
    lines += ["## Is `default` on the Pareto front?", ""] + verdicts + [""]
    if args.ccx:
        cp = ccx_point()
        if cp is not None:
            lines += ["## CalculiX (default preset mesh, no fibres, Q = 0, K/μ = 1000, δ = 5 mm)", "",
                      markdown_table([cp], list(cp)), ""]
    text = "\n".join(lines)
    (args.out / "errors.md").write_text(text + "\n")
    if table:
        ecols = RUN_FIELDS + [k for k in table[0] if k not in RUN_FIELDS]
        (args.out / "errors.csv").unlink(missing_ok=True)
        for r in table:
            append_csv(args.out / "errors.csv", r, ecols)
        plot(table, args.out / "time_vs_error.png")
    print(text)
    print(f"written {args.out}/errors.md, errors.csv, time_vs_error.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
