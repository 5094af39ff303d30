"""The generational GA of the optimisation problem (docs/physics.md), written by hand on DEAP.

Loop (one generation)::

    g = 0:  draw the initial population (Latin hypercube or uniform in the gene box)
    g > 0:  elites   = the n_elite best distinct individuals, copied unchanged
            parents  = tournament selection (size 2) of population − n_elite
            children = pairwise SBX (cxSimulatedBinaryBounded) with probability cx_prob,
                       then polynomial mutation (mutPolynomialBounded, per-gene indpb)
                       with probability mut_prob; genes are clamped to their bounds
                       before each bounded operator (DEAP's operators return complex
                       numbers for out-of-bound genes) and after
            population = elites + children
    evaluate the individuals whose fitness is invalid (cache first, then the executor),
    update the hall of fame, record statistics, check the stopping rules, then hand the
    generation to the recorder (the runner's writes the checkpoint and the tables) and the
    callbacks; stop when a rule fires. NSGA-II runs this same loop with its own selection and
    survival (:class:`GeneticAlgorithm` lists the hooks).

Progress
    An optional :class:`EvaluationProgress` hears of each generation's batch before it is
    evaluated and of each evaluation as it finishes (through the executor's per-result
    callback, in completion order). It only observes: outcomes, their order and every
    random stream are the same with and without it.

Fitness
    DEAP fitness values are the pair (infeasible, F_p) with weights (−1, −1), compared
    lexicographically: every failed design ranks below every feasible one, and feasible
    designs rank by F_p (:mod:`whisker_opt.optimise.penalty`).

Stopping rules (checked after every generation, first match wins)
    ``target_fp``: the best design is feasible and its F_p <= ``target_fp``, F_p taken in the
    strain ``target_strain`` names: divided by the run's gauge factor ξ for 'uncalibrated' (the
    default: the unit of the thesis' F_p <= 1e-3 rule), as read for 'calibrated';
    ``resolution``: the best design is feasible and its f1 has stayed below the run's f1
    resolution (its fidelity preset's, :attr:`whisker_opt.experiment.fidelity.Preset.f1_resolution`,
    in the run's calibrated strain) for the last N = ``resolution_generations`` generations, both
    in the same strain (a ratio of the two does not depend on ξ); off when N = 0 or the run has no
    recorded fidelity. Below the resolution f1 is mesh error: more generations refine noise;
    ``stall``: with b_g the best F_p after generation g and N = ``stall_generations``,
    mean_{k=g−N+1..g} (b_{k−1} − b_k)/|b_{k−1}| <= ``stall_tol`` (needs g >= N);
    ``max_generations``: g = ``max_generations`` (generation 0 is the initial population).
    The rule that fired is ``state.stop_reason``; :meth:`GeneticAlgorithm.stop_detail` says why
    in one line (kept in ``state.extra["stop_detail"]``).

Reproducibility
    All GA randomness is drawn from Python's ``random`` (DEAP's operators use it) inside
    :func:`_ga_rng`, which installs the GA's own RNG states (kept in :class:`GAState`,
    with NumPy's) and saves them back, then restores the caller's. Nothing else — an
    evaluator running in this process, dask, tqdm — can shift the GA's stream, so the
    same seed gives the same run with any executor, and a run resumed from a checkpoint
    continues the exact same stream.

The DEAP ``creator`` classes are created once, at import of this module (guarded with
``hasattr``), so that checkpoints (:mod:`whisker_opt.optimise.statefile`) and worker processes
rebuild individuals wherever this module is imported.
"""

from __future__ import annotations

import contextlib
import logging
import math
import random
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Sequence

import numpy as np
from deap import base, creator, tools

from whisker_opt.optimise.evalcache import EvalCache, evaluation_seed
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GENE_NAMES, genes_dict
from whisker_opt.experiment.measures import measure_values
from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.optimise.penalty import PenaltyTerm, dynamic_penalty, fitness_values, penalise, penalty_terms
from whisker_opt.numfmt import short_float
from whisker_opt.optimise.aggregate import aggregate_columns, objective_column

