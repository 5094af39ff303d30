"""The subcommands of ``whisker-opt``: each is (help text, argument adder, runner).

Runners import their heavy dependencies lazily so ``whisker-opt --help`` stays fast.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path
from typing import Callable

from whisker_opt.config import ConfigError, WhiskerConfig, dump_config, load_config

logger = logging.getLogger(__name__)


def _user_errors() -> tuple[type[BaseException], ...]:
    # FileExistsError: `run --out DIR` where DIR already holds a run (resume it instead)
    errs: list[type[BaseException]] = [ConfigError, FileNotFoundError, FileExistsError]
    try:
        from geometry.design import InvalidDesignError

        errs.append(InvalidDesignError)
    except ImportError:  # pragma: no cover - geometry is a core package
        pass
    from whisker_opt.verify import VerifyError

    errs.append(VerifyError)
    return tuple(errs)


USER_ERRORS = _user_errors()


def design_from_config(cfg: WhiskerConfig, trim: float = 0.0):
    """The validated :class:`geometry.design.WhiskerDesign` described by ``cfg.design``."""
    from geometry.design import WhiskerDesign

    d = WhiskerDesign(**cfg.design.model_dump(), trim=trim)
    d.validate()
    return d


def new_run_dir(cfg: WhiskerConfig, config_path: Path, kind: str) -> Path:
    """Create ``<results_dir>/<name or stem>-<kind>-<UTC time>`` (only after validation)."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    name = cfg.output.name or config_path.stem
    run_dir = Path(cfg.output.results_dir) / f"{name}-{kind}-{stamp}"
    k = 1
    while run_dir.exists():
        k += 1
        run_dir = Path(cfg.output.results_dir) / f"{name}-{kind}-{stamp}-{k}"
    run_dir.mkdir(parents=True)
    (run_dir / "config.yaml").write_text(dump_config(cfg))
    return run_dir


# ----------------------------------------------------------------------------- mesh
def _mesh_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", type=Path, help="YAML run file (design + fidelity sections are used)")
    p.add_argument("--trim", type=float, default=None, help="mesh the design trimmed by this length [mm]")
    p.add_argument("--method", choices=["auto", "fresh", "template", "swept"], default=None, help="override fidelity.mesh_method")
    p.add_argument("--step", action="store_true", help="also export the CAD solid as STEP and STL")
    p.add_argument("--out", type=Path, default=None, help="output directory (default: a new run directory)")


def _mesh_run(args: argparse.Namespace) -> int:
    from geometry.mesh import build_mesh
    from whisker_opt.fidelity import mesh_sizing

    cfg = load_config(args.config)
    trim = cfg.scene.trim if args.trim is None else args.trim
    design = design_from_config(cfg, trim=trim)
    method = args.method or cfg.fidelity.mesh_method
    out = args.out or new_run_dir(cfg, args.config, "mesh")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    wm = build_mesh(design, mesh_sizing(cfg.fidelity, design), method=method)
    elapsed = time.perf_counter() - t0
    wm.save(out / "mesh.npz")
    from fem.io import write_vtu

    write_vtu(out / "mesh.vtu", wm.mesh)
    if args.step:
        from geometry.cad import build_solid, export_step, export_stl

        solid = build_solid(design)
        export_step(solid, out / "whisker.step")
        export_stl(solid, out / "whisker.stl")
    report = dict(wm.report.as_dict(), mesh_seconds=round(elapsed, 3), method=method)
    (out / "mesh_report.json").write_text(json.dumps(report, indent=2))
    width = max(len(k) for k in report)
    print(f"mesh of {design.describe()}")
    for k, v in report.items():
        print(f"  {k:<{width}}  {v}")
    print(f"written to {out}")
    return 0


# ----------------------------------------------------------------------------- simulate
def scene_spec_from_config(cfg: WhiskerConfig, design, Q: float):
    """The :class:`whisker_opt.scene.SceneSpec` of a config for one design and pressure."""
    from whisker_opt.fidelity import mesh_sizing, resolve
    from whisker_opt.scene import SceneSpec

    preset = resolve(cfg.fidelity)
    return SceneSpec(
        design=design,
        Q=Q,
        contact_ratio=cfg.scene.contact_ratio,
        contact_at=cfg.scene.contact_at,
        delta_max=cfg.scene.delta_max,
        c10=cfg.material.C10,
        d1=cfg.material.D1,
        calibration=cfg.scene.calibration,
        band_width=cfg.scene.band_width,
        n_pressure_steps=preset.n_pressure_steps,
        n_deflection_steps=preset.n_deflection_steps,
        sizing=mesh_sizing(cfg.fidelity, design),
        mesh_method=cfg.fidelity.mesh_method,
    )


