"""Which command reads which trim and initial-pressure key: one meaning per key.

Two kinds of job take a trim and an initial pressure from a run file, each from its own keys:

- the jobs of one given design (``mesh``, ``simulate``, ``export``) trim it by ``scene.trim`` and
  pressurise it to ``scene.Q_i``;
- the jobs of the GA's genomes (``run``, ``resume``, ``verify``, the Python API's ``evaluate``,
  ``robustness`` of a run's designs) trim by ``optimiser.trim``, and Q_i is the gene Q_i;
- ``compensate`` tabulates trims from 0 to ``optimiser.trim`` of the design intact at ``scene.Q_i``;
- ``calibrate`` takes the trims and pressures of its measurement files.

A key of :data:`TRIM_AND_Q_KEYS` that a run file sets (to a value other than its default) and the
running job does not read is warned about in one line naming the key, its value and what the job
uses instead, unless the job uses that same value in its place (:func:`whisker_opt.wiring.unread_keys`);
nothing is refused, so older run files load as before. ``docs/config.md`` shows :data:`COMMAND_READS` as a table (:mod:`whisker_opt.config.reference`).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

#: The trim and initial-pressure keys whose meaning depends on the job (module docstring).
TRIM_AND_Q_KEYS: tuple[str, ...] = ("scene.trim", "scene.Q_i", "optimiser.trim")

#: Of :data:`TRIM_AND_Q_KEYS`, the keys each job reads (``evaluate`` is the Python API's;
#: ``robustness`` also reads ``scene.Q_i`` when it studies a config's own design).
COMMAND_READS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "mesh": ("scene.trim",),
    "simulate": ("scene.trim", "scene.Q_i"),
    "export": ("scene.trim", "scene.Q_i"),
    "run": ("optimiser.trim",),
    "resume": ("optimiser.trim",),
    "evaluate": ("optimiser.trim",),
    "verify": ("optimiser.trim",),
    "compensate": ("scene.Q_i", "optimiser.trim"),
    "robustness": ("optimiser.trim",),
    "calibrate": (),
})
