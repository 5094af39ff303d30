"""The whisker's materials as the thesis built and modelled them: the one home of their constants.

Every model of the whisker that starts from these materials reads them here: the design's fibre
(:class:`geometry.design.WhiskerDesign`), the scene's rubber (``SceneSpec.c10`` of
:mod:`whisker_opt.experiment.spec`), the wall cell's geometry and mechanisms (:mod:`whisker_opt.wallcell`), the
beam model's modulus (:data:`whisker_opt.analysis.beam.DEFAULT_E`), the viewer's fibres and the benchmarks. A
leaf module: it imports nothing.
"""

#: Neo-Hookean C10 of the rubber [MPa], the thesis' FE value (μ = 2 C10, small-strain E = 6 C10).
RUBBER_C10 = 0.14
#: Young's modulus of the fibre [MPa], the thesis' FE value (an aramid's, per its source).
FIBRE_MODULUS = 31067.0
#: Poisson ratio of the fibre [-], the thesis' FE value.
FIBRE_POISSON = 0.36
#: Diameter of the fibre [mm].
FIBRE_DIAMETER = 0.38