def _simulate_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", type=Path, help="YAML run file (design, material, scene, fidelity)")
    p.add_argument("--out", type=Path, default=None, help="output directory (default: a new run directory)")


UNCOMPENSATED = "trimmed_uncompensated"
"""Scene name of the trimmed whisker still at the intact pressure Q_i (no compensation)."""


def write_scene_vtus(out: Path, name: str, res) -> list[Path]:
    """Write the kept states of a scene result as ``<out>/<name>_<state>.vtu``.

    One file per state of :attr:`whisker_opt.scene.SceneResult.states`: ``pressurised``,
    ``delta_<δ>`` for every solved deflection increment but the last, and ``deflected``
    (the last increment, written once). Point array ``displacement`` [mm], cell array
    ``pressure`` (the element pressure unknown) [MPa].

    Parameters
    ----------
    out : Path
    name : str
        Scene name (file prefix).
    res : whisker_opt.scene.SceneResult
        Solved with ``keep_states=True``.

    Returns
    -------
    list of Path
    """
    from fem.io import write_vtu

    if not res.states:
        raise ValueError(f"scene {name!r}: no states kept; solve it with run_scene(..., keep_states=True)")
    last = res.states.get("deflected")
    paths = []
    for state_name, st in res.states.items():
        if state_name.startswith("delta_") and st is last:
            continue  # the same state as 'deflected'
        paths.append(write_vtu(out / f"{name}_{state_name}.vtu", res.mesh.mesh, point_data={"displacement": st.u},
                               cell_data={"pressure": st.p}))
    return paths


def scene_entry(spec, res, gauge_variant: str = "line", **extra) -> dict:
    """The ``scenes.json`` entry of a solved scene (read by :mod:`whisker_opt.viewer`).

    Parameters
    ----------
    spec : whisker_opt.scene.SceneSpec
    res : whisker_opt.scene.SceneResult
    gauge_variant : {'line', 'centroid'}
        Which gauge reading the curves use.
    **extra
        Further keys (e.g. ``wall_s``, ``genes``).
    """
    entry = {
        "design": spec.design.as_dict(),
        "Q_MPa": spec.Q,
        "trim": spec.design.trim,
        "delta_l_mm": res.delta_l,
        "length_q_mm": res.length_q,
        "contact_ratio": spec.contact_ratio,
        "contact_at": spec.contact_at,
        "contact_x": res.contact_x,
        "radial_growth_mm": res.radial_growth,
        "solved_delta_mm": res.delta.tolist(),
        "eps_line": res.eps_line.tolist(),
        "eps_centroid": res.eps_centroid.tolist(),
        "gauge_variant": gauge_variant,
        "timings_s": {k: round(v, 4) for k, v in res.timings.items()},
    }
    if res.mesh is not None:
        entry["mesh"] = res.mesh.report.as_dict()
    entry["reports"] = [r.as_dict() if hasattr(r, "as_dict") else str(r) for r in res.reports]
    entry.update(extra)
    return entry


def solve_scenes(out: Path, specs: dict, gauge_variant: str = "line", **extra) -> tuple[dict, dict]:
    """Solve scenes keeping their states; write their VTUs into ``out``.

    Parameters
    ----------
    out : Path
        Created when missing.
    specs : dict of str -> whisker_opt.scene.SceneSpec
        Scene name -> spec, solved in order.
    gauge_variant : {'line', 'centroid'}
    **extra
        Added to every ``scenes.json`` entry.

    Returns
    -------
    results : dict of str -> SceneResult
    entries : dict of str -> dict
        ``scenes.json`` entries (:func:`scene_entry`, with ``wall_s``).
    """
    from whisker_opt.scene import run_scene

    out.mkdir(parents=True, exist_ok=True)
    results, entries = {}, {}
    for name, spec in specs.items():
        t0 = time.perf_counter()
        res = run_scene(spec, keep_states=True)
        wall = time.perf_counter() - t0
        write_scene_vtus(out, name, res)
        results[name] = res
        entries[name] = scene_entry(spec, res, gauge_variant, wall_s=round(wall, 3), **extra)
        logger.info("scene %s: Q=%.4g MPa, trim=%.4g mm, eps(delta_max)=%.6g, %.2f s", name, spec.Q,
                    spec.design.trim, res.eps_line[-1], wall)
    return results, entries


