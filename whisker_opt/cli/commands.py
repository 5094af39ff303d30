"""The subcommands of ``whisker-opt``: each is (help text, argument adder, runner).

Runners parse arguments, call :mod:`whisker_opt.workflows` and print; they import the heavy
modules lazily so ``whisker-opt --help`` stays fast.

Every bad input is refused before anything is computed or written: option values by their
argparse types (:mod:`whisker_opt.cli.arguments`), output folders by
:func:`~whisker_opt.cli.arguments.ensure_writable_dir`, run directories by
:func:`~whisker_opt.cli.rundir.check_run_dir`. A computation that fails on valid inputs (a
scene that does not converge, a mesh that cannot be made) becomes a
:class:`~whisker_opt.cli.failures.ComputationFailed` (exit status 3).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Callable

from whisker_opt.cli.arguments import (
    VIEW_TYPES,
    ArgumentError,
    OutputError,
    ensure_writable_dir,
    finite_float_in,
    int_in,
    nonempty_path,
    positive_float,
    settings_arguments,
)
from whisker_opt.cli.failures import ComputationFailed, computation_errors, describe_failure
from whisker_opt.cli.outfolder import study_folder, writing
from whisker_opt.cli import robustness as _robustness
from whisker_opt.cli.rundir import check_run_dir
from whisker_opt.config.model import ConfigError, load_config
from whisker_opt.experiment.fidelity import PRESET_NAMES
from whisker_opt.optimise.checkpoint import RunDirectoryError


def _user_errors() -> tuple[type[BaseException], ...]:
    # FileExistsError: `run --out DIR` where DIR already holds a run (resume it instead)
    # SchedulerUnreachable: no dask scheduler answers at optimiser.executor.scheduler_address (nothing ran)
    from geometry.design import InvalidDesignError
    from whisker_opt.analysis.verify import VerifyError
    from whisker_opt.optimise.dask_executor import SchedulerUnreachable
    from whisker_opt.output.journal import JournalError
    from whisker_opt.output.lock import RunDirectoryBusy
    from whisker_opt.output.storage import UnsafeLink

    return (ConfigError, FileNotFoundError, FileExistsError, InvalidDesignError, VerifyError, SchedulerUnreachable,
            RunDirectoryError, OutputError, ArgumentError, RunDirectoryBusy, UnsafeLink, JournalError)


USER_ERRORS = _user_errors()
"""Exceptions that are the user's to fix: one line on stderr, exit status 2."""


def _computation_errors() -> tuple[type[BaseException], ...]:
    # MachineFailure: workers killed or lost, the dask scheduler lost during a run (the run resumes later)
    from whisker_opt.optimise.executors import MachineFailure

    return (ComputationFailed, MachineFailure)


COMPUTATION_ERRORS = _computation_errors()
"""Exceptions of a computation that did not succeed on valid inputs: one line, exit status 3 (a
:class:`~whisker_opt.optimise.dask_executor.SchedulerUnreachable` before anything ran is a user error)."""

#: ``--trim`` and ``scene.trim`` [mm] (docs/config.md)
_TRIM = finite_float_in(0.0, 100.0, "mm")
#: ``--verify-top`` / ``--top``: as :func:`whisker_opt.analysis.verify.check_args`
_TOP = int_in(1, 1000, name="top")
#: ``resume --max-generations``
_GENERATIONS = int_in(0, 1_000_000)


def _raised_by(exc: BaseException, function: str) -> bool:
    """Whether ``exc`` was raised in a function of this name (its traceback's innermost frame)."""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    return tb is not None and tb.tb_frame.f_code.co_name == function


def _config_args(p: argparse.ArgumentParser, helptext: str) -> None:
    """CONFIG and the options that change it: ``--set``, ``--preset``, ``--defaults``."""
    p.add_argument("config", type=Path, help=helptext)
    settings_arguments(p, "optimiser.ga.population=20", "accept an empty run file (every key at its default)",
                       "; the run directory's config.yaml holds the result")


def _progress_arg(p: argparse.ArgumentParser) -> None:
    # SUPPRESS: `whisker-opt --no-progress COMMAND` (the top-level option) is not overwritten
    p.add_argument("--no-progress", action="store_true", default=argparse.SUPPRESS, help="no progress bar")


