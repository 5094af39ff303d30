"""How far is the GA's f1 from a mesh-converged f1, and which refinement moves it?

f1 = mean |ε_i − ε_c| is the difference of two close readings (intact at Q_i, trimmed 5 mm and
vented, contact at the tip), so a mesh error of 0.1 % in either reading is 7e-5 of f1. One
evaluation per row, both scenes on swept meshes (:mod:`geometry.swept`, the family of the
shipped templates) with the ``default`` preset's increments (1 pressure, 3 deflection: the
spline of the curves is then within 1e-5 of 20 increments), line reading, calibrated strain;
only the mesh differs between rows. Two studies:

``directions``
    From the ``default`` sizing (1 wall layer, 8 sectors, chamber layers of half the fibre
    pitch, body elements ≤ 10 mm) refine **one** parameter at a time, then all together.
``ladder``
    The mesh ladder, level k = 1 … 4 (:func:`whisker_opt.experiment.fidelity.ladder_sizing`: k wall
    layers, 8/10/12/16 sectors, chamber layers of pitch/(2k), body elements ≤ 10/k mm; level 1 is the
    ``default`` preset's sizing, levels 2–4 the presets ``level2`` … ``level4``), on swept meshes of each
    design (``--method swept``) or on the shipped templates mapped to it as the GA meshes (``template``). Designs: the thesis' default, a slim thin-walled and a
    stout thick-walled one, the case-1 optimum and seeded random designs of the case-1 box
    (α ∈ [2.5, 6]°, l ∈ [10, 15] mm, t ∈ [2, 6] mm, Q_i ∈ [0.01, 0.2] MPa, seed 2026). Per design:
    f1 at every level, whether it is monotone, the observed order p and the Richardson value
    from the three finest levels (non-uniform ratios solved exactly), and each level's
    distance from the finest; over the random designs, the Spearman rank correlation between
    level 1 and the finest level.

Rows are appended to a CSV as they finish (a killed run continues where it stopped)::

    python3 -m benchmarks.accuracy.f1_convergence directions [--designs default,case1]
    python3 -m benchmarks.accuracy.f1_convergence ladder [--designs default,slim-thin,stout-thick,case1,rand0,...]
        [--levels 1,2,3,4] [--random 8] [--csv results/f1_ladder.csv]
    python3 -m benchmarks.accuracy.f1_convergence presets [--presets coarse,fine] [--designs ...] [--csv ...]
    python3 -m benchmarks.accuracy.f1_convergence report [--csv results/f1_ladder.csv] [--method template]
        [--plot docs/figures/f1_ladder.png]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from benchmarks.common import append_csv, design_from_genes, markdown_table, preset_spec, read_csv
from benchmarks.mesh_study import DESIGNS, Q_I
from benchmarks.numerics import richardson
from geometry.mesh import build_mesh
from geometry.sizing import MeshSizing
from whisker_opt.experiment import objective
from whisker_opt.optimise.evaluator import SceneEvaluator
from whisker_opt.experiment.fidelity import ladder_sizing
from whisker_opt.experiment.scene import run_scene

#: (alpha [deg], l [mm], t [mm], Q_i [MPa]): the designs of the time-vs-error study at its Q_i, and the case-1 optimum
NAMED = {**{name: (*genes, Q_I) for name, genes in DESIGNS.items()}, "case1": (4.0515, 11.069, 2.6521, 0.19986)}
BOX = ((2.5, 6.0), (10.0, 15.0), (2.0, 6.0), (0.01, 0.2))
SEED = 2026
TRIM = 5.0
BASE = MeshSizing(wall_layers=1.0, n_theta=8, axial_pitch_fraction=0.5, h_body=10.0, name="dir-base")

#: direction -> list of (label, sizing changes)
DIRECTIONS = {
    "wall": [("wall 2", {"wall_layers": 2.0}), ("wall 3", {"wall_layers": 3.0}), ("wall 4", {"wall_layers": 4.0})],
    "theta": [("theta 12", {"n_theta": 12}), ("theta 16", {"n_theta": 16}), ("theta 24", {"n_theta": 24})],
    "axial": [("axial 0.25", {"axial_pitch_fraction": 0.25}), ("axial 0.125", {"axial_pitch_fraction": 0.125})],
    "body": [("body 5", {"h_body": 5.0}), ("body 2.5", {"h_body": 2.5})],
    "all": [("all x2", {"wall_layers": 2.0, "n_theta": 16, "axial_pitch_fraction": 0.25, "h_body": 5.0}),
            ("all x3", {"wall_layers": 3.0, "n_theta": 24, "axial_pitch_fraction": 0.17, "h_body": 3.3})],
}
FIELDS = ["design", "mesh", "level", "alpha", "l", "t", "Q_i", "elements", "time_s", "delta_l", "eps_i5", "eps_c5",
          "diff5", "f1"]
#: the other readings recorded beside the line reading's columns: eps_i5_<name>, eps_c5_<name>, diff5_<name>, f1_<name>
OTHER_READINGS = ("section",)
READING_FIELDS = [f"{c}_{n}" for n in OTHER_READINGS for c in ("eps_i5", "eps_c5", "diff5", "f1")]


def random_designs(n: int, seed: int = SEED) -> dict:
    """``n`` designs drawn uniformly in :data:`BOX` with ``seed`` (names rand0 …)."""
    rng = np.random.default_rng(seed)
    lo, hi = np.array(BOX).T
    return {f"rand{i}": tuple(float(v) for v in np.round(lo + (hi - lo) * rng.random(4), 4)) for i in range(n)}


def evaluate(name: str, genes: tuple, label: str, sizing: MeshSizing | None, level: int = 0, method: str = "swept",
             preset: str = "default") -> dict:
    """One evaluation (intact at Q_i + trimmed vented) on meshes of ``sizing`` made by ``method`` ('swept': the
    design meshed directly; 'auto': the nearest shipped template mapped to it, as the GA does) with ``preset``'s
    increments (``sizing`` None: the preset's own sizing too, i.e. the preset as a run uses it); its row."""
    alpha, l, t, q_i = genes  # noqa: E741
    over = {"mesh_method": method} if sizing is None else {"sizing": sizing, "mesh_method": method}
    base = preset_spec(design_from_genes(alpha, l, t), preset, **over)
    ev = SceneEvaluator(base, trim=TRIM)
    intact, trimmed = ev.specs({"alpha": alpha, "l": l, "t": t, "Q_i": q_i})
    t0 = time.perf_counter()
    res, n_el = {}, 0
    for scene, spec in (("intact", intact), ("trimmed", trimmed)):
        wm = build_mesh(spec.design, spec.sizing, method=spec.mesh_method, num_threads=1)
        n_el = n_el or wm.mesh.n_elements
        res[scene] = run_scene(spec, wm)
    delta = ev.samples()
    f1 = objective.f1(res["intact"].curve(delta, ev.gauge_variant), res["trimmed"].curve(delta, ev.gauge_variant))
    ei, ec = float(res["intact"].eps["line"][-1]), float(res["trimmed"].eps["line"][-1])
    row = {"design": name, "mesh": label, "level": level, "alpha": alpha, "l": l, "t": t, "Q_i": q_i,
           "elements": n_el, "time_s": f"{time.perf_counter() - t0:.1f}", "delta_l": f"{res['intact'].delta_l:.5f}",
           "eps_i5": f"{ei:.6f}", "eps_c5": f"{ec:.6f}", "diff5": f"{ei - ec:+.6f}", "f1": f"{f1:.5e}"}
    for n in OTHER_READINGS:
        ei, ec = float(res["intact"].eps[n][-1]), float(res["trimmed"].eps[n][-1])
        f1n = objective.f1(res["intact"].curve(delta, n), res["trimmed"].curve(delta, n))
        row.update({f"eps_i5_{n}": f"{ei:.6f}", f"eps_c5_{n}": f"{ec:.6f}", f"diff5_{n}": f"{ei - ec:+.6f}",
                    f"f1_{n}": f"{f1n:.5e}"})
    return row


def spearman(a: list[float], b: list[float]) -> float:
    """Spearman's rank correlation (no ties expected)."""
    ra, rb = np.argsort(np.argsort(a)), np.argsort(np.argsort(b))
    return float(np.corrcoef(ra, rb)[0, 1])


def report(rows: list[dict], prefix: str = "ladder", reading: str = "line") -> str:
    """Per-design convergence table of ``reading``'s f1 (rows whose mesh label starts with ``prefix``) and the
    rank correlation over the random designs."""
    suffix = "" if reading == "line" else f"_{reading}"
    rows = [{**r, "f1": r[f"f1{suffix}"], "diff5": r[f"diff5{suffix}"]} for r in rows if r.get(f"f1{suffix}")]
    out = []
    by = {}
    for r in rows:
        if r["mesh"].startswith(prefix):
            by.setdefault(r["design"], {})[int(r["level"])] = r
    table = []
    for name, lv in by.items():
        ks = sorted(lv)
        f1 = [float(lv[k]["f1"]) for k in ks]
        row = {"design": name, "levels": ",".join(map(str, ks)),
               "f1": " / ".join(f"{v:.3e}" for v in f1),
               "diff5": " / ".join(lv[k]["diff5"] for k in ks),
               "delta_l": " / ".join(f"{float(lv[k]['delta_l']):.3f}" for k in ks),
               "time_s": " / ".join(lv[k]["time_s"] for k in ks)}
        inc = np.diff(f1)
        row["monotone"] = "yes" if len(inc) and (np.all(inc > 0) or np.all(inc < 0)) else "no"
        if len(ks) >= 3:
            p, rich = richardson([1.0 / k for k in ks[-3:]], f1[-3:])
            row["p"] = f"{p:.2f}" if math.isfinite(p) else "-"
            row["richardson"] = f"{rich:.3e}" if math.isfinite(rich) else "-"
        fin = f1[-1]
        row["level1 vs finest"] = f"{f1[0] - fin:+.2e} ({(f1[0] - fin) / fin:+.0%})"
        table.append(row)
    out.append(markdown_table(table, ["design", "levels", "f1", "monotone", "p", "richardson", "level1 vs finest",
                                      "diff5", "delta_l", "time_s"]))
    rand = [n for n in by if n.startswith("rand") and 1 in by[n] and len(by[n]) >= 2]
    for k in (2, 3, 4):
        have = [n for n in rand if k in by[n]]
        if len(have) >= 4:
            a = [float(by[n][1]["f1"]) for n in have]
            b = [float(by[n][k]["f1"]) for n in have]
            out.append(f"\nSpearman(level 1, level {k}) over {len(have)} random designs: {spearman(a, b):.3f}")
    return "\n".join(out)


def plot(rows: list[dict], path: Path, prefix: str = "tpl-ladder", reading: str = "line") -> None:
    """``reading``'s f1 against the ladder level per design (log scale), the GA's level marked; written to ``path``."""
    col = "f1" if reading == "line" else f"f1_{reading}"
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by: dict = {}
    for r in rows:
        if r["mesh"].startswith(prefix):
            if r.get(col):
                by.setdefault(r["design"], {})[int(r["level"])] = float(r[col])
    fig, ax = plt.subplots(figsize=(7.5, 4.8), dpi=120)
    for name, lv in by.items():
        ks = sorted(lv)
        named = not name.startswith("rand")
        ax.plot(ks, [lv[k] for k in ks], marker="o", lw=2.0 if named else 1.0, alpha=1.0 if named else 0.55,
                ls="-" if named else "--", label=name)
    ax.set_yscale("log")
    levels = sorted({k for lv in by.values() for k in lv})
    names = {1: "1 (default,\nthe GA's)", 5: "5 (reference)"}
    ax.set_xticks(levels, [names.get(k, str(k)) for k in levels])
    ax.set_xlabel("mesh ladder level")
    ax.set_ylabel("f1 [calibrated strain]")
    ax.set_title(f"f1, {reading} reading, over the mesh ladder\n(templates as the GA meshes; dashed: seeded random "
                 "designs)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=3, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("study", choices=("directions", "ladder", "presets", "report"))
    ap.add_argument("--designs", default=None)
    ap.add_argument("--only", default=",".join(DIRECTIONS), help="directions: which refinements")
    ap.add_argument("--levels", default="1,2,3,4")
    ap.add_argument("--presets", default="coarse,fine", help="presets: the named presets evaluated as a run uses them")
    ap.add_argument("--random", type=int, default=8, help="ladder: number of seeded random designs")
    ap.add_argument("--csv", default=None)
    ap.add_argument("--plot", default=None, help="report: also draw f1 over the ladder into this PNG")
    ap.add_argument("--reading", choices=("line", *OTHER_READINGS), default="line", help="report: whose f1")
    ap.add_argument("--method", choices=("swept", "template"), default="swept",
                    help="ladder: swept meshes of each design, or the shipped templates mapped to it (the GA's path)")
    args = ap.parse_args(argv)
    designs = {**NAMED, **random_designs(args.random)}
    csv = Path(args.csv or f"results/f1_{args.study if args.study != 'report' else 'ladder'}.csv")
    done = {(r["design"], r["mesh"]) for r in read_csv(csv)} if csv.exists() else set()
    if args.study == "directions":
        names = (args.designs or "default,case1").split(",")
        jobs = [(n, label, replace(BASE, **ch, name=f"dir-{label.replace(' ', '')}"), 0)
                for n in names for label, ch in [("base", {})] + [r for d in args.only.split(",") for r in DIRECTIONS[d]]]
    elif args.study == "ladder":
        names = (args.designs or ",".join(designs)).split(",")
        levels = [int(k) for k in args.levels.split(",")]
        tag = "tpl-ladder" if args.method == "template" else "ladder"
        jobs = [(n, f"{tag}{k}", ladder_sizing(k), k) for k in levels for n in names]
    elif args.study == "presets":
        names = (args.designs or ",".join(designs)).split(",")
        jobs = [(n, f"preset-{p}", p, 0) for p in args.presets.split(",") for n in names]
    else:
        jobs = []
    method = "auto" if args.method == "template" else "swept"
    for name, label, sizing, k in jobs:
        if (name, label) in done:
            continue
        if args.study == "presets":
            row = evaluate(name, designs[name], label, None, 0, "auto", preset=sizing)
        else:
            row = evaluate(name, designs[name], label, sizing, k, method)
        append_csv(csv, row, FIELDS + READING_FIELDS)
        print("|".join(str(v) for v in row.values()), file=sys.stderr, flush=True)
    rows = read_csv(csv) if csv.exists() else []
    if args.study in ("directions", "presets"):
        print(markdown_table(rows, ["design", "mesh", "elements", "time_s", "delta_l", "eps_i5", "eps_c5", "diff5", "f1"]))
    else:
        prefix = "tpl-ladder" if args.method == "template" else "ladder"
        print(report(rows, prefix, args.reading))
        if args.plot:
            plot(rows, Path(args.plot), prefix, args.reading)
    return 0


if __name__ == "__main__":
    sys.exit(main())
