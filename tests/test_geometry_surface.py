"""The closed triangulated surface of a whisker (geometry.surface), the input of the fresh mesher."""

from __future__ import annotations

import math

import numpy as np
import pytest

from geometry import analytic
from geometry.design import WhiskerDesign
from geometry.surface import closed_surface


@pytest.mark.parametrize("n_theta", [24, 96])
def test_the_surface_is_closed_outward_and_encloses_the_inscribed_solid(n_theta):
    """Each edge is shared by two triangles, once in each direction (closed and consistently oriented); the
    enclosed volume is the solid's times n sin(2π/n)/(2π), the ratio of a regular n-gon's area to its circle's."""
    d = WhiskerDesign()
    P, T = closed_surface(d, h=0.5, n_theta=n_theta)
    edges = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    directed = {tuple(e) for e in edges.tolist()}
    assert len(directed) == len(edges) and all((b, a) in directed for a, b in directed)
    volume = np.einsum("ij,ij->i", P[T[:, 0]], np.cross(P[T[:, 1]], P[T[:, 2]])).sum() / 6.0
    ratio = n_theta * math.sin(2 * math.pi / n_theta) / (2 * math.pi)
    assert volume == pytest.approx(analytic.solid_volume(d) * ratio, rel=1e-9)
