"""The evaluations of the run-time-against-error study: its designs, its scene configurations
(mesh levels, presets, increments, tolerances, shortcuts), one GA evaluation under a
configuration, and the errors of a set of rows against their Richardson references.

Shared by ``benchmarks.accuracy.time_vs_error`` (the study), ``benchmarks.accuracy.sizing_study``
and ``benchmarks.accuracy.gauge_readings`` (the same designs and references).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

from benchmarks.common import design_from_genes, preset_spec, report_stats
from benchmarks.numerics import front_ratio, pareto, richardson_or_p2
from whisker_opt.experiment import objective

logger = logging.getLogger(__name__)

#: designs: the thesis' default and two opposite corners of the GA box (α, l, t)
DESIGNS = {
    "default": (2.862, 15.0, 3.0),
    "slim-thin": (6.0, 15.0, 2.0),
    "stout-thick": (2.5, 10.0, 6.0),
}
Q_I = 0.2
TRIM = 5.0
QUANTITIES = ("delta_l", "eps5", "f1")
N_THETA = {1: 8, 2: 10, 3: 12, 4: 16}


@dataclass(frozen=True)
class Config:
    """One scene configuration (applied to both scenes of an evaluation).

    Attributes
    ----------
    name : str
        Label, unique within the run.
    family : str
        'mesh', 'preset', 'increments', 'rtol' or 'shortcut'.
    preset : str
        Fidelity preset the other settings start from.
    overrides : dict
        SceneSpec fields replacing the preset's (sizing, mesh_method, step counts).
    solve : dict
        SolveOptions fields replacing the preset's.
    level : int
        Mesh level k of the 'mesh' family (0 otherwise).
    """

    name: str
    family: str
    preset: str = "default"
    overrides: dict = field(default_factory=dict, hash=False)
    solve: dict = field(default_factory=dict, hash=False)
    level: int = 0


def mesh_level(k: int) -> Config:
    """Swept mesh of level k (nominal size 1/k), 10 deflection and 2 pressure steps."""
    from geometry.mesh import MeshSizing

    sizing = MeshSizing(wall_layers=float(k), n_theta=N_THETA[k], axial_pitch_fraction=0.5 / k, h_body=10.0 / k,
                        name=f"level{k}")
    return Config(f"mesh L{k}", "mesh", overrides={"sizing": sizing, "mesh_method": "swept",
                                                   "n_deflection_steps": 10, "n_pressure_steps": 2}, level=k)


def configs(quick: bool) -> list[Config]:
    """The configurations of a run (quick: levels 1-3 and a few variations)."""
    levels = (1, 2, 3) if quick else (1, 2, 3, 4)
    out = [mesh_level(k) for k in levels]
    out += [Config(p, "preset", preset=p) for p in (("coarse", "default") if quick else ("coarse", "default", "fine"))]
    out += [Config(f"{n} defl. steps", "increments", overrides={"n_deflection_steps": n})
            for n in ((5,) if quick else (2, 5, 10, 20))]
    out += [Config(f"rtol {r:g}", "rtol", solve={"rtol": r}) for r in ((1e-5,) if quick else (1e-4, 1e-6, 1e-10))]
    out += [Config("full Newton", "shortcut", solve={"reuse_tangent": 0.0}),
            Config("swept mesh", "shortcut", overrides={"mesh_method": "swept"})]
    if not quick:
        out += [Config("fresh mesh", "shortcut", overrides={"mesh_method": "fresh"}),
                Config("no predictor", "shortcut", solve={"extrapolate": False}),
                Config("interm. rtol 1e-4", "shortcut", solve={"intermediate_rtol": 1e-4})]
    return out


def evaluate(design_name: str, cfg: Config) -> dict:
    """One evaluation (intact at Q_i + trimmed vented) of a design under ``cfg``; its row.

    Meshes are built here (fresh fTetWild meshes with one thread), so the time includes
    meshing as in the GA; f1 uses the evaluator's own samples and curve interpolation.
    """
    from geometry.mesh import build_mesh
    from whisker_opt.optimise.evaluator import SceneEvaluator
    from whisker_opt.experiment.scene import run_scene

    alpha, l, t = DESIGNS[design_name]
    base = preset_spec(design_from_genes(alpha, l, t), cfg.preset, **cfg.overrides)
    if cfg.solve:
        base = replace(base, solve_options=replace(base.solve_options, **cfg.solve))
    ev = SceneEvaluator(base, trim=TRIM)
    intact, trimmed = ev.specs({"alpha": alpha, "l": l, "t": t, "Q_i": Q_I})
    t0 = time.perf_counter()
    results, n_el, stats = {}, 0, []
    for name, spec in (("intact", intact), ("trimmed", trimmed)):
        wm = build_mesh(spec.design, spec.sizing, method=spec.mesh_method, num_threads=1)
        n_el = n_el or wm.mesh.n_elements
        results[name] = run_scene(spec, wm)
        stats.append(report_stats(results[name].reports))
        if name == "intact":
            t_intact = time.perf_counter() - t0
    wall = time.perf_counter() - t0
    delta = ev.samples()
    f1 = objective.f1(results["intact"].curve(delta, ev.gauge_variant),
                      results["trimmed"].curve(delta, ev.gauge_variant))
    return {"design": design_name, "config": cfg.name, "family": cfg.family, "level": cfg.level,
            "n_elements": n_el, "time_s": wall, "time_intact_s": t_intact,
            "iterations": sum(s["iterations"] for s in stats), "increments": sum(s["increments"] for s in stats),
            "delta_l": results["intact"].delta_l, "eps5": float(results["intact"].eps["line"][-1]), "f1": f1}


ERR_FLOOR = 1e-9  # errors below this (the reference level itself) are drawn at the floor


def analyse(rows: list[dict]) -> tuple[list[dict], dict]:
    """Errors of every row against its design's Richardson references; references by design."""
    out, refs = [], {}
    for dname in dict.fromkeys(r["design"] for r in rows):
        mine = [r for r in rows if r["design"] == dname]
        levels = sorted((r for r in mine if r["family"] == "mesh"), key=lambda r: int(r["level"]))
        if len(levels) < 2:
            logger.warning("design %s: fewer than two mesh levels, no reference", dname)
            continue
        h = [1.0 / int(r["level"]) for r in levels]
        refs[dname] = {q: richardson_or_p2(h, [float(r[q]) for r in levels]) for q in QUANTITIES}
        for r in mine:
            e = {f"err_{q}": abs(float(r[q]) - refs[dname][q][0]) / abs(refs[dname][q][0]) for q in QUANTITIES}
            out.append({**r, **e})
        times = [float(r["time_s"]) for r in out if r["design"] == dname]
        mine_out = [r for r in out if r["design"] == dname]
        for q in QUANTITIES:
            errs = [max(r[f"err_{q}"], ERR_FLOOR) for r in mine_out]
            mask = pareto(times, errs)
            for i, r in enumerate(mine_out):
                r[f"front_{q}"] = bool(mask[i])
                r[f"ratio_{q}"] = front_ratio(times, errs, i)
    return out, refs

