"""Fitted model parameters: real-valued run-file keys named by their dotted paths.

Any key of :class:`whisker_opt.config.model.WhiskerConfig` whose type is a real number can be fitted
(``material.C10``, ``scene.calibration``, ``design.fibre_radius_frac``, ``design.fibre_E``, and any key a
later model adds), so a new model knob is calibrated without code here. A parameter vector becomes a
run file by setting those keys over the run file's own content and validating the result, exactly as
``--set KEY=VALUE`` does (:func:`whisker_opt.config.model.apply_settings`), but with the numbers
themselves rather than their text.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from pydantic import ValidationError

from whisker_opt.config.calibration import CalibrationConfig
from whisker_opt.config.fields import field_range, field_unit, strip_optional
from whisker_opt.config.messages import resolve
from whisker_opt.config.model import ConfigError, WhiskerConfig, format_validation_error, with_key


logger = logging.getLogger(__name__)

#: Most decades the bounds of a positive parameter may span (upper/lower <= 10**this); a wider span is refused.
MAX_DECADES = 6
#: Decades above which the span is warned about.
WARN_DECADES = 3


@dataclass(frozen=True)
class ModelParameter:
    """One fitted parameter.

    Attributes
    ----------
    path : str
        Dotted run-file key, e.g. ``material.C10``.
    lower, upper, start : float
        Bounds and start value, in the key's unit.
    unit : str
        The key's unit (docs/config.md).
    description : str
        The key's description.
    """

    path: str
    lower: float
    upper: float
    start: float
    unit: str
    description: str


def with_values(data: dict, values: dict[str, float]) -> dict:
    """A copy of the run file ``data`` with each dotted key of ``values`` set (sections created as needed).

    Raises
    ------
    ConfigError
        A key below a value that is not a section.
    """
    out = dict(data)
    for path, value in values.items():
        out = with_key(out, path.split("."), value, path)
    return out


def _key_value(data: dict, path: str, cfg: WhiskerConfig) -> Any:
    """The value a (validated) config gives a dotted key."""
    node: Any = cfg
    for part in path.split("."):
        node = getattr(node, part) if node is not None else None
    return node


def resolve_parameters(section: CalibrationConfig, data: dict, source: str) -> tuple[ModelParameter, ...]:
    """The section's parameters, each checked against the key it names.

    Parameters
    ----------
    section : CalibrationConfig
    data : dict
        The run file's content (what :func:`whisker_opt.config.model.load_config` validated).
    source : str
        The run file's name, for messages.

    Returns
    -------
    tuple of ModelParameter

    Raises
    ------
    ConfigError
        A path that names no key, a section, a key that is not a real number, a key of the
        ``calibration`` section itself, or bounds (or a start) outside the key's allowed range; one line
        naming ``calibration.parameters[i]`` and the problem.
    """
    base = WhiskerConfig.model_validate(data)
    out = []
    for i, p in enumerate(section.parameters):
        where = f"{source}: calibration.parameters[{i}]"
        parts = p.path.split(".")
        if parts[0] == "calibration":
            raise ConfigError(f"{where}.path: {p.path!r}: the calibration section's own keys cannot be fitted")
        cls, info = resolve(WhiskerConfig, parts)
        if info is None or cls is not None:
            what = "a section, not a key" if cls is not None else "no key of a run file (see docs/config.md)"
            raise ConfigError(f"{where}.path: {p.path!r} is {what}")
        tp, _ = strip_optional(info.annotation)
        if tp is not float:
            raise ConfigError(f"{where}.path: {p.path!r} is not a real-valued key (its type is "
                              f"{getattr(tp, '__name__', tp)}); only real numbers can be fitted")
        unit = field_unit(info)
        rng = field_range(info.annotation, info)
        for name in ("lower", "upper", "start"):
            value = getattr(p, name)
            if value is None:
                continue
            try:
                WhiskerConfig.model_validate(with_values(data, {p.path: float(value)}))
            except ValidationError as exc:
                if any(tuple(e["loc"]) == tuple(parts) for e in exc.errors()):  # the key's own range
                    raise ConfigError(f"{where}.{name}: {value!r} is outside the allowed range {rng} ({unit}) of "
                                      f"{p.path}") from None
                why = format_validation_error(exc, "").splitlines()[0].removeprefix(": ")  # a check of the whole file
                raise ConfigError(f"{where}.{name}: {p.path} = {value!r} makes the run file impossible: {why}") from None
            except ConfigError as exc:  # a key below a value that is not a section
                raise ConfigError(f"{where}.path: {exc}") from None
        start = p.start if p.start is not None else _key_value(data, p.path, base)
        if start is None or not p.lower <= float(start) <= p.upper:
            raise ConfigError(f"{where}.start: the run file gives {p.path} = {start!r}, outside [lower, upper] = "
                              f"[{p.lower!r}, {p.upper!r}]; give a start or widen the bounds")
        _check_span(where, p.path, float(p.lower), float(p.upper), float(start), unit, section.diff_step)
        out.append(ModelParameter(p.path, float(p.lower), float(p.upper), float(start), unit,
                                  info.description or ""))
    return tuple(out)


def _check_span(where: str, path: str, lower: float, upper: float, start: float, unit: str,
                diff_step: float) -> None:
    """Refuse bounds of a positive parameter that span more than :data:`MAX_DECADES` decades; warn above
    :data:`WARN_DECADES`, or when the Jacobian's step exceeds the start value.

    The fit steps each parameter by ``diff_step * (upper - lower)`` on a linear scale: bounds such as
    [1e-12, 100] for a value near 0.1 make that step twenty times the value itself, and the fit's
    derivatives say nothing about the parameter (legal for the key, surely a slip).

    Raises
    ------
    ConfigError
        One line naming the parameter, its bounds and the allowed span.
    """
    step = diff_step * (upper - lower)
    if lower > 0 and upper / lower > 10 ** MAX_DECADES:
        raise ConfigError(
            f"{where}: bounds [{lower:g}, {upper:g}] {unit} of {path} span {math.log10(upper / lower):.1f} decades; at "
            f"most {MAX_DECADES} are allowed (upper/lower <= 1e{MAX_DECADES}): the fit steps the parameter by "
            f"calibration.diff_step x (upper - lower) = {step:.3g} {unit}, {step / abs(start):.3g} times its start "
            f"{start:g}, and cannot resolve it; bound it around a plausible value")
    if lower > 0 and upper / lower > 10 ** WARN_DECADES:
        logger.warning("%s: bounds [%g, %g] %s of %s span %.1f decades: the fit steps the parameter on a linear "
                       "scale, by %.3g %s; narrow them if the fit ends at a bound or far from the start", where,
                       lower, upper, unit, path, math.log10(upper / lower), step, unit)
    elif start != 0 and step > abs(start):
        logger.warning("%s: the fit's finite-difference step calibration.diff_step x (upper - lower) = %.3g %s of "
                       "%s exceeds its start %g: its derivatives will be coarse; narrow the bounds [%g, %g] or "
                       "lower calibration.diff_step", where, step, unit, path, start, lower, upper)


def fit_values(parameters: Sequence[ModelParameter], values: Sequence[float]) -> dict[str, float]:
    """``{dotted key: value}`` of a parameter vector."""
    return {p.path: float(v) for p, v in zip(parameters, values)}


def configure(data: dict, parameters: Sequence[ModelParameter], values, source: str = "calibration") -> WhiskerConfig:
    """The run file ``data`` with the parameters set to ``values``, validated.

    Parameters
    ----------
    data : dict
        A run file's content.
    parameters : sequence of ModelParameter
    values : array_like, shape (n_parameters,)
    source : str
        Names the run file in a refusal.

    Raises
    ------
    ConfigError
        A value outside its key's range (the bounds are checked against it, so only a start
        outside them gets here) or a run file that the values make impossible.
    """
    values = np.asarray(values, dtype=float)
    if values.shape != (len(parameters),):
        raise ValueError(f"values: shape {values.shape}, expected ({len(parameters)},)")
    merged = with_values(data, fit_values(parameters, values))
    try:
        return WhiskerConfig.model_validate(merged)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source, merged)) from None
