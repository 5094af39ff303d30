"""Evaluations on dask.distributed: a LocalCluster, or an existing scheduler reached by address.

The executor contract is that of :mod:`whisker_opt.optimise.executors`: one outcome per design,
in input order, each seeded by its design's seed. A task that does not finish because its
worker was lost is submitted again (never recorded against the design); while tasks wait with
no worker connected, a warning every ``heartbeat_s``.

A scheduler given by address is probed before a client is made (:func:`probe_scheduler`): a
TCP connection and dask's handshake within ``timeout_s`` in all, so an address where nothing
listens, or where a service that is not dask listens (one that never answers, or answers
garbage), is a :class:`SchedulerUnreachable` in one line before anything runs, never a hang.
A scheduler lost during a run (killed, its machine gone) ends the run with a
:class:`~whisker_opt.optimise.executors.MachineFailure` in one line; its last checkpoint stays,
and it resumes from there. distributed's own error records of that loss (tracebacks of the
client's reconnection attempts) are dropped while the executor lives (:class:`_SchedulerLossFilter`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import threading
import time
from concurrent.futures import CancelledError as FutureCancelled
from typing import Any, Sequence

from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.optimise.executors import (
    _THREAD_ENV_VARS,
    CONNECT_TIMEOUT_S,
    HEARTBEAT_S,
    MAX_RETRIES,
    Evaluator,
    MachineFailure,
    OnResult,
    _BaseExecutor,
    _check_picklable,
    _notify,
    guarded_call,
)

logger = logging.getLogger(__name__)

#: Seconds to gather a finished task's result before it counts as lost with its worker.
RESULT_TIMEOUT_S = 30.0

#: Seconds a LocalCluster may have no worker at all while evaluations wait, before the run stops: its nannies
#: gave up restarting killed workers (a remote scheduler's workers may join later: there it is only warned about).
NO_WORKER_TIMEOUT_S = 60.0

#: Loggers of distributed that report the loss of the scheduler with tracebacks of their own.
_LOSS_LOGGERS = ("distributed.client", "distributed.utils", "distributed.core", "distributed.batched")


class SchedulerUnreachable(MachineFailure):
    """The dask scheduler of ``optimiser.executor.scheduler_address`` cannot be reached, or what answers
    there is not a dask scheduler; raised before anything runs (a bad input: exit status 2)."""


class _SchedulerLossFilter(logging.Filter):
    """Drops distributed's error records of a lost scheduler connection (the executor reports it in one line)."""

    def filter(self, record: logging.LogRecord) -> bool:  # noqa: D102 - logging.Filter.filter
        exc = record.exc_info[1] if record.exc_info else None
        if isinstance(exc, (OSError, asyncio.CancelledError, asyncio.TimeoutError)):
            return False
        return not str(record.msg).startswith("Failed to reconnect to scheduler")


def _dask_task(evaluator: Evaluator, genes: dict[str, float], seed: int, timeout_s: float | None,
               threads: int | None = None) -> EvalOutcome:
    return guarded_call(evaluator, genes, seed, timeout_s, "thread", threads)


