"""Executors: same results with serial, processes and dask; timeouts, exceptions and crashes recorded."""

from __future__ import annotations

import math
import pickle

import pytest

from whisker_opt.optimise.dask_executor import DaskExecutor, connect_scheduler
from whisker_opt.optimise.backend import make_executor, preflight
from whisker_opt.optimise.executors import MachineFailure, ProcessExecutor, SerialExecutor
from whisker_opt.config.optimiser import ExecutorConfig, OptimiserConfig
from whisker_opt.optimise.runner import run_optimisation
from tests.analytic_fitness import AnalyticFitness, FailureRegion

GOOD = {"alpha": 3.0, "l": 12.0, "t": 4.0, "Q_i": 0.05}


def _cfg(kind: str, **executor) -> OptimiserConfig:
    return OptimiserConfig.model_validate(
        {
            "ga": {"population": 12},
            "stopping": {"max_generations": 4, "target_fp": 0.0, "stall_generations": 100},
            "executor": {"kind": kind, "n_workers": 2, **executor},
        }
    )


EV = AnalyticFitness(
    optimum=(4.0, 12.0, 4.0, 0.05),
    failures=(FailureRegion("alpha", 5.2, "invalid_geometry"), FailureRegion("t", 5.6, "raise")),
)


def _fingerprint(summary):
    return summary.population, summary.fitness, summary.best


def test_serial_processes_and_dask_give_identical_runs(tmp_path):
    results = {}
    for kind, extra in [("serial", {}), ("processes", {}), ("dask", {"dask_processes": True})]:
        s = run_optimisation(_cfg(kind, **extra), tmp_path / kind, EV, seed=21, progress=False)
        results[kind] = s
    ref = _fingerprint(results["serial"])
    assert results["serial"].n_failures > 0  # failures travel through every executor the same way
    for kind in ("processes", "dask"):
        assert _fingerprint(results[kind]) == ref, kind
        assert results[kind].n_evaluations == results["serial"].n_evaluations
        assert results[kind].n_cache_hits == results["serial"].n_cache_hits


def test_dask_threads_localcluster_matches_serial(tmp_path):
    a = run_optimisation(_cfg("serial"), tmp_path / "a", EV, seed=4, progress=False)
    b = run_optimisation(_cfg("dask", dask_processes=False), tmp_path / "b", EV, seed=4, progress=False)
    assert _fingerprint(a) == _fingerprint(b)


#: A limit no good design comes near (an analytic evaluation takes microseconds, the worker's imports are
#: done before its clock starts) and that a hang always reaches (it never answers): the timeout tests do
#: not depend on the machine's speed or load.
TIMEOUT_S = 3.0


def test_process_pool_timeout_crash_and_exception_are_recorded_and_pool_recovers():
    ev = AnalyticFitness(
        failures=(
            FailureRegion("alpha", 5.8, "raise"),
            FailureRegion("t", 5.8, "hang"),
            FailureRegion("l", 14.9, "crash"),
        ),
        hang_s=math.inf,
    )
    genes = [
        GOOD,
        {**GOOD, "alpha": 5.9},
        {**GOOD, "t": 5.9},
        {**GOOD, "l": 14.95},
        {**GOOD, "alpha": 3.5},
    ]
    with ProcessExecutor(ev, n_workers=2, timeout_s=TIMEOUT_S) as ex:
        out = ex.map(genes, [1, 2, 3, 4, 5])
        assert [o.status for o in out] == ["ok", "error", "timeout", "error", "ok"]
        assert out[0].f1 == pytest.approx(ev.f1(GOOD))
        assert out[1].reason.startswith("RuntimeError: deliberate failure") and "traceback" in out[1].extra
        assert f"exceeded {TIMEOUT_S:g} s" in out[2].reason
        assert "worker process died (exit code 3) in 3 attempts" in out[3].reason  # its own crash, every time
        again = ex.map([GOOD] * 3, [1, 1, 1])  # replaced workers keep serving
        assert [o.status for o in again] == ["ok"] * 3
        assert all(o.timings["eval_s"] >= 0 for o in out + again)


def test_serial_timeout_uses_alarm_and_run_continues():
    ev = AnalyticFitness(failures=(FailureRegion("t", 5.8, "hang"),), hang_s=math.inf)
    with SerialExecutor(ev, timeout_s=TIMEOUT_S) as ex:
        out = ex.map([{**GOOD, "t": 5.9}, GOOD], [1, 2])  # an endless hang: only the alarm ends it
    assert [o.status for o in out] == ["timeout", "ok"]
    assert f"exceeded {TIMEOUT_S:g} s" in out[0].reason


def test_dask_timeout_and_exception():
    ev = AnalyticFitness(failures=(FailureRegion("t", 5.8, "hang"), FailureRegion("alpha", 5.8, "raise")),
                         hang_s=math.inf)  # its abandoned thread sleeps on, a daemon of this process
    with DaskExecutor(ev, n_workers=2, processes=False, timeout_s=TIMEOUT_S) as ex:
        out = ex.map([{**GOOD, "t": 5.9}, {**GOOD, "alpha": 5.9}, GOOD], [1, 2, 3])
    assert [o.status for o in out] == ["timeout", "error", "ok"]


def test_unpicklable_evaluator_is_refused_up_front():
    with pytest.raises(TypeError, match="cannot be pickled"):
        ProcessExecutor(lambda g: None)
    cfg = ExecutorConfig(kind="serial")
    with make_executor(cfg, lambda g: None) as ex:  # serial needs no pickling
        assert ex.kind == "serial"


