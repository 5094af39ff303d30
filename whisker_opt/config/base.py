"""Base class of every typed configuration model.

Habit borrowed from pydantic-settings style configs: ``extra="forbid"`` turns a typo in a
YAML file into an error that names the key, and ``frozen=True`` makes a resolved config
an immutable value that can be hashed, pickled to workers and written next to results.
A section may list keys it has renamed (``RENAMED``): the old key is still read, with a
deprecation warning that names the new one, and a file giving both is an error.
``allow_inf_nan=False``: NaN and infinities are never values of a run file (``.nan`` or
``.inf`` in YAML is an error that says "not a finite number"). A boolean given for a number
(``t: yes``, which YAML reads as true) is taken as 1 or 0 with a warning naming the key.
"""

from __future__ import annotations

import logging
import typing
import warnings
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

logger = logging.getLogger(__name__)


class ConfigError(ValueError):
    """A configuration file that cannot be used; the message names the key and the problem."""


class InvalidValues(ValidationError, ConfigError):
    """A model of a run file validated directly (``GenesConfig(...)``, ``WhiskerConfig.model_validate(...)``)
    with values it refuses: still pydantic's error (``errors()``, ``title``), and a :class:`ConfigError` whose
    text names each problem by its key path in a run file (``optimiser.genes.alpha: expected ...``), never
    by a class name."""

    text: str = ""

    def __str__(self) -> str:
        return self.text

    @classmethod
    def of(cls, err: ValidationError, model: type[BaseModel], data: Any) -> "InvalidValues":
        from whisker_opt.config.messages import describe

        root, prefix = KEY_PATHS.get(model, (model, ()))
        lines: list[str] = []
        for e in err.errors():
            line = describe({**e, "loc": (*prefix, *e["loc"])}, root, None)
            if line not in lines:
                lines.append(line)
        try:
            out = cls.from_exception_data(err.title, err.errors(include_url=False))
        except (KeyError, TypeError, ValueError):  # an error type pydantic-core cannot rebuild (e.g. 'path_type')
            from pydantic_core import PydanticCustomError

            out = cls.from_exception_data(err.title, [
                {"type": PydanticCustomError(e["type"], e["msg"].replace("{", "(").replace("}", ")")),
                 "loc": e["loc"], "input": e.get("input")} for e in err.errors(include_url=False)])
        out.text = "; ".join(lines)
        return out


#: Where each model of a run file stands: model -> (the run file's model, the key path of its section), filled
#: in by :mod:`whisker_opt.config.model` once the run file's model is defined.
KEY_PATHS: dict[type, tuple[type, tuple[str, ...]]] = {}


class StrictModel(BaseModel):
    """Frozen pydantic model that rejects unknown keys and reads renamed ones.

    Attributes
    ----------
    RENAMED : dict of str -> str
        Old key -> new key of this section, e.g. ``{"delta_max": "trim"}``.
    SECTION : str
        The section's key in a run file (for messages).
    SHAPE : str
        How the section is written, for the message when something else is given.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True, allow_inf_nan=False)
    RENAMED: ClassVar[dict[str, str]] = {}
    SECTION: ClassVar[str] = ""
    SHAPE: ClassVar[str] = "a mapping of keys"

    def __init__(self, /, **data: Any) -> None:
        try:
            super().__init__(**data)
        except ValidationError as exc:
            if isinstance(exc, InvalidValues):
                raise
            raise InvalidValues.of(exc, type(self), data) from None

    # Validation builds nested sections as BaseModel.__init__ would, not through the __init__ above (whose
    # keyword arguments could not carry a YAML mapping's integer key): only a direct call comes here.
    __init__.__pydantic_base_init__ = True  # type: ignore[attr-defined]

    @classmethod
    def model_validate(cls, obj: Any, *args: Any, **kwargs: Any):
        try:
            return super().model_validate(obj, *args, **kwargs)
        except ValidationError as exc:
            if isinstance(exc, InvalidValues):
                raise
            raise InvalidValues.of(exc, cls, obj) from None

    @model_validator(mode="before")
    @classmethod
    def _renamed_keys(cls, data: Any) -> Any:
        if not cls.RENAMED or not isinstance(data, dict):
            return data
        data = dict(data)
        for old, new in cls.RENAMED.items():
            if old not in data:
                continue
            if new in data:
                raise ValueError(f"'{old}' is the old name of '{new}'; give only '{new}'")
            where = f"{cls.SECTION}." if cls.SECTION else ""
            msg = f"config key '{where}{old}' is deprecated: write '{where}{new}'"
            warnings.warn(msg, DeprecationWarning, stacklevel=2)
            logger.warning(msg)
            data[new] = data.pop(old)
        return data

    @model_validator(mode="before")
    @classmethod
    def _booleans_for_numbers(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        for name, f in cls.model_fields.items():
            value = data.get(name)
            if isinstance(value, bool) and _is_number(f.annotation):
                where = f"{cls.SECTION}." if cls.SECTION else ""
                logger.warning("config key '%s%s': %r is a boolean (YAML reads yes/no/on/off so), taken as the "
                               "number %d; write a number", where, name, value, int(value))
        return data


def _is_number(annotation: Any) -> bool:
    """Whether a field's type is a number (``float``, ``int``, or one of them or None)."""
    args = typing.get_args(annotation)
    kinds = [a for a in args if a is not type(None)] if args else [annotation]
    return bool(kinds) and all(k in (float, int) for k in kinds)
