"""How the base is held, by name: the one registry of the base mechanisms (``scene.base_support``).

Each mechanism is a module of :mod:`whisker_opt.experiment.bases` with a ``NAME``, an ``ORDER``, a one-line
``DESCRIPTION``, ``PARAMETERS`` (the :class:`whisker_opt.experiment.spec.SceneSpec` fields it reads beyond the
mesh, each with its range and source in the module's docstring) and ``hold(wm, spec) -> BaseHold``: what holds
the whisker mesh ``wm`` (its ``mesh``, ``node_sets`` and ``face_sets``, :class:`geometry.mesh.WhiskerMesh`).
The scene (:func:`whisker_opt.experiment.scene.make_problem`) adds the hold's displacement sets (prescribed to
zero) and elastic supports to every problem, and sums the base reaction over its nodes and supports. The
modules load the finite-element code only when they hold, so the run-file models may list the names without it.

Adding a mechanism: one module in ``whisker_opt/experiment/bases/`` (found by
:func:`whisker_opt.experiment.registry.mechanisms`, ordered by its
``ORDER``), its parameters as fields of ``SceneSpec`` and keys of the ``scene`` section, and a test.
``python3 -m whisker_opt.experiment.base_supports`` lists the registered mechanisms.
"""

from __future__ import annotations

import sys
from typing import Mapping

from whisker_opt.experiment.bases import BaseHold
from whisker_opt.experiment.registry import Mechanism, mechanisms
from whisker_opt.experiment.registry import listing as mechanism_listing

__all__ = ["BASE_MECHANISMS", "BASE_SUPPORTS", "BaseHold", "base_hold", "listing"]


#: The base mechanisms, by name (read-only); the first is the default.
BASE_MECHANISMS: Mapping[str, Mechanism] = mechanisms("whisker_opt.experiment.bases", "hold")
#: Their names: the values ``scene.base_support`` allows.
BASE_SUPPORTS: tuple[str, ...] = tuple(BASE_MECHANISMS)


def base_hold(wm, spec) -> BaseHold:
    """The hold of ``spec.base_support`` on the whisker mesh ``wm``."""
    return BASE_MECHANISMS[spec.base_support].act(wm, spec)


def listing() -> str:
    """One line per registered mechanism, in order: its name, its description and the parameters it reads."""
    return mechanism_listing(BASE_MECHANISMS)


if __name__ == "__main__":  # python3 -m whisker_opt.experiment.base_supports: the registered mechanisms
    sys.stdout.write(listing())
