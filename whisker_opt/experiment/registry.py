"""Discovery of the modules of a plug-in package: the one way a registry of the project finds its entries.

A registry (the readings, measures, rubber laws, base mechanisms, gauge patches, cap joints and reductions) is a
package of modules, one per entry, each with an ``ORDER`` (an int that places it in listings and makes the first
one the default) and, for most, a ``NAME``. :func:`discover` imports every module of the package and returns
them in that order; the registry reads what it needs from each. Adding an entry is adding a module: no list to
edit.

The scene's mechanisms (the base, the gauge patch, the cap joint) share one shape: each module has a ``NAME``, a
one-line ``DESCRIPTION``, the ``PARAMETERS`` it reads and one callable that acts on the scene;
:func:`mechanisms` makes such a package a read-only registry of :class:`Mechanism` and :func:`listing` its
one-line-per-entry listing.
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass
from types import MappingProxyType, ModuleType
from typing import Any, Callable, Mapping

__all__ = ["Mechanism", "discover", "listing", "mechanisms"]


def discover(package: str) -> list[ModuleType]:
    """Every module of the package ``package`` (a dotted name), imported, ordered by ``(ORDER, NAME)``.

    Parameters
    ----------
    package : str
        E.g. ``"whisker_opt.experiment.bases"``.

    Returns
    -------
    list of module
        Sorted by their ``ORDER`` and then by their ``NAME`` (the module's own name where it has none).

    Raises
    ------
    AttributeError
        A module without ``ORDER``: the message names it.
    """
    pkg = importlib.import_module(package)
    mods = [importlib.import_module(f"{pkg.__name__}.{m.name}") for m in pkgutil.iter_modules(pkg.__path__)]
    for m in mods:
        if not hasattr(m, "ORDER"):
            raise AttributeError(f"{m.__name__}: a module of the registry {package} needs an ORDER (an int)")
    return sorted(mods, key=lambda m: (m.ORDER, getattr(m, "NAME", m.__name__)))


@dataclass(frozen=True)
class Mechanism:
    """One registered mechanism of the scene: its module's ``NAME``, ``DESCRIPTION``, ``PARAMETERS`` and the
    callable that acts (``hold``, ``membranes``, ``factor``, as its registry names it)."""

    name: str
    description: str
    parameters: tuple[str, ...]
    act: Callable[..., Any]


def mechanisms(package: str, act: str) -> Mapping[str, Mechanism]:
    """The mechanisms of ``package`` by name, in :func:`discover` order (read-only; the first is the default),
    each acting by its module's callable named ``act``."""
    return MappingProxyType({m.NAME: Mechanism(m.NAME, m.DESCRIPTION, tuple(m.PARAMETERS), getattr(m, act))
                             for m in discover(package)})


def listing(registry: Mapping[str, Mechanism]) -> str:
    """One line per mechanism, in order: its name, its description and the parameters it reads."""
    return "".join(f"{m.name}: {m.description}" + (f" (reads {', '.join(m.parameters)})" if m.parameters else "")
                   + "\n" for m in registry.values())