def _simulate_run(args: argparse.Namespace) -> int:
    import numpy as np

    cfg = load_config(args.config)
    sc = cfg.scene
    if sc.pair:
        if sc.trim <= 0:
            raise ConfigError(f"{args.config}: scene.trim: must be > 0 for a pair (got {sc.trim})")
        trimmed = design_from_config(cfg, sc.trim)
        scenes = {"intact": scene_spec_from_config(cfg, design_from_config(cfg, 0.0), sc.Q)}
        if sc.Q > 0:  # the trimmed whisker still at Q_i: what trimming alone does to the reading
            scenes[UNCOMPENSATED] = scene_spec_from_config(cfg, trimmed, sc.Q)
        scenes["trimmed"] = scene_spec_from_config(cfg, trimmed, 0.0)
    else:
        scenes = {"scene": scene_spec_from_config(cfg, design_from_config(cfg, sc.trim), sc.Q)}
    out = args.out or new_run_dir(cfg, args.config, "simulate")
    delta = np.round(np.arange(0.0, sc.delta_max + 0.5 * sc.delta_step, sc.delta_step), 10)
    results, summary = solve_scenes(out, scenes, sc.gauge_variant)
    cols = {"delta_mm": delta}
    for name, res in results.items():
        spec = scenes[name]
        cols[f"eps_{name}"] = res.curve(delta, sc.gauge_variant)
        cols[f"eps_{name}_solved_line"] = np.interp(delta, res.delta, res.eps_line)
        print(
            f"{name:8s} Q={spec.Q:.4g} MPa  L={spec.design.length:.4g} mm  dl(Q)={res.delta_l:.5g} mm  "
            f"eps(delta_max)={res.eps_line[-1]:.6g} (centroid {res.eps_centroid[-1]:.6g})  "
            f"{summary[name]['wall_s']:.2f} s"
        )
    if sc.pair:
        f1 = float(np.mean(np.abs(cols["eps_intact"][1:] - cols["eps_trimmed"][1:])))
        summary["f1"] = f1
        print(f"f1 = mean |eps_i - eps_c| = {f1:.6g}")
        if UNCOMPENSATED in results:
            f1u = float(np.mean(np.abs(cols["eps_intact"][1:] - cols[f"eps_{UNCOMPENSATED}"][1:])))
            summary["f1_uncompensated"] = f1u
            print(f"uncompensated (trimmed at Q_i): mean |eps_i - eps_u| = {f1u:.6g}")
    header = ",".join(cols)
    np.savetxt(out / "curve.csv", np.column_stack(list(cols.values())), delimiter=",", header=header, comments="")
    (out / "scenes.json").write_text(json.dumps(summary, indent=2, default=float))
    print(f"written to {out}")
    return 0


# ----------------------------------------------------------------------------- run / resume / report
def evaluator_from_config(cfg: WhiskerConfig, keep_curves: bool = False):
    """The GA's :class:`whisker_opt.evaluator.SceneEvaluator` for a config."""
    from whisker_opt.evaluator import SceneEvaluator
    from whisker_opt.ga_config import OptimiserConfig

    opt = cfg.optimiser or OptimiserConfig()
    base = scene_spec_from_config(cfg, design_from_config(cfg, 0.0), 0.0)
    return SceneEvaluator(base, opt.delta_max, cfg.scene.delta_step, cfg.scene.gauge_variant, keep_curves)


def _run_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", type=Path, help="YAML run file with an `optimiser` section")
    p.add_argument("--out", type=Path, default=None, help="run directory (default: a new one under output.results_dir)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--verify", choices=("coarse", "default", "fine"), default=None,
                   help="after the run, re-evaluate the best designs at this preset (as `whisker-opt verify`)")
    p.add_argument("--verify-top", type=int, default=3, help="designs re-evaluated by --verify (default 3)")


