"""The compiled element tangent (fem.jit) against the vectorised numpy reference.

Both compute the same sums (fem.assembly's derivation); they may differ only by the order
of floating-point additions, so they must agree to round-off (1e-12 of the largest entry)
for every term: the neo-Hookean and Yeoh (d2f ≠ 0) materials, the mixed D1 = 0 and the
displacement formulations, with follower pressure and embedded fibres on top. The
consistency of either with finite differences is tests/test_fem_tangent.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from fem import jit
from fem.assembly import Assembler
from fem.material import NeoHookean, Yeoh
from fem.mesh import boundary_faces
from fem.meshgen import box_mesh
from fem.problem import EmbeddedTrusses, FollowerPressure, Problem
from tests.test_fem_tangent import _distorted, _state

pytestmark = pytest.mark.skipif(not jit.AVAILABLE, reason="numba not installed")


@pytest.fixture(scope="module")
def mesh():
    return _distorted(box_mesh(1.0, 1.0, 2.0, 2, 2, 3))  # 72 curved P2 tets


CASES = {
    "neohooke-mixed-D1=0": (NeoHookean(0.5, 0.0), "mixed"),
    "neohooke-displacement": (NeoHookean(0.5, 0.4), "displacement"),
    "yeoh-mixed": (Yeoh((0.5, 0.1, 0.03), 0.4), "mixed"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_numba_tangent_equals_numpy(mesh, case):
    material, formulation = CASES[case]
    _, _, f6 = boundary_faces(mesh.cells)
    top = f6[np.all(mesh.points[f6][:, :, 2] > 1.5, axis=1)]
    fib = EmbeddedTrusses(np.array([0, 5, 9, 20]), np.full((4, 3), 0.2), np.array([[0, 1], [1, 2], [2, 3]]),
                          youngs_modulus=3.0e4, area=0.01)
    prob = Problem(mesh, material, pressures=(FollowerPressure(top),), trusses=(fib,), formulation=formulation)
    u, p = _state(prob, seed=7, scale=0.01)
    R_np, d_np, j_np = Assembler(prob, kernel="numpy").evaluate(u, p, (0.3,))
    asm = Assembler(prob, kernel="numba")
    assert asm.kernel == "numba"
    R_nb, d_nb, j_nb = asm.evaluate(u, p, (0.3,))
    assert np.array_equal(R_np, R_nb) and j_np == j_nb  # the residual path is shared
    scale = np.abs(d_np).max()
    assert scale > 1.0
    np.testing.assert_allclose(d_nb, d_np, rtol=0, atol=1e-12 * scale)


def test_kernel_choice_is_validated(mesh):
    prob = Problem(mesh, NeoHookean(0.5, 0.0))
    with pytest.raises(ValueError, match="kernel='gpu'"):
        Assembler(prob, kernel="gpu")
    assert Assembler(prob).kernel == "numba"
