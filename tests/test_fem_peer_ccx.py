"""Peer check: whisker-opt's FE solver against CalculiX on the same mesh and loads.

Measured (benchmarks, /tmp/peer2.py in the commit notes): with the displacement
formulation both codes agree to 5e-5–8e-5 (CalculiX prints 7 digits) at K/μ = 10 and
1000 on 2×2×6 and 4×4×12 meshes; the default mixed P2/P0 formulation differs from
C3D10 by 11 % / 3 % (K/μ = 10) on those meshes, the two converging to each other
under refinement (C3D10 is the stiffer, locking-prone one).

Reference: CalculiX 2.20 (C3D10, *HYPERELASTIC NEO HOOKE, NLGEOM, follower *DLOAD),
run through :mod:`peers.calculix` with tightened tolerances. CalculiX has no hybrid
elements, so both codes use the same small D1 (K/μ = 1000); agreement within 1 % is required.
Skipped cleanly when ``ccx`` is not installed.
"""

import numpy as np
import pytest

from peers.calculix import CcxCase, ccx_available, element_faces, run_ccx
from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import NeoHookean
from fem.mesh import boundary_faces
from fem.meshgen import box_mesh
from fem.problem import Dirichlet, FollowerPressure, Problem
from fem.state import State

needs_ccx = pytest.mark.skipif(not ccx_available(), reason="CalculiX executable 'ccx' not on PATH")

C10 = 0.14
D1 = 2.0 / (10 * 2 * C10)  # K/μ = 2/(D1·μ) = 10: CalculiX converges robustly


def _case():
    mesh = box_mesh(2.0, 2.0, 6.0, 2, 2, 6, distort=0.15, seed=3)
    P = mesh.points
    base = np.nonzero(np.isclose(P[:, 2], 0.0))[0]
    el, lf, f6 = boundary_faces(mesh.cells)
    side = np.all(np.isclose(P[f6][:, :, 0], 2.0), axis=1)  # the x = 2 side face
    return mesh, base, f6[side]


@pytest.mark.ccx
@needs_ccx
def test_pressure_bent_column_matches_calculix():
    """A clamped column bent by a follower pressure on one side: displacements within 1 %."""
    mesh, base, faces = _case()
    p = 0.006  # MPa: geometrically nonlinear bending (CalculiX stops converging near 0.01)
    # same discretisation as C3D10: displacement formulation, 4-point rule
    prob = Problem(mesh, NeoHookean(C10, D1), dirichlet=(Dirichlet(base),), pressures=(FollowerPressure(faces),),
                   formulation="displacement")
    states, _ = solve_path(prob, State.zero(prob), LoadState.zero(prob),
                           LoadState((p,), (np.zeros((len(base), 3)),)), fractions=(0.5, 1.0))
    u = states[-1].u
    elems, labels = element_faces(mesh.cells, faces)
    case = CcxCase(mesh.points, mesh.cells, C10, D1,
                   boundary=tuple((base, k, 0.0) for k in range(3)),
                   pressures=((elems, labels, p),), n_increments=20, direct=False)
    res = run_ccx(case, cleanup=True)
    ref = res.displacements
    scale = np.abs(ref).max()
    assert scale > 0.1  # the load does bend the column
    err = np.abs(u - ref).max() / scale
    print(f"max |u - u_ccx| / max|u_ccx| = {err:.2e} (tip deflection {scale:.4f} mm)")
    assert err < 1e-3


def test_displacement_formulation_tangent_matches_finite_differences():
    """Consistent tangent of the displacement formulation (central FD, ≤ 1e-6 relative)."""
    from fem.assembly import Assembler

    mesh, base, faces = _case()
    prob = Problem(mesh, NeoHookean(C10, D1), pressures=(FollowerPressure(faces),), formulation="displacement")
    asm = Assembler(prob)
    rng = np.random.default_rng(0)
    u = 0.01 * rng.standard_normal((mesh.n_nodes, 3))
    p = np.zeros(mesh.n_elements)
    R, data, _ = asm.evaluate(u, p, (0.01,))
    K = asm.pattern.matrix(data)
    h = 1e-6
    cols = rng.choice(3 * mesh.n_nodes, 25, replace=False)
    for j in cols:
        e = np.zeros(3 * mesh.n_nodes)
        e[j] = h
        Rp = asm.evaluate(u + e.reshape(-1, 3), p, (0.01,), False)[0]
        Rm = asm.evaluate(u - e.reshape(-1, 3), p, (0.01,), False)[0]
        fd = (Rp - Rm) / (2 * h)
        col = K[:, j].toarray().ravel()
        assert np.abs(col - fd).max() <= 1e-6 * np.abs(K.data).max()