def design_scene_specs(cfg: WhiskerConfig, genes: dict) -> dict:
    """The scenes shown for a genome: intact at Q_i, trimmed uncompensated (still at Q_i) and
    trimmed vented (Q = 0, the GA's compensated state).

    The uncompensated scene is left out when Q_i = 0 (it would equal the vented one).

    Parameters
    ----------
    cfg : WhiskerConfig
    genes : dict
        ``alpha`` [deg], ``l``, ``t`` [mm], ``Q_i`` [MPa] (numbers or numeric strings).

    Returns
    -------
    dict of str -> whisker_opt.scene.SceneSpec
        Keys ``intact``, ``trimmed_uncompensated`` (when Q_i > 0), ``trimmed``.

    Raises
    ------
    geometry.design.InvalidDesignError
        The genome's intact or trimmed geometry is impossible.
    """
    from dataclasses import replace

    intact, trimmed = evaluator_from_config(cfg).specs(genes)
    specs = {"intact": intact}
    if intact.Q > 0:
        specs[UNCOMPENSATED] = replace(trimmed, Q=intact.Q)
    specs["trimmed"] = trimmed
    return specs


def write_design_scenes(out: Path, cfg: WhiskerConfig, genes: dict, specs: dict | None = None) -> dict:
    """Solve the scenes of a genome (:func:`design_scene_specs`) and write them into ``out``:
    one VTU per state (:func:`write_scene_vtus`) and ``scenes.json`` with the gauge readings.

    Parameters
    ----------
    out : Path
    cfg : WhiskerConfig
    genes : dict
    specs : dict, optional
        Precomputed :func:`design_scene_specs` of ``genes``.

    Returns
    -------
    dict of str -> whisker_opt.scene.SceneResult
    """
    specs = design_scene_specs(cfg, genes) if specs is None else specs
    clean = {k: float(v) for k, v in genes.items() if k in ("alpha", "l", "t", "Q_i")}
    results, entries = solve_scenes(out, specs, cfg.scene.gauge_variant, genes=clean)
    (out / "scenes.json").write_text(json.dumps(entries, indent=2, default=float))
    return results


def _finish_best(run_dir: Path, cfg: WhiskerConfig, summary) -> None:
    """Re-run the best design of a run summary with curves and deformed meshes (VTU) into ``run_dir/best``."""
    best_genes = summary.best.get("genes") if isinstance(summary.best, dict) else None
    if not best_genes:
        return
    import numpy as np

    from whisker_opt.storage import write_best_curves

    try:
        specs = design_scene_specs(cfg, best_genes)
    except Exception as exc:  # the best of a run where every design failed
        logger.warning("best design cannot be re-run: %s", exc)
        return
    results = write_design_scenes(run_dir / "best", cfg, best_genes, specs)
    delta = evaluator_from_config(cfg).samples()
    curves = {name: results[name].curve(delta, cfg.scene.gauge_variant) for name in ("intact", "trimmed")}
    write_best_curves(run_dir, np.concatenate([[0.0], delta]), np.concatenate([[0.0], curves["intact"]]),
                      np.concatenate([[0.0], curves["trimmed"]]),
                      f"best design {', '.join(f'{k}={v:.4g}' for k, v in best_genes.items())}")


def _run_run(args: argparse.Namespace) -> int:
    from whisker_opt.runner import check_new_run_dir, run_optimisation
    from whisker_opt.ga_config import OptimiserConfig

    cfg = load_config(args.config)
    if args.verify:  # refuse bad --verify arguments before the run, not after it
        from whisker_opt.verify import check_args

        check_args(args.verify, args.verify_top)
    opt = cfg.optimiser or OptimiserConfig()
    ev = evaluator_from_config(cfg)
    run_dir = args.out or new_run_dir(cfg, args.config, "run")
    check_new_run_dir(run_dir)  # before anything is written into the directory
    run_dir.mkdir(parents=True, exist_ok=True)
    if not (run_dir / "config.yaml").exists():
        (run_dir / "config.yaml").write_text(dump_config(cfg))
    summary = run_optimisation(opt, run_dir, ev, opt.resolve_seed(cfg.seed), progress=not args.no_progress)
    _finish_best(run_dir, cfg, summary)
    from whisker_opt.runner import report

    print(report(run_dir))
    if args.verify:
        from whisker_opt.verify import format_rows, verify_run

        print(f"\nverification at preset {args.verify}")
        print(format_rows(verify_run(run_dir, args.verify, args.verify_top), args.verify))
    print(f"written to {run_dir}")
    return 0


