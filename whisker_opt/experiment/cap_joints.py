"""How the cap is joined to the body, by name: the one registry of ``material.cap_joint``.

Each joint is a module of :mod:`whisker_opt.experiment.caps` with a ``NAME``, an ``ORDER``, a one-line
``DESCRIPTION``, ``PARAMETERS`` (the :class:`whisker_opt.experiment.spec.SceneSpec` fields it reads, each with its
range and source in the module's docstring) and ``factor(values, c, mu) -> float``: the factor s on the cap's
moduli that stands for the joint (``values`` its parameters by name, ``c`` [mm] the cap's thickness, ``mu``
[MPa] the cap law's initial shear modulus; 1 for a tied cap). :func:`whisker_opt.experiment.rubber_laws.rubber_material`
scales the cap's elements by it, for the solver, the result files and the viewer alike.

Adding a joint: one module in ``whisker_opt/experiment/caps/`` (found by
:func:`whisker_opt.experiment.registry.mechanisms`), its parameters as fields of ``SceneSpec`` and keys of the
``material`` section, and a test. ``python3 -m whisker_opt.experiment.cap_joints`` lists the registered joints.
"""

from __future__ import annotations

import sys
from typing import Mapping

from whisker_opt.experiment.registry import Mechanism, mechanisms
from whisker_opt.experiment.registry import listing as mechanism_listing

__all__ = ["CAP_JOINTS", "JOINTS", "cap_factor", "listing"]


#: The joints, by name (read-only); the first is the default.
JOINTS: Mapping[str, Mechanism] = mechanisms("whisker_opt.experiment.caps", "factor")
#: Their names: the values ``material.cap_joint`` allows.
CAP_JOINTS: tuple[str, ...] = tuple(JOINTS)


def cap_factor(joint: str, source, c: float, mu: float) -> float:
    """The factor on the cap's moduli of the joint ``joint`` (module docstring), its parameters read as the
    attributes of the same names of ``source`` (a :class:`whisker_opt.experiment.spec.SceneSpec` or the run
    file's ``material`` section)."""
    if joint not in JOINTS:
        raise ValueError(f"cap joint {joint!r}: must be " + " or ".join(map(repr, CAP_JOINTS)))
    j = JOINTS[joint]
    return float(j.act({p: float(getattr(source, p)) for p in j.parameters}, c, mu))


def listing() -> str:
    """One line per registered joint, in order: its name, its description and the parameters it reads."""
    return mechanism_listing(JOINTS)


if __name__ == "__main__":  # python3 -m whisker_opt.experiment.cap_joints: the registered joints
    sys.stdout.write(listing())