class DaskExecutor(_BaseExecutor):
    """Evaluate on dask.distributed: a LocalCluster by default, or an existing scheduler.

    Parameters
    ----------
    evaluator : callable
        Picklable ``evaluate(genes) -> EvalOutcome``; must be importable on the workers.
    n_workers : int
        Workers of the LocalCluster (ignored with ``scheduler_address``).
    scheduler_address : str or None
        Connect to this scheduler instead of starting a LocalCluster.
    processes : bool
        LocalCluster workers are processes (True) or threads of this process (False).
    threads_per_worker : int
        BLAS/OpenMP threads of LocalCluster worker processes. Each worker runs one task
        at a time (``nthreads=1``), so concurrent evaluations never share a global RNG.
    timeout_s : float or None
        Per-evaluation limit, enforced inside the task (see the module docstring).
    max_retries : int
        Re-submissions of a design whose task was lost with its worker.
    heartbeat_s : float
        While tasks wait, a log line every ``heartbeat_s`` (a warning when no worker is connected).
    connect_timeout_s : float, optional
        Seconds to reach ``scheduler_address`` (default :data:`CONNECT_TIMEOUT_S`).

    Raises
    ------
    SchedulerUnreachable
        The scheduler cannot be reached, or what answers is not a dask scheduler.
    """

    kind = "dask"

    def __init__(
        self,
        evaluator: Evaluator,
        n_workers: int = 2,
        scheduler_address: str | None = None,
        processes: bool = True,
        threads_per_worker: int = 1,
        timeout_s: float | None = None,
        max_retries: int = MAX_RETRIES,
        heartbeat_s: float = HEARTBEAT_S,
        connect_timeout_s: float | None = None,
    ) -> None:
        _check_picklable(evaluator)
        self.evaluator = evaluator
        self.timeout_s = timeout_s
        self.threads = int(threads_per_worker)  # MKL threads of each evaluating thread (fem.linsolve.mkl_threads)
        self.max_retries = int(max_retries)
        self.heartbeat_s = float(heartbeat_s)
        self._cluster = None
        self._loss_filter = _SchedulerLossFilter()
        for name in _LOSS_LOGGERS:
            logging.getLogger(name).addFilter(self._loss_filter)
        self._address = scheduler_address
        try:
            self._start(n_workers, processes, threads_per_worker, connect_timeout_s)
        except BaseException:
            self._remove_filter()
            raise
        logger.info("dask executor: %s", self._client)

    def _start(self, n_workers: int, processes: bool, threads_per_worker: int,
               connect_timeout_s: float | None) -> None:
        """The client: of the scheduler at ``self._address``, or of a new LocalCluster."""
        if self._address:
            self._client = connect_scheduler(self._address, connect_timeout_s)
            return
        from distributed import Client, LocalCluster

        kwargs: dict[str, Any] = {}
        if processes:
            kwargs["env"] = {k: str(threads_per_worker) for k in _THREAD_ENV_VARS}
        self._cluster = LocalCluster(
            n_workers=int(n_workers),
            threads_per_worker=1,
            processes=processes,
            dashboard_address=None,
            silence_logs=logging.ERROR,
            **kwargs,
        )
        self._client = Client(self._cluster)

    def _remove_filter(self) -> None:
        for name in _LOSS_LOGGERS:
            logging.getLogger(name).removeFilter(self._loss_filter)

    def _scheduler_lost(self, n_pending: int, n_total: int, why: str) -> MachineFailure:
        address = f"at {self._address}" if self._address else "of the LocalCluster"
        return MachineFailure(
            f"the dask scheduler {address} was lost with {n_pending} of {n_total} evaluation(s) of this batch "
            f"unfinished ({why}); the run stops here and resumes from its last checkpoint once a scheduler runs "
            f"again")

    def _check_workers(self, since: float | None, n_pending: int, n_total: int) -> float | None:
        """When the LocalCluster's workers have all been gone for :data:`NO_WORKER_TIMEOUT_S`, a MachineFailure;
        else the time since which none is connected (None while one is)."""
        if self._n_workers() > 0:
            return None
        now = time.monotonic()
        if since is not None and now - since > NO_WORKER_TIMEOUT_S:
            raise MachineFailure(
                f"the dask LocalCluster has had no worker for {now - since:.0f} s with {n_pending} of {n_total} "
                "evaluation(s) of this batch unfinished (its workers were killed and not restarted: short of memory, "
                "or killed from outside); the run stops here and resumes from its last checkpoint")
        return now if since is None else since

    def _connected(self) -> bool:
        return getattr(self._client, "status", "running") == "running"

    def _submit(self, genes: dict[str, float], seed: int):
        return self._client.submit(_dask_task, self.evaluator, dict(genes), int(seed), self.timeout_s, self.threads,
                                   pure=False)

    def _n_workers(self) -> int:
        try:
            return len(self._client.scheduler_info().get("workers", {}))
        except Exception:  # noqa: BLE001 - the scheduler itself is gone: reported by the caller
            return 0

    def map(self, genes_list: Sequence[dict[str, float]], seeds: Sequence[int],
            on_result: OnResult | None = None) -> list[EvalOutcome]:
        """Submit every design and gather in input order.

        A task that does not finish (its worker was lost, or dask gave up on it), or whose result
        cannot be gathered within ``RESULT_TIMEOUT_S``, is submitted again, up to ``max_retries``
        times; then :class:`MachineFailure`. A lost scheduler (every future cancelled, the client
        no longer connected) is a :class:`MachineFailure` at once. The task
        itself never raises for a design's fault (:func:`guarded_call`), so a task that does
        not finish is always the machine's fault. While tasks wait, a warning every
        ``heartbeat_s`` says when no worker is connected.
        """
        from distributed import wait
        from distributed.comm import CommClosedError

        n = len(genes_list)
        results: list[EvalOutcome | None] = [None] * n
        attempts = [1] * n
        # the scheduler's connection is gone (distributed cancels every future: FuturesCancelledError)
        lost = (FutureCancelled, asyncio.CancelledError, CommClosedError, OSError)
        try:
            pending = {i: self._submit(genes_list[i], seeds[i]) for i in range(n)}
        except lost as exc:
            raise self._scheduler_lost(n, n, _why(exc)) from None
        waited = 0.0
        no_worker_since: float | None = None
        while pending:
            poll = min(self.heartbeat_s, 2.0)
            try:
                done = set(wait(list(pending.values()), timeout=poll, return_when="FIRST_COMPLETED").done)
            except TimeoutError:
                done = set()
            except lost as exc:
                raise self._scheduler_lost(len(pending), n, _why(exc)) from None
            if not self._connected():
                raise self._scheduler_lost(len(pending), n, f"client {self._client.status}")
            done |= {f for f in pending.values() if f.status not in ("pending", "finished")}  # e.g. "lost"
            if not done:
                waited += poll
                if self._cluster is not None:  # our own cluster: no worker left for long is a machine failure
                    no_worker_since = self._check_workers(no_worker_since, len(pending), n)
                if waited % self.heartbeat_s < poll:
                    n_workers = self._n_workers()
                    log = logger.warning if n_workers == 0 else logger.info
                    log("dask: %d evaluation(s) waiting for %.0f s; %d worker(s) connected to %s", len(pending),
                        waited, n_workers, self._client.scheduler.address)
                continue
            waited = 0.0
            no_worker_since = None
            for i, f in list(pending.items()):
                if f not in done:
                    continue
                del pending[i]
                out = None
                if f.status == "finished":
                    # its result may be lost with its worker meanwhile: gathering it from a dead worker can
                    # wait without end, so it is bounded (a few bytes from a live worker take milliseconds)
                    with contextlib.suppress(Exception):
                        out = f.result(timeout=RESULT_TIMEOUT_S)
                reason = f.status if out is None else ""
                if out is None and f.status == "error":
                    with contextlib.suppress(Exception):
                        reason = f"error: {f.exception()}"
                f.release()
                if out is not None:
                    results[i] = _notify(on_result, i, out)
                    continue
                if attempts[i] > self.max_retries:
                    raise MachineFailure(
                        f"dask could not evaluate design {dict(genes_list[i])} in {attempts[i]} attempts "
                        f"(task {reason}: its worker was lost); the run stops here and resumes from its last "
                        "checkpoint")
                if not self._connected():
                    raise self._scheduler_lost(len(pending) + 1, n, reason)
                attempts[i] += 1
                logger.warning("dask task of design %d %s %s; submitting it again (attempt %d of %d)", i,
                               dict(genes_list[i]), reason, attempts[i], self.max_retries + 1)
                try:
                    pending[i] = self._submit(genes_list[i], seeds[i])
                except lost as exc:
                    raise self._scheduler_lost(len(pending) + 1, n, _why(exc)) from None
        return results  # type: ignore[return-value]

    def close(self) -> None:
        """Close the client and the LocalCluster, if any."""
        with contextlib.suppress(Exception, asyncio.CancelledError):
            self._client.close()
        if self._cluster is not None:
            with contextlib.suppress(Exception, asyncio.CancelledError):
                self._cluster.close()
            self._cluster = None
        self._remove_filter()


