"""Every registered rubber law (whisker_opt/experiment/rubbers/) against its own energy: f′ and f″ the
derivatives of f in Ī1, the first Piola stress the derivative of the energy in F and the tangent that of the
stress, zero stress and the law's shear modulus in the reference state. A law's own closed forms are tested
beside these, one test each (the Yeoh fits: tests/test_model_form.py)."""

from __future__ import annotations

import numpy as np
import pytest

from whisker_opt.experiment.rubber_laws import RUBBERS, rubber_law

#: A finite deformation with stretch, shear and volume change (det ≈ 1.06): Ī1 − 3 ≈ 0.10.
F_TEST = np.array([[1.25, 0.10, -0.05], [0.04, 0.92, 0.08], [-0.06, 0.03, 0.93]])
#: Central-difference step (truncation and round-off ≪ 1e-7 relative at these magnitudes).
H = 1e-6
C10, D1 = 0.21, 0.03  # the material section's constants (read by a law without its own)


def _stress(law, F):
    return law.stress_tangent(F, np.linalg.inv(F), np.linalg.det(F))


@pytest.mark.parametrize("name", RUBBERS)
def test_f_derivatives_are_the_derivatives_of_f(name):
    """f′(Ī1) and f″(Ī1) against central differences of f and f′ over 3 ≤ Ī1 ≤ 3.6, the shape kept."""
    law = rubber_law(name, C10, D1)
    i1 = np.linspace(3.0, 3.6, 13).reshape(13, 1)
    f, df, d2f = law.f_derivatives(i1)
    assert f.shape == df.shape == d2f.shape == i1.shape
    (fp, dfp, _), (fm, dfm, _) = law.f_derivatives(i1 + H), law.f_derivatives(i1 - H)
    np.testing.assert_allclose(df, (fp - fm) / (2 * H), rtol=1e-7, atol=1e-9 * np.abs(df).max())
    np.testing.assert_allclose(d2f, (dfp - dfm) / (2 * H), rtol=1e-6, atol=1e-7 * np.abs(df).max())


@pytest.mark.parametrize("name", RUBBERS)
def test_stress_and_tangent_are_derivatives_of_the_energy(name):
    """P = ∂W/∂F and A = ∂P/∂F at a finite deformation, by central differences."""
    law = rubber_law(name, C10, D1)
    P, A = _stress(law, F_TEST)
    P_fd, A_fd = np.zeros((3, 3)), np.zeros((3, 3, 3, 3))
    for k in range(3):
        for L in range(3):
            dF = np.zeros((3, 3))
            dF[k, L] = H
            P_fd[k, L] = (law.energy(F_TEST + dF) - law.energy(F_TEST - dF)) / (2 * H)
            A_fd[..., k, L] = (_stress(law, F_TEST + dF)[0] - _stress(law, F_TEST - dF)[0]) / (2 * H)
    assert np.abs(P - P_fd).max() <= 1e-7 * np.abs(P).max()
    assert np.abs(A - A_fd).max() <= 1e-7 * np.abs(A).max()


@pytest.mark.parametrize("name", RUBBERS)
def test_the_reference_state_is_stress_free_with_the_laws_shear_modulus(name):
    """P(I) = 0; the initial shear modulus μ = 2 f′(3) is the law's ``shear_modulus``; D1 reaches the law."""
    law = rubber_law(name, C10, D1)
    assert np.abs(_stress(law, np.eye(3))[0]).max() <= 1e-15
    assert 2.0 * float(law.f_derivatives(np.array(3.0))[1]) == pytest.approx(law.shear_modulus, rel=1e-14)
    assert law.d1 == D1
