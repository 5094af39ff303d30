"""The best designs of a run: the one place they are chosen (docs/physics.md §6, "Best designs").

Every list of a run's best designs — the report's table, ``best_designs`` in ``best.json``,
``whisker-opt verify --top N``, the verification of ``run --verify``, ``whisker-opt robustness
RUN_DIR`` and ``whisker-opt view --rank N`` — comes from :func:`best_designs`, so they name the
same designs in the same order.

Distinct designs
    Two genomes x and y are distinct by d when their distance in normalised gene space,

        D(x, y) = max_i |x_i − y_i| / (hi_i − lo_i),

    (the max-norm, each gene scaled by its bound range ``optimiser.genes``) is at least
    d = ``optimiser.distinct_distance`` (default 0.02: 2 % of a gene's range, e.g. 0.07° of α,
    0.08 mm of t, 0.0038 MPa of Q_i), and D > 0 (a repeat of one genome is never a second design,
    also with d = 0). A GA's last generations crowd round its optimum, so its hall of fame (distinct
    only as exact genomes) would otherwise list near-copies of one design.

Selection
    Greedy over the feasible evaluations (status ``ok`` with an f1) in increasing F_p (ties by
    eval id): a design is taken when it is distinct from every design taken before, until ``n``
    are taken. The first is the run's best design; each later one is the best design at least d
    from all better ones. Failed evaluations are never listed.
"""

from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, Sequence

from whisker_opt.genes import GENE_NAMES

#: Keys of an entry of :func:`best_designs`, in the order ``best.json`` shows them.
ENTRY_KEYS = ("rank", "eval_id", "generation", "genes", "f1", "F_p", "f1_uncalibrated", "F_p_uncalibrated",
              "distance_to_better")


def gene_distance(a: Sequence[float], b: Sequence[float], bounds: Sequence[tuple[float, float]]) -> float:
    """D(a, b) = max_i |a_i − b_i| / (hi_i − lo_i): the max-norm distance in normalised gene space.

    Parameters
    ----------
    a, b : sequence of float
        Genomes in the run's gene order (``optimiser.genes.names()``).
    bounds : sequence of (lo, hi)
        The gene bounds (``optimiser.genes.bounds()``), hi > lo.

    Returns
    -------
    float
    """
    return max(abs(float(x) - float(y)) / (float(hi) - float(lo)) for x, y, (lo, hi) in zip(a, b, bounds))


def _number(v: Any) -> float | None:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def best_designs(records: Iterable[Mapping[str, Any]], bounds: Sequence[tuple[float, float]], n: int,
                 distance: float, calibration: float | None = None,
                 names: Sequence[str] = GENE_NAMES, objective: str = "f1") -> list[dict[str, Any]]:
    """The ``n`` best feasible designs of a run, pairwise distinct by ``distance`` (module docstring).

    Parameters
    ----------
    records : iterable of mapping
        Evaluation rows (``state.records`` or ``evaluations.csv`` read back): the genes by name,
        ``f1``, ``F_p``, ``status`` and ``eval_id``, ``generation``; numbers may be strings.
    bounds : sequence of (lo, hi)
        The gene bounds in ``names`` order.
    n : int
        Most designs returned (>= 1).
    distance : float
        d = ``optimiser.distinct_distance``, in [0, 1].
    calibration : float, optional
        The gauge factor ξ of the run's calibrated f1 and F_p: adds them divided by ξ
        (``f1_uncalibrated``, ``F_p_uncalibrated``); None leaves those None.
    names : sequence of str
        The genome (``optimiser.genes.names()``; default :data:`GENE_NAMES`).
    objective : str
        What the run minimises (:func:`whisker_opt.optimise.aggregate.objective_column`): an aggregate over
        variants such as ``f1_robust`` is added to each entry after ``f1`` (the nominal design's).

    Returns
    -------
    list of dict
        At most ``n`` entries (fewer when the run has fewer distinct feasible designs), best first,
        with the keys :data:`ENTRY_KEYS`: ``rank`` (1 = best), ``genes`` (dict), ``f1`` and ``F_p``
        (calibrated strain, as the run ranks them), and ``distance_to_better``, D to the nearest
        better-ranked entry (None for the first).

    Raises
    ------
    ValueError
        ``n`` < 1 or ``distance`` outside [0, 1] (naming the value and the range).
    """
    if int(n) < 1:
        raise ValueError(f"best_designs: n={n!r} outside the allowed range >= 1")
    if not 0.0 <= float(distance) <= 1.0:
        raise ValueError(f"best_designs: distance={distance!r} outside the allowed range [0, 1]")
    feasible = []
    for k, r in enumerate(records):
        if r.get("status", "ok") != "ok":
            continue
        f1, fp = _number(r.get("f1")), _number(r.get("F_p"))
        genome = [_number(r.get(g)) for g in names]
        if f1 is None or fp is None or None in genome:
            continue
        eid = _number(r.get("eval_id"))
        feasible.append((fp, eid if eid is not None else float(k), genome, f1, r))
    feasible.sort(key=lambda item: (item[0], item[1]))
    xi = float(calibration) if calibration else None
    chosen: list[dict[str, Any]] = []
    genomes: list[list[float]] = []
    for fp, _, genome, f1, r in feasible:
        if len(chosen) >= int(n):
            break
        gaps = [gene_distance(genome, g, bounds) for g in genomes]
        if gaps and (min(gaps) <= 0.0 or min(gaps) < float(distance)):
            continue
        generation = _number(r.get("generation"))
        eid = _number(r.get("eval_id"))
        chosen.append({
            "rank": len(chosen) + 1,
            "eval_id": int(eid) if eid is not None else None,
            "generation": int(generation) if generation is not None else None,
            "genes": dict(zip(names, genome)),
            "f1": f1,
            **({objective: _number(r.get(objective))} if objective != "f1" else {}),
            "F_p": fp,
            "f1_uncalibrated": f1 / xi if xi else None,
            "F_p_uncalibrated": fp / xi if xi else None,
            "distance_to_better": min(gaps) if gaps else None,
        })
        genomes.append(genome)
    return chosen


def run_best_designs(state, cfg, n: int | None = None) -> list[dict[str, Any]]:
    """:func:`best_designs` of a GA state with its optimiser config.

    Parameters
    ----------
    state : whisker_opt.optimise.ga.GAState
        Its ``records`` and, for the uncalibrated values, the gauge factor in ``extra["fidelity"]``.
    cfg : whisker_opt.config.optimiser.OptimiserConfig
        The gene bounds and ``distinct_distance``.
    n : int, optional
        Default ``ga.hall_of_fame``.

    Returns
    -------
    list of dict
    """
    from whisker_opt.optimise.aggregate import objective_column

    xi = ((state.extra or {}).get("fidelity") or {}).get("calibration")
    return best_designs(state.records, cfg.genes.bounds(), cfg.ga.hall_of_fame if n is None else n,
                        cfg.distinct_distance, xi, cfg.genes.names(), objective_column(cfg))


def describe_distance(distance: float) -> str:
    """``"pairwise >= 0.02 apart (largest gene difference / bound range)"``: what distinct means, in words."""
    return f"pairwise >= {float(distance):g} apart (largest gene difference / its bound range)"
