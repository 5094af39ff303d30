"""The executor a run's ``optimiser.executor`` section asks for, and the check that it can start."""

from __future__ import annotations

from whisker_opt.config.optimiser import ExecutorConfig
from whisker_opt.optimise.dask_executor import DaskExecutor, probe_scheduler
from whisker_opt.optimise.executors import Evaluator, ProcessExecutor, SerialExecutor, _BaseExecutor


def preflight(cfg: ExecutorConfig) -> None:
    """Check that the executor of ``cfg`` can start, before a run writes anything.

    A dask scheduler given by address must answer as one within the connection timeout
    (:func:`~whisker_opt.optimise.dask_executor.probe_scheduler`, which raises
    :class:`~whisker_opt.optimise.dask_executor.SchedulerUnreachable`); the other executors
    start their workers on this machine.
    """
    if cfg.kind == "dask" and cfg.scheduler_address:
        probe_scheduler(cfg.scheduler_address)


def make_executor(cfg: ExecutorConfig, evaluator: Evaluator) -> _BaseExecutor:
    """The executor described by ``cfg`` (use it as a context manager)."""
    if cfg.kind == "serial":
        return SerialExecutor(evaluator, cfg.timeout_s, cfg.threads_per_worker)
    if cfg.kind == "processes":
        return ProcessExecutor(evaluator, cfg.n_workers, cfg.timeout_s, cfg.start_method, cfg.threads_per_worker)
    if cfg.kind == "dask":
        return DaskExecutor(
            evaluator, cfg.n_workers, cfg.scheduler_address, cfg.dask_processes, cfg.threads_per_worker, cfg.timeout_s
        )
    raise ValueError(f"executor.kind: unknown {cfg.kind!r}")  # pragma: no cover - validated by pydantic
