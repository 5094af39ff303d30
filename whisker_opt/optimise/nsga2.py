"""Multi-objective mode (``optimiser.algorithm: nsga2``): NSGA-II on DEAP, its archive and hypervolume.

Objectives (all minimised; ``optimiser.objectives``, docs/physics.md "Multi-objective mode")
    ``f1`` itself; any other measure of :mod:`whisker_opt.experiment.measures` by name (``sensitivity``,
    ``delta_l``, ...), itself when the low end is preferred, its negative when the high end is; and for a
    gene g_j its normalised distance from the preferred end of its range,
    d_j = (x − lo)/(hi − lo) (prefer low) or (hi − x)/(hi − lo) (prefer high): the same d_j as the
    penalty terms (:meth:`whisker_opt.optimise.penalty.PenaltyTerm.distance`), here an objective
    of its own instead of a factor of F_p. f1 is always one of them: the hall of fame (hence
    ``best.json``, verify and the report) ranks by the F_p of f1, and f1_ref scales the hypervolume.
    A failed evaluation gets F_p of the failure for every measure and 2 for every gene:
    every feasible design dominates it (its graded F_p, >= ``failure_penalty``, exceeds any
    feasible f1, and d_j <= 1), and failures rank among themselves by their graded F_p.

Loop (one generation; Deb et al. 2002)
    g = 0:  the initial population, drawn exactly as the GA draws it (Latin hypercube or uniform)
    g > 0:  parents  = N binary tournaments on (non-domination rank, then larger crowding distance;
                       DEAP's ``sortNondominated`` and ``assignCrowdingDist``)
            children = the GA's bounded operators: pairwise SBX with probability cx_prob, polynomial
                       mutation with probability mut_prob (per-gene indpb), genes clamped to their bounds
            population = ``tools.selNSGA2`` (fronts, then crowding distance) of parents ∪ children,
                       exact genome duplicates removed first while N distinct ones remain
    The loop, evaluation, cache, executors, progress, checkpoints and RNG handling are the GA's
    (:class:`whisker_opt.optimise.ga.GeneticAlgorithm`): this class overrides its selection
    (:meth:`NSGA2.select_parents`, no carried-over elites), survival (:meth:`NSGA2.survive`), what
    the hall of fame is offered and the archive kept beside it, the statistics, the stopping rules
    and the log line. The hall of fame ranks every evaluated design by the penalised F_p of the same
    config: its best is the design the single-objective GA's score would pick, written to
    ``best.json`` as usual. The front's files (``pareto.csv``, ``pareto.png``, ``hypervolume.png``)
    and its verification at a finer preset are the run recorder's
    (:mod:`whisker_opt.optimise.recorder`); this module only says what the front is (:meth:`NSGA2.front_rows`).

Archive and hypervolume
    The archive (``state.extra["archive"]``: eval ids) is the non-dominated subset of every
    feasible design evaluated so far, one per genome. Its hypervolume (:func:`pareto.hypervolume`)
    is taken in normalised objectives z = (f1 / f1_ref, ±m / m_ref, d_j, ...) against the reference point
    r = (1.1, ..., 1.1), with f1_ref the largest f1 of the feasible designs of generation 0
    (``state.extra["f1_ref"]``, fixed for the run) and m_ref likewise the largest |m| of another measure
    objective (``state.extra["measure_refs"]``; −m for a measure preferred high). Every d_j <= 1 < 1.1, so the
    archive's hypervolume never decreases. Without a high-preferred measure it is at most 1.1^n; a
    high-preferred measure's z reaches below −1, so the volume can exceed that (:func:`hypervolume_basis`, the
    one line that says so on the plots and in the report).

Stopping rules (after every generation, first match wins)
    ``stall``: with h_g the hypervolume after generation g and N = ``stall_generations``,
    mean_{k=g−N+1..g} (h_k − h_{k−1})/|h_{k−1}| <= ``stall_tol`` (needs g >= N; a zero h counts
    as no improvement); ``max_generations``. ``target_fp`` and ``resolution`` do not apply: no
    single score is driven to a target, and a front spans f1 values above the resolution too.
"""

from __future__ import annotations

import logging
import random
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

from deap import creator, tools

from whisker_opt.config.optimiser import ExecutorConfig, OptimiserConfig
from whisker_opt.experiment.measures import MEASURES
from whisker_opt.numfmt import short_float
from whisker_opt.optimise.ga import GAState, GeneticAlgorithm, Individual, stalled
from whisker_opt.optimise.pareto import hypervolume, non_dominated
from whisker_opt.optimise.penalty import PenaltyTerm, dynamic_penalty