logger = logging.getLogger(__name__)

if not hasattr(creator, "WhiskerFitness"):
    creator.create("WhiskerFitness", base.Fitness, weights=(-1.0, -1.0))
if not hasattr(creator, "WhiskerIndividual"):
    creator.create("WhiskerIndividual", list, fitness=creator.WhiskerFitness, info=None)

Individual = creator.WhiskerIndividual

#: Multi-objective individuals of m = 2..5 minimised objectives (:mod:`whisker_opt.optimise.nsga2`), created
#: here with the others so that every checkpoint loads wherever this module is imported.
for _m in range(2, 6):
    if not hasattr(creator, f"WhiskerMOFitness{_m}"):
        creator.create(f"WhiskerMOFitness{_m}", base.Fitness, weights=(-1.0,) * _m)
    if not hasattr(creator, f"WhiskerMOIndividual{_m}"):
        creator.create(f"WhiskerMOIndividual{_m}", list, fitness=getattr(creator, f"WhiskerMOFitness{_m}"), info=None)

#: Names of the stopping rules, in order of precedence.
STOP_RULES: tuple[str, ...] = ("target_fp", "resolution", "stall", "max_generations")


@dataclass
class GAState:
    """Everything a generation needs from the previous ones (checkpointed after each).

    Attributes
    ----------
    seed : int
        Master seed of the run.
    generation : int
        Last completed generation (−1 before the initial population is evaluated).
    population : list of Individual
        Current population; each individual has ``fitness.values = (infeasible, F_p)`` and
        ``info`` (dict: eval_id, generation, f1, kappas, fp, status, reason).
    hof : deap.tools.HallOfFame
        Best distinct designs ever seen (``hof[0]`` is the best).
    logbook : list of dict
        Per-generation statistics (see :meth:`GeneticAlgorithm.generation_stats`).
    records : list of dict
        One row per evaluated individual (cache hits included, flagged).
    cache : EvalCache
        Outcomes by rounded genome.
    rng_py, rng_np : tuple
        States of Python's ``random`` and NumPy's global RNG, as the GA left them.
    n_evaluations, n_cache_hits, n_failures : int
        Evaluator calls, individuals served by the cache, failed individuals.
    elapsed_s : float
        Wall time of the completed generations, summed over sessions [s].
    stop_reason : str or None
        The stopping rule that fired (:data:`STOP_RULES`), None while running.
    """

    seed: int
    generation: int
    population: list
    hof: Any
    logbook: list[dict]
    records: list[dict]
    cache: EvalCache
    rng_py: tuple
    rng_np: tuple
    n_evaluations: int = 0
    n_cache_hits: int = 0
    n_failures: int = 0
    elapsed_s: float = 0.0
    stop_reason: str | None = None
    extra: dict = field(default_factory=dict)


Callback = Callable[[GAState, dict], None]


class Recorder:
    """Observer of a run's generations (the run directory's files, a test's log); the base class does nothing.

    :meth:`GeneticAlgorithm.run` calls :meth:`generation` once per completed generation, in order,
    after the state holds it (statistics row, stopping rule) and before the plain callbacks. It must
    not change the state: the algorithm writes nothing itself, what is kept of a run is the recorder's.
    """

    def generation(self, state: GAState, row: dict) -> None:
        """Generation ``row["generation"]`` is complete; ``row`` is its statistics row (``state.logbook[-1]``)."""


class EvaluationProgress:
    """Observer of the evaluations of a run (progress bars, logs); the base class does nothing.

    Its methods are called in the GA's process; they must not change the state.
    """

    def start_generation(self, state: GAState, generation: int, n_to_run: int, n_cached: int) -> None:
        """Generation ``generation`` sends ``n_to_run`` designs to the executor; ``n_cached``
        individuals take their outcome from the cache (or from a twin in the same batch)."""

    def result(self, state: GAState, generation: int, genes: dict[str, float], outcome: EvalOutcome,
               fp: float | None) -> None:
        """One design of the batch finished (completion order); ``fp`` is its F_p when feasible, else None."""


