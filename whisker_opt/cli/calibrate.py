"""``whisker-opt calibrate CONFIG``: fit model parameters to a prototype's measurements (docs/calibration.md).

:data:`COMMAND` is the (help text, argument adder, runner) entry of
:data:`whisker_opt.cli.commands.REGISTRY`. The run file, its ``calibration`` section, the parameters,
every measurement file and the held-out names are checked before the results folder is made (a bad
one exits with status 2 and one line naming the file, row and column, or the key); a scene that does
not converge during the fit exits with status 3. A fit that stops at its evaluation budget before it
converges (or before any parameter moves) writes its outputs headed ``NOT CALIBRATED`` and exits with
status :data:`NOT_CALIBRATED` (4). A calibration stopped by a kill continues where it stopped
when started again with ``--out`` at the same folder (:data:`whisker_opt.calibration.job.JOURNAL`). A fit that converges but cannot reach the observations is not a
failure: the summary and ``calibration.json`` say which observation is missed and by how much, and
warn of a parameter at a bound or a χ²/ν above its limit.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from whisker_opt.cli.arguments import ensure_writable_dir, nonempty_path, settings_arguments
from whisker_opt.cli.failures import ComputationFailed, computation_errors, describe_failure
from whisker_opt.cli.outfolder import study_folder, writing
from whisker_opt.config.model import load_config

#: Exit status of a fit that wrote its outputs but did not converge (budget exhausted, nothing moved).
NOT_CALIBRATED = 4

HELP = "fit model parameters to measurements of a prototype; write calibration.json and a calibrated run file"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """CONFIG, ``--set``/``--preset``/``--defaults`` as for the other commands, and ``--out``."""
    p.add_argument("config", type=Path, help="YAML run file with a `calibration` section (docs/calibration.md)")
    settings_arguments(p, "calibration.max_evaluations=10",
                       "accept an empty run file (it then has no calibration section, which is refused)")
    p.add_argument("--out", type=nonempty_path, default=None,
                   help="output folder (default: a new one under output.results_dir)")
    p.add_argument("--no-progress", action="store_true", default=argparse.SUPPRESS, help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Check everything, fit, write ``calibration.json``, ``calibrated.yaml``, ``calibration.png``; print a summary.

    Returns 0, or :data:`NOT_CALIBRATED` when the fit did not converge (its outputs say so).
    """
    from whisker_opt.calibration.job import JOURNAL, STUDY, calibrate, journal_inputs, prepare
    from whisker_opt.optimise.rundir import check_output_folder
    from whisker_opt.workflows import record_config

    cfg = load_config(args.config, allow_empty=args.defaults, settings=tuple(args.settings))
    prepared = prepare(cfg, args.config)  # every input checked before a folder is made
    if args.out is not None:
        ensure_writable_dir(args.out, "--out")
        check_output_folder(args.out, "calibrate")
    else:
        ensure_writable_dir(cfg.output.results_dir, f"{args.config}: output.results_dir")
    out = study_folder(args, cfg, args.config, "calibrate", JOURNAL, STUDY, journal_inputs(prepared))
    try:
        with writing(out, "calibrate"):
            record_config(out, cfg, "calibrate")
            result = calibrate(prepared, out, progress=not getattr(args, "no_progress", False))
    except computation_errors() as exc:
        raise ComputationFailed(describe_failure(exc, "calibrate", Path(out))) from exc
    except FloatingPointError as exc:
        raise ComputationFailed(f"calibrate: {exc}") from exc
    print(result.summary)
    print(f"written to {out} ({', '.join(p.name for p in result.paths.values())})")
    if not result.outcome.calibrated:
        print(f"whisker-opt calibrate: {result.outcome.warnings()[0]}; the outputs in {out} are headed NOT "
              f"CALIBRATED (exit status {NOT_CALIBRATED})", file=sys.stderr)
        return NOT_CALIBRATED
    return 0


#: The entry of :data:`whisker_opt.cli.commands.REGISTRY`.
COMMAND = (HELP, add_arguments, run)
