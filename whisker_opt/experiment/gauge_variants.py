"""The gauge readings by name: the one registry of the variants.

Each reading is a module of :mod:`whisker_opt.experiment.readings` with a ``NAME``, a one-line
``DESCRIPTION``, ``state(mesh, u, gauge)`` (what it needs of one displacement: stretches, a strain) and
``relative(now, onset, gauge, context) -> float`` (the uncalibrated reading of a state relative to contact onset;
``context`` a :class:`whisker_opt.experiment.gauge.ReadingContext`, what the reading may know of its scene).
:class:`whisker_opt.experiment.gauge.GaugeReader` reads every registered reading; the scene's result
(:attr:`whisker_opt.experiment.scene.SceneResult.eps`), the evaluation's outcome and its measures
(:mod:`whisker_opt.experiment.measures`) and ``scene.gauge_variant`` follow this registry. The reading modules
load the finite-element code only when they read, so the run-file models may list the names without it.

A reading that samples points of its own (beyond the gauge line and centre of
:class:`whisker_opt.experiment.gauge.GaugeGeometry`) also has ``points(design) -> (points (n, 3), data)``; they are
located with the gauge, once per mesh, and reach it as ``gauge.sites[NAME]``.

Adding a reading: one module in ``whisker_opt/experiment/readings/`` (found by :func:`_registry`, ordered by its
``ORDER``) and a test. ``python3 -m whisker_opt.experiment.gauge_variants`` lists the registered readings (the
configuration reference points there instead of listing them).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Callable, Mapping


@dataclass(frozen=True)
class GaugeReading:
    """One registered gauge reading (see the module docstring for ``state`` and ``relative``)."""

    name: str
    description: str
    state: Callable[..., Any]
    relative: Callable[..., float]
    points: Callable[..., Any] | None = None


def _registry() -> dict[str, GaugeReading]:
    """Every module of :mod:`whisker_opt.experiment.readings`, in the order of their ``ORDER``."""
    from whisker_opt.experiment.registry import discover

    mods = discover("whisker_opt.experiment.readings")
    return {m.NAME: GaugeReading(m.NAME, m.DESCRIPTION, m.state, m.relative, getattr(m, "points", None))
            for m in mods}


#: The gauge readings, by name, in the order a reader returns them (read-only).
GAUGE_READINGS: Mapping[str, GaugeReading] = MappingProxyType(_registry())
#: Their one-line descriptions, by name (the names ``scene.gauge_variant`` allows).
GAUGE_VARIANTS: Mapping[str, str] = MappingProxyType({n: r.description for n, r in GAUGE_READINGS.items()})


def listing() -> str:
    """One line per registered reading, in order: its name and its description."""
    return "".join(f"{name}: {doc}\n" for name, doc in GAUGE_VARIANTS.items())


if __name__ == "__main__":  # python3 -m whisker_opt.experiment.gauge_variants: the registered readings
    sys.stdout.write(listing())
