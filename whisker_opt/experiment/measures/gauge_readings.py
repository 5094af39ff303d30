"""``eps_i_<variant>``, ``eps_c_<variant>``: every gauge reading at the largest deflection.

For every reading of :data:`whisker_opt.experiment.gauge_variants.GAUGE_VARIANTS`, the reading of the intact
(i) or the trimmed (c) scene at δ_max: ``extra["readings"][variant]["intact" | "trimmed"]``. A family of
measures, one pair per registered reading, so this module has :func:`family` instead of one ``NAME``.
"""

from __future__ import annotations

from typing import Callable

from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS

ORDER = 100  # place in the registry (after the single measures)

#: The letter of each scene of an evaluation in the names of its readings (i: intact, c: compensated).
SCENE_LETTER: dict[str, str] = {"intact": "i", "trimmed": "c"}


def _reading(variant: str, scene: str) -> Callable[..., float]:
    def read(outcome) -> float:
        return outcome.extra["readings"][variant][scene]
    return read


def family() -> list[dict]:
    """The measures' fields (``name``, ``unit``, ``description``, ``read``, ``calibrated``): two per reading,
    in the readings' order, intact first."""
    return [dict(name=f"eps_{SCENE_LETTER[s]}_{v}", unit="-", read=_reading(v, s), calibrated=True,
                 description=f"{v} gauge reading of the {s} scene at the largest deflection: {doc}")
            for v, doc in GAUGE_VARIANTS.items() for s in SCENE_LETTER]
