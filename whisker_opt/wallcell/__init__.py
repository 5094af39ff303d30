"""The wall cell, a research model of the chamber wall: a periodic cell of the fibre-wound wall (axisymmetric +
n = 1 harmonic, on :mod:`fem.axisym.harmonic`), its named mechanisms, and what a wall law does to the gauge reading
through the beam model. It makes the stored table of the runtime law (:mod:`whisker_opt.wall`); nothing of a run
imports it."""
