"""Where design evaluations run: in-process, in a local process pool, or on dask.

Every executor exposes the same two methods (and is a context manager)::

    outcomes = ex.map(genes_list, seeds)   # list[dict[str, float]], list[int] -> list[EvalOutcome]
    ex.close()

and guarantees, for every design, one :class:`~whisker_opt.experiment.outcome.EvalOutcome` in input
order, whatever happens inside the evaluator:

- an exception becomes status ``"error"`` with ``"<Type>: <message>"`` as reason and the
  traceback in ``extra["traceback"]``; the run never crashes because of one design;
- a failure of the machine is never recorded against a design: a worker process that dies
  (killed by the operating system, out of memory, a signal) or a dask task whose worker is
  lost is run again on a fresh worker, up to ``max_retries`` times. A design that still
  kills its worker by a crash of its own (an exit code, a segfault) is then recorded as
  ``"error"``; one whose worker is still killed from outside (SIGKILL/SIGTERM, a lost dask
  worker) raises :class:`MachineFailure`, which stops the run; it resumes from its last
  checkpoint;
- an evaluation longer than ``timeout_s`` becomes status ``"timeout"``;
- before each call, Python's ``random`` and NumPy's global RNG are seeded with the
  design's seed (:func:`whisker_opt.optimise.evalcache.evaluation_seed`), so the evaluator's
  randomness, if any, does not depend on the executor, the worker or the order;
- the wall time of the call is added as ``timings["eval_s"]``;
- ``map(..., on_result=f)`` calls ``f(index, outcome)`` here as each design's final outcome is
  known (completion order, once per design): it observes only, and an exception in it is logged.

Timeouts
    ``serial``: SIGALRM in the main thread (interrupts Python code; a C extension is
    interrupted when it returns to Python). ``processes``: the parent kills the worker
    process at the deadline and starts a fresh one, so even a hang inside C code (e.g. a
    CAD boolean) is stopped. ``dask``: the task runs the evaluator in a helper thread and
    gives up waiting at the deadline; the abandoned computation keeps its thread until it
    returns (threads cannot be killed), so prefer ``processes`` for evaluations that may
    hang forever.

The ``processes`` pool is a small hand-written one (not ``ProcessPoolExecutor``) so that a
timeout or a crash is attributed to the one design that caused it, and only that worker
is replaced. Workers are started with the ``spawn`` method by default: the evaluator must
be picklable and importable (a module-level class or function), which is checked up front.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing as mp
import os
import pickle
import random
import signal
import threading
import time
import traceback
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import wait as mp_wait
from typing import Any, Callable, Iterator, Sequence

from whisker_opt.experiment.outcome import EvalOutcome

logger = logging.getLogger(__name__)

Evaluator = Callable[[dict[str, float]], EvalOutcome]
OnResult = Callable[[int, EvalOutcome], None]

_THREAD_ENV_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")

#: Re-runs of a design whose worker died or was lost, before the failure is final.
MAX_RETRIES = 2
#: Seconds between warnings while dask tasks wait (e.g. no worker connected).
HEARTBEAT_S = 30.0
#: Seconds to reach a dask scheduler before giving up.
CONNECT_TIMEOUT_S = 20.0
#: Exit codes of a worker process killed from outside (SIGKILL, SIGTERM): a machine failure.
_KILLED_FROM_OUTSIDE = (-signal.SIGKILL, -signal.SIGTERM)


class MachineFailure(RuntimeError):
    """Evaluations cannot run for a reason outside the designs (workers killed or lost, no
    scheduler): the run stops, nothing is recorded against a design, and it can be resumed."""


class _EvalTimeout(BaseException):
    """Raised by the SIGALRM handler; a BaseException so ``except Exception`` in user code does not swallow it."""


def _seed_globals(seed: int) -> None:
    random.seed(seed)
    try:
        import numpy as np

        np.random.seed(seed % 2**32)
    except ImportError:  # pragma: no cover - numpy is a hard dependency
        pass


def _call_with_alarm(fn: Callable[[], Any], timeout_s: float) -> Any:
    def _handler(signum, frame):  # noqa: ARG001
        raise _EvalTimeout()

    old = signal.signal(signal.SIGALRM, _handler)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    try:
        return fn()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


def _call_with_thread(fn: Callable[[], Any], timeout_s: float) -> Any:
    box: dict[str, Any] = {}

    def _target() -> None:
        try:
            box["out"] = fn()
        except BaseException as exc:  # noqa: BLE001 - re-raised in the caller
            box["exc"] = exc

    th = threading.Thread(target=_target, name="whisker-eval", daemon=True)
    th.start()
    th.join(timeout_s)
    if th.is_alive():
        logger.warning("evaluation abandoned after %.3g s; its thread keeps running until it returns", timeout_s)
        raise _EvalTimeout()
    if "exc" in box:
        raise box["exc"]
    return box["out"]


def guarded_call(
    evaluator: Evaluator,
    genes: dict[str, float],
    seed: int,
    timeout_s: float | None = None,
    timeout_mode: str = "none",
    threads: int | None = None,
) -> EvalOutcome:
    """Evaluate one design; never raises for a problem inside the evaluator.

    Parameters
    ----------
    evaluator : callable
        ``evaluate(genes) -> EvalOutcome``.
    genes : dict
        Gene values by name.
    seed : int
        Seed of ``random`` and NumPy's global RNG for this call.
    timeout_s : float or None
        Wall-clock limit [s].
    timeout_mode : {"none", "alarm", "thread"}
        How the limit is enforced here ("none": enforced by the caller, or no limit).
    threads : int or None
        MKL threads of the evaluating thread (:func:`fem.linsolve.mkl_threads`), so that an
        evaluation in this process rounds as one in a worker started with that many threads;
        None: as the process is set up.

    Returns
    -------
    EvalOutcome
        The evaluator's outcome (validated), or a ``"timeout"`` / ``"error"`` outcome;
        ``timings["eval_s"]`` holds the wall time.
    """
    from fem.linsolve import mkl_threads  # imported before the clock starts: a first import is not the design's time

    _seed_globals(seed)
    t0 = time.perf_counter()

    def _call() -> Any:
        with mkl_threads(threads):
            return evaluator(dict(genes))

    try:
        if timeout_s is not None and timeout_mode == "alarm":
            out = _call_with_alarm(_call, timeout_s)
        elif timeout_s is not None and timeout_mode == "thread":
            out = _call_with_thread(_call, timeout_s)
        else:
            out = _call()
        if not isinstance(out, EvalOutcome):
            out = EvalOutcome.failure("error", f"evaluator returned {type(out).__name__}, not EvalOutcome")
        out = out.validated()
    except _EvalTimeout:
        out = EvalOutcome.failure("timeout", f"evaluation exceeded {timeout_s:g} s")
    except Exception as exc:  # noqa: BLE001 - any evaluator bug becomes a recorded failure
        out = EvalOutcome.failure(
            "error", f"{type(exc).__name__}: {exc}", extra={"traceback": traceback.format_exc()}
        )
    return out.with_timing(eval_s=time.perf_counter() - t0)


@contextlib.contextmanager
def _thread_env(n_threads: int) -> Iterator[None]:
    """Temporarily set the BLAS/OpenMP thread variables (inherited by spawned children)."""
    old = {k: os.environ.get(k) for k in _THREAD_ENV_VARS}
    os.environ.update({k: str(n_threads) for k in _THREAD_ENV_VARS})
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT, SIGTERM and SIGHUP until the block ends, then deliver them (main thread only).

    A worker's start sends it its evaluator through a pipe: an interrupt in the middle of that write
    leaves the fresh interpreter a cut message, which it reports with a traceback of its own after the
    run has said it was interrupted.
    """
    names = ("SIGINT", "SIGTERM", "SIGHUP")
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    old = {sig: signal.signal(sig, lambda s, frame: got.append(s))  # noqa: ARG005
           for sig in (getattr(signal, n) for n in names if hasattr(signal, n))}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
        for sig in got:
            signal.raise_signal(sig)


