"""Base class of every typed configuration model.

Habit borrowed from pydantic-settings style configs: ``extra="forbid"`` turns a typo in a
YAML file into an error that names the key, and ``frozen=True`` makes a resolved config
an immutable value that can be hashed, pickled to workers and written next to results.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class StrictModel(BaseModel):
    """Frozen pydantic model that rejects unknown keys."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)