def _read(args: argparse.Namespace):
    """The run file of ``args.config`` with its settings (``--set``, ``--preset``, ``--defaults``)."""
    return load_config(args.config, allow_empty=args.defaults, settings=tuple(args.settings))


def _check_output(args: argparse.Namespace, cfg, command: str | None = None) -> None:
    """Refuse an output folder that cannot be created or written, or (``command``) that holds a GA run or another
    command's results (:func:`~whisker_opt.optimise.rundir.check_output_folder`), before anything is computed."""
    if args.out is not None:
        ensure_writable_dir(args.out, "--out")
        if command is not None:
            from whisker_opt.optimise.rundir import check_output_folder

            check_output_folder(args.out, command)
    else:
        ensure_writable_dir(cfg.output.results_dir, f"{args.config}: output.results_dir")


def _out_dir(args: argparse.Namespace, cfg, kind: str) -> Path:
    from whisker_opt.workflows import new_run_dir

    return args.out or new_run_dir(cfg, args.config, kind)


def _failed(exc: BaseException, command: str, out: Path | None = None, scenes=()) -> ComputationFailed:
    return ComputationFailed(describe_failure(exc, command, out, scenes))


# ----------------------------------------------------------------------------- mesh
def _mesh_args(p: argparse.ArgumentParser) -> None:
    _config_args(p, "YAML run file (design + fidelity sections are used)")
    p.add_argument("--trim", type=_TRIM, default=None, help="mesh the design trimmed by this length [mm], 0..100")
    p.add_argument("--method", choices=["auto", "fresh", "template", "swept"], default=None, help="override fidelity.mesh_method")
    p.add_argument("--step", action="store_true", help="also export the CAD solid as STEP and STL")
    p.add_argument("--out", type=nonempty_path, default=None, help="output directory (default: a new run directory)")


def _mesh_run(args: argparse.Namespace) -> int:
    import whisker_opt.wiring as wiring
    import whisker_opt.workflows as workflows

    cfg = _read(args)
    wiring.design_from_config(cfg, trim=cfg.scene.trim if args.trim is None else args.trim)  # refuse before mkdir
    _check_output(args, cfg, "mesh")
    out = _out_dir(args, cfg, "mesh")
    try:
        with writing(out, "mesh"):
            design, report = workflows.mesh(cfg, out, trim=args.trim, method=args.method, step=args.step,
                                            progress=not args.no_progress)
    except computation_errors() as exc:
        raise _failed(exc, "mesh") from exc
    width = max(len(k) for k in report)
    trim_from = "--trim" if args.trim is not None else "scene.trim"
    print(f"mesh of {design.describe()}" + (f", trimmed by {design.trim:g} mm ({trim_from})" if design.trim else ""))
    for k, v in report.items():
        print(f"  {k:<{width}}  {v}")
    print(f"written to {out}")
    return 0


# ----------------------------------------------------------------------------- simulate
def _simulate_args(p: argparse.ArgumentParser) -> None:
    _config_args(p, "YAML run file (design, material, scene, fidelity)")
    p.add_argument("--out", type=nonempty_path, default=None, help="output directory (default: a new run directory)")


def _simulate_run(args: argparse.Namespace) -> int:
    import whisker_opt.workflows as workflows

    cfg = _read(args)
    specs = workflows.simulation_specs(cfg, str(args.config))  # refuse a bad pair before creating the directory
    _check_output(args, cfg, "simulate")
    out = _out_dir(args, cfg, "simulate")
    try:
        with writing(out, "simulate"):
            sim = workflows.simulate(cfg, out, str(args.config))
    except computation_errors() as exc:
        raise _failed(exc, "simulate", out, list(specs)) from exc
    for name, res in sim.results.items():
        spec = sim.specs[name]
        print(
            f"{name:8s} Q={spec.Q:.4g} MPa  L={spec.design.length:.4g} mm  dl(Q)={res.delta_l:.5g} mm  "
            f"eps(deflection)={res.eps['line'][-1]:.6g} (centroid {res.eps['centroid'][-1]:.6g})  "
            f"F(deflection)={res.contact_force[-1]:.5g} N  k=F(d1)/d1={res.contact_stiffness:.5g} N/mm  "
            f"{sim.summary[name]['wall_s']:.2f} s"
        )
    print(f"wall law: {next(iter(sim.specs.values())).law.describe()} (material.wall_law)")
    if sim.f1 is not None:
        print(f"f1 = mean |eps_i - eps_c| = {sim.f1:.6g}")
    if sim.f1_uncompensated is not None:
        print(f"uncompensated (trimmed at Q_i): mean |eps_i - eps_u| = {sim.f1_uncompensated:.6g}")
    print(f"written to {out}")
    return 0