def _resume_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="run directory written by `whisker-opt run`")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _resume_run(args: argparse.Namespace) -> int:
    from whisker_opt.runner import report, resume_optimisation

    cfg_path = args.run_dir / "config.yaml"
    if not cfg_path.is_file():
        raise FileNotFoundError(f"{cfg_path}: not found; is {args.run_dir} a run directory?")
    cfg = load_config(cfg_path)
    summary = resume_optimisation(args.run_dir, evaluator_from_config(cfg), progress=not args.no_progress)
    if not (args.run_dir / "best").is_dir():
        _finish_best(args.run_dir, cfg, summary)
    print(report(args.run_dir))
    return 0


def _verify_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="run directory written by `whisker-opt run`")
    p.add_argument("--preset", choices=("coarse", "default", "fine"), default="fine",
                   help="fidelity preset of the re-evaluation (default: fine)")
    p.add_argument("--top", type=int, default=3, help="number of best feasible designs to re-evaluate (default 3)")


def _verify_run(args: argparse.Namespace) -> int:
    from whisker_opt.verify import format_rows, verify_run

    rows = verify_run(args.run_dir, args.preset, args.top)
    print(format_rows(rows, args.preset))
    print(f"written to {args.run_dir / f'verify_{args.preset}.csv'}")
    return 0


def _report_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="run directory written by `whisker-opt run`")


def _report_run(args: argparse.Namespace) -> int:
    from whisker_opt.runner import report

    if not args.run_dir.is_dir():
        raise FileNotFoundError(f"{args.run_dir}: no such run directory")
    print(report(args.run_dir))
    return 0


# ----------------------------------------------------------------------------- compensate
def scene_response(cfg: WhiskerConfig, runner):
    """``response(design, Q, deltas) -> ε(δ)``: the config's scene at ``cfg.scene.contact_ratio``.

    ``runner`` is a :class:`whisker_opt.scene.SceneRunner` (its memo shares scenes between calls).
    """
    import numpy as np

    def response(d, Q, deltas):
        res = runner.run(scene_spec_from_config(cfg, d, float(Q)))
        return res.curve(np.asarray(deltas, dtype=float), cfg.scene.gauge_variant)

    return response


def scene_sensitivity(cfg: WhiskerConfig, runner, delta_ref: float = 1.0):
    """``sensitivity(design, a, Q) -> ε(δ_ref)/δ_ref`` [1/mm] from the config's scene at contact ratio a.

    The scene pushes at x = a·L_Q of the pressurised whisker; for a < 1 it places the
    contact node ring there itself (:func:`whisker_opt.scene.run_scene`, swept meshes).
    """
    import dataclasses

    import numpy as np

    def sensitivity(d, a, Q):
        spec = dataclasses.replace(scene_spec_from_config(cfg, d, float(Q)), contact_ratio=float(a))
        eps = runner.run(spec).curve(np.array([delta_ref]), cfg.scene.gauge_variant)
        return float(eps[0]) / delta_ref

    return sensitivity


def _compensate_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", type=Path, help="YAML run file (design, scene.Q = Q_i, optimiser.delta_max = largest trim)")
    p.add_argument("--step", type=float, default=1.0, help="trim step of the table [mm]")
    p.add_argument("--delta-ref", type=float, default=1.0,
                   help="deflection of the point measures and of the sensitivity ε(δ)/δ [mm] (SPEC §8: 1)")
    p.add_argument("--compare-a", type=float, nargs="+", default=[0.5, 0.75, 1.0], metavar="A",
                   help="contact ratios of the beam-vs-FE sensitivity comparison")
    p.add_argument("--compare-Q", type=float, nargs="+", default=[0.0, 0.1, 0.2], metavar="Q",
                   help="pressures [MPa] of the beam-vs-FE sensitivity comparison")
    p.add_argument("--no-compare", action="store_true", help="skip the beam-vs-FE sensitivity comparison")
    p.add_argument("--out", type=Path, default=None, help="output directory")


