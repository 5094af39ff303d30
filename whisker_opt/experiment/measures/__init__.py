"""The named measures of one evaluation: numbers read from its outcome by name, one module each.

A measure is a small object with a name, a unit, a description and a function from a successful
:class:`whisker_opt.experiment.outcome.EvalOutcome` (as :class:`whisker_opt.optimise.evaluator.SceneEvaluator`
fills it) to a float. The GA's penalties, the NSGA-II objectives, the robustness study and ``verify`` read
them from :data:`MEASURES` by name.

Each measure is one module of this package (``f1``, ``sensitivity``, ``delta_l``, ``von_mises_max``; the
module docstring says what it reads), found by :func:`_registry` and ordered by its ``ORDER``. The module has
a ``NAME``, an ``ORDER``, a ``UNIT`` (``"-"`` for a pure number), a one-line ``DESCRIPTION``, a pure function
``read(outcome) -> float`` and, where they differ from the defaults, ``CALIBRATED = True`` (proportional to
the gauge factor ξ) and ``WORSE = -1.0`` (smaller is worse). A module that stands for a family of measures
has ``family()`` instead, the fields of each (``gauge_readings``: ``eps_i_<variant>`` and ``eps_c_<variant>``
of every registered gauge reading). A measure module imports nothing of this package's face.

What a measure may read: the outcome's ``f1``, and its ``extra`` as the evaluator fills it
(:meth:`whisker_opt.optimise.evaluator.SceneEvaluator.__call__`): ``genes`` (the genome evaluated, by gene
name, Q_i among them), ``delta_l``, ``eps_i_max``, ``eps_c_max``, ``deflection``, ``readings``
(``[variant][scene]``), ``von_mises_max`` (``[scene]``) and ``iterations``. A measure is a function of those
two scenes, intact at Q_i and trimmed, vented: the recovery rate also needs the trimmed whisker left at Q_i,
a third scene the evaluation does not solve, so it stays with the studies that solve it
(:mod:`whisker_opt.robustness`, :mod:`whisker_opt.analysis.compensation`).

Adding a measure: one module in ``whisker_opt/experiment/measures/`` (and a test of its value against an
outcome).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Callable, Mapping

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


def _measures_of(module) -> tuple[Measure, ...]:
    """The measures a module of this package declares (one, or its ``family()``)."""
    if hasattr(module, "family"):
        return tuple(Measure(**fields) for fields in module.family())
    return (Measure(module.NAME, module.UNIT, module.DESCRIPTION, module.read,
                    getattr(module, "CALIBRATED", False), getattr(module, "WORSE", 1.0)),)


def _registry() -> dict[str, Measure]:
    """Every measure of every module of this package, the modules in the order of their ``ORDER``."""
    from whisker_opt.experiment.registry import discover

    measures = [x for m in discover(__name__) for x in _measures_of(m)]
    names = [x.name for x in measures]
    if len(set(names)) != len(names):
        raise ValueError(f"measures: a name registered twice: {sorted({n for n in names if names.count(n) > 1})}")
    return {x.name: x for x in measures}


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