def _why(exc: BaseException) -> str:
    """A lost connection's exception in a few words (its first line)."""
    if "scheduler-connection-lost" in str(exc):  # distributed cancelled every future of the lost client
        return "the client lost its connection to the scheduler"
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0][:200]}" if text else type(exc).__name__


async def _identity(address: str, timeout_s: float) -> Any:
    """Connect to ``address`` and ask it who it is (dask's ``identity`` call); the caller bounds the time."""
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout_s)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def probe_scheduler(address: str, timeout_s: float | None = None) -> None:
    """Check that a dask scheduler answers at ``address`` within ``timeout_s``.

    A TCP connection first (nothing listening, no route: "cannot reach"), then dask's handshake
    and its ``identity`` call, each within ``timeout_s``. The handshake runs in a thread of its
    own with its own event loop (it works where an event loop already runs, e.g. in a notebook),
    and it is abandoned at the deadline: a service that accepts the connection and then says
    nothing cannot hold it, which distributed's ``Client`` (it waits for the handshake without a
    limit) would.

    Parameters
    ----------
    address : str
        ``tcp://HOST:PORT`` or ``tls://HOST:PORT``.
    timeout_s : float, optional
        Seconds for the connection and the handshake (default :data:`CONNECT_TIMEOUT_S`).

    Raises
    ------
    SchedulerUnreachable
        Nothing listens there, nothing answers within ``timeout_s``, the answer is not dask's
        protocol, or it is not a scheduler's; one line naming ``optimiser.executor.scheduler_address``.
    """
    timeout_s = CONNECT_TIMEOUT_S if timeout_s is None else float(timeout_s)
    key = "optimiser.executor.scheduler_address"
    expected = "expected the address of a running dask scheduler (`dask scheduler` prints it)"
    _, _, rest = address.rpartition("://")
    host, _, port = rest.rpartition(":")
    try:  # first TCP alone: nothing listening is told apart from a service that is not dask
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except (OSError, ValueError) as exc:
        raise SchedulerUnreachable(f"{key}: cannot reach the dask scheduler at {address!r} within {timeout_s:g} s "
                                   f"({_why(exc)}); {expected}") from None
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["reply"] = asyncio.run(asyncio.wait_for(_identity(address, timeout_s), timeout_s))
        except BaseException as exc:  # noqa: BLE001 - reported below, in the caller's thread
            box["error"] = exc

    th = threading.Thread(target=target, name="whisker-dask-probe", daemon=True)
    th.start()
    th.join(timeout_s + 2.0)
    exc = box.get("error")
    if th.is_alive() or isinstance(exc, (asyncio.TimeoutError, TimeoutError)):
        raise SchedulerUnreachable(f"{key}: {address!r}: no dask scheduler answered within {timeout_s:g} s (a "
                                   f"service that is not dask, or a scheduler that hangs); {expected}")
    if isinstance(exc, OSError):  # refused, no route, closed: distributed's CommClosedError is an OSError too
        raise SchedulerUnreachable(f"{key}: cannot reach the dask scheduler at {address!r} within {timeout_s:g} s "
                                   f"({_why(exc)}); {expected}")
    if isinstance(exc, (KeyboardInterrupt, SystemExit)):
        raise exc
    if exc is not None:  # garbage: distributed cannot decode it (a MemoryError for a frame length of exabytes)
        what = "its answer is no dask message" if isinstance(exc, MemoryError) else _why(exc)
        raise SchedulerUnreachable(f"{key}: {address!r}: what answers there does not speak dask's protocol "
                                   f"({what}); {expected}")
    reply = box.get("reply")
    kind = reply.get("type") if isinstance(reply, dict) else None
    if kind != "Scheduler":
        what = f"a dask {kind}" if isinstance(kind, str) else "no dask scheduler"
        raise SchedulerUnreachable(f"{key}: {address!r}: {what} answers there, not a scheduler; {expected}")


def connect_scheduler(address: str, timeout_s: float | None = None):
    """A dask ``Client`` of the scheduler at ``address``, after :func:`probe_scheduler`.

    Parameters
    ----------
    address : str
    timeout_s : float, optional
        Seconds to reach it (default :data:`CONNECT_TIMEOUT_S`).

    Raises
    ------
    ImportError
        dask.distributed is not installed.
    SchedulerUnreachable
        The scheduler cannot be reached within ``timeout_s``, or what answers is not one (one line
        naming the address).
    """
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - optional extra
        raise ImportError("executor 'dask' needs dask[distributed]: pip install 'whisker-opt[dask]'") from exc
    timeout_s = CONNECT_TIMEOUT_S if timeout_s is None else float(timeout_s)
    probe_scheduler(address, timeout_s)
    try:
        return Client(address, timeout=timeout_s)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise SchedulerUnreachable(f"optimiser.executor.scheduler_address: cannot reach the dask scheduler at "
                                   f"{address!r} within {timeout_s:g} s ({_why(exc)})") from None
