"""Typed configuration of the optimiser (the ``optimiser:`` section of a run file, docs/physics.md).

The defaults are the thesis' GA settings: genes x = [α, l, t, Q_i] in [2.5, 6] deg × [10, 15] mm ×
[2, 6] mm × [0.01, 0.2] MPa; penalties C = [0.5, 0.2, 0.2] on (Q_i low, t high, α low);
population 50, tournament of size 2; stop at 50 generations, best F_p ≤ 1e-3, or a mean
relative improvement of the best F_p over 20 generations ≤ 1e-9; and (not the thesis') when the
best f1 has stayed below the preset's f1 resolution for 5 generations. The variation settings
(SBX / polynomial-mutation indices and probabilities) are not given by the thesis; the
defaults are the usual ones for bounded real genes (Deb & Agrawal 1995, NSGA-II code).
Every numeric field carries its range (``Field`` constraints) and its unit
(``json_schema_extra``); ``docs/config.md`` is generated from these models.

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

from pydantic import ConfigDict, Field, field_validator, model_validator

from whisker_opt.config.base import StrictModel
from whisker_opt.config.messages import describe
from whisker_opt.config.robustness import RobustObjectiveConfig
from whisker_opt.wall.law import WALL_LAW_NAMES
from whisker_opt.experiment.measures import MEASURE_NAMES
from whisker_opt.genes import GENE_NAMES, check_gene_bounds, gene_key



class _Bounds(StrictModel):
    """A closed interval [lo, hi] with lo < hi; subclasses set the units and the outer limits.

    Written ``{lo: .., hi: ..}`` or as a two-item list ``[lo, hi]``.
    """

    SHAPE = "[lo, hi] or {lo: .., hi: ..}"

    @model_validator(mode="before")
    @classmethod
    def _from_pair(cls, data: Any) -> Any:
        if isinstance(data, (list, tuple)):
            if len(data) != 2:
                raise ValueError(f"bounds must be [lo, hi] or {{lo: .., hi: ..}}, got a list of {len(data)} items")
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
    """Range of the gene α, the cone half-angle: ``{lo, hi}`` or ``[lo, hi]``, lo < hi."""

    lo: float = Field(2.5, ge=0, lt=45, description="lower bound of alpha", json_schema_extra={"unit": "deg"})
    hi: float = Field(6.0, gt=0, lt=45, description="upper bound of alpha", json_schema_extra={"unit": "deg"})


class ChamberEndBounds(_Bounds):
    """Range of the gene l, the x where the chamber ends: ``{lo, hi}`` or ``[lo, hi]``, lo < hi."""

    lo: float = Field(10.0, gt=0, le=200, description="lower bound of l", json_schema_extra={"unit": "mm"})
    hi: float = Field(15.0, gt=0, le=200, description="upper bound of l", json_schema_extra={"unit": "mm"})


class WallBounds(_Bounds):
    """Range of the gene t, the chamber wall thickness: ``{lo, hi}`` or ``[lo, hi]``, lo < hi."""

    lo: float = Field(2.0, gt=0, le=50, description="lower bound of t", json_schema_extra={"unit": "mm"})
    hi: float = Field(6.0, gt=0, le=50, description="upper bound of t", json_schema_extra={"unit": "mm"})


class PressureBounds(_Bounds):
    """Range of the gene Q_i, the initial pressure: ``{lo, hi}`` or ``[lo, hi]``, lo < hi."""

    lo: float = Field(0.01, ge=0, le=1, description="lower bound of Q_i", json_schema_extra={"unit": "MPa"})
    hi: float = Field(0.2, gt=0, le=1, description="upper bound of Q_i", json_schema_extra={"unit": "MPa"})


class GeneBounds(_Bounds):
    """Range of an added gene: ``{lo, hi}`` or ``[lo, hi]``, lo < hi, inside the range of the key it sets."""

    lo: float = Field(description="lower bound of the gene")
    hi: float = Field(description="upper bound of the gene")


class GenesConfig(StrictModel):
    """Bounds of the genes: the four [α, l, t, Q_i] always, and any real number of the ``design`` or ``material``
    section added as ``<key>: [lo, hi]`` (e.g. ``fibre_pitch: [2, 4]``, ``L: [60, 80]``, ``C10: [0.1, 0.2]``),
    inside the key's own range; added genes follow the four in the order written and override the section's
    value in every evaluation."""

    model_config = ConfigDict(extra="allow")

    alpha: AlphaBounds = AlphaBounds()
    l: ChamberEndBounds = ChamberEndBounds()
    t: WallBounds = WallBounds()
    Q_i: PressureBounds = PressureBounds()

    @model_validator(mode="before")
    @classmethod
    def _added_genes(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        data = dict(data)
        for name in [k for k in data if k not in cls.model_fields]:
            gene_key(str(name))
            try:
                b = GeneBounds.model_validate(data[name])
            except ValueError as exc:
                raise ValueError(f"gene {name}: {_first_error(exc)}") from None
            check_gene_bounds(str(name), b.lo, b.hi)
            data[name] = b
        return data

    def names(self) -> tuple[str, ...]:
        """The genome: :data:`GENE_NAMES`, then the added genes in the order written."""
        return (*GENE_NAMES, *(self.model_extra or {}))

    def of(self, name: str) -> _Bounds:
        """The bounds of gene ``name``."""
        return getattr(self, name) if name in GENE_NAMES else (self.model_extra or {})[name]

    def bounds(self) -> tuple[tuple[float, float], ...]:
        """``((lo, hi), ...)`` in :meth:`names` order."""
        return tuple((self.of(g).lo, self.of(g).hi) for g in self.names())


def _first_error(exc: ValueError) -> str:
    """The first problem of a validation error of :class:`GeneBounds`, in the words of a run file (or the error's
    text)."""
    errors = getattr(exc, "errors", None)
    if callable(errors):
        return describe(errors()[0], GeneBounds).removeprefix("(top level): ")
    return str(exc)


class PenaltyConfig(StrictModel):
    """One preference term C_j κ_j of the dynamic penalty, κ_j = f1 · d_j (docs/physics.md).

    One term per gene at most.
    """

    gene: str = Field(description="gene the preference applies to (a gene of optimiser.genes)")
    prefer: Literal["low", "high"] = Field(description="preferred end of the gene's range")

    @field_validator("gene")
    @classmethod
    def _a_gene(cls, v: str) -> str:
        gene_key(v)  # one line naming the allowed keys; whether it is in the genome is checked by the optimiser
        return v
    weight: float = Field(ge=0, le=100, description="penalty coefficient C_j", json_schema_extra={"unit": "-"})


_DEFAULT_PENALTIES = (
    PenaltyConfig(gene="Q_i", prefer="low", weight=0.5),
    PenaltyConfig(gene="t", prefer="high", weight=0.2),
    PenaltyConfig(gene="alpha", prefer="low", weight=0.2),
)


class ObjectiveConfig(StrictModel):
    """One objective of the multi-objective mode (``algorithm: nsga2``), minimised.

    A measure of :data:`whisker_opt.experiment.measures.MEASURES` (``f1``, the compensation error,
    docs/physics.md §4; ``sensitivity``, ``delta_l``, ``von_mises_max``, the gauge readings) is minimised
    (prefer low) or maximised (prefer high); a gene of ``optimiser.genes`` is an objective towards its
    preferred end of the range, measured by the same normalised distance d_j as the penalty terms.
    Written ``{name: t, prefer: high}`` or as the bare name (preferring the low end).
    """

    name: str = Field(description="a measure (f1, sensitivity, delta_l, von_mises_max, eps_i_line, ...) or a gene "
                      "of optimiser.genes")
    prefer: Literal["low", "high"] = Field("low", description="preferred end (f1: low only)")

    @model_validator(mode="before")
    @classmethod
    def _from_name(cls, data: Any) -> Any:
        return {"name": data} if isinstance(data, str) else data

    @field_validator("name")
    @classmethod
    def _known(cls, v: str) -> str:
        if v in MEASURE_NAMES:
            return v
        try:
            gene_key(v)
        except ValueError:
            raise ValueError(f"name={v!r} is neither a measure ({', '.join(MEASURE_NAMES)}) nor a gene "
                             f"(alpha, l, t, Q_i or an added gene of optimiser.genes)") from None
        return v

    @model_validator(mode="after")
    def _f1_is_minimised(self) -> "ObjectiveConfig":
        if self.name == "f1" and self.prefer != "low":
            raise ValueError(f"objective f1: prefer={self.prefer!r} not allowed, f1 is minimised (prefer 'low')")
        return self


_DEFAULT_OBJECTIVES = (ObjectiveConfig(name="f1"), ObjectiveConfig(name="Q_i", prefer="low"))


class ParetoConfig(StrictModel):
    """Outputs of the multi-objective mode: the Pareto front and its verification at a finer preset."""

    verify: bool = Field(True, description="re-evaluate the front at the next finer fidelity preset after the run "
                         "(coarse -> default, default -> fine)")
    verify_max: int = Field(200, ge=1, le=10_000, description="most front designs re-evaluated (spread along the "
                            "front when it holds more)", json_schema_extra={"unit": "designs"})


class GAConfig(StrictModel):
    """Selection, variation and elitism of the generational GA; n_elite < population, tournament ≤ population."""

    population: int = Field(50, ge=2, le=10_000, description="individuals per generation",
                            json_schema_extra={"unit": "-"})
    tournament: int = Field(2, ge=1, le=100, description="tournament size of the selection",
                            json_schema_extra={"unit": "-"})
    cx_prob: float = Field(0.9, ge=0, le=1, description="probability that a pair is crossed (SBX)",
                           json_schema_extra={"unit": "-"})
    mut_prob: float = Field(0.4, ge=0, le=1, description="probability that an offspring is mutated",
                            json_schema_extra={"unit": "-"})
    indpb: float = Field(0.25, ge=0, le=1, description="per-gene mutation probability", json_schema_extra={"unit": "-"})
    eta_cx: float = Field(15.0, ge=0, le=1000, description="SBX distribution index", json_schema_extra={"unit": "-"})
    eta_mut: float = Field(20.0, ge=0, le=1000, description="polynomial-mutation distribution index",
                           json_schema_extra={"unit": "-"})
    n_elite: int = Field(2, ge=0, le=1000, description="best distinct individuals copied unchanged",
                         json_schema_extra={"unit": "-"})
    hall_of_fame: int = Field(10, ge=1, le=1000, description="best distinct designs remembered",
                              json_schema_extra={"unit": "-"})
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
    """Stop at whichever rule fires first, checked after every generation (docs/physics.md)."""

    max_generations: int = Field(
        50, ge=0, le=100_000,
        description="generations bred after the initial population (generation 0)",
        json_schema_extra={"unit": "generations"},
    )
    target_fp: float = Field(1e-3, ge=0, le=1e9, description="stop when the best design is feasible and its F_p <= "
                             "this, in the strain named by target_strain", json_schema_extra={"unit": "-"})
    target_strain: Literal["uncalibrated", "calibrated"] = Field(
        "uncalibrated", description="strain unit of target_fp: 'uncalibrated' compares F_p / scene.calibration (the "
        "simulated strain of the thesis' F_p <= 1e-3 rule), 'calibrated' compares F_p as the gauge reads it")
    stall_generations: int = Field(
        20, ge=1, le=100_000, description="window N of the stall rule", json_schema_extra={"unit": "generations"}
    )
    stall_tol: float = Field(
        1e-9, ge=0, le=1,
        description="stop when the mean relative improvement of the best F_p over the window <= this",
        json_schema_extra={"unit": "-"},
    )
    resolution_generations: int = Field(
        5, ge=0, le=100_000,
        description="stop when the best design's f1 has stayed below the fidelity preset's f1 resolution for this "
        "many consecutive generations (below it f1 is mesh error); 0 = off",
        json_schema_extra={"unit": "generations"},
    )


class ExecutorConfig(StrictModel):
    """Where evaluations run; ``scheduler_address`` only with kind ``dask``."""

    kind: Literal["serial", "processes", "dask"] = Field("serial", description="evaluation back end")
    n_workers: int = Field(2, ge=1, le=4096, description="worker processes (processes, dask LocalCluster)",
                           json_schema_extra={"unit": "-"})
    scheduler_address: str | None = Field(
        None, min_length=1, max_length=500,
        description="dask scheduler address, e.g. tcp://host:8786; null starts a LocalCluster",
    )
    dask_processes: bool = Field(True, description="LocalCluster workers are processes (True) or threads (False)")
    threads_per_worker: int = Field(
        1, ge=1, le=256, description="BLAS/OpenMP threads per worker (OMP/MKL/OPENBLAS_NUM_THREADS); the serial executor "
        "evaluates with MKL pinned to as many, so every executor rounds alike",
        json_schema_extra={"unit": "-"},
    )
    timeout_s: float | None = Field(
        None, gt=0, le=604_800, description="wall-clock limit of one evaluation; null = no limit",
        json_schema_extra={"unit": "s"},
    )
    start_method: Literal["spawn", "forkserver", "fork"] = Field(
        "spawn", description="multiprocessing start method of the 'processes' pool"
    )

    @model_validator(mode="after")
    def _address_needs_dask(self) -> "ExecutorConfig":
        if self.scheduler_address is not None and self.kind != "dask":
            raise ValueError(f"scheduler_address is only used with kind 'dask' (kind is {self.kind!r})")
        if self.scheduler_address is not None:
            check_scheduler_address(self.scheduler_address)
        return self


#: Transports of a dask scheduler address this program connects to (``tcp://`` when none is written).
SCHEDULER_SCHEMES = ("tcp", "tls")


def check_scheduler_address(address: str) -> None:
    """Refuse a dask scheduler address that is not ``[tcp://|tls://]HOST:PORT``.

    Raises
    ------
    ValueError
        One line with the address and the allowed form.
    """
    import re

    scheme, sep, rest = address.strip().rpartition("://")
    form = "expected tcp://HOST:PORT or tls://HOST:PORT (e.g. tcp://node1:8786)"
    if sep and scheme not in SCHEDULER_SCHEMES:
        raise ValueError(f"scheduler_address {address!r}: the transport {scheme!r} is not supported; {form}")
    m = re.fullmatch(r"(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):([0-9]{1,5})", rest)
    if m is None or not 0 < int(m.group(2)) < 65536:
        raise ValueError(f"scheduler_address {address!r}: no host and port (1..65535) in it; {form}")


class CacheConfig(StrictModel):
    """Evaluation cache keyed by the rounded genome."""

    enabled: bool = Field(True, description="reuse outcomes of designs already evaluated")
    decimals: int = Field(
        6, ge=0, le=15, description="genes are rounded to this many decimals to form the key",
        json_schema_extra={"unit": "-"},
    )
    cache_failures: bool = Field(True, description="also reuse failed outcomes (timeouts, errors, ...)")


class WallLawSetConfig(StrictModel):
    """The GA minimises the mean or the worst f1 over several chamber-wall laws (docs/physics.md §14)."""

    laws: tuple[str, ...] = Field(
        ("embedded", "sliding"), min_length=2, max_length=len(WALL_LAW_NAMES),
        description="the wall laws each genome is evaluated under ('calibrated' with material.wall_slope)")
    objective: Literal["mean", "worst"] = Field(
        "mean", description="mean: the mean of f1 over the laws; worst: the largest")

    @field_validator("laws")
    @classmethod
    def _distinct_laws(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        bad = [n for n in v if n not in WALL_LAW_NAMES]
        if bad:
            raise ValueError(f"{bad[0]!r} is not one of the wall laws {', '.join(map(repr, WALL_LAW_NAMES))}")
        dup = sorted({n for n in v if v.count(n) > 1})
        if dup:
            raise ValueError(f"each law once; repeated: {dup}")
        return v


class OptimiserConfig(StrictModel):
    """The ``optimiser:`` section of a run file: genes, penalties, GA, stopping rules, executor and cache."""

    SECTION = "optimiser"
    RENAMED = {"delta_max": "trim"}

    genes: GenesConfig = GenesConfig()
    trim: float = Field(5.0, gt=0, le=100, description="length Δ cut off the tip of the compensated (vented) "
                      "whisker of the GA's genomes (run, resume, verify, evaluate, robustness); the largest trim of "
                      "`compensate` (simulate, export and mesh use scene.trim)", json_schema_extra={"unit": "mm"})
    penalties: tuple[PenaltyConfig, ...] = Field(
        _DEFAULT_PENALTIES, max_length=4, description="preference terms C_j κ_j of the dynamic penalty, one per gene"
    )
    distinct_distance: float = Field(
        0.02, ge=0, le=1,
        description="the best designs a run lists (report, best.json, verify --top, robustness, view --rank) are "
        "pairwise at least this far apart: the largest gene difference, each gene divided by its bound range "
        "(0 = only repeats of one genome are dropped)",
        json_schema_extra={"unit": "-"},
    )
    failure_penalty: float = Field(
        1e3, gt=0, le=1e12,
        description="base B of the F_p of a failed evaluation; a grade by failure kind and violation is added",
        json_schema_extra={"unit": "-"},
    )
    algorithm: Literal["ga", "nsga2"] = Field(
        "ga", description="ga: one penalised score F_p; nsga2: a Pareto front of the objectives (NSGA-II)")
    objectives: tuple[ObjectiveConfig, ...] = Field(
        _DEFAULT_OBJECTIVES,
        description="objectives of nsga2 (2..5 items), f1 and at least one other measure or gene, each once; measures prefer low unless {name, prefer: high}")
    pareto: ParetoConfig = ParetoConfig()
    ga: GAConfig = GAConfig()
    stopping: StoppingConfig = StoppingConfig()
    executor: ExecutorConfig = ExecutorConfig()
    cache: CacheConfig = CacheConfig()
    robust: RobustObjectiveConfig | None = Field(
        None, description="minimise f1_robust, mean + k·std of f1 over the tolerances of the robustness section, "
        "instead of f1 (docs/physics.md §10; algorithm ga only); null = f1 itself")
    law_spread_top: int = Field(
        1, ge=0, le=1000,
        description="at the end of a run, the best this many distinct designs are solved again under every available "
        "chamber-wall law and their f1 and recovery rate reported (law_spread.csv); 0 = not done",
        json_schema_extra={"unit": "-"})
    wall_laws: WallLawSetConfig | None = Field(
        None, description="minimise the mean or the worst f1 over several chamber-wall laws (f1_mean_over_laws, "
        "f1_worst_over_laws) instead of f1 under material.wall_law alone (a model-form-robust optimum; algorithm ga "
        "only); null = the one law")
    seed: int | None = Field(
        None, ge=0, le=2**32 - 1, description="GA seed; null = the run file's top-level seed",
        json_schema_extra={"unit": "-"},
    )

    @field_validator("penalties")
    @classmethod
    def _distinct_genes(cls, v: tuple[PenaltyConfig, ...]) -> tuple[PenaltyConfig, ...]:
        seen = [p.gene for p in v]
        dup = sorted({g for g in seen if seen.count(g) > 1})
        if dup:
            raise ValueError(f"one penalty per gene; repeated: {dup}")
        return v

    @field_validator("objectives")
    @classmethod
    def _objectives_distinct(cls, v: tuple[ObjectiveConfig, ...]) -> tuple[ObjectiveConfig, ...]:
        names = [o.name for o in v]
        if not 2 <= len(names) <= 5:
            raise ValueError(f"{len(names)} objective(s) {names}; allowed 2..5 items")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"each objective once; repeated: {dup}")
        if "f1" not in names:  # the hall of fame, best.json and the hypervolume's scale rank by f1
            raise ValueError(f"objectives {names} must include f1")
        return v

    @model_validator(mode="after")
    def _genes_of_the_genome(self) -> "OptimiserConfig":
        genome = self.genes.names()
        for what, name in [*(("penalties", p.gene) for p in self.penalties),
                           *(("objectives", o.name) for o in self.objectives if o.name not in MEASURE_NAMES)]:
            if name not in genome:
                raise ValueError(f"{what}: gene {name!r} is not a gene of optimiser.genes; allowed: "
                                 f"{', '.join(genome)}")
        return self

    @model_validator(mode="after")
    def _one_robust_mode(self) -> "OptimiserConfig":
        if self.robust is not None and self.wall_laws is not None:
            raise ValueError("robust and wall_laws are both set: choose one robust objective (tolerances or wall laws)")
        if self.algorithm == "nsga2" and (self.robust is not None or self.wall_laws is not None):
            which = "robust" if self.robust is not None else "wall_laws"
            raise ValueError(f"algorithm 'nsga2' with {which} set: an aggregate over variants is an objective of "
                             f"algorithm 'ga' only; set algorithm: ga or {which}: null")
        return self

    def resolve_seed(self, top_level_seed: int) -> int:
        """The seed of the GA: ``seed`` when set, else the run file's top-level seed."""
        return int(self.seed if self.seed is not None else top_level_seed)
