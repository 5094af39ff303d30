"""The simulated experiment: fidelity presets, the pressurise-then-deflect scene, the gauge,
f1 and the evaluator that turns a genome into an outcome."""
