"""The smeared winding (geometry.fibre_field) against the discrete helices it replaces.

Closed forms (docstring of geometry.fibre_field):
* stored stiffness: Σ_q w k = E_f A_f × (total helix length), because ∫ w dr = 1 and
  ∫ k 2πr dr = n s E_f A_f per unit axial length;
* the direction at a point on a helix is that helix's unit tangent dX/ds;
* the field lives only in the wall of the chamber c ≤ x ≤ l.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem.assembly import Assembler
from fem.material import NeoHookean
from fem.problem import Problem
from fem.quadrature import tet_rule
from fem.mesh import mapped_points
from geometry.design import WhiskerDesign
from geometry.fibre_field import profile_half_width, smeared_fibres
from geometry.fibres import helix_xyz
from geometry.mesh import MeshSizing, build_mesh


@pytest.fixture(scope="module", params=[0.5, 0.3])
def case(request):
    d = WhiskerDesign(fibre_radius_frac=request.param)
    wm = build_mesh(d, MeshSizing(wall_layers=2.0), method="swept")
    return d, wm, smeared_fibres(wm.mesh, d)


def _helix_length(d: WhiskerDesign) -> float:
    x = np.linspace(d.c, d.l, 200001)
    return float(np.linalg.norm(np.diff(helix_xyz(d, x, 0.0), axis=0), axis=1).sum())


def test_stored_stiffness_equals_the_discrete_fibres(case):
    d, wm, ff = case
    asm = Assembler(Problem(wm.mesh, NeoHookean(0.14, 0.0), fibre_fields=(ff,)))
    stored = float(np.sum(asm.topo.field_kernels[0].wk))  # Σ_q w k  [N·mm/mm]
    exact = d.fibre_E * d.fibre_area * d.n_fibres * _helix_length(d)
    # the element means of the profile are integrated to ~1e-3 on curved elements of a 2-layer wall
    assert stored == pytest.approx(exact, rel=5e-3)


def test_direction_is_the_helix_tangent(case):
    d, wm, ff = case
    rule = tet_rule(2)
    Xq = mapped_points(wm.mesh.points, wm.mesh.cells[ff.elements], rule.points)  # (n, n_qp, 3)
    # helix tangent at the same (x, θ) and r = r_f(x): finite difference of helix_xyz in x
    x = Xq[..., 0].ravel()
    th = np.arctan2(Xq[..., 2], Xq[..., 1]).ravel()
    phase = th - 2.0 * math.pi * (x - d.c) / d.fibre_pitch
    h = 1e-6
    t = np.array([(helix_xyz(d, [xi + h], ph) - helix_xyz(d, [xi - h], ph))[0] for xi, ph in zip(x, phase)])
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    # same direction, same sense (right-handed about +x), up to the FD error
    np.testing.assert_allclose(ff.directions.reshape(-1, 3), t, atol=1e-6)


def test_field_stays_in_the_chamber_wall(case):
    d, wm, ff = case
    X = wm.mesh.points[wm.mesh.cells[ff.elements]]  # (n, 10, 3)
    x = X[..., 0]
    r = np.hypot(X[..., 1], X[..., 2])
    h = profile_half_width(d)
    # every reinforced element touches the band |r − r_f| < h of the chamber
    touches = np.any((np.abs(r - d.r_fibre(x)) < h + 1e-9) & (x > d.c - 1e-9) & (x < d.l + 1e-9), axis=1)
    assert np.all(touches)
    assert ff.stiffness.min() > 0.0


def test_no_fibres_gives_an_empty_field():
    d = WhiskerDesign(n_fibres=0)
    wm = build_mesh(d, MeshSizing(), method="swept")
    ff = smeared_fibres(wm.mesh, d)
    assert len(ff.elements) == 0