logger = logging.getLogger(__name__)

#: Stopping rules of the multi-objective mode, in order of precedence.
STOP_RULES: tuple[str, ...] = ("stall", "max_generations")
#: Normalised coordinate of the hypervolume's reference point in every objective.
HV_REFERENCE = 1.1
#: d_j given to the gene objectives of a failed design (every feasible d_j is <= 1).
FAILED_DISTANCE = 2.0


@dataclass(frozen=True)
class Objective:
    """One minimised objective: a measure (:mod:`whisker_opt.experiment.measures`; ``high`` minimises its
    negative), or a gene's normalised distance from its preferred end.

    Parameters
    ----------
    name : str
        A measure name (``f1``, ``sensitivity``, ...) or a gene name.
    prefer : {"low", "high"}
        Preferred end (``low`` for f1).
    lo, hi : float
        The gene's bounds (unused for a measure).
    gene : bool
        The objective is a gene's distance.
    """

    name: str
    prefer: str
    lo: float = 0.0
    hi: float = 1.0
    gene: bool = False

    def value(self, values: Mapping[str, Any]) -> float:
        """The minimised value from ``values`` (genes and measures by name): d_j ∈ [0, 1] of a gene
        (:meth:`PenaltyTerm.distance`), the measure (prefer low) or its negative (prefer high)."""
        if self.gene:
            return PenaltyTerm(self.name, self.prefer, 0.0, self.lo, self.hi).distance(float(values[self.name]))
        v = float(values[self.name])
        return v if self.prefer == "low" else -v

    @property
    def label(self) -> str:
        """Axis / column label, e.g. ``f1`` or ``Q_i (prefer low)``."""
        return self.name if self.name == "f1" else f"{self.name} (prefer {self.prefer})"


def hypervolume_basis(objectives: Sequence[Objective], state: GAState | None = None) -> str:
    """What the hypervolume is measured in, in one line: the normalised coordinates z of each objective (with
    the run's scales once generation 0 has set them) and the reference point, e.g.
    ``z = (f1 / 4.8e-3, −sensitivity / 0.021, d(Q_i)); reference point z = (1.1, 1.1, 1.1)``.

    A gene's d lies in [0, 1] and a low-preferred measure's z in [0, 1] over generation 0; a high-preferred
    measure's z = −m/m_ref lies in [−1, 0] there and below −1 once a design passes generation 0's best, so the
    volume may exceed 1.1^n (the box from the origin to the reference point)."""
    refs = (state.extra or {}) if state is not None else {}
    scales = {"f1": refs.get("f1_ref"), **refs.get("measure_refs", {})}
    parts = []
    for o in objectives:
        if o.gene:
            parts.append(f"d({o.name})")
        else:
            ref = scales.get(o.name)
            parts.append(f"{'' if o.prefer == 'low' else '−'}{o.name} / "
                         f"{short_float(ref, 2) if ref else o.name + '_ref'}")
    corner = ", ".join(f"{HV_REFERENCE:g}" for _ in objectives)
    return f"z = ({', '.join(parts)}); reference point z = ({corner})"


def objective_terms(cfg: OptimiserConfig) -> tuple[Objective, ...]:
    """The configured objectives, genes with their bounds."""
    out = []
    for o in cfg.objectives:
        if o.name in MEASURES:
            out.append(Objective(o.name, o.prefer))
        else:
            b = cfg.genes.of(o.name)
            out.append(Objective(o.name, o.prefer, float(b.lo), float(b.hi), gene=True))
    return tuple(out)


def make_algorithm(cfg: OptimiserConfig, seed: int) -> GeneticAlgorithm:
    """The optimiser ``cfg.algorithm`` names: :class:`GeneticAlgorithm` or :class:`NSGA2`."""
    return NSGA2(cfg, seed) if cfg.algorithm == "nsga2" else GeneticAlgorithm(cfg, seed)


def spread(items: Sequence[Any], k: int) -> list[Any]:
    """``k`` of ``items`` (k >= 1) evenly spaced by position, both ends included when k >= 2: item
    round(q (n − 1)/(k − 1)) for q = 0..k−1 (all of them when k >= n)."""
    n = len(items)
    if k >= n:
        return list(items)
    return [items[i] for i in sorted({round(q * (n - 1) / max(k - 1, 1)) for q in range(k)})]


