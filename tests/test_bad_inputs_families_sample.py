"""A cheap sample of the families of :mod:`tests.bad_input_families` through the real command line.

``python3 -m benchmarks.reliability.bad_inputs --families`` runs them all (about two minutes); here the first
cases of each family (wall laws, genes, writers, state files) run as subprocesses on the fixture run (about
10 s to make), each refused as the harness expects (exit 2, one stderr line naming the key or file, no
traceback, nothing written or changed), and ``compensate --map`` on the beam model is interrupted with SIGINT
and run again: it continues in its folder, and a doctored journal is refused without a change.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest

from tests.bad_input_families import FAMILIES, build_family_cases, interrupted_study
from tests.bad_input_harness import Workspace, run_case

#: Cases of each family in the sample.
PER_FAMILY = 2
#: Cases run beside the sample: a checkpoint whose optimiser section is another run's (found by the harness).
ALSO = ("another run's config",)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    w = Workspace(tmp_path_factory.mktemp("bad_input_families"))
    w.make_run()
    return w


@pytest.mark.slow
def test_a_sample_of_each_family_is_refused_in_one_line(workspace):
    cases = build_family_cases(workspace)
    sample = [c for tag in FAMILIES[:4] for c in [c for c in cases if c.name.startswith(tag)][:PER_FAMILY]]
    sample += [c for c in cases if any(k in c.name for k in ALSO) and c not in sample]
    assert {c.name.split()[0] for c in sample} == set(FAMILIES[:4])
    with ThreadPoolExecutor(2) as ex:
        outcomes = list(ex.map(lambda c: run_case(c, workspace, timeout=120.0), sample))
    problems = {o.case.name: o.problems for o in outcomes if o.problems}
    assert problems == {}, problems


@pytest.mark.slow
def test_an_interrupted_map_continues_in_its_folder(tmp_path):
    o = interrupted_study("compensate", tmp_path / "study")
    assert [s[:3] for s in o.steps] == [("SIGINT", 130, 130), ("doctored journal", 2, 2), ("again", 0, 0)], o.steps
    assert o.problems == [], o.problems
