"""Dynamic penalty (docs/physics.md) and the graded penalty of failed evaluations.

Feasible designs
    F_p(x) = f1(x) + Σ_j C_j κ_j(x),  κ_j(x) = f1(x) · d_j(x),

    where d_j ∈ [0, 1] is the normalised distance of gene g_j from its preferred bound:
    d_j = (x − lo)/(hi − lo) when the low end is preferred, (hi − x)/(hi − lo) when the high
    end is. E.g. κ_2 = f1 · (Q_i − Q_min)/(Q_max − Q_min). Because every κ_j is proportional
    to f1, F_p = f1 (1 + Σ C_j d_j): the preferences steer the search without hiding a
    good f1, and a perfect match (f1 = 0) stays optimal wherever it lies.

Failed designs
    F_p = B + rank(status) · B/10 + min(v, B/10),

    with B the configured base (``failure_penalty``), rank 1..5 by kind (timeout, solve
    failed, mesh failed, invalid geometry, error: from "possibly fine" to "no design at
    all") and v >= 0 the evaluator's ``extra["violation"]`` (how far the design lies outside
    the feasible region), so a less infeasible design ranks better and the search is
    steered back. Ranking never relies on B being large: the DEAP fitness is the pair
    (infeasible, F_p), compared lexicographically, so any failure ranks below every
    feasible design whatever its F_p (see :func:`fitness_values`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Mapping

from whisker_opt.config.optimiser import GenesConfig, OptimiserConfig
from whisker_opt.experiment.measures import measure_values
from whisker_opt.experiment.outcome import FAILURE_STATUSES, EvalOutcome

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class PenaltyTerm:
    """One preference C_j κ_j on a gene with bounds [lo, hi].

    Parameters
    ----------
    gene : str
        Gene name (a gene of ``optimiser.genes``, :meth:`whisker_opt.config.optimiser.GenesConfig.names`).
    prefer : {"low", "high"}
        Preferred end of the range.
    weight : float
        C_j [-].
    lo, hi : float
        Gene bounds (units of the gene).
    """

    gene: str
    prefer: str
    weight: float
    lo: float
    hi: float

    def distance(self, x: float) -> float:
        """Normalised distance d_j ∈ [0, 1] of ``x`` from the preferred bound."""
        d = (x - self.lo) / (self.hi - self.lo)
        if self.prefer == "high":
            d = 1.0 - d
        return min(max(d, 0.0), 1.0)

    @property
    def column(self) -> str:
        """Column name of κ_j in the results tables."""
        return f"kappa_{self.gene}"


@dataclass(frozen=True)
class Penalised:
    """An outcome turned into fitness.

    Attributes
    ----------
    feasible : bool
        The evaluation succeeded with a usable f1.
    f1 : float or None
        Objective 1 [-] (None for a failure).
    kappas : dict
        κ_j per gene [-] (empty for a failure).
    fp : float
        Penalised fitness F_p [-], to be minimised.
    """

    feasible: bool
    f1: float | None
    kappas: dict[str, float]
    fp: float


def penalty_terms(cfg: OptimiserConfig) -> tuple[PenaltyTerm, ...]:
    """The configured preference terms with the bounds of their genes."""
    genes: GenesConfig = cfg.genes
    return tuple(
        PenaltyTerm(p.gene, p.prefer, float(p.weight), genes.of(p.gene).lo, genes.of(p.gene).hi)
        for p in cfg.penalties
    )


def dynamic_penalty(f1: float, genes: Mapping[str, float], terms: tuple[PenaltyTerm, ...]) -> tuple[dict[str, float], float]:
    """κ_j and F_p of a feasible design.

    Parameters
    ----------
    f1 : float
        Objective 1 [-], finite and >= 0.
    genes : mapping
        Gene values by name.
    terms : tuple of PenaltyTerm

    Returns
    -------
    kappas : dict
        κ_j = f1 · d_j per gene.
    fp : float
        F_p = f1 + Σ C_j κ_j.
    """
    kappas = {t.gene: f1 * t.distance(float(genes[t.gene])) for t in terms}
    fp = f1 + sum(t.weight * kappas[t.gene] for t in terms)
    return kappas, fp


def failure_penalty(status: str, violation: float, base: float) -> float:
    """Graded F_p of a failed evaluation: B + rank·B/10 + min(v, B/10).

    Parameters
    ----------
    status : str
        A failure status (:data:`whisker_opt.experiment.outcome.FAILURE_STATUSES`).
    violation : float
        Distance outside the feasible region reported by the evaluator (>= 0; anything
        else, e.g. NaN, counts as 0).
    base : float
        B, the configured ``failure_penalty``.
    """
    rank = FAILURE_STATUSES.index(status) + 1 if status in FAILURE_STATUSES else len(FAILURE_STATUSES)
    v = float(violation) if isinstance(violation, (int, float)) and math.isfinite(violation) else 0.0
    step = base / 10.0
    return base + rank * step + min(max(v, 0.0), step)


def penalise(
    outcome: EvalOutcome, genes: Mapping[str, float], terms: tuple[PenaltyTerm, ...], failure_base: float,
    objective: str = "f1",
) -> Penalised:
    """Turn an outcome into fitness (dynamic penalty or graded failure penalty).

    ``objective`` names the measure the dynamic penalty is built on: f1, or its aggregate over variants
    (``f1_robust``, ...; :mod:`whisker_opt.optimise.aggregate`), which ``Penalised.f1`` then holds.
    """
    if outcome.ok:
        f1 = measure_values(outcome, (objective,))[objective]
        kappas, fp = dynamic_penalty(f1, genes, terms)
        if fp >= failure_base:
            logger.warning(
                "feasible F_p=%.6g >= failure_penalty=%.6g: failures still rank below it "
                "(lexicographic fitness), but raise failure_penalty for readable tables",
                fp, failure_base,
            )
        return Penalised(True, f1, kappas, fp)
    return Penalised(False, None, {}, failure_penalty(outcome.status, outcome.extra.get("violation", 0.0), failure_base))


def fitness_values(p: Penalised) -> tuple[float, float]:
    """DEAP fitness values (infeasible flag, F_p), both minimised, compared lexicographically."""
    return (0.0 if p.feasible else 1.0, p.fp)