@contextlib.contextmanager
def _ga_rng(state: GAState) -> Iterator[None]:
    """Install the GA's RNG states in ``random`` / ``numpy.random``, save them back after."""
    outer_py, outer_np = random.getstate(), np.random.get_state()
    random.setstate(state.rng_py)
    np.random.set_state(state.rng_np)
    try:
        yield
    finally:
        state.rng_py = random.getstate()
        state.rng_np = np.random.get_state()
        random.setstate(outer_py)
        np.random.set_state(outer_np)


def gauge_factor(state: GAState) -> float | None:
    """The gauge factor ξ of a run's calibrated f1 (stored with its fidelity), or None when unknown
    (a run started without a fidelity, e.g. on an analytic test fitness)."""
    xi = (state.extra.get("fidelity") or {}).get("calibration")
    return float(xi) if xi else None


def uncalibrated(value: float | None, xi: float | None) -> float | None:
    """A calibrated f1 or F_p in simulated (uncalibrated) strain: value / ξ (both are proportional
    to every reading, docs/physics.md); None when ξ is unknown."""
    return None if value is None or xi is None else float(value) / xi


def target_value(best_fp: float, target_strain: str, xi: float | None) -> float:
    """The best F_p in the unit of ``stopping.target_fp``: F_p / ξ for 'uncalibrated' (F_p itself
    when ξ is unknown, i.e. the readings are taken as they come), F_p for 'calibrated'."""
    return best_fp / xi if target_strain == "uncalibrated" and xi else best_fp


def run_resolution(state: GAState) -> float | None:
    """The f1 resolution of a run in its calibrated strain (stored with its fidelity), or None when unknown."""
    res = (state.extra.get("fidelity") or {}).get("f1_resolution")
    try:
        res = float(res)
    except (TypeError, ValueError):
        return None
    return res if math.isfinite(res) and res > 0 else None


def in_strain(value: float | None, strain: str, xi: float | None) -> str:
    """A calibrated f1, F_p or resolution written in the strain ``strain`` first, the other beside it:
    ``"1.2e-4 uncalibrated (4.7e-4 calibrated)"``; the value alone when ξ is unknown."""
    if value is None:
        return "-"
    if not xi:
        return short_float(value, 2)
    cal, uncal = f"{short_float(value, 2)} calibrated", f"{short_float(value / xi, 2)} uncalibrated"
    return f"{uncal} ({cal})" if strain == "uncalibrated" else f"{cal} ({uncal})"


def below_resolution_for(logbook: Sequence[dict], resolution: float, objective: str = "f1") -> int:
    """How many of the last generations in a row had a feasible best design with f1 (or the aggregate
    ``objective`` the run minimises, e.g. ``f1_robust``) < ``resolution``."""
    k = 0
    for row in reversed(logbook):
        f1 = row.get(f"best_{objective}")
        if not (row.get("best_feasible") and f1 is not None and float(f1) < resolution):
            break
        k += 1
    return k


def stalled(history: Sequence[float], n: int, tol: float, higher_is_better: bool = False) -> bool:
    """The stall rule (module docstring): over the last ``n`` generations of ``history`` (one value
    per generation), the mean relative gain h_k = (b_{k−1} − b_k)/|b_{k−1}| (for a value minimised;
    (b_k − b_{k−1})/|b_{k−1}| with ``higher_is_better``, e.g. a hypervolume) is <= ``tol``; a term
    with b_{k−1} = 0 counts as 0. False before ``n`` + 1 values."""
    if len(history) <= n:
        return False
    window = history[-(n + 1):]
    sign = 1.0 if higher_is_better else -1.0
    rel = [sign * (b - a) / abs(a) if a != 0 else 0.0 for a, b in zip(window[:-1], window[1:])]
    return float(np.mean(rel)) <= tol


