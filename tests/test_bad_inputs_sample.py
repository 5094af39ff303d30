"""A cheap sample of the bad-input harness (:mod:`tests.bad_input_cases`) through the real command line.

``python3 -m benchmarks.reliability.bad_inputs`` runs all of its cases (minutes); here every 25th case
that does not compute before failing runs as a subprocess in a fresh workspace (its fixture run about
10 s), spanning every subcommand group, and each must be refused as the harness expects: its exit
status, one stderr line naming the option or file, no traceback or abort, nothing written or changed.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest

from tests.bad_input_cases import build_cases
from tests.bad_input_harness import Workspace, run_case

STRIDE = 25


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    w = Workspace(tmp_path_factory.mktemp("bad_inputs"))
    w.make_run()
    return w


@pytest.mark.slow
def test_a_sample_of_the_bad_inputs_is_refused_in_one_line(workspace):
    cases = [c for c in build_cases(workspace) if not c.slow]
    sample = cases[::STRIDE]
    assert len(sample) >= 10 and {c.argv[0] for c in sample if c.argv} >= {"mesh", "resume", "compensate", "view"}
    with ThreadPoolExecutor(2) as ex:
        outcomes = list(ex.map(lambda c: run_case(c, workspace, timeout=120.0), sample))
    problems = {o.case.name: o.problems for o in outcomes if o.problems}
    assert problems == {}, problems
