"""The result of evaluating one design: the contract between an evaluator and the GA.

An evaluator is any picklable callable ``evaluate(genes: dict[str, float]) -> EvalOutcome``
(:mod:`whisker_opt.optimise.ga`). It reports the raw objective
f1 = mean |ε_i − ε_c| when it succeeds, or a failure status with a human-readable
reason. The GA, not the evaluator, turns an outcome into the penalised fitness F_p
(:mod:`whisker_opt.optimise.penalty`).

Conventions an evaluator may follow for the optional dictionaries:

``timings``
    Seconds spent per stage, e.g. ``{"mesh": 1.2, "solve": 30.4}``. The executors add
    ``"eval_s"`` (wall time of the whole call, measured around the evaluator).
``extra``
    Anything small and picklable. Keys the GA understands:

    - ``"violation"`` (float >= 0): for a failed design, how far it lies outside the
      feasible region (e.g. how much material is missing, in mm). It grades the failure
      penalty so the search is steered back towards feasible designs.
    - ``"delta"``, ``"eps_i"``, ``"eps_c"`` (sequences): the response curves; when the
      best design carries them, the runner writes ``best_curves.csv`` and its plot.
    - ``"traceback"``: set by the executors when the evaluator raised.
    - ``"genes"`` (dict): the genome evaluated, by gene name; with the numbers the scenes gave
      (:class:`whisker_opt.optimise.evaluator.SceneEvaluator`), what the measures read
      (:mod:`whisker_opt.experiment.measures`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

#: Every status an outcome may carry; anything but ``"ok"`` is a failure.
STATUSES: tuple[str, ...] = ("ok", "invalid_geometry", "mesh_failed", "solve_failed", "timeout", "error")

#: The failure statuses, ordered from "closest to a usable design" to "worst".
FAILURE_STATUSES: tuple[str, ...] = ("timeout", "solve_failed", "mesh_failed", "invalid_geometry", "error")


@dataclass(frozen=True)
class EvalOutcome:
    """Result of one design evaluation (picklable, immutable).

    Parameters
    ----------
    status : str
        One of :data:`STATUSES`.
    f1 : float or None
        Objective 1, mean |ε_i(δ) − ε_c(δ)| over the deflection samples [-];
        required (finite, >= 0) when ``status == "ok"``, ``None`` otherwise.
    reason : str
        Why the evaluation failed (empty on success).
    timings : dict
        Seconds per stage; see the module docstring.
    extra : dict
        Additional small picklable data; see the module docstring.
    measures : dict
        Named numbers the evaluator computed beyond those the measures read from ``f1`` and ``extra``
        (:mod:`whisker_opt.experiment.measures`): the aggregates over variants of an evaluation
        (:mod:`whisker_opt.optimise.aggregate`), e.g. ``f1_robust``. Empty for a single evaluation.
    """

    status: str
    f1: float | None = None
    reason: str = ""
    timings: dict[str, float] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    measures: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"EvalOutcome.status: {self.status!r} is not one of {STATUSES}")

    @property
    def ok(self) -> bool:
        """True for a successful evaluation with a usable (finite, non-negative) f1."""
        return (
            self.status == "ok"
            and self.f1 is not None
            and isinstance(self.f1, (int, float))
            and math.isfinite(self.f1)
            and self.f1 >= 0.0
        )

    @classmethod
    def success(cls, f1: float, timings: dict | None = None, extra: dict | None = None) -> "EvalOutcome":
        """A successful outcome with objective ``f1``."""
        return cls("ok", float(f1), "", dict(timings or {}), dict(extra or {}))

    @classmethod
    def failure(
        cls, status: str, reason: str, timings: dict | None = None, extra: dict | None = None
    ) -> "EvalOutcome":
        """A failed outcome with a status from :data:`FAILURE_STATUSES` and a reason."""
        if status not in FAILURE_STATUSES:
            raise ValueError(f"EvalOutcome.failure: status {status!r} is not one of {FAILURE_STATUSES}")
        return cls(status, None, str(reason), dict(timings or {}), dict(extra or {}))

    def with_timing(self, **seconds: float) -> "EvalOutcome":
        """A copy with extra entries in ``timings``."""
        return EvalOutcome(self.status, self.f1, self.reason, {**self.timings, **seconds}, dict(self.extra),
                           dict(self.measures))

    def validated(self) -> "EvalOutcome":
        """This outcome, or an ``"error"`` outcome when it claims success without a usable f1.

        A misbehaving evaluator (NaN, negative or missing f1 with status ``"ok"``) must not
        crash the run nor be ranked; it becomes a recorded failure.
        """
        if self.status != "ok" or self.ok:
            return self
        return EvalOutcome(
            "error", None, f"evaluator returned status 'ok' with unusable f1={self.f1!r}",
            dict(self.timings), dict(self.extra),
        )
