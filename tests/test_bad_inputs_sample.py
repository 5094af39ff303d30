"""Cheap samples of the bad-input harnesses through the real command line.

``python3 -m benchmarks.reliability.bad_inputs`` runs all the cases of :mod:`tests.bad_input_cases` (minutes) and,
with ``--families``, the families of :mod:`tests.bad_input_families` (about two minutes). Here:

* every 25th case of the first that does not compute before failing, spanning every subcommand group;
* the first cases of each family (wall laws, genes, writers, state files) and a checkpoint whose optimiser
  section is another run's;

each runs as a subprocess on a fixture run of its own (about 10 s to make) and must be refused as the harness
expects: its exit status, one stderr line naming the option, key or file, no traceback or abort, nothing written
or changed. And ``compensate --map`` on the beam model is interrupted with SIGINT and run again: it continues in
its folder, and a doctored journal is refused without a change.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest

from tests.bad_input_cases import build_cases
from tests.bad_input_families import FAMILIES, build_family_cases, interrupted_study
from tests.bad_input_harness import Workspace, run_case

#: Every STRIDE-th case of the first harness is in its sample.
STRIDE = 25
#: Cases of each family in the families' sample.
PER_FAMILY = 2
#: Cases run beside the families' sample: a checkpoint whose optimiser section is another run's.
ALSO = ("another run's config",)


def _workspace(tmp_path_factory, name: str) -> Workspace:
    w = Workspace(tmp_path_factory.mktemp(name))
    w.make_run()
    return w


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    return _workspace(tmp_path_factory, "bad_inputs")


@pytest.fixture(scope="module")
def families_workspace(tmp_path_factory):
    return _workspace(tmp_path_factory, "bad_input_families")


def _assert_refused(sample, workspace: Workspace) -> None:
    """Run the sample two at a time; every case refused as its harness expects."""
    with ThreadPoolExecutor(2) as ex:
        outcomes = list(ex.map(lambda c: run_case(c, workspace, timeout=120.0), sample))
    problems = {o.case.name: o.problems for o in outcomes if o.problems}
    assert problems == {}, problems


@pytest.mark.slow
def test_a_sample_of_the_bad_inputs_is_refused_in_one_line(workspace):
    cases = [c for c in build_cases(workspace) if not c.slow]
    sample = cases[::STRIDE]
    assert len(sample) >= 10 and {c.argv[0] for c in sample if c.argv} >= {"mesh", "resume", "compensate", "view"}
    _assert_refused(sample, workspace)


@pytest.mark.slow
def test_a_sample_of_each_family_is_refused_in_one_line(families_workspace):
    cases = build_family_cases(families_workspace)
    sample = [c for tag in FAMILIES[:4] for c in [c for c in cases if c.name.startswith(tag)][:PER_FAMILY]]
    sample += [c for c in cases if any(k in c.name for k in ALSO) and c not in sample]
    assert {c.name.split()[0] for c in sample} == set(FAMILIES[:4])
    _assert_refused(sample, families_workspace)


@pytest.mark.slow
def test_an_interrupted_map_continues_in_its_folder(tmp_path):
    o = interrupted_study("compensate", tmp_path / "study")
    assert [s[:3] for s in o.steps] == [("SIGINT", 130, 130), ("doctored journal", 2, 2), ("again", 0, 0)], o.steps
    assert o.problems == [], o.problems
