"""Typed configuration of tolerance studies (the ``robustness:`` section of a run file, docs/physics.md §10).

A moulded whisker is never exactly the designed one. The section states the fabrication
tolerances (half-widths "± h") of six parameters, how the deviations are distributed and
which estimator propagates them (:mod:`whisker_opt.optimise.robust`); ``whisker-opt
robustness`` and the robust objective of the GA (``optimiser.robust``) read it.

Example::

    robustness:
      tolerances: {alpha: 0.2, l: 0.3, t: 0.1, fibre_radius: 0.2, C10: 10, calibration: 0.1}
      distribution: uniform
      method: sample
      sample: {n: 32, design: lhs}
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from whisker_opt.config.base import StrictModel
from whisker_opt.genes import GEOMETRY_GENES

#: The toleranced parameters, in the order of a deviation vector: the geometry genes, then
#: the fibre radius, the rubber's C10 and the gauge calibration.
TOLERANCE_KEYS: tuple[str, ...] = (*GEOMETRY_GENES, "fibre_radius", "C10", "calibration")


class TolerancesConfig(StrictModel):
    """Half-widths h of the fabrication tolerances: a parameter lies within its nominal value ± h."""

    alpha: float = Field(0.2, ge=0, le=2, description="cone half-angle α ± this", json_schema_extra={"unit": "deg"})
    l: float = Field(0.3, ge=0, le=3, description="chamber end l ± this", json_schema_extra={"unit": "mm"})  # noqa: E741
    t: float = Field(0.1, ge=0, le=1, description="wall thickness t ± this", json_schema_extra={"unit": "mm"})
    fibre_radius: float = Field(
        0.2, ge=0, le=2, description="fibre helix radius r_f ± this; applied as design.fibre_radius_frac ± this / t "
        "(t the nominal wall thickness), the fraction clipped to [0, 1]", json_schema_extra={"unit": "mm"})
    C10: float = Field(10.0, ge=0, lt=100, description="rubber constant material.C10 ± this percentage of it",
                       json_schema_extra={"unit": "%"})
    calibration: float = Field(0.1, ge=0, le=2, description="gauge calibration factor scene.calibration ± this",
                               json_schema_extra={"unit": "-"})

    def half_widths(self) -> tuple[float, ...]:
        """The half-widths in :data:`TOLERANCE_KEYS` order (C10 in per cent)."""
        return tuple(float(getattr(self, k)) for k in TOLERANCE_KEYS)


class SampleConfig(StrictModel):
    """The seeded sample of estimator (a)."""

    n: int = Field(32, ge=2, le=100_000, description="number of deviated designs evaluated; the sensitivities "
                   "(a linear fit) need at least the number of non-zero tolerances + 1, fewer is refused",
                   json_schema_extra={"unit": "-"})
    design: Literal["lhs", "monte_carlo"] = Field("lhs", description="Latin hypercube or plain Monte Carlo")
    seed: int | None = Field(None, ge=0, le=2**32 - 1, description="seed of the sample; null = the run file's "
                             "top-level seed (the same sample for every design)", json_schema_extra={"unit": "-"})


class RobustnessConfig(StrictModel):
    """Fabrication tolerances and how they are propagated to f1 and the recovery rate."""

    SECTION = "robustness"

    tolerances: TolerancesConfig = TolerancesConfig()
    distribution: Literal["uniform", "normal"] = Field(
        "uniform", description="independent deviations: 'uniform' on ± h (σ = h/√3) or 'normal' with ± h = "
        "normal_sigmas standard deviations")
    normal_sigmas: float = Field(3.0, gt=0, le=10, description="a tolerance is this many standard deviations of the "
                                 "normal distribution", json_schema_extra={"unit": "-"})
    method: Literal["expansion", "sample", "both"] = Field(
        "sample", description="estimator of `whisker-opt robustness`: the seeded sample (the default: f1 is not "
        "smooth near a perfect match, docs/physics.md §10), the first-order expansion (2n+1 evaluations plus the "
        "worst corners), or both")
    fd_step: float = Field(1.0, gt=0, le=1, description="central-difference step of the expansion, as a fraction of "
                           "each tolerance", json_schema_extra={"unit": "-"})
    sample: SampleConfig = SampleConfig()
    recovery_scalar: Literal["mean", "last", "gap"] = Field(
        "mean", description="how a curve becomes the scalar of the recovery rate (docs/physics.md §7)")
    top: int = Field(3, ge=1, le=1000, description="best feasible designs of a run studied (distinct by optimiser.distinct_distance)",
                     json_schema_extra={"unit": "-"})

    def sample_seed(self, top_level_seed: int) -> int:
        """``sample.seed`` when set, else the run file's top-level seed."""
        return int(self.sample.seed if self.sample.seed is not None else top_level_seed)


class RobustObjectiveConfig(StrictModel):
    """The GA minimises ``f1_robust`` = mean + k·std of f1 over the tolerances of the ``robustness`` section instead
    of f1 (which stays the nominal design's)."""

    k: float = Field(1.0, ge=0, le=10, description="weight of the standard deviation in mean + k·std",
                     json_schema_extra={"unit": "-"})
    method: Literal["expansion", "sample"] = Field(
        "expansion", description="estimator of mean and std: first-order expansion (2n+1 evaluations per design) or "
        "the seeded sample of robustness.sample (n + 1)")
