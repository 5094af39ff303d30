"""Evaluations on dask.distributed: a LocalCluster, or an existing scheduler reached by address.

The executor contract is that of :mod:`whisker_opt.optimise.executors`: one outcome per design,
in input order, each seeded by its design's seed. A task that does not finish because its
worker was lost is submitted again (never recorded against the design); a scheduler that
cannot be reached is a :class:`~whisker_opt.optimise.executors.MachineFailure` before anything
runs; while tasks wait with no worker connected, a warning every ``heartbeat_s``.
"""

from __future__ import annotations

import contextlib
import logging
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


def _dask_task(evaluator: Evaluator, genes: dict[str, float], seed: int, timeout_s: float | None) -> EvalOutcome:
    return guarded_call(evaluator, genes, seed, timeout_s, "thread")


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
    connect_timeout_s : float
        Time to reach ``scheduler_address``.

    Raises
    ------
    MachineFailure
        The scheduler cannot be reached.
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
        connect_timeout_s: float = CONNECT_TIMEOUT_S,
    ) -> None:
        _check_picklable(evaluator)
        self.evaluator = evaluator
        self.timeout_s = timeout_s
        self.max_retries = int(max_retries)
        self.heartbeat_s = float(heartbeat_s)
        self._cluster = None
        if scheduler_address:
            self._client = connect_scheduler(scheduler_address, connect_timeout_s)
        else:
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
        logger.info("dask executor: %s", self._client)

    def _submit(self, genes: dict[str, float], seed: int):
        return self._client.submit(_dask_task, self.evaluator, dict(genes), int(seed), self.timeout_s, pure=False)

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
        times; then :class:`MachineFailure`. The task
        itself never raises for a design's fault (:func:`guarded_call`), so a task that does
        not finish is always the machine's fault. While tasks wait, a warning every
        ``heartbeat_s`` says when no worker is connected.
        """
        from distributed import wait

        n = len(genes_list)
        results: list[EvalOutcome | None] = [None] * n
        attempts = [1] * n
        pending = {i: self._submit(genes_list[i], seeds[i]) for i in range(n)}
        waited = 0.0
        while pending:
            poll = min(self.heartbeat_s, 2.0)
            try:
                done = set(wait(list(pending.values()), timeout=poll, return_when="FIRST_COMPLETED").done)
            except TimeoutError:
                done = set()
            done |= {f for f in pending.values() if f.status not in ("pending", "finished")}  # e.g. "lost"
            if not done:
                waited += poll
                if waited % self.heartbeat_s < poll:
                    n_workers = self._n_workers()
                    log = logger.warning if n_workers == 0 else logger.info
                    log("dask: %d evaluation(s) waiting for %.0f s; %d worker(s) connected to %s", len(pending),
                        waited, n_workers, self._client.scheduler.address)
                continue
            waited = 0.0
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
                attempts[i] += 1
                logger.warning("dask task of design %d %s %s; submitting it again (attempt %d of %d)", i,
                               dict(genes_list[i]), reason, attempts[i], self.max_retries + 1)
                pending[i] = self._submit(genes_list[i], seeds[i])
        return results  # type: ignore[return-value]

    def close(self) -> None:
        """Close the client and the LocalCluster, if any."""
        with contextlib.suppress(Exception):
            self._client.close()
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close()
            self._cluster = None


def connect_scheduler(address: str, timeout_s: float = CONNECT_TIMEOUT_S):
    """A dask ``Client`` of the scheduler at ``address``.

    Raises
    ------
    ImportError
        dask.distributed is not installed.
    MachineFailure
        The scheduler cannot be reached within ``timeout_s`` (one line naming the address).
    """
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - optional extra
        raise ImportError("executor 'dask' needs dask[distributed]: pip install 'whisker-opt[dask]'") from exc
    try:
        return Client(address, timeout=timeout_s)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise MachineFailure(f"executor.scheduler_address: cannot reach the dask scheduler at {address!r} within "
                             f"{timeout_s:g} s ({type(exc).__name__}: {str(exc).splitlines()[0][:200]})") from None