def _compensate_run(args: argparse.Namespace) -> int:
    """Δ → Q table (FE, with the analytic Q beside it) and the beam-vs-FE sensitivity comparison.

    Writes ``compensation_table.{csv,json,png}`` and, unless ``--no-compare``,
    ``sensitivity_comparison.{csv,png}`` and prints both. The FE deflection samples are
    δ_max/10 … δ_max (10 points), with ``--delta-ref`` added if missing.
    """
    import numpy as np

    from whisker_opt.beam import BeamModel
    from whisker_opt.compensation import compare_sensitivity, compensation_table, write_comparison, write_table
    from whisker_opt.ga_config import OptimiserConfig
    from whisker_opt.scene import SceneRunner

    cfg = load_config(args.config)
    opt = cfg.optimiser or OptimiserConfig()
    if cfg.scene.Q <= 0:
        raise ConfigError(f"{args.config}: scene.Q: the intact pressure Q_i must be > 0 for compensation (got {cfg.scene.Q})")
    dref = float(args.delta_ref)
    if not 0.0 < dref <= cfg.scene.delta_max:
        raise ConfigError(f"--delta-ref {dref:g}: must lie in (0, scene.delta_max = {cfg.scene.delta_max:g}] mm")
    bad_a = [a for a in args.compare_a if not 0.0 < a <= 1.0]
    bad_q = [q for q in args.compare_Q if q < 0.0]
    if bad_a or bad_q:
        raise ConfigError(f"--compare-a must lie in (0, 1] (got {bad_a}), --compare-Q must be >= 0 (got {bad_q})")
    runner = SceneRunner()
    design = design_from_config(cfg, 0.0)
    model = BeamModel(calibration=cfg.scene.calibration)
    deltas = np.linspace(cfg.scene.delta_max / 10, cfg.scene.delta_max, 10)
    if not np.any(np.abs(deltas - dref) <= 1e-9):
        deltas = np.sort(np.append(deltas, dref))

    response = scene_response(cfg, runner)
    fe_sensitivity = scene_sensitivity(cfg, runner, dref)

    out = args.out or new_run_dir(cfg, args.config, "compensate")
    t0 = time.perf_counter()
    table = compensation_table(design, cfg.scene.Q, opt.delta_max, response, step=args.step, deltas=deltas,
                               method="root", analytic_model=model)
    paths = write_table(out, table, delta_ref=dref)
    t_table = time.perf_counter() - t0
    print(f"compensation table of {design.describe()}, Q_i = {cfg.scene.Q:g} MPa ({t_table:.0f} s)")
    print(paths["csv"].read_text())
    print(f"monotone (Q non-increasing in Δ): {table.is_monotone()}")
    if not args.no_compare:
        t0 = time.perf_counter()
        cmp = compare_sensitivity(design, fe_sensitivity, a_values=args.compare_a, Q_values=args.compare_Q,
                                  model=model)
        cpaths = write_comparison(out, cmp)
        paths.update({f"comparison_{k}": v for k, v in cpaths.items()})
        print(f"beam vs FE gauge sensitivity ε(δ={dref:g} mm)/δ [1/mm] ({time.perf_counter() - t0:.0f} s); "
              f"rows a, columns Q [MPa]: beam / FE / (beam-FE)/FE")
        for i, ai in enumerate(cmp.a):
            cells = "  ".join(f"Q={qj:g}: {cmp.beam[i, j]:.5f} / {cmp.fe[i, j]:.5f} / "
                              f"{100 * cmp.relative_difference[i, j]:+.1f}%" for j, qj in enumerate(cmp.Q))
            print(f"  a={ai:g}  {cells}")
        print(f"max |relative difference| = {100 * cmp.max_abs_relative_difference:.1f}%")
    print(f"written to {out} ({', '.join(str(p) for p in paths.values())})")
    return 0


def _view_command():
    from whisker_opt.viewer import VIEW_COMMAND

    return VIEW_COMMAND


def _view_args(p: argparse.ArgumentParser) -> None:
    try:
        add = _view_command()[1]
    except ImportError as exc:  # pyvista missing: the command explains itself when run
        p.add_argument("path", type=Path, help=f"run directory or VTU (viewer unavailable: {exc})")
        return
    add(p)


def _view_run(args: argparse.Namespace) -> int:
    return _view_command()[2](args)


REGISTRY: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {
    "mesh": ("build and mesh a design; write the mesh and a quality report", _mesh_args, _mesh_run),
    "simulate": ("run one scene or the intact/trimmed pair; write the curve, reports and meshes", _simulate_args, _simulate_run),
    "run": ("run the GA optimisation of a config; write a results directory", _run_args, _run_run),
    "resume": ("continue an interrupted run from its last checkpoint", _resume_args, _resume_run),
    "report": ("print a run's summary table and rebuild its plots", _report_args, _report_run),
    "verify": ("re-evaluate a run's best designs at a finer fidelity preset (is the optimum real?)",
               _verify_args, _verify_run),
    "compensate": ("FE compensation table: vent pressure per trim, recovery rates, plot", _compensate_args, _compensate_run),
    "view": ("view result meshes with pyvista (or save a screenshot off-screen)", _view_args, _view_run),
}
