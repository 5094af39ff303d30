"""Closed-form 3×3 determinant/inverse against LAPACK (numpy.linalg)."""

import numpy as np

from fem.tensor3 import det3, det_inv3


def test_det_inv_match_lapack():
    rng = np.random.default_rng(3)
    F = np.eye(3) + 0.4 * rng.standard_normal((50, 4, 3, 3))
    J, G = det_inv3(F)
    assert np.allclose(J, np.linalg.det(F), rtol=1e-13, atol=1e-14)
    assert np.allclose(det3(F), J, rtol=1e-14, atol=1e-15)
    assert np.allclose(G, np.linalg.inv(F), rtol=1e-12, atol=1e-12)
    assert np.allclose(F @ G, np.eye(3), atol=1e-12)


def test_singular_gives_nonfinite_inverse_not_error():
    F = np.zeros((2, 3, 3))
    F[0] = np.eye(3)
    J, G = det_inv3(F)
    assert J[0] == 1.0 and J[1] == 0.0
    assert np.all(np.isfinite(G[0])) and not np.all(np.isfinite(G[1]))
