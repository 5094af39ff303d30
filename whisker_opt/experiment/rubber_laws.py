"""The rubber laws by name: the one registry of the rubbers of :attr:`whisker_opt.experiment.spec.SceneSpec.rubber`.

Each law is one module of :mod:`whisker_opt.experiment.rubbers` (``neo_hookean``, ``yeoh``), found by
:func:`_registry` and ordered by its ``ORDER``, with

- ``LAWS``: the names it registers, ``name -> (constants, source)``: the law's own constants (a tuple of
  floats, empty for a law of the material section's C10) and where they come from;
- ``make(constants, c10, d1)``: its factory, the isochoric law (a :class:`fem.material.IsochoricI1Material`)
  of those constants, the material section's C10 = ``c10`` [MPa] where the law reads it and D1 = ``d1``
  [1/MPa], which every law takes.

A law whose energy the solver does not have is a frozen dataclass subclassing
:class:`fem.material.IsochoricI1Material` in its own module, beside its factory and constants (the base class
supplies the stress, the tangent and the post-processing from ``f_derivatives``; CONTRIBUTING.md). The names
(:data:`RUBBERS`) are the allowed values of ``material.rubber`` and ``material.cap_rubber``; :func:`rubber_law`
and :func:`rubber_material` make the law of a name, for the solver, the result files and the viewer alike.
``python3 -m whisker_opt.experiment.rubber_laws`` lists the registered laws.

Adding a rubber law: one module in ``whisker_opt/experiment/rubbers/`` (and a test of its energy).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Callable, Mapping

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from fem.material import IsochoricI1Material


@dataclass(frozen=True)
class RubberLaw:
    """A registered rubber law: a factory of the isochoric law with the law's own constants.

    Attributes
    ----------
    make : callable
        ``make(constants, c10, d1) -> fem.material.IsochoricI1Material``; ``c10`` [MPa] is the material
        section's C10, ``d1`` [1/MPa] its D1, which every law takes.
    constants : tuple of float
        The law's own constants (empty for a law of the material section's C10).
    source : str
        Where the constants come from.
    """

    make: Callable[[tuple, float, float], IsochoricI1Material]
    constants: tuple[float, ...] = ()
    source: str = ""

    def law(self, c10: float, d1: float) -> IsochoricI1Material:
        """The law with D1 = ``d1`` (and C10 = ``c10`` for a law that reads it)."""
        return self.make(self.constants, c10, d1)


def _registry() -> dict[str, RubberLaw]:
    """Every law of every module of :mod:`whisker_opt.experiment.rubbers`, the modules in ``ORDER``."""
    from whisker_opt.experiment.registry import discover

    mods = discover("whisker_opt.experiment.rubbers")
    laws = [(name, RubberLaw(m.make, tuple(constants), source))
            for m in mods
            for name, (constants, source) in m.LAWS.items()]
    names = [n for n, _ in laws]
    if len(set(names)) != len(names) or "same" in names:
        raise ValueError(f"rubber laws: a name registered twice or reserved ('same'): {names}")
    return dict(laws)


#: The rubber laws by name, read-only (module docstring).
RUBBER_LAWS: Mapping[str, RubberLaw] = MappingProxyType(_registry())

#: The names of the rubber laws (:data:`RUBBER_LAWS`), the default ``neo_hookean`` first.
RUBBERS: tuple[str, ...] = tuple(RUBBER_LAWS)


def rubber_law(name: str, c10: float, d1: float) -> IsochoricI1Material:
    """The isochoric law called ``name``, one of :data:`RUBBERS`: the one place a rubber's name
    becomes a law, by its registered factory (:meth:`RubberLaw.law`).

    Parameters
    ----------
    name : str
    c10 : float
        The material section's C10 [MPa] (read by a law without constants of its own, e.g. 'neo_hookean').
    d1 : float
        [1/MPa], for every law.

    Returns
    -------
    fem.material.IsochoricI1Material

    Raises
    ------
    ValueError
        An unknown name (the message lists :data:`RUBBERS`).
    """
    if name not in RUBBER_LAWS:
        raise ValueError(f"rubber {name!r}: must be " + " or ".join(map(repr, RUBBERS)))
    return RUBBER_LAWS[name].law(c10, d1)


def rubber_material(rubber: str, cap_rubber: str, c10: float, d1: float, cap: np.ndarray,
                    cap_factor: float = 1.0) -> IsochoricI1Material:
    """The rubber of a whisker: one law, or the cap's law on the cap's elements and the body's elsewhere, the cap's
    moduli scaled by its joint's factor.

    Parameters
    ----------
    rubber, cap_rubber : str
        :attr:`whisker_opt.experiment.spec.SceneSpec.rubber` and ``cap_rubber`` ('same', or one of
        :data:`RUBBERS`).
    c10, d1 : float
        [MPa], [1/MPa] (:func:`rubber_law`).
    cap : ndarray of bool, shape (n_el,)
        The cap's elements (:func:`whisker_opt.experiment.spec.cap_elements`); not read for one law.
    cap_factor : float
        s > 0 on the cap's moduli (its joint, :func:`whisker_opt.experiment.cap_joints.cap_factor`; 1 = tied).

    Returns
    -------
    fem.material.IsochoricI1Material
        :func:`rubber_law` of ``rubber``, or a :class:`fem.material.ElementwiseMaterial` of
        (body, cap) laws with group 1 on ``cap``; a :class:`fem.material.ScaledMaterial` of it (s on ``cap``,
        1 elsewhere) when ``cap_factor`` ≠ 1.
    """
    from fem.material import ElementwiseMaterial, ScaledMaterial

    body = rubber_law(rubber, c10, d1)
    cap = np.asarray(cap, dtype=bool)
    mat = body if cap_rubber in ("same", rubber) else \
        ElementwiseMaterial((body, rubber_law(cap_rubber, c10, d1)), cap.astype(np.int64))
    if cap_factor == 1.0:
        return mat
    return ScaledMaterial(mat, np.where(cap, float(cap_factor), 1.0))


def cap_law(rubber: str, cap_rubber: str, c10: float, d1: float) -> IsochoricI1Material:
    """The law of the cap's elements: ``cap_rubber``'s, or the body's for 'same'."""
    return rubber_law(rubber if cap_rubber == "same" else cap_rubber, c10, d1)


def listing() -> str:
    """One line per registered law: its name, its constants and their source."""
    return "".join(f"{name}: constants {law.constants or '(none)'}; {law.source}\n"
                   for name, law in RUBBER_LAWS.items())


if __name__ == "__main__":  # python3 -m whisker_opt.experiment.rubber_laws: the registered laws
    sys.stdout.write(listing())