# ----------------------------------------------------------------------------- export
def _export_args(p: argparse.ArgumentParser) -> None:
    _config_args(p, "YAML run file (design, material, scene, fidelity)")
    p.add_argument("--out", type=nonempty_path, default=None, help="output directory (default: a new run directory)")
    p.add_argument("--increments", type=int_in(1, 10_000, name="increments"), default=10,
                   help="deck: initial and largest increment 1/N of each phase (default 10)")
    p.add_argument("--flavour", choices=("calculix", "abaqus"), default="calculix",
                   help="deck: 'calculix' (C3D10, the rubber compressible at K/mu = 20; runs in ccx) or 'abaqus' "
                        "(hybrid C3D10H, the rubber incompressible) (default calculix)")
    p.add_argument("--bulk-ratio", type=finite_float_in(1.0, 1e6, lo_open=True), default=None,
                   help="deck: K/mu of the rubber where material.D1 = 0 (default: 20 for calculix, "
                        "incompressible for abaqus)")


def _export_run(args: argparse.Namespace) -> int:
    import whisker_opt.export as export
    import whisker_opt.workflows as workflows

    cfg = _read(args)
    specs = export.check_deckable(cfg, str(args.config))  # refuse before creating the directory
    _check_output(args, cfg, "export")
    out = _out_dir(args, cfg, "export")
    try:
        with writing(out, "export"):
            res = export.export(cfg, out, str(args.config), n_increments=args.increments, flavour=args.flavour,
                                bulk_ratio=args.bulk_ratio)
    except computation_errors() as exc:
        raise _failed(exc, "export", out, list(specs)) from exc
    for name, path in res.decks.items():
        print(f"{name:8s} deck {path.name}")
    for name, (step, stl) in res.solids.items():
        print(f"{name:8s} solid {step.name}, {stl.name}")
    print(f"written to {out}")
    return 0


# ----------------------------------------------------------------------------- run / resume / report / verify
def _run_args(p: argparse.ArgumentParser) -> None:
    _config_args(p, "YAML run file with an `optimiser` section")
    p.add_argument("--out", type=nonempty_path, default=None,
                   help="run directory (default: a new one under output.results_dir); it must be new, empty, or "
                        "hold a run of the same config killed before its first checkpoint")
    p.add_argument("--overwrite", action="store_true",
                   help="--out holds a run: delete it and start again (a folder holding no run is never emptied)")
    _progress_arg(p)
    p.add_argument("--verify", choices=PRESET_NAMES, default=None,
                   help="after the run, re-evaluate the best designs at this preset (as `whisker-opt verify`)")
    p.add_argument("--verify-top", type=_TOP, default=3, help="designs re-evaluated by --verify, 1..1000 (default 3)")


def _run_run(args: argparse.Namespace) -> int:
    import whisker_opt.workflows as workflows
    from whisker_opt.optimise.runner import check_new_run_dir
    from whisker_opt.report import report
    from whisker_opt.output.lock import RunDirLock

    cfg = _read(args)
    if args.verify:  # refuse bad --verify arguments before the run, not after it
        from whisker_opt.analysis.verify import check_args

        check_args(args.verify, args.verify_top)
    workflows.check_runnable(cfg)  # an impossible design or executor is refused before the directory is made
    if args.out is not None and not args.overwrite:
        check_new_run_dir(args.out)  # a run already there: resume it instead
    _check_output(args, cfg)
    run_dir = args.study_out = _out_dir(args, cfg, "run")
    run_dir.mkdir(parents=True, exist_ok=True)
    with RunDirLock(run_dir, "run"):  # the run and its verification: one writer
        try:
            workflows.run(cfg, run_dir, progress=not args.no_progress, overwrite=args.overwrite)
        except computation_errors() as exc:  # re-solving the best design for its meshes, after the GA
            raise ComputationFailed(f"the GA run is complete in {run_dir}, but solving its best design again for "
                                    f"its meshes failed: {describe_failure(exc, 'run')}") from exc
        print(report(run_dir))
        if args.verify:
            from whisker_opt.analysis.verify import format_rows, verify_run

            print(f"\nverification at preset {args.verify}")
            print(format_rows(verify_run(run_dir, args.verify, args.verify_top), args.verify))
    print(f"written to {run_dir}")
    return 0