def _invalidate(ind) -> None:
    del ind.fitness.values
    ind.info = None


class GeneticAlgorithm:
    """The GA on the genes of ``optimiser.genes`` ([α, l, t, Q_i] and any added ones), and the generation loop its variants share.

    One generation (:meth:`run_generation`): breed (:meth:`carry_over` + :meth:`select_parents`
    varied by :meth:`vary`; generation 0 draws :meth:`initial_population`), evaluate (cache,
    executor, records, progress: :meth:`evaluate`), keep the next population (:meth:`survive`),
    update the hall of fame (:meth:`hall_of_fame_entries`) and what the variant keeps beside it
    (:meth:`after_evaluation`), then the statistics row (:meth:`generation_stats`), the stopping
    rules (:meth:`set_stop`) and the log line (:meth:`generation_summary`). A variant such as
    :class:`whisker_opt.optimise.nsga2.NSGA2` overrides these hooks, never the loop. The loop
    writes no file: :meth:`run` hands each generation to a :class:`Recorder`.

    Parameters
    ----------
    cfg : OptimiserConfig
        Genes, penalties, GA settings, stopping rules and cache settings.
    seed : int
        Master seed (GA streams and per-design evaluator seeds derive from it).
    """

    #: Columns the variant adds to the statistics row (``generations.csv``).
    EXTRA_GENERATION_COLUMNS: tuple[str, ...] = ()

    def __init__(self, cfg: OptimiserConfig, seed: int) -> None:
        self.cfg = cfg
        self.seed = int(seed)
        self.names: tuple[str, ...] = cfg.genes.names()
        #: Measures (:mod:`whisker_opt.experiment.measures`) recorded beside f1 and handed to :meth:`fitness_of`.
        self.measure_columns: tuple[str, ...] = ()
        #: What the run minimises: f1, or its aggregate over variants (``f1_robust``, ...; optimise/aggregate.py).
        self.objective: str = objective_column(cfg)
        bounds = cfg.genes.bounds()
        self.low = [float(lo) for lo, _ in bounds]
        self.up = [float(hi) for _, hi in bounds]
        self.terms: tuple[PenaltyTerm, ...] = penalty_terms(cfg)
        self.individual_class = Individual
        ga = cfg.ga
        tb = base.Toolbox()
        tb.register("select", tools.selTournament, tournsize=ga.tournament)
        tb.register("mate", tools.cxSimulatedBinaryBounded, eta=ga.eta_cx, low=self.low, up=self.up)
        tb.register("mutate", tools.mutPolynomialBounded, eta=ga.eta_mut, low=self.low, up=self.up, indpb=ga.indpb)
        self.toolbox = tb

    # ------------------------------------------------------------------ state
    def new_state(self) -> GAState:
        """A fresh state: nothing evaluated, RNGs seeded with the master seed."""
        state = GAState(
            seed=self.seed,
            generation=-1,
            population=[],
            hof=tools.HallOfFame(self.cfg.ga.hall_of_fame),
            logbook=[],
            records=[],
            cache=EvalCache(self.cfg.cache.decimals, self.cfg.cache.enabled, self.cfg.cache.cache_failures),
            rng_py=random.Random(self.seed).getstate(),
            rng_np=np.random.RandomState(self.seed % 2**32).get_state(),
        )
        state.extra["gene_names"] = list(self.names)
        return state

    def genes_of(self, ind: Sequence[float]) -> dict[str, float]:
        """Gene values by name."""
        return {n: float(x) for n, x in zip(self.names, ind)}

    def clamp(self, ind) -> bool:
        """Clamp every gene into its bounds, in place; True when something moved."""
        moved = False
        for i, (lo, hi) in enumerate(zip(self.low, self.up)):
            x = ind[i]
            y = min(max(float(x.real if isinstance(x, complex) else x), lo), hi)
            if y != x:
                ind[i] = y
                moved = True
        return moved

    # ------------------------------------------------------------------ breeding
    def initial_population(self) -> list:
        """Initial individuals (uses the global ``random``; call inside :func:`_ga_rng`).

        The Latin hypercube (one draw in each of the ``population`` strata of every gene, strata
        shuffled per gene) is drawn here rather than by ``scipy.stats.qmc.LatinHypercube``: the
        library draws from a NumPy generator, in another order (all offsets, then the
        permutations), so it cannot give the numbers of this stream, the one DEAP's operators
        share and the checkpoint records; with it every seeded run's initial population, hence
        every evaluation after it, would change (the numbers are pinned by
        ``tests/test_ga_initial_population.py``).
        """
        n = self.cfg.ga.population
        cols = []
        for lo, hi in zip(self.low, self.up):
            if self.cfg.ga.init == "lhs":
                strata = list(range(n))
                random.shuffle(strata)
                cols.append([lo + (hi - lo) * (s + random.random()) / n for s in strata])
            else:
                cols.append([random.uniform(lo, hi) for _ in range(n)])
        pop = [self.individual_class(list(row)) for row in zip(*cols)]
        for ind in pop:
            self.clamp(ind)
        return pop

    def carry_over(self, population: list) -> list:
        """Individuals kept unchanged into the next population: clones of the ``n_elite`` best with distinct genes."""
        out, seen = [], set()
        for ind in tools.selBest(population, len(population)):
            if len(out) >= self.cfg.ga.n_elite:
                break
            key = tuple(ind)
            if key in seen:
                continue
            seen.add(key)
            out.append(self.toolbox.clone(ind))
        return out

    def select_parents(self, population: list, n: int) -> list:
        """``n`` parents: tournaments of ``ga.tournament`` on the fitness (call inside :func:`_ga_rng`)."""
        return self.toolbox.select(population, n)

    def vary(self, parents: list) -> list:
        """Children of ``parents``: pairwise SBX with probability cx_prob, then polynomial mutation with
        probability mut_prob, genes clamped to their bounds (call inside :func:`_ga_rng`)."""
        ga = self.cfg.ga
        tb = self.toolbox
        offspring = [tb.clone(ind) for ind in parents]
        for i in range(1, len(offspring), 2):
            if random.random() < ga.cx_prob:
                a, b = offspring[i - 1], offspring[i]
                self.clamp(a)
                self.clamp(b)
                tb.mate(a, b)
                _invalidate(a)
                _invalidate(b)
        for ind in offspring:
            if random.random() < ga.mut_prob:
                self.clamp(ind)
                tb.mutate(ind)
                _invalidate(ind)
        for ind in offspring:
            if self.clamp(ind) and ind.fitness.valid:  # pragma: no cover - operators clip already
                _invalidate(ind)
        return offspring

    def breed(self, population: list) -> list:
        """The next generation's individuals: :meth:`carry_over` + the varied :meth:`select_parents`
        (call inside :func:`_ga_rng`)."""
        kept = self.carry_over(population)
        return kept + self.vary(self.select_parents(population, len(population) - len(kept)))

    def survive(self, population: list, bred: list, generation: int) -> list:
        """The population after generation ``generation``: the bred individuals (call inside :func:`_ga_rng`)."""
        return bred

    def hall_of_fame_entries(self, bred: list) -> list:
        """The individuals of a generation offered to the hall of fame (the GA's: all bred ones)."""
        return bred

    def after_evaluation(self, state: GAState, first: int) -> None:
        """Keep what the variant needs of the records from index ``first`` on (nothing for the GA)."""

    # ------------------------------------------------------------------ evaluation
    def fitness_of(self, pen, genes: dict[str, float]) -> tuple[float, ...]:
        """DEAP fitness values of a penalised outcome: (infeasible, F_p) (:func:`fitness_values`); ``genes`` also
        holds the values of :attr:`measure_columns`."""
        return fitness_values(pen)

    def evaluate(self, state: GAState, individuals: list, executor, generation: int,
                 progress: EvaluationProgress | None = None) -> dict[str, int]:
        """Give every individual with an invalid fitness its fitness, recording each one.

        Designs found in the cache, or repeated within the batch, are not sent to the
        executor (flagged ``cache_hit``). Returns counts for the statistics. ``progress``
        observes the batch (:class:`EvaluationProgress`); the executor must then accept
        ``map(genes, seeds, on_result=...)``.
        """
        cache = state.cache
        invalid = [ind for ind in individuals if not ind.fitness.valid]
        keys = []
        to_run: dict[Any, dict[str, float]] = {}
        for j, ind in enumerate(invalid):
            key = cache.key(ind) if cache.enabled else (j,)
            keys.append(key)
            if cache.get(key) is None and key not in to_run:
                to_run[key] = self.genes_of(ind)
        run_keys = list(to_run)
        seeds = [evaluation_seed(self.seed, cache.key(to_run[k].values())) for k in run_keys]
        batch = [to_run[k] for k in run_keys]
        if progress is None:
            outcomes: list[EvalOutcome] = executor.map(batch, seeds) if run_keys else []
        else:
            progress.start_generation(state, generation, len(run_keys), len(invalid) - len(run_keys))

            def on_result(i: int, out: EvalOutcome) -> None:
                fp = None
                if out.ok:  # F_p of f1 or of its aggregate over variants
                    fp = dynamic_penalty(measure_values(out, (self.objective,))[self.objective], batch[i], self.terms)[1]
                progress.result(state, generation, batch[i], out, fp)

            outcomes = executor.map(batch, seeds, on_result=on_result) if run_keys else []
        fresh = dict(zip(run_keys, outcomes))
        xi = gauge_factor(state)
        for k, out in fresh.items():
            cache.put(k, out)
        first_use = set(fresh)
        n_hits = n_fail = 0
        for ind, key in zip(invalid, keys):
            if key in first_use:
                out, hit = fresh[key], False
                first_use.discard(key)
            else:
                out = fresh[key] if key in fresh else cache.get(key)
                hit = True
                n_hits += 1
            genes = self.genes_of(ind)
            pen = penalise(out, genes, self.terms, self.cfg.failure_penalty, self.objective)
            f1 = measure_values(out, ("f1",))["f1"]
            measures = measure_values(out, self.measure_columns)
            ind.fitness.values = self.fitness_of(pen, {**genes, **measures})
            eval_id = len(state.records)
            if not pen.feasible:
                n_fail += 1
            ind.info = {
                "eval_id": eval_id,
                "generation": generation,
                "f1": f1,
                "kappas": dict(pen.kappas),
                "fp": pen.fp,
                "status": out.status,
                "reason": out.reason,
            }
            if self.objective != "f1":  # the aggregate the run minimises, beside the nominal f1
                ind.info.update({"objective": self.objective, self.objective: pen.f1})
            if measures:
                ind.info["measures"] = measures
            rec: dict[str, Any] = {"eval_id": eval_id, "generation": generation, **genes, "f1": f1}
            aggregates = aggregate_columns(self.cfg)  # empty for a failed evaluation
            rec.update(measure_values(out, aggregates) if out.ok else dict.fromkeys(aggregates))
            rec.update(measures)
            for t in self.terms:
                rec[t.column] = pen.kappas.get(t.gene)
            rec.update(
                F_p=pen.fp,
                f1_uncalibrated=uncalibrated(f1, xi) if pen.feasible else None,
                F_p_uncalibrated=uncalibrated(pen.fp, xi) if pen.feasible else None,
                status=out.status,
                reason=out.reason,
                time_s=0.0 if hit else float(out.timings.get("eval_s", 0.0)),
                cache_hit=hit,
            )
            state.records.append(rec)
        state.n_evaluations += len(run_keys)
        state.n_cache_hits += n_hits
        state.n_failures += n_fail
        return {"evals": len(run_keys), "cache_hits": n_hits, "n_failures": n_fail, "n_invalid": len(invalid)}

    # ------------------------------------------------------------------ statistics / stopping
    def population_fps(self, pop: list) -> tuple[list[float], list[float]]:
        """F_p of the feasible individuals of ``pop``, and of all of them (fitness = (infeasible, F_p))."""
        return ([ind.fitness.values[1] for ind in pop if ind.fitness.values[0] == 0.0],
                [ind.fitness.values[1] for ind in pop])

    def generation_stats(self, state: GAState, generation: int, counts: dict[str, int], wall_s: float) -> dict:
        """Statistics row of one generation (best = hall of fame best, mean over feasible)."""
        feas, all_fp = self.population_fps(state.population)
        best = state.hof[0]
        row: dict[str, Any] = {
            "generation": generation,
            "evals": counts["evals"],
            "cache_hits": counts["cache_hits"],
            "n_failures": counts["n_failures"],
            "n_feasible": len(feas),
            "best_fp": best.fitness.values[1],
            "best_fp_uncalibrated": (uncalibrated(best.fitness.values[1], gauge_factor(state))
                                     if best.fitness.values[0] == 0.0 else None),
            "best_feasible": best.fitness.values[0] == 0.0,
            "best_f1": best.info["f1"] if best.info else None,
            **({f"best_{self.objective}": best.info.get(self.objective) if best.info else None}
               if self.objective != "f1" else {}),
            "min_fp": min(feas) if feas else min(all_fp),
            "mean_fp": float(np.mean(feas)) if feas else math.nan,
            "total_evals": state.n_evaluations,
            "time_s": wall_s,
        }
        row.update({f"best_{n}": float(x) for n, x in zip(self.names, best)})
        return row

    def stop_reason(self, state: GAState) -> str | None:
        """The first stopping rule that fires after the last generation, or None."""
        st = self.cfg.stopping
        last = state.logbook[-1]
        if last["best_feasible"] and target_value(last["best_fp"], st.target_strain, gauge_factor(state)) <= st.target_fp:
            return "target_fp"
        res = run_resolution(state)
        if st.resolution_generations and res is not None \
                and below_resolution_for(state.logbook, res, self.objective) >= st.resolution_generations:
            return "resolution"
        if stalled([row["best_fp"] for row in state.logbook], st.stall_generations, st.stall_tol):
            return "stall"
        if state.generation >= st.max_generations:
            return "max_generations"
        return None

    def stop_detail(self, state: GAState) -> str | None:
        """Why the run stopped, in one line naming the rule and its numbers (None while running).

        f1, F_p and the resolution are written in the strain of ``stopping.target_strain`` first.
        """
        rule, st = state.stop_reason, self.cfg.stopping
        if rule is None or not state.logbook:
            return None
        last, xi = state.logbook[-1], gauge_factor(state)
        g = state.generation
        if rule == "target_fp":
            return (f"target_fp: the best F_p {in_strain(last['best_fp'], st.target_strain, xi)} is <= "
                    f"stopping.target_fp = {st.target_fp:g} ({st.target_strain} strain) at generation {g}")
        if rule == "resolution":
            res, n = run_resolution(state), st.resolution_generations
            preset = (state.extra.get("fidelity") or {}).get("preset", "?")
            return (f"resolution: the best design's {self.objective} has stayed below the f1 resolution "
                    f"~{in_strain(res, st.target_strain, xi)} of preset {preset} for {n} generations "
                    f"({g - n + 1}..{g}; stopping.resolution_generations = {n}), at generation {g} "
                    f"{in_strain(last[f'best_{self.objective}'], st.target_strain, xi)}: further generations would rank mesh "
                    f"error; verify the best designs at a finer preset")
        if rule == "stall":
            return (f"stall: the mean relative improvement of the best F_p over the last {st.stall_generations} "
                    f"generations is <= stopping.stall_tol = {st.stall_tol:g} (generation {g})")
        return f"max_generations: generation {g} = stopping.max_generations"

    def set_stop(self, state: GAState) -> None:
        """Check the stopping rules (:meth:`stop_reason`) and keep the rule and its :meth:`stop_detail`."""
        state.stop_reason = self.stop_reason(state)
        state.extra["stop_detail"] = self.stop_detail(state)

    def generation_summary(self, row: dict) -> str:
        """What the log line of a generation says of its result: the best F_p and whether it is feasible."""
        return f"best F_p={row['best_fp']:.6g} ({'feasible' if row['best_feasible'] else 'FAILED'})"

    # ------------------------------------------------------------------ loop
    def run_generation(self, state: GAState, executor, progress: EvaluationProgress | None = None) -> dict:
        """Breed (or draw), evaluate and keep one generation (class docstring); returns its statistics row."""
        t0 = time.perf_counter()
        gen = state.generation + 1
        with _ga_rng(state):
            bred = self.initial_population() if gen == 0 else self.breed(state.population)
        first = len(state.records)
        counts = self.evaluate(state, bred, executor, gen, progress)
        with _ga_rng(state):
            state.population = self.survive(state.population, bred, gen)
        state.hof.update(self.hall_of_fame_entries(bred))
        self.after_evaluation(state, first)
        state.generation = gen
        wall = time.perf_counter() - t0
        state.elapsed_s += wall
        row = self.generation_stats(state, gen, counts, wall)
        row["elapsed_s"] = state.elapsed_s
        state.logbook.append(row)
        self.set_stop(state)
        logger.info(
            "generation %d: %s, %d evals, %d cache hits, %d failures%s",
            gen, self.generation_summary(row), counts["evals"], counts["cache_hits"], counts["n_failures"],
            f", stop: {state.stop_reason}" if state.stop_reason else "",
        )
        return row

    def run(self, state: GAState, executor, callbacks: Sequence[Callback] = (),
            progress: EvaluationProgress | None = None, recorder: Recorder | None = None) -> GAState:
        """Run generations until a stopping rule fires.

        After each generation ``recorder.generation(state, row)`` (:class:`Recorder`), then
        ``callback(state, row)`` for each of ``callbacks``; ``progress`` (:class:`EvaluationProgress`)
        hears of each evaluation.
        """
        while state.stop_reason is None:
            row = self.run_generation(state, executor, progress)
            if recorder is not None:
                recorder.generation(state, row)
            for cb in callbacks:
                cb(state, row)
        return state


