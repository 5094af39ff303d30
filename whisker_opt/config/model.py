"""Typed, validated configuration of whisker-opt runs (YAML -> pydantic models).

Every numeric field carries its range and unit; unknown keys are errors that name the
key (``extra="forbid"`` on :class:`whisker_opt.config.base.StrictModel`). Units: mm, N,
MPa, degrees for angles. Defaults reproduce shared/SPEC.md.

A YAML file has these top-level sections, all optional::

    design:     the whisker geometry and fibres (SPEC §2-3)
    material:   rubber law (SPEC §4)
    scene:      the simulated experiment (SPEC §5)
    fidelity:   preset name and optional overrides of mesh size / increments
    optimiser:  genes, penalties, GA, stopping, executor (SPEC §6), see whisker_opt.config.optimiser
    output:     where results go
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import Field, ValidationError, model_validator

from whisker_opt.config.base import StrictModel
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.experiment.fidelity import PRESET_NAMES


class ConfigError(ValueError):
    """A configuration file that cannot be used; the message names the key and the problem."""


class DesignConfig(StrictModel):
    """Whisker geometry (SPEC §2) and fibre winding (SPEC §3)."""

    SECTION = "design"
    RENAMED = {"alpha_deg": "alpha"}

    D: float = Field(18.0, gt=0, le=100, description="base outer diameter at x = 0 [mm], (0, 100]")
    L: float = Field(70.0, gt=0, le=500, description="intact whisker length [mm], (0, 500]")
    alpha: float = Field(2.862, ge=0, lt=45, description="cone half-angle α [deg], [0, 45)")
    c: float = Field(2.0, gt=0, le=50, description="cap thickness, chamber starts at x = c [mm], (0, 50]")
    l: float = Field(15.0, gt=0, le=200, description="x where the chamber ends [mm], (0, 200]")
    t: float = Field(3.0, gt=0, le=50, description="chamber wall thickness (radial) [mm], (0, 50]")
    x_ss: float = Field(6.0, ge=0, le=200, description="gauge position from the base [mm], [0, 200]")
    e: float = Field(2.0, gt=0, le=50, description="gauge grid length (axial) [mm], (0, 50]")
    fibre_radius_frac: float = Field(
        0.5, ge=0, le=1, description="fibre radius inside the wall: 0 = cavity, 1 = outer surface [-], [0, 1]"
    )
    fibre_pitch: float = Field(3.0, gt=0, le=100, description="helix pitch [mm], (0, 100]")
    fibre_diameter: float = Field(0.38, gt=0, le=5, description="fibre diameter [mm], (0, 5]")
    n_fibres: int = Field(2, ge=0, le=8, description="number of helices, evenly rotated [-], 0..8")
    fibre_E: float = Field(31067.0, gt=0, le=1e6, description="fibre Young's modulus [MPa], (0, 1e6]")
    fibre_nu: float = Field(0.36, ge=0, lt=0.5, description="fibre Poisson ratio [-], [0, 0.5)")


class MaterialConfig(StrictModel):
    """Incompressible neo-Hookean rubber, W = C10 (I1bar - 3) + (1/D1)(J - 1)^2 (SPEC §4)."""

    C10: float = Field(0.14, gt=0, le=100, description="neo-Hookean C10 = mu/2 [MPa], (0, 100]")
    D1: float = Field(0.0, ge=0, le=100, description="compressibility D1 = 2/K; 0 = incompressible [1/MPa], [0, 100]")


class SceneConfig(StrictModel):
    """The simulated experiment: pressurise, then deflect, read the gauge (SPEC §5)."""

    SECTION = "scene"
    RENAMED = {"Q": "Q_i", "delta_max": "deflection"}

    Q_i: float = Field(
        0.0, ge=0, le=1.0,
        description="initial (intact) chamber pressure Q_i of `simulate` and `compensate`; the pressure of the "
        "single scene when `pair` is false [MPa], [0, 1]",
    )
    trim: float = Field(0.0, ge=0, le=100, description="trimmed length for `simulate` [mm], [0, 100]")
    contact_ratio: float = Field(1.0, gt=0, le=1, description="contact position a, x = a L_Q [-], (0, 1]")
    contact_at: Literal["pressurised", "reference"] = Field(
        "pressurised",
        description="'pressurised': the contact at x = a L_Q (SPEC §5); 'reference': at x = a L, the pusher "
        "staying where it stood before the whisker extended",
    )
    deflection: float = Field(5.0, gt=0, le=30, description="largest tip deflection δ_max [mm], (0, 30]")
    delta_step: float = Field(0.01, gt=0, le=1, description="deflection sampling of the curve [mm], (0, 1]")
    calibration: float = Field(3.9, gt=0, le=100, description="gauge calibration factor xi [-], (0, 100]")
    band_width: float = Field(
        1.0, gt=0, le=10, description="axial width of the contact band of nodes [mm], (0, 10]"
    )
    gauge_variant: Literal["line", "centroid"] = Field(
        "line", description="'line': mean log strain of the gauge line; 'centroid': thesis' element-centroid log strain"
    )
    pair: bool = Field(
        True, description="`simulate` runs the intact (Q) / trimmed (vented) pair instead of one scene"
    )


class FidelityConfig(StrictModel):
    """Accuracy/speed preset, optionally overridden field by field."""

    preset: Literal[PRESET_NAMES] = Field("default", description="named preset (see whisker_opt.experiment.fidelity)")
    h_wall: float | None = Field(None, gt=0, le=10, description="override: element size in the chamber wall [mm]")
    h_body: float | None = Field(None, gt=0, le=50, description="override: element size in the solid body [mm]")
    n_deflection_steps: int | None = Field(
        None, ge=1, le=1000, description="override: solved deflection increments [-], 1..1000"
    )
    n_pressure_steps: int | None = Field(
        None, ge=1, le=1000, description="override: solved pressure increments [-], 1..1000"
    )
    mesh_method: Literal["auto", "fresh", "template", "swept"] = Field(
        "auto",
        description="'template' maps a stored template mesh; 'swept' builds a structured swept mesh; "
        "'fresh' re-tetrahedralises with fTetWild; 'auto' tries them in that order",
    )


class OutputConfig(StrictModel):
    """Where results are written."""

    results_dir: Path = Field(Path("results"), description="parent folder of run directories")
    name: str | None = Field(None, min_length=1, max_length=100, description="run name (default: config stem + time)")


class WhiskerConfig(StrictModel):
    """A whole run file. ``optimiser`` is validated by :mod:`whisker_opt.config.optimiser` when present."""

    design: DesignConfig = DesignConfig()
    material: MaterialConfig = MaterialConfig()
    scene: SceneConfig = SceneConfig()
    fidelity: FidelityConfig = FidelityConfig()
    optimiser: OptimiserConfig | None = Field(None, description="GA section, see whisker_opt.config.optimiser")
    output: OutputConfig = OutputConfig()
    seed: int = Field(0, ge=0, le=2**32 - 1, description="master random seed [-]")


def format_validation_error(err: ValidationError, source: str = "config") -> str:
    """One line per problem: ``source: key.path: message (got value)``."""
    lines = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "<root>"
        got = e.get("input")
        got_s = "" if isinstance(got, dict) else f" (got {got!r})"
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
        lines.append(f"{source}: {loc}: {msg}{got_s}")
    return "\n".join(lines)


def load_config(path: str | Path) -> WhiskerConfig:
    """Read and validate a YAML run file.

    Raises
    ------
    ConfigError
        Missing file, YAML syntax error or a validation problem; the message names the key.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such config file")
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: YAML syntax error: {exc}".replace("\n", " ")) from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: top level must be a mapping of sections, got {type(data).__name__}")
    try:
        return WhiskerConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, str(path))) from None


def dump_config(cfg: WhiskerConfig) -> str:
    """The fully resolved config as YAML (defaults filled in), for storing beside results."""
    return yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)
