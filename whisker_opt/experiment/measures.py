"""The named measures of one evaluation: numbers read from its outcome by name.

A measure is a small object with a name, a unit, a description and a function from a successful
:class:`whisker_opt.experiment.outcome.EvalOutcome` (as :class:`whisker_opt.optimise.evaluator.SceneEvaluator`
fills it) to a float. The GA's penalties, the NSGA-II objectives, the robustness study and ``verify`` read
them from :data:`MEASURES` by name. The measures:

``f1``
    The compensation error mean_k |ε_i(δ_k) − ε_c(δ_k)| (:mod:`whisker_opt.experiment.objective`): ``outcome.f1``.
``sensitivity``
    S = ε_c(δ_max) / δ_max [1/mm]: the gauge reading of the trimmed, vented scene (the run's
    ``scene.gauge_variant``, relative to contact onset, times ξ) at the largest deflection δ_max, per
    millimetre of that deflection of the contact: the secant slope of the compensated response through
    the onset, ``extra["eps_c_max"] / extra["deflection"]``.
``delta_l``
    Δl [mm], the axial extension of the intact whisker's tip after pressurisation to Q_i (the mean
    x-displacement of the tip face's nodes): ``extra["delta_l"]``.
``von_mises_max``
    The largest nodal von Mises stress [MPa] of the two deflected states (intact at Q_i and trimmed,
    vented, both at δ_max; :func:`whisker_opt.experiment.scene.peak_von_mises`):
    max of ``extra["von_mises_max"]``.
``eps_i_<variant>``, ``eps_c_<variant>``
    For every gauge reading of :data:`whisker_opt.experiment.gauge_variants.GAUGE_VARIANTS`, the reading of the
    intact (i) or the trimmed (c) scene at δ_max: ``extra["readings"][variant]["intact" | "trimmed"]``.

Adding a measure: one entry of :func:`_registry` (and a test of its value against the outcome).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Callable, Mapping

from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS
from whisker_opt.experiment.outcome import EvalOutcome


@dataclass(frozen=True)
class Measure:
    """One named number of an evaluation.

    Parameters
    ----------
    name : str
        Its name: a column of ``evaluations.csv`` and an objective name of NSGA-II.
    unit : str
        ``"-"`` for a pure number.
    description : str
        One line: what it is.
    read : callable
        ``read(outcome) -> float`` of a successful outcome.
    calibrated : bool
        Proportional to the gauge factor ξ (a gauge reading or a number built from readings, docs/physics.md
        §4): a design whose only deviation is ξ has this measure times ξ'/ξ without another solve.
    worse : float
        +1 where a larger value is worse, −1 where a smaller one is (the ``worst`` reduction over variants,
        :mod:`whisker_opt.optimise.aggregate`).
    """

    name: str
    unit: str
    description: str
    read: Callable[[EvalOutcome], float]
    calibrated: bool = False
    worse: float = 1.0

    def __call__(self, outcome: EvalOutcome) -> float:
        """The measure of a successful ``outcome``.

        Raises
        ------
        ValueError
            The outcome failed, or it lacks what the measure reads (one line).
        """
        if not outcome.ok:
            raise ValueError(f"measure {self.name}: the evaluation failed ({outcome.status}); it has no {self.name}")
        try:
            return float(self.read(outcome))
        except (KeyError, TypeError) as exc:
            raise ValueError(f"measure {self.name}: the outcome holds no {exc} (an evaluation by another "
                             f"evaluator?)") from None


#: The letter of each scene of an evaluation in the names of its readings (i: intact, c: compensated).
SCENE_LETTER: dict[str, str] = {"intact": "i", "trimmed": "c"}


def _sensitivity(o: EvalOutcome) -> float:
    return o.extra["eps_c_max"] / o.extra["deflection"]


def _peak(o: EvalOutcome) -> float:
    return max(o.extra["von_mises_max"].values())


def _reading(variant: str, scene: str) -> Callable[[EvalOutcome], float]:
    def read(o: EvalOutcome) -> float:
        return o.extra["readings"][variant][scene]
    return read


def _registry() -> dict[str, Measure]:
    fixed = (
        Measure("f1", "-", "compensation error mean |eps_i - eps_c| over the deflection samples", lambda o: o.f1,
                calibrated=True),
        Measure("sensitivity", "1/mm", "gauge reading of the trimmed, vented scene at the largest deflection per "
                "mm of that deflection, eps_c(delta_max) / delta_max", _sensitivity, calibrated=True, worse=-1.0),
        Measure("delta_l", "mm", "axial tip extension of the intact whisker after pressurisation to Q_i",
                lambda o: o.extra["delta_l"]),
        Measure("von_mises_max", "MPa", "largest nodal von Mises stress of the intact and the trimmed scene at "
                "the largest deflection", _peak),
    )
    readings = tuple(
        Measure(f"eps_{SCENE_LETTER[s]}_{v}", "-", f"{v} gauge reading of the {s} scene at the largest deflection: {doc}",
                _reading(v, s), calibrated=True)
        for v, doc in GAUGE_VARIANTS.items() for s in SCENE_LETTER)
    return {m.name: m for m in (*fixed, *readings)}


#: Every measure by name (read-only).
MEASURES: Mapping[str, Measure] = MappingProxyType(_registry())
#: The measure names, in registry order.
MEASURE_NAMES: tuple[str, ...] = tuple(MEASURES)


def measure(name: str) -> Measure:
    """The measure called ``name``.

    Raises
    ------
    ValueError
        One line naming the unknown name and the allowed ones.
    """
    if name not in MEASURES:
        raise ValueError(f"measure {name!r} is not one of {', '.join(MEASURE_NAMES)}")
    return MEASURES[name]


def measure_values(outcome: EvalOutcome, names) -> dict[str, float | None]:
    """``{name: value}`` of the measures ``names`` of ``outcome`` (None for a failed one; NaN where the
    outcome lacks what a measure reads).

    A name the outcome holds in its ``measures`` (an aggregate over variants such as ``f1_robust``,
    :mod:`whisker_opt.optimise.aggregate`) is read from there; any other must be a registered measure.
    """
    out: dict[str, float | None] = {}
    for n in names:
        if n in outcome.measures:
            out[n] = float(outcome.measures[n]) if outcome.ok else None
            continue
        m = measure(n)
        if not outcome.ok:
            out[n] = None
            continue
        try:
            out[n] = m(outcome)
        except ValueError:
            out[n] = math.nan
    return out
