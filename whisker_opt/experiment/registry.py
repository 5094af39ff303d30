"""Discovery of the modules of a plug-in package: the one way a registry of the project finds its entries.

A registry (the readings, measures, rubber laws, base mechanisms, gauge patches, cap joints and reductions) is a
package of modules, one per entry, each with an ``ORDER`` (an int that places it in listings and makes the first
one the default) and, for most, a ``NAME``. :func:`discover` imports every module of the package and returns
them in that order; the registry reads what it needs from each. Adding an entry is adding a module: no list to
edit.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

__all__ = ["discover"]


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
