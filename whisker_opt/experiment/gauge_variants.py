"""The names of the gauge readings: the one registry of the variants, a leaf module.

:class:`whisker_opt.experiment.gauge.GaugeReader` returns the readings in this order; the scene's result
(:attr:`whisker_opt.experiment.scene.SceneResult.eps`), the evaluation's outcome and its measures
(:mod:`whisker_opt.experiment.measures`) follow it. It imports nothing, so the run-file models may list the
measures' names without loading the FE code.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

#: The gauge readings, by name, in the order a reader returns them (the one registry of the variants:
#: :class:`GaugeReader`, the scene's result (:attr:`whisker_opt.experiment.scene.SceneResult.eps`), the
#: evaluation's outcome and its measures (:mod:`whisker_opt.experiment.measures`) all follow it).
GAUGE_VARIANTS: Mapping[str, str] = MappingProxyType({
    "line": "mean logarithmic strain along the gauge line, relative to contact onset, times ξ",
    "centroid": "axial Eulerian log strain at the centroid of the element under the gauge centre, relative to "
                "contact onset, times ξ (the thesis' readout)",
})
