"""``neo_hookean`` (the default rubber): W = C10 (Ī1 − 3) + (1/D1)(J − 1)² of the material section's C10 and D1.

The energy is the solver's :class:`fem.material.NeoHookean`; the law has no constants of its own
(docs/physics.md §1).
"""

from __future__ import annotations

ORDER = 0  # place in the registry (the default law first)

#: The registered names: ``name -> (constants, source)``.
LAWS: dict[str, tuple[tuple[float, ...], str]] = {"neo_hookean": ((), "material.C10 and material.D1")}


def make(constants: tuple, c10: float, d1: float):
    """W = C10 (Ī1 − 3) with the material section's C10 = ``c10`` (:class:`fem.material.NeoHookean`);
    ``constants`` is empty and not read."""
    from fem.material import NeoHookean

    return NeoHookean(c10, d1)