def _run_dir_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=nonempty_path, help="run directory written by `whisker-opt run`")


def _resume_args(p: argparse.ArgumentParser) -> None:
    _run_dir_args(p)
    _progress_arg(p)
    p.add_argument("--from-previous", action="store_true",
                   help="continue from the previous checkpoint (checkpoint.prev.json) when the last one is damaged; "
                        "the damaged one is kept as checkpoint.damaged.json")
    p.add_argument("--allow-config-change", action="store_true",
                   help="continue although the run's config.yaml was edited since the run started: the remaining "
                        "generations use the edited file, and the change is recorded (report, best.json, run.log)")
    p.add_argument("--trust-pickle", action="store_true",
                   help="convert the checkpoint.pkl of an earlier version to checkpoint.json, then resume; this "
                        "loads a pickle: only for a run directory you wrote or trust")
    p.add_argument("--max-generations", type=_GENERATIONS, default=None, metavar="N",
                   help="extend the run to N generations (raises optimiser.stopping.max_generations; "
                        "a finished run continues), 0..1000000")


def _resume_run(args: argparse.Namespace) -> int:
    import whisker_opt.workflows as workflows
    from whisker_opt.optimise.checkpoint import (
        DAMAGED_NAME,
        OLDER_NAME,
        convert_older_checkpoint,
        has_older_checkpoint,
        restore_previous,
    )
    from whisker_opt.report import report
    from whisker_opt.output.lock import RunDirLock

    if args.trust_pickle and not has_older_checkpoint(args.run_dir):
        raise ArgumentError(f"--trust-pickle: {args.run_dir} holds no {OLDER_NAME} of an earlier version to convert")
    run_dir = check_run_dir(args.run_dir, need_config=True, load_state=not (args.from_previous or args.trust_pickle),
                            allow_unstarted=True, allow_older=args.trust_pickle)
    args.study_out = run_dir
    ensure_writable_dir(run_dir, "run_dir")
    with RunDirLock(run_dir, "resume"):
        if args.trust_pickle:
            gen = convert_older_checkpoint(run_dir)
            print(f"converted {OLDER_NAME} (generation {gen}) to the checkpoint format of this version")
        if args.from_previous:
            gen = restore_previous(run_dir)
            print(f"continuing from the previous checkpoint (generation {gen}); the replaced one is kept as "
                  f"{DAMAGED_NAME}")
        try:
            workflows.resume(run_dir, progress=not args.no_progress, max_generations=args.max_generations,
                             allow_config_change=args.allow_config_change)
        except computation_errors() as exc:  # re-solving the best design for its meshes, after the GA
            raise ComputationFailed(f"the GA run is complete in {run_dir}, but solving its best design again for "
                                    f"its meshes failed: {describe_failure(exc, 'resume')}") from exc
        except ValueError as exc:
            if not _raised_by(exc, "resume_optimisation") or isinstance(exc, USER_ERRORS):
                raise
            raise ArgumentError(str(exc)) from None  # N below the generations already run
        print(report(run_dir))
    return 0


def _verify_args(p: argparse.ArgumentParser) -> None:
    _run_dir_args(p)
    p.add_argument("--preset", choices=PRESET_NAMES, default="fine",
                   help="fidelity preset of the re-evaluation (default: fine)")
    p.add_argument("--top", type=_TOP, default=3,
                   help="number of best feasible designs to re-evaluate, 1..1000 (default 3)")
    p.add_argument("--no-law-spread", action="store_true",
                   help="skip the designs' f1 and recovery rate under every chamber-wall law at the run's preset")


def _verify_run(args: argparse.Namespace) -> int:
    from whisker_opt.analysis.verify import check_args, format_rows, verify_run

    check_args(args.preset, args.top)
    from whisker_opt.output.lock import RunDirLock

    check_run_dir(args.run_dir, need_config=True)
    ensure_writable_dir(args.run_dir, f"run_dir (verify_{args.preset}.csv is written there)")
    with RunDirLock(args.run_dir, "verify"):
        rows = verify_run(args.run_dir, args.preset, args.top)
        print(format_rows(rows, args.preset))
        print(f"written to {args.run_dir / f'verify_{args.preset}.csv'}")
        if not args.no_law_spread:
            from whisker_opt.analysis.law_spread import format_spread
            from whisker_opt.analysis.verify import law_spread_run

            spread, run_preset = law_spread_run(args.run_dir, args.top, not args.no_progress)
            print(format_spread(spread, run_preset))
            print(f"written to {args.run_dir / 'law_spread.csv'}")
    return 0


