"""A cheap analytic stand-in for the FE evaluator, with a known optimum.

Used by the GA tests and to demonstrate the executors without FE solves:

    f1(x) = offset + scale · Σ_i w_i ((x_i − x*_i)/(hi_i − lo_i))²,

a bowl whose minimum f1 = offset lies at x* inside the gene box. With ``offset = 0`` the
penalised optimum is x* too, since every κ_j is proportional to f1 (F_p(x*) = 0).

Failure regions make designs with ``genes[gene] > above`` fail on purpose, to test that
failures are recorded, graded and never ranked best:

- a failure status (``"invalid_geometry"``, ``"mesh_failed"``, ``"solve_failed"``, ...):
  returned with ``extra["violation"] = genes[gene] − above``;
- ``"raise"``: the evaluator raises ``RuntimeError`` (the executor records ``"error"``);
- ``"nan"``: returns status ``"ok"`` with ``f1 = NaN`` (must become ``"error"``);
- ``"hang"``: sleeps ``hang_s`` seconds before answering (to test timeouts; ``math.inf``: it never
  answers, so a timeout always fires however slow the machine);
- ``"crash"``: the process exits at once (only for the ``processes`` executor!).

A :class:`Hold` stops evaluations at a known point of a run, in whatever process they run, until the
test releases them (or kills the run there): a file barrier in place of a race against the clock.
"""

from __future__ import annotations

import math
import os
import signal
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whisker_opt.config.optimiser import GenesConfig
from whisker_opt.genes import GENE_NAMES
from whisker_opt.experiment.outcome import FAILURE_STATUSES, EvalOutcome

_DEFAULT_BOUNDS = GenesConfig().bounds()


@dataclass(frozen=True)
class FailureRegion:
    """Designs with ``genes[gene] > above`` fail with ``kind`` (see the module docstring)."""

    gene: str
    above: float
    kind: str = "invalid_geometry"

    def __post_init__(self) -> None:
        allowed = FAILURE_STATUSES + ("raise", "nan", "hang", "crash", "kill", "kill_once")
        if self.kind not in allowed:
            raise ValueError(f"FailureRegion.kind: {self.kind!r} not in {allowed}")
        if self.gene not in GENE_NAMES:
            raise ValueError(f"FailureRegion.gene: {self.gene!r} not in {GENE_NAMES}")


@dataclass(frozen=True)
class Hold:
    """A file barrier for evaluations: once armed, an evaluation creates ``folder/held`` and waits until
    ``folder/release`` exists.

    Parameters
    ----------
    folder : str
        The barrier's folder (it must exist).
    run_dir : str or None
        Armed once the checkpoint of this run directory is at ``generation`` or later (None: armed
        from the first evaluation on).
    generation : int
        See ``run_dir``.
    """

    folder: str
    run_dir: str | None = None
    generation: int = 0

    @property
    def held(self) -> Path:
        return Path(self.folder) / "held"

    @property
    def release_file(self) -> Path:
        return Path(self.folder) / "release"

    def armed(self) -> bool:
        """True when an evaluation now has to wait."""
        if self.run_dir is None:
            return True
        from whisker_opt.optimise.checkpoint import load_checkpoint

        try:
            return load_checkpoint(Path(self.run_dir))[0].generation >= self.generation
        except Exception:  # noqa: BLE001 - no checkpoint yet (or one being replaced): not armed
            return False

    def wait(self) -> None:
        """Hold the calling evaluation when armed (see the class docstring)."""
        if self.armed():
            self.held.touch()
            while not self.release_file.exists():
                time.sleep(0.005)

    def wait_held(self, proc, timeout: float = 600.0) -> None:
        """Return once an evaluation of ``proc`` (a ``subprocess.Popen``, still running) is held; the
        ``timeout`` only ends a run that never gets there."""
        deadline = time.monotonic() + timeout
        while not self.held.exists():
            assert proc.poll() is None, f"the run ended before it was held: {proc.communicate()}"
            assert time.monotonic() < deadline, f"no evaluation held within {timeout:g} s"
            time.sleep(0.005)

    def release(self) -> None:
        """Let the held evaluations (and every later one) go on."""
        self.release_file.touch()


