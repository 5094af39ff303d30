"""Bad inputs through every ``whisker-opt`` subcommand and option, each as a subprocess.

Every case is a hand-made bad input: an option value out of range, not a number, NaN or
infinite; an output path that cannot be written (read-only, under a regular file, an
existing file); a missing, empty, non-UTF-8 or malformed config; a run directory with a
truncated, empty or garbage ``checkpoint.json``, a damaged ``optimiser.json``,
``config.yaml``, ``best.json``, ``scenes.json``, ``evaluations.csv`` or VTU file; an
unsolvable scene; and faults and hostile folders: a dask scheduler address where nothing
listens, or a service that is not dask (silent, or answering garbage); a state file that is a
dangling symbolic link; a ``run.lock`` or ``run.log`` that is a link to another file; JSON
nested too deeply to read; implausible calibration inputs (σ of 1e-300, bounds over 14
decades); ``view`` with a ``DISPLAY`` where no X server runs. What a case must do:

* exit with status 2 (a bad input, refused before any computation) or 3 (a computation
  that the inputs allowed did not succeed: the solve-failure cases), or 0 where the case
  must fall back (``view`` without a working display renders off-screen; its one stderr line
  names the picture, which must exist);
* write exactly one line to stderr, naming what is wrong, and no Python traceback;
* not abort (no signal, no VTK crash);
* write nothing: the paths a case names as outputs must not appear, and the run
  directories it reads must be left byte for byte as they were (except the files a
  computation-failure case keeps on purpose).

The table has one row per case (case, exit code, expected code, stderr lines, traceback
yes/no, seconds, first stderr line); the totals follow. Usage::

    python3 -m benchmarks.reliability.bad_inputs [--jobs 2] [--skip-slow] [--only SUBSTRING] [--keep]
                                                 [--checkout OTHER_CHECKOUT] [--cli "whisker-opt"]

The fixtures (a tiny run made with ``whisker-opt run`` on a coarse, 2-individual,
0-generation config: about 10 s) live in a temporary folder (``--workdir`` to choose it).
``--skip-slow`` leaves out the two solve-failure cases, which compute for 20-60 s each, and
the silent scheduler, which is refused after the 20 s connection timeout.

``--families`` runs the families of :mod:`tests.bad_input_families` instead: wall laws and law sets, genes
over wall-law keys, writers into a run directory or another command's folder, doctored checkpoints, and
``compensate --map`` and ``calibrate`` interrupted with SIGINT (a doctored journal refused, then the same
command continuing in its folder); a last line sums up the tracebacks, wrong exits and writes by refused
commands.

The cases, their fixtures and the check of one case are the test harness
:mod:`tests.bad_input_harness` and :mod:`tests.bad_input_cases`; ``tests/test_bad_inputs_sample.py``
runs a cheap sample of them in the test suite.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import shlex
import shutil
import sys
import tempfile
import time
from pathlib import Path

from tests.bad_input_cases import build_cases
from tests.bad_input_families import build_family_cases, interrupted_studies
from tests.bad_input_harness import FixtureError, Workspace, run_case


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=2, help="cases run at once (default 2)")
    ap.add_argument("--skip-slow", action="store_true", help="leave out the cases that compute before failing")
    ap.add_argument("--only", default=None, help="run only the cases whose name contains this")
    ap.add_argument("--families", action="store_true",
                    help="run the families of tests/bad_input_families.py instead (wall laws, genes, writers, state "
                         "files, interrupted studies)")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds before a case counts as hung")
    ap.add_argument("--workdir", type=Path, default=None, help="fixture folder (default: a temporary one)")
    ap.add_argument("--keep", action="store_true", help="keep the fixture folder")
    ap.add_argument("--verbose", action="store_true", help="print the whole stderr of failing cases")
    ap.add_argument("--cli", default=None,
                    help="command line of whisker-opt (default: python3 -m whisker_opt.cli of this checkout), "
                         "e.g. 'whisker-opt' for the installed console script")
    ap.add_argument("--checkout", type=Path, default=None,
                    help="run the packages of another checkout (its root becomes the children's PYTHONPATH)")
    args = ap.parse_args(argv)
    root = args.workdir or Path(tempfile.mkdtemp(prefix="whisker-opt-bad-inputs-"))
    try:
        env = {"PYTHONPATH": str(args.checkout.resolve())} if args.checkout else None
        w = Workspace(root, shlex.split(args.cli) if args.cli else None, env)
        try:
            w.make_run()
        except FixtureError as exc:
            sys.exit(str(exc))
        cases = build_family_cases(w) if args.families else build_cases(w)
        n_all = len(cases)
        if args.skip_slow:
            cases = [c for c in cases if not c.slow]
        if args.only:
            cases = [c for c in cases if args.only in c.name]
        t0 = time.perf_counter()
        with concurrent.futures.ThreadPoolExecutor(max(1, args.jobs)) as ex:
            outcomes = list(ex.map(lambda c: run_case(c, w, args.timeout), cases))
        studies = interrupted_studies(root / "studies") if args.families and not args.only else []
        wall = time.perf_counter() - t0
        width = max(len(o.case.name) for o in outcomes)
        print(f"{'case':<{width}}  exit  exp lines  tb    s  written  first stderr line")
        for o in outcomes:
            first = o.lines[0] if o.lines else ""
            if len(first) > 150:
                first = first[:147] + "..."
            flag = "" if not o.problems else "  <-- " + "; ".join(o.problems)
            wrote = any(p.startswith(("wrote", "changed")) for p in o.problems)
            print(f"{o.case.name:<{width}}  {str(o.rc):>4}  {o.case.expect:>3} {len(o.lines):>5}  "
                  f"{'yes' if o.traceback else 'no':<3} {o.seconds:>5.1f}  {'yes' if wrote else 'no':<7}  "
                  f"{first}{flag}")
            if args.verbose and o.problems:
                print("    " + o.stderr.replace("\n", "\n    ").rstrip())
        for st in studies:
            for label, rc, expect, err in st.steps:
                tb = "yes" if "Traceback (most recent" in err else "no"
                first = next((ln for ln in err.splitlines() if ln.strip()), "")[:150]
                print(f"{st.name + ': ' + label:<{width}}  {str(rc):>4}  {expect:>3}     -  {tb:<3} {st.seconds:>5.1f}  "
                      f"{'yes' if st.wrote_refused and label == 'doctored journal' else 'no':<7}  {first}")
            if st.problems:
                print(f"    <-- {'; '.join(st.problems)}")
        n = len(outcomes)
        tot = {
            "cases": f"{n} (of {n_all})",
            "expected exit code": sum(o.rc == o.case.expect for o in outcomes),
            "exit 2": sum(o.rc == 2 for o in outcomes),
            "exit 3": sum(o.rc == 3 for o in outcomes),
            "exit 0 (a fallback)": sum(o.rc == 0 for o in outcomes),
            "other exit": sum(o.rc not in (0, 2, 3) for o in outcomes),
            "one stderr line": sum(len(o.lines) == 1 for o in outcomes),
            "tracebacks": sum(o.traceback for o in outcomes),
            "aborts": sum(o.aborted for o in outcomes),
            "timed out (computing)": sum(o.timed_out for o in outcomes),
            "wrote or changed files": sum(any(p.startswith(("wrote", "changed")) for p in o.problems)
                                          for o in outcomes),
            "message lacks the option/file": sum(any(p.startswith("message lacks") for p in o.problems)
                                                 for o in outcomes),
            "over 5 s (computed)": sum(o.seconds > 5 and not o.case.slow for o in outcomes),
            "cases with any problem": sum(bool(o.problems) for o in outcomes),
            "wall time": f"{wall:.0f} s",
        }
        print()
        for k, v in tot.items():
            print(f"{k:<32} {v}")
        tracebacks = sum(o.traceback for o in outcomes) + sum(st.traceback for st in studies)
        wrong = sum(o.rc != o.case.expect for o in outcomes) + sum(st.wrong_exits for st in studies)
        writes = tot["wrote or changed files"] + sum(st.wrote_refused for st in studies)
        print(f"summary: {n + sum(len(st.steps) for st in studies)} commands, {tracebacks} tracebacks, {wrong} wrong "
              f"exits, {writes} writes by refused commands, "
              f"{sum(bool(o.problems) for o in outcomes) + sum(bool(st.problems) for st in studies)} with any problem")
        return 0 if not any(o.problems for o in outcomes) and not any(st.problems for st in studies) else 1
    finally:
        if not args.keep and args.workdir is None:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
