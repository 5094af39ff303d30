"""Kill-and-resume of the GA: SIGKILL a run at N seeded moments, resume it, compare.

Each moment starts :func:`whisker_opt.optimise.runner.run_optimisation` (analytic evaluator,
serial executor, population 10, generations 0 … 6, a slow emulated disk) in a child process,
kills it with SIGKILL at the moment (:func:`tests.kill_harness.moments`: right after
``optimiser.json``, during generation 0, during the checkpoint writes of generation 0 and
of the last generation, after the last generation, then seeded random ones), resumes it with
:func:`whisker_opt.optimise.runner.resume_optimisation` and compares the final population,
hall of fame, best design, counters and ``evaluations.csv`` (every column but ``time_s``)
with an uninterrupted run of the same seed; the resumed directory must also hold every
output and no temporary file.

Usage::

    python3 -m benchmarks.reliability.kill_resume [--n 31] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from tests import kill_harness as kh


def _short(name: str) -> str:
    """``.checkpoint.json.ab12cd.tmp`` -> ``checkpoint.json tmp``."""
    return name.lstrip(".").split(".tmp")[0].rsplit(".", 1)[0] + " tmp" if name.endswith(".tmp") else name


def main(argv: list[str] | None = None) -> int:
    """Run the table; returns 0 when every resumed run is identical, else 1."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=31, help="kill moments (>= 5)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the random moments")
    args = ap.parse_args(argv)
    t_all = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="kill_resume_") as tmp:
        tmp = Path(tmp)
        ref = kh.reference_run(tmp / "ref")
        print(f"uninterrupted run: generations 0..{ref.generations}, {ref.n_evaluations} evaluations, "
              f"{ref.n_cache_hits} cache hits, best F_p {ref.best['F_p']:.6g}")
        print(f"{'#':>3}  {'moment':<28}{'killed':>7}{'gen reached':>12}{'child s':>9}  {'left by the kill':<26}identical")
        for k, m in enumerate(kh.moments(args.n, args.seed)):
            run_dir = tmp / f"run{k}"
            got = kh.kill_at(run_dir, m)
            diff = kh.differences(tmp / "ref", ref, run_dir, kh.resume(run_dir))
            gen = "none" if got["generation"] < 0 else str(got["generation"]) + (" (last)" if got["finished"] else "")
            rows.append((m, got, diff))
            left = [_short(n) for n in got["temporaries"]] + ([] if got["environment"] else ["no environment.json"])
            print(f"{k:>3}  {m.label():<28}{'yes' if got['killed'] else 'ended':>7}{gen:>12}{got['seconds']:>9.2f}  "
                  f"{', '.join(left) or '-':<26}" + ("yes" if not diff else "NO: " + ", ".join(diff)), flush=True)
    n_killed = sum(r[1]["killed"] for r in rows)
    n_tmp = sum(bool(r[1]["temporaries"]) for r in rows)
    n_env = sum(not r[1]["environment"] for r in rows)
    n_same = sum(not r[2] for r in rows)
    by_gen = sorted({r[1]["generation"] for r in rows})
    print(f"\ntotal: {len(rows)} moments, {n_killed} killed ({len(rows) - n_killed} ended first), "
          f"{n_same}/{len(rows)} identical to the uninterrupted run; {n_tmp} kills left a temporary file, "
          f"{n_env} left no environment.json; checkpoints reached: "
          f"{', '.join('none' if g < 0 else str(g) for g in by_gen)}; {time.perf_counter() - t_all:.1f} s")
    return 0 if n_same == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