def _check_picklable(evaluator: Evaluator) -> None:
    try:
        pickle.dumps(evaluator)
    except Exception as exc:  # noqa: BLE001
        raise TypeError(
            f"the evaluator {evaluator!r} cannot be pickled for worker processes "
            f"({type(exc).__name__}: {exc}); use a module-level class or function"
        ) from None


def _notify(on_result: OnResult | None, index: int, outcome: EvalOutcome) -> EvalOutcome:
    """Call ``on_result(index, outcome)`` (a failure of the observer never reaches the run); returns ``outcome``."""
    if on_result is not None:
        try:
            on_result(index, outcome)
        except Exception:  # noqa: BLE001 - a progress display must not stop evaluations
            logger.warning("per-result callback failed for design %d (ignored)", index, exc_info=True)
    return outcome


class _BaseExecutor:
    """Context-manager plumbing shared by the executors."""

    kind = "base"

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Release workers (idempotent)."""

    def map(self, genes_list: Sequence[dict[str, float]], seeds: Sequence[int],
            on_result: OnResult | None = None) -> list[EvalOutcome]:
        raise NotImplementedError


class SerialExecutor(_BaseExecutor):
    """Evaluate in the calling process, one design after the other.

    Parameters
    ----------
    evaluator : callable
    timeout_s : float or None
        Enforced with SIGALRM when called from the main thread, else with a helper thread.
    threads : int
        MKL threads of each evaluation (as a worker process of the other executors has), so a
        serial run rounds as a parallel one (:func:`fem.linsolve.mkl_threads`).
    """

    kind = "serial"

    def __init__(self, evaluator: Evaluator, timeout_s: float | None = None, threads: int = 1) -> None:
        self.evaluator = evaluator
        self.timeout_s = timeout_s
        self.threads = threads

    def map(self, genes_list: Sequence[dict[str, float]], seeds: Sequence[int],
            on_result: OnResult | None = None) -> list[EvalOutcome]:
        """Evaluate each design in order; see the module docstring."""
        main = threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer")
        mode = "alarm" if main else "thread"
        return [_notify(on_result, i, guarded_call(self.evaluator, g, s, self.timeout_s, mode, self.threads))
                for i, (g, s) in enumerate(zip(genes_list, seeds))]


def _die_with_parent(parent_pid: int) -> None:
    """End this worker as soon as its parent process ends (even when the parent is SIGKILLed).

    Linux: ``prctl(PR_SET_PDEATHSIG, SIGKILL)``; elsewhere a daemon thread polls the parent pid.
    """
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        if libc.prctl(1, signal.SIGKILL) == 0:  # PR_SET_PDEATHSIG = 1
            if os.getppid() != parent_pid:  # the parent died before prctl took effect
                os._exit(1)
            return
    except (OSError, AttributeError):
        pass

    def _watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=_watch, name="whisker-parent-watch", daemon=True).start()


def _worker_main(conn, evaluator: Evaluator, parent_pid: int | None = None) -> None:
    """Loop of a pool worker: receive (index, genes, seed), send (index, outcome); None stops."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is handled by the parent
    if parent_pid is not None:
        _die_with_parent(parent_pid)
    import fem.linsolve  # noqa: F401 - what every evaluation imports, before its deadline runs
    try:
        conn.send("ready")
    except (BrokenPipeError, EOFError, OSError):
        return
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):  # parent gone
            return
        if msg is None:
            return
        idx, genes, seed = msg
        out = guarded_call(evaluator, genes, seed)
        try:
            conn.send((idx, out))
        except (BrokenPipeError, EOFError, OSError):  # parent gone
            return
        except Exception as exc:  # noqa: BLE001 - e.g. an unpicklable extra
            try:
                conn.send((idx, EvalOutcome.failure("error", f"outcome could not be sent back: {exc}", out.timings)))
            except Exception:  # noqa: BLE001
                return


