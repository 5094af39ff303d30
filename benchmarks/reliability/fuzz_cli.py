"""Malformed run files through the real command line: ``whisker-opt mesh FILE --out DIR`` as a subprocess.

The variants are those of the config fuzz test (:func:`tests.config_mutations.variants`, one
generator for both): every section and nested section with wrong types, out-of-range, boundary,
NaN/inf and huge values, unknown, misspelled and renamed keys, non-mappings, empty, non-UTF-8 and
binary files. Variants that the run-file checks accept (config and design valid) are skipped:
``mesh`` would compute. Every other variant must

* exit with status 2 (a user error) before computing: no output folder appears;
* write exactly one line to stderr, ``whisker-opt mesh: error: <what>``, naming the file or
  the key at fault, and no Python traceback.

The check of one variant is the test harness :mod:`tests.cli_fuzz_harness`; ``tests/test_cli_fuzz_sample.py``
runs a cheap sample in the test suite. Prints the counts of exit codes, tracebacks (target 0), stderr
shapes and the slowest case; exits 1 when a variant misbehaves. Usage::

    python3 -m benchmarks.reliability.fuzz_cli [--seed 0] [--count 300] [--jobs 2] [--thorough] [--show 10]
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures
import logging
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

from tests.cli_fuzz_harness import needs_cli, run_one
from tests.config_mutations import Variant, variants

ROOT = Path(__file__).resolve().parents[2]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0, help="first seed of the generator (more seeds until --count)")
    ap.add_argument("--count", type=int, default=300, help="least number of refused variants to run through the "
                    "command line (whole seeds are run)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2, help="subprocesses at a time")
    ap.add_argument("--thorough", action="store_true", help="every mutation of every leaf (about 1400 per seed)")
    ap.add_argument("--timeout", type=float, default=120.0, help="limit of one subprocess [s]")
    ap.add_argument("--show", type=int, default=10, help="example stderr lines to print")
    args = ap.parse_args(argv)

    work = Path(tempfile.mkdtemp(prefix="fuzz_cli_"))
    chosen: list[tuple[Variant, Path]] = []
    skipped = generated = 0
    seed = args.seed
    t_gen = time.perf_counter()
    logging.getLogger("whisker_opt.config").setLevel(logging.ERROR)  # renamed keys: no warning here
    while len(chosen) < args.count:  # whole seeds: every kind of variant is run
        folder = work / f"seed{seed}"
        folder.mkdir()
        for v in variants(seed=seed, thorough=args.thorough):
            generated += 1
            path = v.write(folder)
            if needs_cli(v, path):
                chosen.append((v, path))
            else:
                skipped += 1
        seed += 1
    t_gen = time.perf_counter() - t_gen
    print(f"variants generated: {generated} (seeds {args.seed}..{seed - 1}); valid, skipped: {skipped}; "
          f"run through `whisker-opt mesh`: {len(chosen)} ({args.jobs} at a time); generation {t_gen:.1f} s")

    t0 = time.perf_counter()
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        futures = [pool.submit(run_one, v, p, work / "out" / v.name, args.timeout) for v, p in chosen]
        outcomes = [f.result() for f in futures]
    wall = time.perf_counter() - t0

    codes = collections.Counter(o.code for o in outcomes)
    shapes = collections.Counter(len(o.lines) for o in outcomes)
    bad = [o for o in outcomes if o.problems()]
    slowest = max(outcomes, key=lambda o: o.seconds)
    by_kind = collections.Counter(o.variant.kind for o in outcomes)
    print(f"wall time {wall:.1f} s; per case mean {sum(o.seconds for o in outcomes) / len(outcomes):.2f} s")
    print("variants by kind: " + ", ".join(f"{k} {n}" for k, n in sorted(by_kind.items())))
    print("exit codes: " + ", ".join(f"{c}: {n}" for c, n in sorted(codes.items())))
    print(f"tracebacks: {sum(o.traceback for o in outcomes)}")
    print("stderr lines: " + ", ".join(f"{k}: {n}" for k, n in sorted(shapes.items()))
          + f" (besides {sum(o.deprecations for o in outcomes)} deprecation warnings of renamed keys in "
          f"{sum(o.deprecations > 0 for o in outcomes)} cases)")
    print(f"wrote output: {sum(o.wrote for o in outcomes)}")
    print(f"slowest: {slowest.variant.name} {slowest.seconds:.2f} s (exit {slowest.code})")
    print(f"misbehaving: {len(bad)}")
    for o in bad[:20]:
        frames = [f for f in re.findall(r'File "([^"]+)", line (\d+), in (\S+)', o.stderr)
                  if f[0].startswith(str(ROOT))]
        where = f" (last project frame {Path(frames[-1][0]).relative_to(ROOT)}:{frames[-1][1]} in {frames[-1][2]})" \
            if frames else ""
        last = (o.stderr.strip().splitlines() or [""])[-1]
        print(f"  {o.variant.name}: {', '.join(o.problems())}{where}: {last[:200]}")
    if args.show:
        print("examples:")
        step = max(1, len(outcomes) // args.show)
        for o in outcomes[::step][: args.show]:
            print(f"  {o.variant.name}: {(o.lines or [''])[-1].replace(str(o.path.parent), '…')[:220]}")
    shutil.rmtree(work, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
