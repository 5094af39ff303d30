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

from pydantic import BaseModel, ConfigDict, model_validator

logger = logging.getLogger(__name__)


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
