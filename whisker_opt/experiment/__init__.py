"""The simulated experiment: fidelity presets, the pressurise-then-deflect scene, the gauge, f1, the
outcome of an evaluation and its named measures (the evaluator of a genome is :mod:`whisker_opt.optimise.evaluator`)."""
