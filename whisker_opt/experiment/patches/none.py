"""``none`` (the default): the gauge adds nothing to the surface; the readings see the bare rubber's strain.

The limit of a gauge whose backing is far more compliant than the wall under it (``bonded`` tends to it as
``scene.patch_modulus`` × ``scene.patch_thickness`` → 0). No parameters.
"""

from __future__ import annotations

NAME = "none"
ORDER = 0  # place in the registry (the default first)
DESCRIPTION = "the bare rubber surface under the gauge (no sheet)"
PARAMETERS: tuple[str, ...] = ()


def membranes(wm, spec) -> tuple:
    """No sheet."""
    return ()
