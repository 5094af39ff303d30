"""One evaluation over variants of a design: every measure reduced by one named reduction.

A design may be evaluated not once but at several variants: the deviated designs of its fabrication
tolerances (:class:`FabricationVariants`, the estimators of :mod:`whisker_opt.optimise.robust`), the
chamber-wall laws of ``optimiser.wall_laws`` (:class:`LawVariants`), or any other set that says how it
evaluates a variant and how it estimates the mean and the spread of a measure over them. The
:class:`AggregateEvaluator` evaluates the nominal design and every variant, reads every measure of
:mod:`whisker_opt.experiment.measures` at each, and reduces each measure over the variants by the reduction
its run names (:data:`REDUCTIONS`). Each reduction is one module of :mod:`whisker_opt.optimise.reductions`
(``mean``, ``worst``, ``mean_plus_k_std``) with a ``NAME``, an ``ORDER`` and a pure function
``reduce(spread, k, worse) -> float`` of one measure's :class:`Spread` over the variants, ``k`` of
``mean_plus_k_std`` and ``worse`` of the measure (:attr:`whisker_opt.experiment.measures.Measure.worse`);
:func:`_registry` finds every module there, in the order of their ``ORDER``.

The outcome's ``f1`` and ``extra`` are those of the nominal design, so every measure by its own name (``f1``,
``sensitivity``, ...) is the nominal design's. The reduced measures are named ``<measure>_<label>`` in the
outcome's ``measures`` (e.g. ``f1_robust``, ``sensitivity_mean_over_laws``), beside ``f1_mean`` and ``f1_std``,
the variant set's mean and spread of f1. The GA minimises the aggregate of f1 (:func:`objective_column`).

Adding a reduction: one module in ``whisker_opt/optimise/reductions/`` (and a test of its value).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Callable, Mapping

import numpy as np

from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.experiment.measures import MEASURE_NAMES, MEASURES, measure_values
from whisker_opt.experiment.outcome import EvalOutcome

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Spread:
    """One measure over the variants of an evaluation.

    Parameters
    ----------
    values : tuple of float
        The measure at each evaluated variant (NaN where it could not be read).
    mean, std : float
        The variant set's estimate of its mean and standard deviation.
    """

    values: tuple[float, ...]
    mean: float
    std: float


def _registry() -> dict[str, Callable[[Spread, float, float], float]]:
    """Every module of :mod:`whisker_opt.optimise.reductions`, by ``NAME``, in the order of their ``ORDER``."""
    from whisker_opt.experiment.registry import discover

    mods = discover("whisker_opt.optimise.reductions")
    return {m.NAME: m.reduce for m in mods}


#: The reductions over variants, by name: ``reduce(spread, k, worse) -> float`` (module docstring).
REDUCTIONS: Mapping[str, Callable[[Spread, float, float], float]] = MappingProxyType(_registry())


def reduce(name: str, spread: Spread, k: float = 1.0, worse: float = 1.0) -> float:
    """The reduction ``name`` of :data:`REDUCTIONS` of one measure's ``spread``.

    Raises
    ------
    ValueError
        ``name`` is not a registered reduction (one line naming the allowed ones).
    """
    if name not in REDUCTIONS:
        raise ValueError(f"reduction {name!r} is not one of {', '.join(REDUCTIONS)}")
    return REDUCTIONS[name](spread, float(k), float(worse))


def aggregate_label(cfg: OptimiserConfig) -> str | None:
    """The suffix of the aggregated measures of a run: ``robust`` (``optimiser.robust``),
    ``<objective>_over_laws`` (``optimiser.wall_laws``), or None for a run of single evaluations."""
    if cfg.robust is not None:
        return "robust"
    if cfg.wall_laws is not None:
        return f"{cfg.wall_laws.objective}_over_laws"
    return None


def aggregate_name(measure: str, label: str | None) -> str:
    """``<measure>_<label>``, the name of a measure's aggregate (``measure`` itself when ``label`` is None)."""
    return measure if label is None else f"{measure}_{label}"