def _report_run(args: argparse.Namespace) -> int:
    from whisker_opt.report import report

    check_run_dir(args.run_dir)
    ensure_writable_dir(args.run_dir, "run_dir (report rebuilds its plots)")
    print(report(args.run_dir))
    return 0


# ----------------------------------------------------------------------------- compensate
def _compensate_args(p: argparse.ArgumentParser) -> None:
    _config_args(p, "YAML run file (design, scene.Q_i, optimiser.trim = largest trim)")
    p.add_argument("--step", type=positive_float(100.0, "mm"), default=1.0,
                   help="trim step of the table or the map [mm], (0, 100]")
    p.add_argument("--delta-ref", type=positive_float(30.0, "mm"), default=1.0,
                   help="deflection of the point measures and of the sensitivity ε(δ)/δ [mm], "
                        "(0, scene.deflection] (docs/physics.md: 1)")
    p.add_argument("--compare-a", type=finite_float_in(0.0, 1.0, lo_open=True), nargs="+", default=[0.5, 0.75, 1.0],
                   metavar="A", help="contact ratios of the beam-vs-FE sensitivity comparison, (0, 1]")
    p.add_argument("--compare-Q", type=finite_float_in(0.0, 1.0, "MPa"), nargs="+", default=[0.0, 0.1, 0.2],
                   metavar="Q", help="pressures [MPa] of the beam-vs-FE sensitivity comparison, [0, 1]")
    p.add_argument("--no-compare", action="store_true", help="skip the beam-vs-FE sensitivity comparison")
    p.add_argument("--map", action="store_true",
                   help="the full map Q(Δ, a) over trims 0, STEP, …, optimiser.trim and the contact ratios of --a "
                        "(default 0.45 0.55 0.7 0.85 1) instead of the table: compensation_map.{csv,json,png} "
                        "(--delta-ref and --compare-* do not apply)")
    p.add_argument("--a", type=finite_float_in(0.0, 1.0, lo_open=True), nargs="+", default=None, metavar="A",
                   help="contact ratios of the map, (0, 1], at least two distinct (implies --map)")
    _progress_arg(p)
    p.add_argument("--out", type=nonempty_path, default=None, help="output directory")


#: Most trims ``compensate`` solves (each a root search of FE scenes): a smaller --step is surely a slip.
MAX_TRIMS = 1000


def _check_step(step: float, trim_max: float, source: str) -> None:
    """Refuse a ``--step`` that makes more than :data:`MAX_TRIMS` trims of 0 … ``optimiser.trim``."""
    n = int(trim_max / step) + 1
    if n > MAX_TRIMS:
        raise ArgumentError(f"--step: {step:g} mm makes {n} trims of 0 … optimiser.trim = {trim_max:g} mm of {source} "
                            f"(each a compensation of FE scenes); at most {MAX_TRIMS} are allowed: a step of at least "
                            f"{trim_max / (MAX_TRIMS - 1):.3g} mm")


def _compensate_map_run(args: argparse.Namespace, cfg) -> int:
    """The map Q(Δ, a) (``--map``/``--a``): solve, write, print the Q table."""
    import whisker_opt.compensation as compensation

    a_values = compensation.MAP_CONTACT_RATIOS if args.a is None else args.a
    if len(set(a_values)) < 2:
        raise ArgumentError(f"--a: {' '.join(f'{x:g}' for x in a_values)}: give at least two distinct contact "
                            f"ratios in (0, 1]")
    _check_output(args, cfg, "compensate")
    out = study_folder(args, cfg, args.config, "compensate", compensation.MAP_JOURNAL, compensation.MAP_STUDY,
                       compensation.map_inputs(cfg, args.step, a_values))
    try:
        with writing(out, "compensate", "compensate --map"):
            res = compensation.compensate_map(cfg, out, step=args.step, a_values=a_values, source=str(args.config),
                                              progress=not args.no_progress)
    except computation_errors() as exc:
        raise _failed(exc, "compensate", out) from exc
    m = res.map
    print(f"compensation map of {m.design_text}, Q_i = {m.Q_i:g} MPa: {m.trims.size} trims x "
          f"{m.a.size} contact ratios ({res.seconds:.0f} s)")
    print("vent pressure Q [MPa] (* at a bound: 0 = vent fully, Q_i), recovery rate [%] in brackets")
    print("trim_mm  " + "  ".join(f"{'a=' + format(x, 'g'):>16}" for x in m.a))
    for i, t in enumerate(m.trims):
        cells = "  ".join(f"{m.Q[i, j]:8.4f}{'*' if m.at_bound[i, j] and t > 0 else ' '}"
                          f"({m.recovery_rate[i, j]:5.1f})" for j in range(m.a.size))
        print(f"{t:7g}  {cells}")
    print(f"written to {out} ({', '.join(str(p) for p in res.paths.values())})")
    return 0


