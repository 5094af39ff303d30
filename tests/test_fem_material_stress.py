"""Each law's own Cauchy and von Mises stress (fem.material) against closed forms.

Incompressible homogeneous stretches, the lateral faces free (the pressure chosen so that the
lateral stress is zero): with σ = 2 f'(Ī1) dev(B) + p I (J = 1),

* uniaxial F = diag(λ, λ^-½, λ^-½): σ_xx = 2 f'(Ī1) (λ² − 1/λ), Ī1 = λ² + 2/λ;
* equibiaxial F = diag(λ, λ, λ⁻²): σ_xx = σ_yy = 2 f'(Ī1) (λ² − λ⁻⁴), Ī1 = 2λ² + λ⁻⁴;

with 2 f' = μ = 2 C10 for the neo-Hookean law and 2 W'(Ī1) = 2 Σ_k k C_k0 (Ī1 − 3)^(k−1) for
Yeoh (Holzapfel 2000, §6.5; Ogden 1984, §7.2).
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.material import ElementwiseMaterial, NeoHookean, Yeoh, von_mises_stress

C10 = 0.14
YEOH = (0.041520, 4.5462e-4, 1e-5)
LAWS = {"neo_hookean": NeoHookean(C10), "yeoh": Yeoh(YEOH)}


def _slope(name: str, i1: float) -> float:
    """W'(Ī1) of the test laws, by hand."""
    if name == "neo_hookean":
        return C10
    return sum(k * c * (i1 - 3.0) ** (k - 1) for k, c in enumerate(YEOH, start=1))


def _stretch(kind: str, lam: float) -> tuple[np.ndarray, float, float]:
    """(F, Ī1, σ_xx / (2 W')) of an incompressible uniaxial or equibiaxial stretch λ."""
    if kind == "uniaxial":
        return np.diag([lam, lam**-0.5, lam**-0.5]), lam**2 + 2 / lam, lam**2 - 1 / lam
    return np.diag([lam, lam, lam**-2]), 2 * lam**2 + lam**-4, lam**2 - lam**-4


def _lateral_free_pressure(F: np.ndarray, slope: float) -> float:
    """p with σ_zz = 2 W' (B_zz − tr B / 3) + p = 0."""
    B = F @ F.T
    return -2 * slope * (B[2, 2] - np.trace(B) / 3)


@pytest.mark.parametrize("name", LAWS)
@pytest.mark.parametrize("kind", ["uniaxial", "equibiaxial"])
@pytest.mark.parametrize("lam", [0.6, 1.0, 1.5, 3.0])
def test_incompressible_stretch_closed_form(name, kind, lam):
    law = LAWS[name]
    F, i1, shape = _stretch(kind, lam)
    w1 = _slope(name, i1)
    p = _lateral_free_pressure(F, w1)
    sigma = law.cauchy_stress(F[None], p)[0]
    s = 2 * w1 * shape
    expected = np.diag([s, 0.0, 0.0]) if kind == "uniaxial" else np.diag([s, s, 0.0])
    np.testing.assert_allclose(sigma, expected, atol=1e-14 * max(1.0, abs(s)))
    assert np.trace(sigma) / 3 == pytest.approx(p, abs=1e-13)  # p is the mean stress, > 0 in tension
    assert law.von_mises(F[None], p)[0] == pytest.approx(abs(s), rel=1e-12, abs=1e-15)
    assert law.von_mises(F[None])[0] == pytest.approx(abs(s), rel=1e-12, abs=1e-15)  # p drops out


def test_neo_hookean_mu_and_yeoh_slope_at_a_known_point():
    """The stress scales: neo-Hookean σ_xx = μ (λ² − 1/λ); Yeoh the same with μ → 2 W'(Ī1) > μ = 2 C10."""
    lam = 2.0
    F, i1, shape = _stretch("uniaxial", lam)
    nh = NeoHookean(C10).cauchy_stress(F[None], _lateral_free_pressure(F, C10))[0, 0, 0]
    assert nh == pytest.approx(2 * C10 * 3.5, rel=1e-14)  # λ² − 1/λ = 3.5
    ye = Yeoh(YEOH).cauchy_stress(F[None], _lateral_free_pressure(F, _slope("yeoh", i1)))[0, 0, 0]
    # Ī1 − 3 = 2: 2 W' = 2 (C10 + 2 C20·2 + 3 C30·2²)
    assert ye == pytest.approx(2 * (YEOH[0] + 2 * YEOH[1] * 2.0 + 3 * YEOH[2] * 2.0**2) * 3.5, rel=1e-13)