def objective_column(cfg: OptimiserConfig) -> str:
    """The name of what the run minimises: ``f1``, or its aggregate (``f1_robust``, ``f1_mean_over_laws``, ...)."""
    return aggregate_name("f1", aggregate_label(cfg))


def aggregate_columns(cfg: OptimiserConfig) -> tuple[str, ...]:
    """The columns of ``evaluations.csv`` after ``f1`` of an aggregated run: the objective, the mean and the std
    of f1 over the variants (none for a run of single evaluations)."""
    label = aggregate_label(cfg)
    return () if label is None else (aggregate_name("f1", label), "f1_mean", "f1_std")


@dataclass(frozen=True)
class LawVariants:
    """The chamber-wall laws of ``optimiser.wall_laws``: one evaluator per law, the same genome.

    Parameters
    ----------
    evaluators : tuple
        ``genes -> EvalOutcome``, one per law.
    laws : tuple of str
        Their names.
    """

    evaluators: tuple
    laws: tuple[str, ...]

    def spreads(self, at: Callable[[Any], np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(values (n, m), mean (m,), std (m,))`` of the outputs of ``at(i)`` over the laws i."""
        from whisker_opt.optimise.robust import column_moments

        values = np.array([at(i) for i in range(len(self.laws))])  # (n_laws, m)
        return (values, *column_moments(values))

    def at(self, nominal, genes: Mapping[str, float], point) -> tuple:
        """The evaluator, genome and gauge-factor scale of law ``point``."""
        return self.evaluators[point], dict(genes), 1.0

    def describe(self, point) -> str:
        return f"wall law {self.laws[point]}"

    def summary(self) -> str:
        return f"{len(self.laws)} wall laws ({', '.join(self.laws)})"


@dataclass(frozen=True)
class FabricationVariants:
    """The deviated designs of the fabrication tolerances (:mod:`whisker_opt.optimise.robust`).

    Parameters
    ----------
    deviate : callable
        ``deviate(nominal_evaluator, genes, x) -> (evaluator, genes, scale)`` of a deviation vector ``x`` in
        :data:`whisker_opt.config.robustness.TOLERANCE_KEYS` order (``whisker_opt.wiring.deviated``).
    half_widths : tuple of float
        The tolerances h_j.
    method : {'expansion', 'sample'}
        The first-order expansion (the nominal design and two per toleranced parameter) or the seeded
        ``points`` (the same for every genome).
    distribution, sigmas, fd_step
        As :func:`whisker_opt.optimise.robust.expansion_estimate`.
    points : tuple of tuple of float
        The sample's deviations (``sample``).
    """

    deviate: Callable
    half_widths: tuple[float, ...]
    method: str = "expansion"
    distribution: str = "uniform"
    sigmas: float = 3.0
    fd_step: float = 1.0
    points: tuple = ()

    def spreads(self, at: Callable[[Any], np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(values (n, m), mean (m,), std (m,))`` of the outputs of ``at(x)`` by the estimator of ``method``."""
        from whisker_opt.optimise.robust import expansion_estimate, sample_estimate

        if self.method == "sample":
            est = sample_estimate(at, np.asarray(self.points, dtype=float))
            return est.values, est.mean, est.std
        est = expansion_estimate(at, self.half_widths, self.distribution, self.sigmas, self.fd_step, corners=False)
        return np.vstack([est.nominal[None, :], est.minus, est.plus]), est.mean, est.std  # (2d + 1, m)

    def at(self, nominal, genes: Mapping[str, float], point) -> tuple:
        return self.deviate(nominal, genes, point)

    def describe(self, point) -> str:
        from whisker_opt.config.robustness import TOLERANCE_KEYS

        where = ", ".join(f"{n}{v:+.4g}" for n, v in zip(TOLERANCE_KEYS, point) if v != 0.0)
        return f"deviated design ({where})"

    def summary(self) -> str:
        return f"the fabrication tolerances ({self.method})"


def _genome_key(evaluator, genes: Mapping[str, float]) -> tuple:
    return evaluator, tuple(sorted((k, float(v)) for k, v in genes.items()))


@dataclass(frozen=True)
class AggregateEvaluator:
    """Picklable evaluator ``genes -> EvalOutcome``: the nominal design's outcome with every measure reduced
    over ``variants`` (module docstring).

    Parameters
    ----------
    nominal : callable
        ``genes -> EvalOutcome`` of the nominal design; every other attribute (``specs``, ``base_spec``,
        ``samples``, ...) is its own.
    variants : LawVariants or FabricationVariants
        What the design is evaluated over.
    reduction : str
        A name of :data:`REDUCTIONS`.
    label : str
        The aggregates' suffix (:func:`aggregate_label`).
    k : float
        k of ``mean_plus_k_std``.

    Notes
    -----
    A variant equal to the nominal design (the same evaluator and genome) is solved once. A variant that
    fails fails the genome, with the variant named. A measure proportional to the gauge factor
    (:attr:`whisker_opt.experiment.measures.Measure.calibrated`) is multiplied by the variant's scale.
    """

    nominal: Any
    variants: Any
    reduction: str = "mean"
    label: str = "mean"
    k: float = 1.0

    def __post_init__(self) -> None:
        if self.reduction not in REDUCTIONS:
            raise ValueError(f"AggregateEvaluator.reduction: {self.reduction!r} is not one of "
                             f"{', '.join(REDUCTIONS)}")

    def __getattr__(self, name: str):
        if name.startswith("__") or name in ("nominal", "variants", "reduction", "label", "k"):
            raise AttributeError(name)
        return getattr(self.nominal, name)

    def __call__(self, genes: dict) -> EvalOutcome:
        t0 = time.perf_counter()
        nominal = self.nominal(genes)
        if not nominal.ok:
            return nominal
        outcomes = {_genome_key(self.nominal, genes): nominal}
        failed: list = []
        scaled = np.array([MEASURES[n].calibrated for n in MEASURE_NAMES])  # (m,)

        def at(point) -> np.ndarray:
            ev, g, scale = self.variants.at(self.nominal, genes, point)
            key = _genome_key(ev, g)
            if key not in outcomes:
                outcomes[key] = ev(g)
            out = outcomes[key]
            if not out.ok:
                failed.append((point, out))
                return np.full(len(MEASURE_NAMES), math.nan)
            v = np.array([math.nan if x is None else x for x in measure_values(out, MEASURE_NAMES).values()])
            return np.where(scaled, v * scale, v)  # (m,)

        values, mean, std = self.variants.spreads(at)
        elapsed = time.perf_counter() - t0
        if failed:
            point, out = failed[0]
            return EvalOutcome.failure(out.status, f"{self.label}: {self.variants.describe(point)}: {out.reason}",
                                       {"total": elapsed}, dict(out.extra))
        spreads = {n: Spread(tuple(float(x) for x in values[:, j]), float(mean[j]), float(std[j]))
                   for j, n in enumerate(MEASURE_NAMES)}
        measures = {aggregate_name(n, self.label): reduce(self.reduction, s, self.k, MEASURES[n].worse)
                    for n, s in spreads.items()}
        measures.update(f1_mean=spreads["f1"].mean, f1_std=spreads["f1"].std)
        objective = aggregate_name("f1", self.label)
        reason = (f"{objective} = {self.reduction} of f1 over {self.variants.summary()} = {measures[objective]:.6g} "
                  f"(mean {spreads['f1'].mean:.6g}, std {spreads['f1'].std:.6g}, k={self.k:g}); "
                  f"f1 (nominal) = {float(nominal.f1):.6g}")
        extra = {**nominal.extra, "variant_f1": list(spreads["f1"].values), "variant_evaluations": len(outcomes)}
        return EvalOutcome("ok", float(nominal.f1), reason,
                           {"total": elapsed, "nominal": nominal.timings.get("total", 0.0)}, extra, measures)