def _compensate_run(args: argparse.Namespace) -> int:
    """Δ → Q table (FE, with the analytic Q beside it) and the beam-vs-FE sensitivity comparison; prints both.
    With ``--map`` (or ``--a``) the map Q(Δ, a) instead (:func:`_compensate_map_run`)."""
    import whisker_opt.compensation as compensation
    import whisker_opt.wiring as wiring
    import whisker_opt.workflows as workflows

    cfg = _read(args)
    # the workflow checks these again; here before a directory is made
    if cfg.scene.Q_i <= 0:
        raise ConfigError(f"{args.config}: scene.Q_i: the intact pressure Q_i must be > 0 for compensation "
                          f"(got {cfg.scene.Q_i})")
    if args.delta_ref > cfg.scene.deflection:
        raise ArgumentError(f"--delta-ref: {args.delta_ref:g} is outside the allowed range (0, scene.deflection = "
                            f"{cfg.scene.deflection:g}] mm of {args.config}")
    wiring.design_from_config(cfg, wiring.optimiser_of(cfg).trim)  # the largest trim must leave a whisker
    _check_step(args.step, float(wiring.optimiser_of(cfg).trim), str(args.config))
    if args.map or args.a is not None:
        return _compensate_map_run(args, cfg)
    _check_output(args, cfg, "compensate")
    out = _out_dir(args, cfg, "compensate")
    try:
        with writing(out, "compensate"):
            res = compensation.compensate(cfg, out, step=args.step, delta_ref=args.delta_ref,
                                          compare_a=args.compare_a, compare_Q=args.compare_Q,
                                          compare=not args.no_compare, source=str(args.config),
                                          progress=not args.no_progress)
    except computation_errors() as exc:
        raise _failed(exc, "compensate", out) from exc
    print(f"compensation table of {res.design.describe()}, Q_i = {cfg.scene.Q_i:g} MPa ({res.table_seconds:.0f} s; "
          f"recovery on the curve {res.table.scalar}s, every column in {res.paths['csv'].name})")
    print(compensation.format_table(res.table, workflows.fidelity_of(cfg)["f1_resolution"]))
    print(f"monotone (Q non-increasing in Δ): {res.table.is_monotone()}")
    cmp = res.comparison
    if cmp is not None:
        print(f"beam vs FE gauge sensitivity ε(δ={args.delta_ref:g} mm)/δ [1/mm] ({res.comparison_seconds:.0f} s); "
              f"rows a, columns Q [MPa]: beam / FE / (beam-FE)/FE")
        for i, ai in enumerate(cmp.a):
            cells = "  ".join(f"Q={qj:g}: {cmp.beam[i, j]:.5f} / {cmp.fe[i, j]:.5f} / "
                              f"{100 * cmp.relative_difference[i, j]:+.1f}%" for j, qj in enumerate(cmp.Q))
            print(f"  a={ai:g}  {cells}")
        print(f"max |relative difference| = {100 * cmp.max_abs_relative_difference:.1f}%")
    print(f"written to {out} ({', '.join(str(p) for p in res.paths.values())})")
    return 0


# ----------------------------------------------------------------------------- init
#: The run file ``init`` writes by default, and into a folder given as ``PATH/``.
INIT_NAME = "whisker.yaml"


def nonempty_text(text: str) -> str:
    """An argparse type: a non-empty path kept as written (``init PATH``, whose trailing '/' means a folder)."""
    nonempty_path(text)
    return text


