"""A cheap sample of the run-file fuzzer through the real command line (:mod:`tests.cli_fuzz_harness`).

``python3 -m benchmarks.reliability.fuzz_cli`` runs some 400 refused variants (minutes); here eight of
seed 0, spread over the generator's kinds, run as ``whisker-opt mesh FILE --out DIR`` subprocesses and
each must exit 2 in one line naming the file or key, with no traceback and no output folder.
"""

from __future__ import annotations

import logging
from concurrent.futures import ThreadPoolExecutor

from tests.cli_fuzz_harness import needs_cli, run_one
from tests.config_mutations import variants

N = 8


def test_a_sample_of_refused_run_files_is_refused_in_one_line(tmp_path, caplog):
    caplog.set_level(logging.ERROR, logger="whisker_opt.config")  # renamed keys are read on purpose
    refused = []
    for v in variants(seed=0):
        path = v.write(tmp_path)
        if needs_cli(v, path):
            refused.append((v, path))
    by_kind: dict[str, list] = {}
    for v, path in refused:
        by_kind.setdefault(v.kind, []).append((v, path))
    sample = [group[0] for group in by_kind.values()]
    sample += [vp for vp in refused[:: max(1, len(refused) // N)] if vp not in sample][: max(0, N - len(sample))]
    assert len(by_kind) >= 3 and len(sample) >= N
    with ThreadPoolExecutor(2) as ex:
        outcomes = list(ex.map(lambda vp: run_one(*vp, tmp_path / "out" / vp[0].name, timeout=120.0), sample))
    problems = {o.variant.name: (o.problems(), o.stderr[-300:]) for o in outcomes if o.problems()}
    assert problems == {}, problems
