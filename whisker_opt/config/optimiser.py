"""Typed configuration of the optimiser (the ``optimiser:`` section of a run file, SPEC §6).

Defaults reproduce shared/SPEC.md §6: genes x = [α, l, t, Q_i] in [2.5, 6] deg × [10, 15] mm ×
[2, 6] mm × [0.01, 0.2] MPa; penalties C = [0.5, 0.2, 0.2] on (Q_i low, t high, α low);
population 50, tournament of size 2; stop at 50 generations, best F_p ≤ 1e-3, or a mean
relative improvement of the best F_p over 20 generations ≤ 1e-9. The variation settings
(SBX / polynomial-mutation indices and probabilities) are not given by the thesis; the
defaults are the usual ones for bounded real genes (Deb & Agrawal 1995, NSGA-II code).

Example::

    optimiser:
      genes:
        alpha: {lo: 2.5, hi: 6.0}
        l: [10, 15]           # a two-item list is accepted too
      trim: 10.0
      penalties:
        - {gene: Q_i, prefer: low, weight: 0.5}
      ga: {population: 20, n_elite: 2}
      stopping: {max_generations: 10}
      executor: {kind: dask, n_workers: 2}
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from whisker_opt.config.base import StrictModel
from whisker_opt.genes import GENE_NAMES, GeneName



class _Bounds(StrictModel):
    """A closed interval [lo, hi] with lo < hi; subclasses set the units and the outer limits."""

    @model_validator(mode="before")
    @classmethod
    def _from_pair(cls, data: Any) -> Any:
        if isinstance(data, (list, tuple)):
            if len(data) != 2:
                raise ValueError(f"bounds must be [lo, hi] or {{lo: .., hi: ..}}, got {list(data)!r}")
            return {"lo": data[0], "hi": data[1]}
        return data

    @model_validator(mode="after")
    def _ordered(self) -> "_Bounds":
        if not self.lo < self.hi:  # type: ignore[attr-defined]
            raise ValueError(
                f"bounds inverted or empty: lo={self.lo!r} must be < hi={self.hi!r}"  # type: ignore[attr-defined]
            )
        return self


class AlphaBounds(_Bounds):
    """Range of the cone half-angle α."""

    lo: float = Field(2.5, ge=0, lt=45, description="lower bound of alpha [deg], [0, 45)")
    hi: float = Field(6.0, gt=0, lt=45, description="upper bound of alpha [deg], (0, 45)")


class ChamberEndBounds(_Bounds):
    """Range of l, the x where the chamber ends."""

    lo: float = Field(10.0, gt=0, le=200, description="lower bound of l [mm], (0, 200]")
    hi: float = Field(15.0, gt=0, le=200, description="upper bound of l [mm], (0, 200]")


class WallBounds(_Bounds):
    """Range of the chamber wall thickness t."""

    lo: float = Field(2.0, gt=0, le=50, description="lower bound of t [mm], (0, 50]")
    hi: float = Field(6.0, gt=0, le=50, description="upper bound of t [mm], (0, 50]")


class PressureBounds(_Bounds):
    """Range of the initial pressure Q_i."""

    lo: float = Field(0.01, ge=0, le=1, description="lower bound of Q_i [MPa], [0, 1]")
    hi: float = Field(0.2, gt=0, le=1, description="upper bound of Q_i [MPa], (0, 1]")


class GenesConfig(StrictModel):
    """Bounds of the four genes [α, l, t, Q_i] (SPEC §6)."""

    alpha: AlphaBounds = AlphaBounds()
    l: ChamberEndBounds = ChamberEndBounds()
    t: WallBounds = WallBounds()
    Q_i: PressureBounds = PressureBounds()

    def bounds(self) -> tuple[tuple[float, float], ...]:
        """``((lo, hi), ...)`` in :data:`GENE_NAMES` order."""
        return tuple((getattr(self, g).lo, getattr(self, g).hi) for g in GENE_NAMES)


class PenaltyConfig(StrictModel):
    """One preference term C_j κ_j of the dynamic penalty (SPEC §6)."""

    gene: GeneName = Field(description="gene the preference applies to")
    prefer: Literal["low", "high"] = Field(description="preferred end of the gene's range")
    weight: float = Field(ge=0, le=100, description="penalty coefficient C_j [-], [0, 100]")


_DEFAULT_PENALTIES = (
    PenaltyConfig(gene="Q_i", prefer="low", weight=0.5),
    PenaltyConfig(gene="t", prefer="high", weight=0.2),
    PenaltyConfig(gene="alpha", prefer="low", weight=0.2),
)


class GAConfig(StrictModel):
    """Selection, variation and elitism of the generational GA."""

    population: int = Field(50, ge=2, le=10_000, description="individuals per generation [-], 2..10000")
    tournament: int = Field(2, ge=1, le=100, description="tournament size of the selection [-], 1..100")
    cx_prob: float = Field(0.9, ge=0, le=1, description="probability that a pair is crossed (SBX) [-], [0, 1]")
    mut_prob: float = Field(0.4, ge=0, le=1, description="probability that an offspring is mutated [-], [0, 1]")
    indpb: float = Field(0.25, ge=0, le=1, description="per-gene mutation probability [-], [0, 1]")
    eta_cx: float = Field(15.0, ge=0, le=1000, description="SBX distribution index [-], [0, 1000]")
    eta_mut: float = Field(20.0, ge=0, le=1000, description="polynomial-mutation distribution index [-], [0, 1000]")
    n_elite: int = Field(2, ge=0, le=1000, description="best individuals copied unchanged [-], 0..1000")
    hall_of_fame: int = Field(10, ge=1, le=1000, description="best distinct designs remembered [-], 1..1000")
    init: Literal["lhs", "uniform"] = Field(
        "lhs", description="initial population: Latin hypercube or independent uniform draws"
    )

    @model_validator(mode="after")
    def _consistent(self) -> "GAConfig":
        if self.n_elite >= self.population:
            raise ValueError(f"n_elite={self.n_elite} must be < population={self.population}")
        if self.tournament > self.population:
            raise ValueError(f"tournament={self.tournament} must be <= population={self.population}")
        return self


class StoppingConfig(StrictModel):
    """Stop at whichever rule fires first (SPEC §6)."""

    max_generations: int = Field(
        50, ge=0, le=100_000,
        description="generations bred after the initial population (generation 0) [-], 0..100000",
    )
    target_fp: float = Field(1e-3, ge=0, le=1e9, description="stop when the best F_p <= this [-], [0, 1e9]")
    stall_generations: int = Field(
        20, ge=1, le=100_000, description="window of the stall rule [generations], 1..100000"
    )
    stall_tol: float = Field(
        1e-9, ge=0, le=1,
        description="stop when the mean relative improvement of the best F_p over the window <= this [-], [0, 1]",
    )


class ExecutorConfig(StrictModel):
    """Where evaluations run."""

    kind: Literal["serial", "processes", "dask"] = Field("serial", description="evaluation back end")
    n_workers: int = Field(2, ge=1, le=4096, description="worker processes (processes, dask LocalCluster) [-]")
    scheduler_address: str | None = Field(
        None, min_length=1, max_length=500,
        description="dask scheduler address, e.g. tcp://host:8786; None starts a LocalCluster",
    )
    dask_processes: bool = Field(True, description="LocalCluster workers are processes (True) or threads (False)")
    threads_per_worker: int = Field(
        1, ge=1, le=256, description="BLAS/OpenMP threads per worker (OMP/MKL/OPENBLAS_NUM_THREADS) [-]"
    )
    timeout_s: float | None = Field(
        None, gt=0, le=604_800, description="wall-clock limit of one evaluation [s]; None = no limit"
    )
    start_method: Literal["spawn", "forkserver", "fork"] = Field(
        "spawn", description="multiprocessing start method of the 'processes' pool"
    )

    @model_validator(mode="after")
    def _address_needs_dask(self) -> "ExecutorConfig":
        if self.scheduler_address is not None and self.kind != "dask":
            raise ValueError(f"scheduler_address is only used with kind 'dask' (kind is {self.kind!r})")
        return self


class CacheConfig(StrictModel):
    """Evaluation cache keyed by the rounded genome."""

    enabled: bool = Field(True, description="reuse outcomes of designs already evaluated")
    decimals: int = Field(
        6, ge=0, le=15, description="genes are rounded to this many decimals to form the key [-], 0..15"
    )
    cache_failures: bool = Field(True, description="also reuse failed outcomes (timeouts, errors, ...)")


class OptimiserConfig(StrictModel):
    """The ``optimiser:`` section of a run file (SPEC §6)."""

    SECTION = "optimiser"
    RENAMED = {"delta_max": "trim"}

    genes: GenesConfig = GenesConfig()
    trim: float = Field(5.0, gt=0, le=100, description="trimmed length Δ of the compensated case [mm], (0, 100]")
    penalties: tuple[PenaltyConfig, ...] = Field(
        _DEFAULT_PENALTIES, max_length=4, description="preference terms C_j κ_j (SPEC §6)"
    )
    failure_penalty: float = Field(
        1e3, gt=0, le=1e12,
        description="base F_p of a failed evaluation [-]; a grade by failure kind and violation is added",
    )
    ga: GAConfig = GAConfig()
    stopping: StoppingConfig = StoppingConfig()
    executor: ExecutorConfig = ExecutorConfig()
    cache: CacheConfig = CacheConfig()
    seed: int | None = Field(
        None, ge=0, le=2**32 - 1, description="GA seed [-]; None = the run file's top-level seed"
    )

    @field_validator("penalties")
    @classmethod
    def _distinct_genes(cls, v: tuple[PenaltyConfig, ...]) -> tuple[PenaltyConfig, ...]:
        seen = [p.gene for p in v]
        dup = sorted({g for g in seen if seen.count(g) > 1})
        if dup:
            raise ValueError(f"one penalty per gene; repeated: {dup}")
        return v

    def resolve_seed(self, top_level_seed: int) -> int:
        """The seed of the GA: ``seed`` when set, else the run file's top-level seed."""
        return int(self.seed if self.seed is not None else top_level_seed)