def test_test_fitness_is_picklable():
    ev = AnalyticFitness(failures=(FailureRegion("alpha", 5.0),), with_curves=True)
    again = pickle.loads(pickle.dumps(ev))
    assert again == ev and again(GOOD).f1 == ev(GOOD).f1


def test_a_worker_killed_from_outside_is_retried_not_recorded(tmp_path):
    """A SIGKILLed worker (as the OOM killer does) costs a retry, never a penalised design."""
    ref = run_optimisation(_cfg("serial"), tmp_path / "serial", EV, seed=5, progress=False)
    kill_once = AnalyticFitness(optimum=EV.optimum, failures=EV.failures + (FailureRegion("l", 11.0, "kill_once"),),
                                marker_dir=str(tmp_path))
    got = run_optimisation(_cfg("processes"), tmp_path / "proc", kill_once, seed=5, progress=False)
    assert len(list(tmp_path.glob("killed_*"))) > 0  # workers were killed
    assert _fingerprint(got) == _fingerprint(ref)
    assert got.n_failures == ref.n_failures


def test_a_design_whose_worker_is_always_killed_stops_the_run():
    ev = AnalyticFitness(failures=(FailureRegion("l", 14.0, "kill"),))
    with ProcessExecutor(ev, n_workers=1, max_retries=1) as ex:
        with pytest.raises(MachineFailure, match="killed by signal 9 2 times"):
            ex.map([GOOD, {**GOOD, "l": 14.5}], [1, 2])


def test_dask_worker_killed_mid_evaluation_ends_as_the_local_run(tmp_path):
    """A LocalCluster worker process SIGKILLed during an evaluation: the task runs again, the run
    is identical to the serial one and nothing is recorded against the design."""
    ref = run_optimisation(_cfg("serial"), tmp_path / "serial", EV, seed=8, progress=False)
    # l > 14 mm: three distinct designs of the run kill their worker once, few enough that the local
    # cluster's nannies restart every one of them on a loaded machine
    kill_once = AnalyticFitness(optimum=EV.optimum, failures=EV.failures + (FailureRegion("l", 14.0, "kill_once"),),
                                marker_dir=str(tmp_path))
    got = run_optimisation(_cfg("dask", dask_processes=True), tmp_path / "dask", kill_once, seed=8, progress=False)
    assert len(list(tmp_path.glob("killed_*"))) == 3
    assert _fingerprint(got) == _fingerprint(ref)


def test_unreachable_scheduler_is_one_line_and_quick():
    import socket
    import time

    with socket.socket() as s:  # a free loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    t0 = time.monotonic()
    with pytest.raises(MachineFailure, match=r"cannot reach the dask scheduler at 'tcp://127.0.0.1:\d+'") as err:
        connect_scheduler(f"tcp://127.0.0.1:{port}", timeout_s=2.0)
    assert "\n" not in str(err.value) and time.monotonic() - t0 < 30
    with pytest.raises(MachineFailure):
        preflight(ExecutorConfig(kind="dask", scheduler_address=f"tcp://127.0.0.1:{port}"))


def test_finite_element_evaluations_are_bit_identical_on_every_executor():
    """The whisker's own evaluator (coarse preset) gives the same numbers, to the last bit, in one process
    (all three designs in a row), in a pool of two processes (one worker solves two of them) and on dask
    workers: an evaluation's Newton solves start from nothing a worker kept from the design before."""
    import whisker_opt.wiring as wiring
    from whisker_opt.api import load_config

    ev = wiring.evaluator(load_config({"fidelity": {"preset": "coarse"}, "optimiser": {"trim": 5.0}}))
    genes = [{"alpha": 2.862, "l": 15.0, "t": 3.0, "Q_i": 0.2}, {"alpha": 4.0515, "l": 11.069, "t": 2.6521, "Q_i": 0.19986},
             {"alpha": 3.5, "l": 12.0, "t": 4.0, "Q_i": 0.1}]
    seeds = [1, 2, 3]

    def numbers(out):
        return [(o.status, o.f1, o.extra["eps_i_max"], o.extra["eps_c_max"], o.extra["delta_l"]) for o in out]

    with SerialExecutor(ev) as ex:
        ref = numbers(ex.map(genes, seeds))
    assert [r[0] for r in ref] == ["ok"] * 3 and len({r[1] for r in ref}) == 3
    with ProcessExecutor(ev, n_workers=2) as ex:
        assert numbers(ex.map(genes, seeds)) == ref
    with DaskExecutor(ev, n_workers=2, processes=True) as ex:
        assert numbers(ex.map(genes, seeds)) == ref


def test_an_interrupt_while_a_worker_starts_comes_once_it_has_started(monkeypatch):
    """Was: a Ctrl-C (or the SIGTERM the command line turns into one) in the middle of a worker's start cut
    the evaluator's message to the fresh interpreter, which printed a traceback of its own."""
    import multiprocessing.process
    import os
    import signal

    ex = ProcessExecutor(AnalyticFitness(), n_workers=1)
    started = []
    real_start = multiprocessing.process.BaseProcess.start

    def interrupted_start(self):
        os.kill(os.getpid(), signal.SIGINT)  # Python runs its handler at the next instruction
        real_start(self)
        started.append(self)

    monkeypatch.setattr(multiprocessing.process.BaseProcess, "start", interrupted_start)
    try:
        with pytest.raises(KeyboardInterrupt):
            ex.map([GOOD], [1])
        assert len(started) == 1 and started[0].pid is not None  # the start was not cut short
    finally:
        ex.close()