def finer_preset(preset: str | None) -> str | None:
    """The next finer fidelity preset in cost order (coarse, default, level2, fine, level3, level4,
    reference), None for the finest or an unknown one."""
    from whisker_opt.experiment.fidelity import PRESET_NAMES

    if preset not in PRESET_NAMES:
        return None
    i = PRESET_NAMES.index(preset)
    return PRESET_NAMES[i + 1] if i + 1 < len(PRESET_NAMES) else None


class NSGA2(GeneticAlgorithm):
    """NSGA-II on the genes of ``optimiser.genes`` (module docstring).

    Parameters
    ----------
    cfg : OptimiserConfig
        ``algorithm: nsga2``; ``objectives`` as in the module docstring, ``ga`` for the population
        and the variation operators (``tournament``, ``n_elite`` unused), ``stopping`` for the rules.
    seed : int
        Master seed.
    """

    EXTRA_GENERATION_COLUMNS = ("hypervolume", "front_size")

    def __init__(self, cfg: OptimiserConfig, seed: int) -> None:
        super().__init__(cfg, seed)
        self.objectives = objective_terms(cfg)
        self.measure_columns = tuple(o.name for o in self.objectives if not o.gene and o.name != "f1")
        self.n_obj = len(self.objectives)
        self.individual_class = getattr(creator, f"WhiskerMOIndividual{self.n_obj}")
        self.toolbox.register("select", tools.selNSGA2)

    # ------------------------------------------------------------------ objectives
    def fitness_of(self, pen, genes: dict[str, float]) -> tuple[float, ...]:
        """Objective vector of a penalised outcome; ``genes`` holds the genes and the measures of
        :attr:`measure_columns` (failures: F_p for every measure, 2 for every gene)."""
        if not pen.feasible:
            return tuple(FAILED_DISTANCE if o.gene else float(pen.fp) for o in self.objectives)
        return tuple(o.value({**genes, "f1": pen.f1}) for o in self.objectives)

    def record_objectives(self, rec: Mapping[str, Any]) -> tuple[float, ...]:
        """Objective vector of a feasible evaluation record."""
        return tuple(o.value(rec) for o in self.objectives)

    def normalised(self, vec: Sequence[float], refs: Mapping[str, float]) -> tuple[float, ...]:
        """z = (f1 / f1_ref, m / m_ref, d_j, ...): the coordinates of the hypervolume, each measure divided by
        its reference (:meth:`measure_refs`)."""
        return tuple(v if o.gene else v / refs[o.name] for o, v in zip(self.objectives, vec))

    def measure_refs(self, state: GAState) -> dict[str, float] | None:
        """Each measure objective's scale: the largest |value| over the feasible designs of the first generation
        with one (``state.extra["f1_ref"]`` for f1, ``"measure_refs"`` for the others); None before."""
        f1_ref = state.extra.get("f1_ref")
        if not f1_ref:
            return None
        return {"f1": f1_ref, **state.extra.get("measure_refs", {})}

    # ------------------------------------------------------------------ selection and survival
    def carry_over(self, population: list) -> list:
        """None: survival keeps the best of parents and children."""
        return []

    def select_parents(self, population: list, n: int) -> list:
        """``n`` binary tournaments on (rank, −crowding distance); call inside :func:`whisker_opt.optimise.ga._ga_rng`."""
        rank: dict[int, int] = {}
        crowd: dict[int, float] = {}
        for r, front in enumerate(tools.sortNondominated(population, len(population))):
            tools.emo.assignCrowdingDist(front)
            for ind in front:
                rank[id(ind)] = r
                crowd[id(ind)] = ind.fitness.crowding_dist
        size = len(population)
        chosen = []
        for _ in range(n):
            a, b = population[random.randrange(size)], population[random.randrange(size)]
            ka, kb = (rank[id(a)], -crowd[id(a)]), (rank[id(b)], -crowd[id(b)])
            chosen.append(b if kb < ka else a)
        return chosen

    def survive(self, population: list, bred: list, generation: int) -> list:
        """``selNSGA2`` of parents ∪ children, distinct genomes when N of them exist (generation 0: all drawn)."""
        if generation == 0:
            return bred
        pool = population + bred
        seen, distinct = set(), []
        for ind in pool:
            key = tuple(ind)
            if key not in seen:
                seen.add(key)
                distinct.append(ind)
        n = self.cfg.ga.population
        return tools.selNSGA2(distinct if len(distinct) >= n else pool, n)

    def hall_of_fame_entries(self, bred: list) -> list:
        """Single-objective copies of the evaluated children (:meth:`penalised`)."""
        return [self.penalised(ind) for ind in bred]

    def after_evaluation(self, state: GAState, first: int) -> None:
        """Fold the generation's records into the archive (:meth:`update_archive`)."""
        self.update_archive(state, first)

    # ------------------------------------------------------------------ archive / hall of fame
    @staticmethod
    def penalised(ind) -> Any:
        """A single-objective copy of an evaluated individual, fitness (infeasible, F_p), for the hall of fame."""
        c = Individual(list(ind))
        info = ind.info or {}
        c.fitness.values = (0.0 if info.get("f1") is not None else 1.0, float(info["fp"]))
        c.info = dict(info)
        return c

    def update_archive(self, state: GAState, first: int) -> None:
        """Fold the records from index ``first`` on into the archive (module docstring)."""
        recs = state.records
        archive = list(state.extra.get("archive", []))
        keys = {state.cache.key([recs[i][g] for g in self.names]) for i in archive}
        for i in range(first, len(recs)):
            r = recs[i]
            if r["f1"] is None or r["status"] != "ok":
                continue
            key = state.cache.key([r[g] for g in self.names])
            if key not in keys:
                keys.add(key)
                archive.append(i)
        keep = non_dominated([self.record_objectives(recs[i]) for i in archive]) if archive else []
        state.extra["archive"] = [archive[k] for k in keep]
        if state.extra.get("f1_ref") is None:
            feas = [float(recs[i]["f1"]) for i in range(first, len(recs)) if recs[i]["f1"] is not None]
            if feas:
                state.extra["f1_ref"] = max(feas) if max(feas) > 0 else 1.0
                if self.measure_columns:
                    ok = [recs[i] for i in range(first, len(recs)) if recs[i]["f1"] is not None]
                    state.extra["measure_refs"] = {
                        m: max(abs(float(r[m])) for r in ok) or 1.0 for m in self.measure_columns}

    def hypervolume(self, state: GAState) -> float:
        """Hypervolume of the archive in normalised objectives (0 before a feasible design exists)."""
        refs = self.measure_refs(state)
        arch = state.extra.get("archive", [])
        if not refs or not arch:
            return 0.0
        pts = [self.normalised(self.record_objectives(state.records[i]), refs) for i in arch]
        return hypervolume(pts, [HV_REFERENCE] * self.n_obj)

    # ------------------------------------------------------------------ statistics / stopping
    def population_fps(self, pop: list) -> tuple[list[float], list[float]]:
        """F_p of the feasible individuals and of all (the fitness holds the objectives, the info F_p)."""
        return ([ind.info["fp"] for ind in pop if ind.info and ind.info.get("f1") is not None],
                [ind.info["fp"] for ind in pop])

    def generation_stats(self, state: GAState, generation: int, counts: dict[str, int], wall_s: float) -> dict:
        """The GA's statistics row (best = the penalised hall of fame's) plus hypervolume and front size."""
        row = super().generation_stats(state, generation, counts, wall_s)
        row["hypervolume"] = self.hypervolume(state)
        row["front_size"] = len(state.extra.get("archive", []))
        return row

    def stop_reason(self, state: GAState) -> str | None:
        """``stall`` on the hypervolume, else ``max_generations`` (module docstring)."""
        st = self.cfg.stopping
        if stalled([row["hypervolume"] for row in state.logbook], st.stall_generations, st.stall_tol,
                   higher_is_better=True):
            return "stall"
        if state.generation >= st.max_generations:
            return "max_generations"
        return None

    def stop_detail(self, state: GAState) -> str | None:
        """Why the run stopped, in one line (the stall rule here is the hypervolume's)."""
        st = self.cfg.stopping
        if state.stop_reason == "stall":
            return (f"stall: the mean relative gain of the front's hypervolume over the last {st.stall_generations} "
                    f"generations is <= stopping.stall_tol = {st.stall_tol:g} (generation {state.generation})")
        return super().stop_detail(state)

    def generation_summary(self, row: dict) -> str:
        """The log line's result: the front's hypervolume and size, and the best F_p."""
        return f"hypervolume {row['hypervolume']:.6g}, front of {row['front_size']}, best F_p={row['best_fp']:.6g}"

    # ------------------------------------------------------------------ the front
    def front_rows(self, state: GAState) -> list[dict[str, Any]]:
        """The archive's designs (sorted by f1) and, when off it, the penalised optimum: genes, f1, F_p, flags."""
        recs = state.records
        arch = sorted(state.extra.get("archive", []), key=lambda i: (recs[i]["f1"], i))
        best = state.hof[0] if state.hof and state.hof[0].fitness.values[0] == 0.0 else None
        best_key = state.cache.key(best) if best is not None else None
        rows = []
        for i in arch:
            r = recs[i]
            rows.append({"eval_id": r["eval_id"], "generation": r["generation"], **{g: r[g] for g in self.names},
                         "f1": r["f1"], **{m: r.get(m) for m in self.measure_columns}, "F_p": r["F_p"], "on_front": True,
                         "penalised_optimum": state.cache.key([r[g] for g in self.names]) == best_key})
        if best is not None and not any(r["penalised_optimum"] for r in rows):
            info = best.info or {}
            rows.append({"eval_id": info.get("eval_id"), "generation": info.get("generation"),
                         **{g: float(x) for g, x in zip(self.names, best)}, "f1": info.get("f1"),
                         **{m: info.get("measures", {}).get(m) for m in self.measure_columns},
                         "F_p": best.fitness.values[1], "on_front": False, "penalised_optimum": True})
        return rows

    def all_points(self, state: GAState) -> list[dict[str, float]]:
        """f1 and genes of every distinct feasible design evaluated (cache hits once)."""
        return [{"f1": r["f1"], **{g: r[g] for g in (*self.names, *self.measure_columns)}} for r in state.records
                if r["f1"] is not None and not r.get("cache_hit")]

    def mark_verified_front(self, rows: list[dict[str, Any]]) -> None:
        """``on_front_verified``: non-domination recomputed on the verified f1 among the verified rows."""
        ok = [r for r in rows if r.get("status_verified") == "ok"]
        keep = set(non_dominated([tuple(o.value({**r, "f1": float(r["f1_verified"])}) for o in self.objectives)
                                  for r in ok]))
        for j, r in enumerate(ok):
            r["on_front_verified"] = j in keep
        for r in rows:
            r.setdefault("on_front_verified", None)

    def verify_rows(self, rows: list[dict[str, Any]], state: GAState, evaluator: Callable, preset: str,
                    executor_cfg: ExecutorConfig | None = None) -> list[dict[str, Any]]:
        """Re-evaluate front rows (and the penalised optimum) at fidelity ``preset``, in place.

        Rows already verified at ``preset`` are kept; at most ``pareto.verify_max`` designs are
        verified, spread evenly along the front (sorted by f1) with both ends and the penalised
        optimum always included. F_p at ``preset`` uses the run's penalty terms
        (F_p = f1 + Σ_j C_j κ_j, :func:`dynamic_penalty`); ``on_front_verified`` is recomputed
        (:meth:`mark_verified_front`).

        Parameters
        ----------
        rows : list of dict
            :meth:`front_rows`, merged with the verified values already kept.
        state : GAState
            The run's state (its cache keys give the evaluation seeds).
        evaluator : callable
            Picklable ``evaluate(genes) -> EvalOutcome`` at fidelity ``preset``.
        preset : str
            Name of the verification preset, written to ``verified_preset``.
        executor_cfg : ExecutorConfig, optional
            Where to evaluate (default: the run's executor).

        Returns
        -------
        list of dict
            ``rows``, with ``verified_preset``, ``status_verified``, ``f1_verified``, ``F_p_verified``
            and ``on_front_verified``.
        """
        from whisker_opt.optimise.backend import make_executor
        from whisker_opt.optimise.evalcache import evaluation_seed

        todo = [j for j, r in enumerate(rows) if r.get("verified_preset") != preset]
        cap = self.cfg.pareto.verify_max
        if len(todo) > cap:
            must = [j for j in todo if rows[j]["penalised_optimum"]]
            todo = sorted(set(must) | set(spread([j for j in todo if j not in must], max(cap - len(must), 1))))
        if todo:
            genes = [{g: float(rows[j][g]) for g in self.names} for j in todo]
            seeds = [evaluation_seed(self.seed, state.cache.key(gs.values())) for gs in genes]
            logger.info("verifying %d front design(s) at preset %s", len(todo), preset)
            t0 = time.perf_counter()
            with make_executor(executor_cfg or self.cfg.executor, evaluator) as ex:
                outs = ex.map(genes, seeds)
            for j, gs, out in zip(todo, genes, outs):
                ok = out.ok
                rows[j].update(verified_preset=preset, status_verified=out.status,
                               f1_verified=float(out.f1) if ok else None,
                               F_p_verified=dynamic_penalty(float(out.f1), gs, self.terms)[1] if ok else None)
            logger.info("front verified at preset %s in %.1f s", preset, time.perf_counter() - t0)
        self.mark_verified_front(rows)
        return rows