@dataclass
class _Worker:
    proc: Any
    conn: Any
    task: tuple[int, float] | None = None  # (index, deadline)


class ProcessExecutor(_BaseExecutor):
    """A local pool of worker processes with per-evaluation hard timeouts.

    Parameters
    ----------
    evaluator : callable
        Picklable ``evaluate(genes) -> EvalOutcome``; sent once to each worker.
    n_workers : int
        Worker processes.
    timeout_s : float or None
        A worker busy for longer on one design is killed and replaced; the design gets
        status ``"timeout"``.
    start_method : str
        ``multiprocessing`` start method ("spawn" is safe with threads in the parent).
    threads_per_worker : int
        OMP/MKL/OPENBLAS_NUM_THREADS of the workers.
    start_timeout_s : float
        A worker that does not report ready within this time (e.g. the evaluator cannot be
        imported in a fresh interpreter) aborts with ``RuntimeError``: that is a set-up
        problem, not a design failure.
    max_retries : int
        Re-runs of a design whose worker died (see the module docstring).
    """

    kind = "processes"

    def __init__(
        self,
        evaluator: Evaluator,
        n_workers: int = 2,
        timeout_s: float | None = None,
        start_method: str = "spawn",
        threads_per_worker: int = 1,
        start_timeout_s: float = 120.0,
        max_retries: int = MAX_RETRIES,
    ) -> None:
        _check_picklable(evaluator)
        self.max_retries = int(max_retries)
        self.evaluator = evaluator
        self.n_workers = int(n_workers)
        self.timeout_s = timeout_s
        self.threads_per_worker = int(threads_per_worker)
        self._ctx = mp.get_context(start_method)
        self.start_timeout_s = float(start_timeout_s)
        self._workers: list[_Worker] = []
        self._counter = 0

    def _spawn(self) -> _Worker:
        parent, child = self._ctx.Pipe(duplex=True)
        self._counter += 1
        proc = self._ctx.Process(
            target=_worker_main, args=(child, self.evaluator, os.getpid()), daemon=True,
            name=f"whisker-worker-{self._counter}",
        )
        with _thread_env(self.threads_per_worker), _signals_held():
            proc.start()
        child.close()
        return _Worker(proc, parent)

    def _await_ready(self, workers: Sequence[_Worker]) -> None:
        """Wait for the start-up handshake; a worker that cannot start is an environment error."""
        deadline = time.monotonic() + self.start_timeout_s
        for w in workers:
            ok = False
            try:
                if w.conn.poll(max(0.0, deadline - time.monotonic())):
                    ok = w.conn.recv() == "ready"
            except (EOFError, OSError):
                ok = False
            if not ok:
                code = w.proc.exitcode
                for v in workers:
                    if v.proc.is_alive():
                        v.proc.kill()
                    if v in self._workers:
                        self._workers.remove(v)
                raise RuntimeError(
                    f"worker process {w.proc.name} failed to start (exit code {code}); "
                    "is the evaluator importable in a fresh interpreter (module-level, not __main__ of a "
                    "script without an `if __name__ == '__main__'` guard)?"
                )

    def _grow(self, n: int) -> None:
        new = [self._spawn() for _ in range(n)]
        self._workers.extend(new)
        self._await_ready(new)

    def _retire(self, w: _Worker, kill: bool) -> None:
        if kill and w.proc.is_alive():
            w.proc.kill()
        w.proc.join(5.0)
        with contextlib.suppress(Exception):
            w.conn.close()
        self._workers.remove(w)

    def _replace(self, w: _Worker, kill: bool) -> None:
        self._retire(w, kill)
        self._grow(1)

    def map(self, genes_list: Sequence[dict[str, float]], seeds: Sequence[int],
            on_result: OnResult | None = None) -> list[EvalOutcome]:
        """Evaluate the designs on the pool; results in input order."""
        n = len(genes_list)
        results: list[EvalOutcome | None] = [None] * n
        missing = min(self.n_workers, max(n, 1)) - len(self._workers)
        if missing > 0:
            self._grow(missing)
        pending = deque(range(n))
        deaths = [0] * n
        inf = float("inf")
        while pending or any(w.task for w in self._workers):
            for w in list(self._workers):
                if w.task is None and pending:
                    if not w.proc.is_alive():  # died while idle: not the next design's fault
                        self._replace(w, kill=False)
                        continue
                    i = pending.popleft()
                    try:
                        w.conn.send((i, dict(genes_list[i]), int(seeds[i])))
                    except (BrokenPipeError, OSError):
                        pending.appendleft(i)
                        self._replace(w, kill=True)
                        continue
                    deadline = time.monotonic() + self.timeout_s if self.timeout_s else inf
                    w.task = (i, deadline)
            busy = [w for w in self._workers if w.task]
            if not busy:
                continue
            next_deadline = min(w.task[1] for w in busy)  # type: ignore[index]
            wait_s = None if next_deadline == inf else max(0.0, next_deadline - time.monotonic())
            mp_wait([w.conn for w in busy] + [w.proc.sentinel for w in busy], wait_s)
            now = time.monotonic()
            for w in busy:
                i, deadline = w.task  # type: ignore[misc]
                got = False
                try:
                    if w.conn.poll():
                        idx, out = w.conn.recv()
                        w.task = None
                        got = True
                        results[idx] = _notify(on_result, idx, out)
                except (EOFError, OSError):
                    pass
                if got:
                    continue
                if not w.proc.is_alive():
                    code = w.proc.exitcode
                    deaths[i] += 1
                    logger.warning("worker %s died (exit code %s) evaluating design %d %s (attempt %d of %d)",
                                   w.proc.name, code, i, dict(genes_list[i]), deaths[i], self.max_retries + 1)
                    w.task = None
                    self._replace(w, kill=False)
                    if deaths[i] <= self.max_retries:
                        pending.appendleft(i)  # a fresh worker tries again: the machine may be at fault
                    elif code in _KILLED_FROM_OUTSIDE:
                        raise MachineFailure(
                            f"the worker evaluating design {dict(genes_list[i])} was killed by signal {-code} "
                            f"{deaths[i]} times (out of memory, or stopped by the system); the run stops here "
                            "and resumes from its last checkpoint")
                    else:
                        results[i] = _notify(on_result, i, EvalOutcome.failure(
                            "error", f"worker process died (exit code {code}) in {deaths[i]} attempts",
                            timings={"eval_s": 0.0}))
                elif now >= deadline:
                    logger.warning("design %d exceeded %.3g s: killing worker %s", i, self.timeout_s, w.proc.name)
                    results[i] = EvalOutcome.failure(
                        "timeout", f"evaluation exceeded {self.timeout_s:g} s (worker killed)",
                        timings={"eval_s": float(self.timeout_s)},  # type: ignore[arg-type]
                    )
                    self._replace(w, kill=True)
                    _notify(on_result, i, results[i])
        return results  # type: ignore[return-value]

    def close(self) -> None:
        """Stop the workers (politely, then by force)."""
        for w in list(self._workers):
            with contextlib.suppress(Exception):
                w.conn.send(None)
        for w in list(self._workers):
            w.proc.join(2.0)
            self._retire(w, kill=True)
