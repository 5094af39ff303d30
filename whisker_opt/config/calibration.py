"""The ``calibration:`` section of a run file: which model parameters ``whisker-opt calibrate`` fits, to what.

A calibration run file is an ordinary run file (design, material, scene, fidelity, ...) plus this
section (docs/calibration.md)::

    calibration:
      source: "bench measurements of prototype P3, 2026-03"
      model: fe
      parameters:
        - {path: material.C10, lower: 0.05, upper: 0.5}
        - {path: design.fibre_radius_frac, lower: 0.05, upper: 0.95, start: 0.5}
      measurements:
        - {file: data/p3_restore.csv, kind: restore}
        - {file: data/p3_ratios.csv, kind: response, weight: 2}
      holdout: [reverse_pressurise]

A parameter is any real-valued key of the run file, named by its dotted path; its bounds and start
are in the unit of that key (docs/config.md). Whether the path names such a key, and whether the
bounds lie in its allowed range, is checked when the section is used
(:func:`whisker_opt.calibration.parameters.resolve_parameters`), since that needs the whole run-file
model. Measurement files are read relative to the run file (:mod:`whisker_opt.calibration.measurements`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator, model_validator

from whisker_opt.config.base import StrictModel

#: A dotted run-file key: two or more names joined by dots.
PATH_PATTERN = r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)+$"
#: Unit of a bound or start value: that of the key the parameter names.
KEY_UNIT = {"unit": "unit of the key"}


class CalibrationParameter(StrictModel):
    """A model parameter to fit: a real-valued run-file key, its bounds and its start value."""

    path: str = Field(pattern=PATH_PATTERN, min_length=3, max_length=200,
                      description="dotted run-file key of a real number, e.g. material.C10, scene.calibration, "
                      "design.fibre_radius_frac")
    lower: float = Field(ge=-1e12, le=1e12, description="lower bound of the fitted value",
                         json_schema_extra=KEY_UNIT)
    upper: float = Field(ge=-1e12, le=1e12, description="upper bound of the fitted value",
                         json_schema_extra=KEY_UNIT)
    start: float | None = Field(None, ge=-1e12, le=1e12, description="start value of the fit; null = the value "
                                "the run file gives the key", json_schema_extra=KEY_UNIT)

    @field_validator("path", mode="before")
    @classmethod
    def _dotted(cls, v):
        if isinstance(v, str) and not re.fullmatch(PATH_PATTERN, v):
            raise ValueError(f"{v!r} is not the dotted path of a key in a section (section.key, e.g. material.C10 or "
                             "scene.calibration); a top-level key such as seed is not a model parameter")
        return v

    @model_validator(mode="after")
    def _ordered(self) -> "CalibrationParameter":
        if not self.lower < self.upper:
            raise ValueError(f"bounds inverted or empty: lower={self.lower!r} must be < upper={self.upper!r}")
        if self.start is not None and not self.lower <= self.start <= self.upper:
            raise ValueError(f"start={self.start!r} must lie in [lower, upper] = [{self.lower!r}, {self.upper!r}]")
        return self


class MeasurementFile(StrictModel):
    """One CSV file of observations of one kind (docs/calibration.md gives the columns of each kind)."""

    file: Path = Field(description="CSV file of observations, relative to the run file")
    kind: Literal["extension", "response", "restore"] = Field(
        description="'extension': Δl(Q); 'response': gauge readings ε(δ) (or their ratio to a reference pressure); "
        "'restore': the pressure at which one whisker's reading matches another's")
    weight: float = Field(1.0, gt=0, le=1e6, description="factor on the file's residuals (after dividing each by "
                          "its stated uncertainty)", json_schema_extra={"unit": "-"})


class CalibrationConfig(StrictModel):
    """What `whisker-opt calibrate` fits: model parameters, measurement files, held-out observations
    (docs/calibration.md)."""

    SECTION = "calibration"

    source: str = Field("", max_length=500, description="where the measurements come from; written into "
                        "calibration.json and the header of calibrated.yaml (required by `whisker-opt calibrate`)")
    model: Literal["fe", "beam"] = Field(
        "fe", description="'fe': the finite-element scenes at the run file's fidelity; 'beam': the beam model of "
        "docs/physics.md §8 (fast; it sees only the geometry, scene.calibration and material.C10)")
    parameters: tuple[CalibrationParameter, ...] = Field((), max_length=20, description="the parameters to fit "
                                                         "(at least one for `whisker-opt calibrate`)")
    measurements: tuple[MeasurementFile, ...] = Field((), max_length=50, description="the measurement files (at "
                                                      "least one for `whisker-opt calibrate`)")
    holdout: tuple[str, ...] = Field((), max_length=1000, description="names of observations left out of the fit "
                                     "and predicted by the fitted model (validation)")
    restore_Q_max: float = Field(0.3, gt=0, le=1, description="a restore observation's matching pressure is "
                                 "searched in [0, this]", json_schema_extra={"unit": "MPa"})
    restore_scan: int = Field(7, ge=2, le=100, description="pressures sampled evenly on [0, restore_Q_max] to "
                              "bracket a restore observation's match before Brent's method refines it",
                              json_schema_extra={"unit": "-"})
    restore_xtol: float = Field(1e-5, gt=0, le=0.01, description="tolerance of the matching pressure",
                                json_schema_extra={"unit": "MPa"})
    max_evaluations: int = Field(40, ge=1, le=100_000, description="largest number of model evaluations of the "
                                 "least-squares fit (those of its finite-difference Jacobian included); a fit that reaches it before it "
                                 "converges is reported NOT CALIBRATED (exit status 4)",
                                 json_schema_extra={"unit": "-"})
    diff_step: float = Field(0.02, gt=0, le=0.5, description="step of the finite-difference Jacobian, as a "
                             "fraction of each parameter's range upper − lower", json_schema_extra={"unit": "-"})
    tolerance: float = Field(1e-3, gt=0, le=0.1, description="relative tolerance of the fit on the cost and on the "
                             "parameters (least_squares ftol and xtol)", json_schema_extra={"unit": "-"})

    @field_validator("parameters", "measurements", "holdout", mode="before")
    @classmethod
    def _none_is_empty(cls, v):
        return () if v is None else v  # a key left empty in YAML (as `whisker-opt init` writes an empty list)

    @field_validator("holdout")
    @classmethod
    def _distinct(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        dup = sorted({n for n in v if v.count(n) > 1})
        if dup:
            raise ValueError(f"each held-out name once; repeated: {dup}")
        return v

    @field_validator("parameters")
    @classmethod
    def _distinct_paths(cls, v: tuple[CalibrationParameter, ...]) -> tuple[CalibrationParameter, ...]:
        paths = [p.path for p in v]
        dup = sorted({p for p in paths if paths.count(p) > 1})
        if dup:
            raise ValueError(f"each parameter once; repeated: {dup}")
        return v
