"""What the gauge adds to the surface it is bonded to, by name: the one registry of ``scene.gauge_patch``.

Each choice is a module of :mod:`whisker_opt.experiment.patches` with a ``NAME``, an ``ORDER``, a one-line
``DESCRIPTION``, ``PARAMETERS`` (the :class:`whisker_opt.experiment.spec.SceneSpec` fields it reads, each with
its range and source in the module's docstring) and ``membranes(wm, spec) -> tuple of fem.problem.Membrane``:
the sheets bonded to the whisker mesh ``wm``. The scene (:func:`whisker_opt.experiment.scene.make_problem`)
adds them to every problem; the readings are unchanged (docs/physics.md §3). The modules load the
finite-element code only when asked for their sheets, so the run-file models may list the names without it.

Adding a choice: one module in ``whisker_opt/experiment/patches/`` (found by
:func:`whisker_opt.experiment.registry.mechanisms`, ordered by its
``ORDER``), its parameters as fields of ``SceneSpec`` and keys of the ``scene`` section, and a test.
``python3 -m whisker_opt.experiment.gauge_patches`` lists the registered choices.
"""

from __future__ import annotations

import sys
from typing import Mapping

from whisker_opt.experiment.registry import Mechanism, mechanisms
from whisker_opt.experiment.registry import listing as mechanism_listing

__all__ = ["GAUGE_PATCHES", "PATCHES", "listing", "patch_membranes"]


#: The choices, by name (read-only); the first is the default.
PATCHES: Mapping[str, Mechanism] = mechanisms("whisker_opt.experiment.patches", "membranes")
#: Their names: the values ``scene.gauge_patch`` allows.
GAUGE_PATCHES: tuple[str, ...] = tuple(PATCHES)


def patch_membranes(wm, spec) -> tuple:
    """The sheets of ``spec.gauge_patch`` on the whisker mesh ``wm``."""
    return tuple(PATCHES[spec.gauge_patch].act(wm, spec))


def listing() -> str:
    """One line per registered choice, in order: its name, its description and the parameters it reads."""
    return mechanism_listing(PATCHES)


if __name__ == "__main__":  # python3 -m whisker_opt.experiment.gauge_patches: the registered choices
    sys.stdout.write(listing())