def _old_neo_hookean_cauchy(F: np.ndarray, c10: float, p) -> np.ndarray:
    """The neo-Hookean nodal stress fem.post computed before the laws did: 2 C10 J^(-5/3) dev(B) + p I."""
    p = np.broadcast_to(np.asarray(p, dtype=float), F.shape[:1])
    J = np.linalg.det(F)
    B = np.einsum("kij,klj->kil", F, F)
    dev = B - np.einsum("kii->k", B)[:, None, None] / 3.0 * np.eye(3)
    return 2.0 * c10 * (J ** (-5.0 / 3.0))[:, None, None] * dev + p[:, None, None] * np.eye(3)


def test_neo_hookean_equals_the_former_post_processing():
    rng = np.random.default_rng(7)
    F = np.eye(3) + 0.3 * rng.standard_normal((200, 3, 3))
    F = F[np.linalg.det(F) > 0.2]
    p = 0.05 * rng.standard_normal(len(F))
    old = _old_neo_hookean_cauchy(F, C10, p)
    new = NeoHookean(C10).cauchy_stress(F, p)
    np.testing.assert_allclose(new, old, rtol=1e-12, atol=1e-13 * np.abs(old).max())
    np.testing.assert_allclose(NeoHookean(C10).von_mises(F, p), von_mises_stress(old), rtol=1e-11, atol=1e-14)


def test_vectorised_over_leading_axes_and_one_row_per_element():
    """(n, q, 3, 3) in, (n, q, 3, 3) out; an ElementwiseMaterial evaluates each row with its element's law,
    and at the nodes a node takes the law of its lowest group."""
    rng = np.random.default_rng(3)
    F = np.eye(3) + 0.2 * rng.standard_normal((4, 5, 3, 3))
    p = 0.01 * rng.standard_normal((4, 5))
    nh, ye = LAWS["neo_hookean"], LAWS["yeoh"]
    sig = ye.cauchy_stress(F, p)
    assert sig.shape == (4, 5, 3, 3) and ye.von_mises(F, p).shape == (4, 5)
    np.testing.assert_allclose(sig[2, 3], ye.cauchy_stress(F[2, 3][None], p[2, 3])[0], rtol=1e-14, atol=1e-16)
    np.testing.assert_array_equal(sig, np.swapaxes(sig, -1, -2))
    groups = np.array([0, 1, 1, 0])
    mixed = ElementwiseMaterial((nh, ye), groups)
    sm = mixed.cauchy_stress(F, p)
    for e, g in enumerate(groups):
        np.testing.assert_allclose(sm[e], (nh, ye)[g].cauchy_stress(F[e], p[e]), rtol=1e-14, atol=1e-16)
    # at the nodes: cells 0 and 1 share node 2; node 5 belongs to no cell
    cells = np.array([[0, 1, 2], [2, 3, 4]])
    used = np.array([True, True, True, True, True, False])
    at = ElementwiseMaterial((nh, ye), np.array([1, 0])).at_nodes(cells, used)
    np.testing.assert_array_equal(at.element_material, [1, 1, 0, 0, 0])
    np.testing.assert_array_equal(ElementwiseMaterial((nh, ye), np.array([1, 0])).at_nodes(cells).element_material,
                                  [1, 1, 0, 0, 0])
    assert nh.at_nodes(cells, used) is nh
    with pytest.raises(ValueError, match="held by no element"):
        ElementwiseMaterial((nh, ye), np.array([1, 0])).at_nodes(cells, np.ones(6, dtype=bool))
