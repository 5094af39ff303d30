"""The chamber wall's law: a periodic cell of the fibre-wound wall (axisymmetric + n = 1 harmonic), its named
mechanisms and the stored table of what pressure does to the wall's bending stiffness."""