def gene_names(state: GAState) -> tuple[str, ...]:
    """The genome of a run's state (:data:`GENE_NAMES` for a state saved before genomes could grow)."""
    return tuple(state.extra.get("gene_names") or GENE_NAMES)


def best_design(state: GAState) -> dict[str, Any]:
    """The best design so far: genes, f1 (and the aggregate over variants the run minimises, e.g.
    ``f1_robust``, when it has one), κ_j, F_p (calibrated, and divided by ξ when the run knows its gauge
    factor), status and where it was found."""
    best = state.hof[0]
    info = dict(best.info or {})
    feasible = best.fitness.values[0] == 0.0
    name = info.get("objective")  # set by an aggregated run only
    objective = {"objective": name, name: info.get(name)} if name else {}
    return {
        "genes": genes_dict(best, gene_names(state)),
        "feasible": feasible,
        "F_p": best.fitness.values[1],
        "f1": info.get("f1"),
        **objective,
        "F_p_uncalibrated": uncalibrated(best.fitness.values[1], gauge_factor(state)) if feasible else None,
        "f1_uncalibrated": uncalibrated(info.get("f1"), gauge_factor(state)),
        "kappas": info.get("kappas", {}),
        "status": info.get("status"),
        "reason": info.get("reason", ""),
        "eval_id": info.get("eval_id"),
        "generation_found": info.get("generation"),
    }
