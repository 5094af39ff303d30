"""Timings: how long the solver, the mesher, a scene and a whole run take."""