@dataclass(frozen=True)
class AnalyticFitness:
    """Picklable analytic evaluator ``evaluate(genes) -> EvalOutcome``.

    Parameters
    ----------
    optimum : tuple of float
        x* = (α [deg], l [mm], t [mm], Q_i [MPa]).
    bounds : tuple of (lo, hi)
        Normalisation of each gene (default: the GA's gene box).
    weights : tuple of float
        w_i.
    scale : float
        Bowl depth [-].
    offset : float
        f1 at the optimum [-].
    failures : tuple of FailureRegion
        Deliberate failures.
    sleep_s : float
        Sleep per evaluation [s], to emulate a slow solver.
    hang_s : float
        Sleep of a ``"hang"`` failure region [s].
    with_curves : bool
        Add small response curves (``delta``, ``eps_i``, ``eps_c``) to ``extra``, built so
        that the mean of |ε_i − ε_c| over δ > 0 equals f1.
    marker_dir : str or None
        Folder of the marker files of ``"kill_once"`` regions: the first evaluation of such a
        design leaves a marker and SIGKILLs its own process (as the system would kill a worker),
        later ones evaluate normally. ``"kill"`` regions SIGKILL their process every time.
    hold : Hold or None
        A barrier every evaluation passes first.
    """

    optimum: tuple[float, ...] = (3.0, 12.0, 4.0, 0.05)
    bounds: tuple[tuple[float, float], ...] = _DEFAULT_BOUNDS
    weights: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0)
    scale: float = 0.01
    offset: float = 0.0
    failures: tuple[FailureRegion, ...] = ()
    sleep_s: float = 0.0
    hang_s: float = 30.0
    with_curves: bool = False
    marker_dir: str | None = None
    hold: Hold | None = None

    def f1(self, genes: dict[str, float]) -> float:
        """The analytic objective (no failures, no sleep)."""
        s = 0.0
        for name, xs, (lo, hi), w in zip(GENE_NAMES, self.optimum, self.bounds, self.weights):
            s += w * ((float(genes[name]) - xs) / (hi - lo)) ** 2
        return self.offset + self.scale * s

    def __call__(self, genes: dict[str, float]) -> EvalOutcome:
        t0 = time.perf_counter()
        if self.hold is not None:
            self.hold.wait()
        if self.sleep_s > 0:
            time.sleep(self.sleep_s)
        for region in self.failures:
            x = float(genes[region.gene])
            if x > region.above:
                if region.kind == "raise":
                    raise RuntimeError(f"deliberate failure: {region.gene}={x:.6g} > {region.above:g}")
                if region.kind == "nan":
                    return EvalOutcome("ok", math.nan)
                if region.kind == "crash":
                    os._exit(3)
                if region.kind == "kill_once":
                    marker = Path(self.marker_dir) / ("killed_" + "_".join(f"{genes[n]:.9g}" for n in GENE_NAMES))
                    if not marker.exists():
                        marker.touch()
                        os.kill(os.getpid(), signal.SIGKILL)
                    continue
                if region.kind == "kill":
                    os.kill(os.getpid(), signal.SIGKILL)
                if region.kind == "hang":
                    end = time.monotonic() + self.hang_s
                    while time.monotonic() < end:  # time.sleep refuses an endless sleep
                        time.sleep(min(3600.0, end - time.monotonic()))
                    continue
                return EvalOutcome.failure(
                    region.kind,
                    f"deliberate {region.kind}: {region.gene}={x:.6g} > {region.above:g}",
                    timings={"model_s": time.perf_counter() - t0},
                    extra={"violation": x - region.above},
                )
        f1 = self.f1(genes)
        extra = {}
        if self.with_curves:
            delta = np.linspace(0.0, 5.0, 11)
            k = 1e-3 * (1.0 + float(genes["Q_i"]))
            extra = {"delta": delta.tolist(), "eps_i": (k * delta).tolist(), "eps_c": ((k + f1 / 2.75) * delta).tolist()}
        return EvalOutcome.success(f1, timings={"model_s": time.perf_counter() - t0}, extra=extra)


class Interrupt:
    """A run callback that raises KeyboardInterrupt once generation ``at`` is recorded (a kill, for the
    resume tests)."""

    def __init__(self, at: int) -> None:
        self.at = at

    def __call__(self, state, row) -> None:
        if state.generation == self.at:
            raise KeyboardInterrupt
