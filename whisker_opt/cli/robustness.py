"""``whisker-opt robustness RUN_DIR|CONFIG``: the best designs of a run, or the design of a config,
under the fabrication tolerances of the ``robustness`` section (docs/physics.md §10).

Every bad input is refused in one line before anything is computed (exit status 2): the
options by their types, the run file (with ``--set``) by its models, the designs by their
geometry checks, the output folder by :func:`~whisker_opt.cli.arguments.ensure_writable_dir`.
A nominal design whose scenes fail ends with exit status 3; a deviated design that fails is
reported in the table and the files (its outputs NaN). The output folder (a run directory by
default) is locked while the study writes (:class:`~whisker_opt.output.lock.RunDirLock`): a run,
resume or study writing there at the same time is refused in one line. A study stopped by a kill
continues where it stopped when started again into the same folder
(:data:`whisker_opt.robustness.JOURNAL`).
"""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path

from whisker_opt.cli.arguments import (
    ArgumentError,
    ensure_writable_dir,
    int_in,
    nonempty_path,
    parse_finite,
    settings_arguments,
)
from whisker_opt.cli.failures import ComputationFailed, computation_errors, describe_failure
from whisker_opt.cli.outfolder import study_folder, writing
from whisker_opt.output.lock import RunDirLock

HELP = "propagate fabrication tolerances to f1 and the recovery rate of a run's best designs or a config's design"


#: Most values of a ``--genes`` genome: the four and the added genes (any real key of two sections).
MAX_GENES = 100


def genome(text: str) -> tuple[float, ...]:
    """An argparse type: ``ALPHA,L,T,Q_I[,ADDED,...]`` (deg, mm, mm, MPa, then each gene ``optimiser.genes``
    adds, in its order), at least four finite numbers (the study checks the count against the config's genome)."""
    parts = [p.strip() for p in str(text).split(",")]
    if not 4 <= len(parts) <= MAX_GENES:
        raise argparse.ArgumentTypeError(f"{text!r}: expected ALPHA,L,T,Q_I and any added genes (4 to {MAX_GENES} "
                                         f"numbers separated by commas), got {len(parts)} item(s)")
    return tuple(parse_finite(p) for p in parts)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The command's arguments."""
    p.add_argument("source", type=nonempty_path, metavar="RUN_DIR|CONFIG",
                   help="a run directory (its best feasible designs, robustness.top of them) or a YAML run file "
                        "(its design: design.alpha, design.l, design.t, scene.Q_i and the keys of any added gene)")
    p.add_argument("--method", choices=["expansion", "sample", "both"], default=None,
                   help="estimator (default robustness.method): first-order expansion, seeded sample, or both")
    p.add_argument("--samples", type=int_in(2, 100_000, name="samples"), default=None, metavar="N",
                   help="points of the sample (robustness.sample.n), 2..100000")
    p.add_argument("--top", type=int_in(1, 1000, name="top"), default=None,
                   help="best feasible designs of a run studied (robustness.top), 1..1000")
    p.add_argument("--genes", type=genome, action="append", default=[], metavar="ALPHA,L,T,Q_I[,...]",
                   help="with a CONFIG: study this genome instead of the config's design (repeatable); the values "
                        "of the genes optimiser.genes adds follow Q_I in their order")
    settings_arguments(p, "robustness.tolerances.alpha=0.5", "accept an empty run file (every key at its default)",
                       "; with a run directory, over its config.yaml")
    p.add_argument("--out", type=nonempty_path, default=None,
                   help="output folder (default: the run directory, or a new one under output.results_dir)")
    p.add_argument("--no-progress", action="store_true", default=argparse.SUPPRESS, help="no progress bar")


def _settings(args: argparse.Namespace) -> tuple[str, ...]:
    extra = []
    if args.method is not None:
        extra.append(f"robustness.method={args.method}")
    if args.samples is not None:
        extra.append(f"robustness.sample.n={args.samples}")
    if args.top is not None:
        extra.append(f"robustness.top={args.top}")
    return (*args.settings, *extra)


def run(args: argparse.Namespace) -> int:
    """Read the source, refuse bad inputs, study the designs, print the table and write the files."""
    import whisker_opt.robustness as rb
    import whisker_opt.wiring as wiring
    from whisker_opt.cli.rundir import check_run_dir
    from whisker_opt.config.model import load_config
    from whisker_opt.optimise.rundir import check_output_folder
    from whisker_opt.workflows import CONFIG_YAML, record_config

    source = Path(args.source)
    settings = _settings(args)
    try:
        if source.is_dir():
            if args.genes:
                raise ArgumentError(f"--genes: only with a CONFIG; {source} is a run directory (its designs are "
                                    "its hall of fame)")
            run_dir = check_run_dir(source, need_config=True)
            cfg = load_config(run_dir / CONFIG_YAML, settings=settings)
            designs = rb.run_designs(run_dir, cfg.robustness.top)
        else:
            cfg = load_config(source, allow_empty=args.defaults, settings=settings)
            designs = rb.config_designs(cfg, args.genes, str(source))
        rb.check_sample_size(cfg, [cfg.robustness.method])
    except rb.RobustnessError as exc:
        raise ArgumentError(str(exc)) from None
    wiring.tolerance_half_widths(cfg)
    for d in designs:  # an impossible genome is refused before anything is solved
        wiring.design_scene_specs(cfg, d.genes)
    # own_run: the study of a run written into its run directory, which keeps its own config.yaml
    own_run = source.is_dir() and (args.out is None or Path(args.out).resolve() == source.resolve())
    if own_run:
        out = args.study_out = ensure_writable_dir(source, "RUN_DIR (robustness.* are written there)")
    else:
        if args.out is not None:
            ensure_writable_dir(args.out, "--out")
            check_output_folder(args.out, "robustness")
        else:
            ensure_writable_dir(cfg.output.results_dir, f"{source}: output.results_dir")
        out = study_folder(args, cfg, source, "robustness", rb.JOURNAL, rb.STUDY, rb.journal_inputs(cfg, designs))
    # one writer: a run or resume of a run directory, another study
    folder = contextlib.nullcontext(out) if own_run else writing(out, "robustness")
    try:
        with folder, RunDirLock(out, "robustness"):
            if not own_run:
                record_config(out, cfg, "robustness")
            results, paths = rb.robustness(cfg, designs, out, progress=not getattr(args, "no_progress", False))
    except computation_errors() as exc:
        raise ComputationFailed(f"the nominal design failed: {describe_failure(exc, 'robustness')}") from exc
    tol = cfg.robustness.tolerances
    print(f"tolerances ({cfg.robustness.distribution}): alpha ±{tol.alpha:g} deg, l ±{tol.l:g} mm, t ±{tol.t:g} mm, "
          f"fibre radius ±{tol.fibre_radius:g} mm, C10 ±{tol.C10:g} %, calibration ±{tol.calibration:g}; "
          f"f1 in calibrated strain, recovery rate (rec) in % ({cfg.robustness.recovery_scalar} of the curves)")
    print(rb.format_table(results))
    print(f"written to {out} ({', '.join(p.name for p in paths.values())})")
    return 0