def _init_args(p: argparse.ArgumentParser) -> None:
    from whisker_opt.config.template import CASES

    p.add_argument("path", type=nonempty_text, nargs="?", default="whisker.yaml", metavar="PATH",
                   help="run file to write (default: whisker.yaml); a PATH ending in '/' is a folder, which gets "
                        "PATH/whisker.yaml")
    p.add_argument("--case", choices=list(CASES), default="demo",
                   help="starting point: demo (a short GA on the coarse preset), case1 (reference case 1), "
                        "simulate (one intact/trimmed pair); default demo")
    p.add_argument("--force", action="store_true", help="overwrite PATH when it exists")


def _init_run(args: argparse.Namespace) -> int:
    from whisker_opt.config.template import render_template
    from whisker_opt.output.storage import atomic_write_text

    path = Path(args.path)
    if args.path.endswith(("/", os.sep)):  # a folder, as the '/' says (Path drops it)
        path = path / INIT_NAME
    if path.is_dir():
        raise OutputError(f"{path}: is a folder; give a file name such as {path / INIT_NAME}, or {path}/")
    if path.exists() and not path.is_file():  # a device node, FIFO or socket: never replaced, even with --force
        raise OutputError(f"{path}: not a regular file (a device, FIFO or socket); give the name of a run file "
                          "such as whisker.yaml")
    if path.exists() and not args.force:
        raise FileExistsError(f"{path} already exists; pass --force to overwrite it")
    ensure_writable_dir(path.parent, f"{path}: its folder")
    text = render_template(args.case)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, text)
    command = "simulate" if args.case == "simulate" else "run"
    print(f"wrote {path} (case {args.case}); edit it, then: whisker-opt {command} {path}")
    return 0


# ----------------------------------------------------------------------------- view
def _view_command():
    from whisker_opt.viewer.command import VIEW_COMMAND

    return VIEW_COMMAND


def _view_args(p: argparse.ArgumentParser) -> None:
    try:
        add = _view_command()[1]
    except ImportError as exc:  # pyvista missing: the command explains itself when run
        p.add_argument("path", type=Path, help=f"run directory or VTU (viewer unavailable: {exc})")
        return
    add(p, types=VIEW_TYPES)
    if "--no-progress" not in p._option_string_actions:  # accepted as by every command (the viewer shows none)
        _progress_arg(p)


def _view_run(args: argparse.Namespace) -> int:
    # the image goes to --screenshot, or (no display, or --plots) into the results folder
    if not hasattr(args, "source") or args.list:
        pass
    elif args.screenshot is not None:
        ensure_writable_dir(args.screenshot.parent, f"--screenshot {args.screenshot}: its folder")
    elif Path(args.source).exists():
        from whisker_opt.viewer.guard import is_headless

        if is_headless() or args.plots:
            root = args.source if Path(args.source).is_dir() else Path(args.source).parent
            ensure_writable_dir(root, "source: the results folder (view.png and plots go there)")
    return _view_command()[2](args)


REGISTRY: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {
    "init": ("write a commented run file to start from (every key with its meaning, unit and range)",
             _init_args, _init_run),
    "mesh": ("build and mesh a design; write the mesh and a quality report", _mesh_args, _mesh_run),
    "simulate": ("run one scene or the intact/trimmed pair; write the curve, reports and meshes", _simulate_args, _simulate_run),
    "run": ("run the GA optimisation of a config; write a results directory", _run_args, _run_run),
    "resume": ("continue an interrupted run from its last checkpoint, or extend a finished one "
               "(--max-generations)", _resume_args, _resume_run),
    "report": ("print a run's summary table and rebuild its plots", _run_dir_args, _report_run),
    "verify": ("re-evaluate a run's best designs at a finer fidelity preset (is the optimum real?)",
               _verify_args, _verify_run),
    "compensate": ("FE compensation table (vent pressure per trim, recovery rates, plot), or with --map the map "
                   "over trims x contact ratios", _compensate_args, _compensate_run),
    "export": ("write a design's scenes as CalculiX/Abaqus decks (.inp) and its solid as STEP and STL",
               _export_args, _export_run),
    "view": ("view result meshes with pyvista (or save a screenshot off-screen)", _view_args, _view_run),
    "calibrate": __import__("whisker_opt.cli.calibrate", fromlist=["COMMAND"]).COMMAND,
    "robustness": (_robustness.HELP, _robustness.add_arguments, _robustness.run),
}
