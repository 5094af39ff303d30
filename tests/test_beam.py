"""Tests of the analytical beam model against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from geometry.design import WhiskerDesign
from whisker_opt.analysis import beam
from whisker_opt.analysis.beam import NO_SOFTENING, BeamModel, ExtensionTable, LinearSoftening

E = 0.84


def _piecewise_uniform_deflection(segments, x_p, P):
    """δ = P Σ ∫_{a}^{b} (x_P - x)² / EI dx = P Σ [(x_P - a)³ - (x_P - b)³] / (3 EI) (exact, per segment)."""
    return P * sum(((x_p - a) ** 3 - (x_p - b) ** 3) / (3.0 * ei) for a, b, ei in segments)


# ----------------------------------------------------------------------------- integrator
@pytest.mark.parametrize("L", [10.0, 70.0, 123.4])
def test_integrator_uniform_cantilever_is_euler_bernoulli(L):
    """Constant EI: δ = P L³ / (3 E I) (Euler-Bernoulli cantilever, tip load)."""
    I = math.pi * 18.0**4 / 64.0
    P = 0.37
    d = beam.castigliano_deflection(L, lambda x: E * I, P, breakpoints=(2.0, 15.0))
    exact = P * L**3 / (3.0 * E * I)
    assert abs(d / exact - 1.0) < 1e-8


def test_integrator_mean_surface_strain_uniform():
    """Constant EI, linear M: the mean strain over a span is the strain at its midpoint."""
    I, r, L, P = 100.0, 4.0, 50.0, 2.0
    eps = beam.mean_surface_strain(L, lambda x: E * I, lambda x: r, (6.0, 8.0), P)
    assert eps == pytest.approx(r * P * (L - 7.0) / (E * I), rel=1e-12)


# ----------------------------------------------------------------------------- uniform cylinder
def test_uniform_cylinder_design_reduces_to_euler_bernoulli():
    """α = 0 design with the chamber treated as solid and no softening: δ = P L³/(3 E I), I = π D⁴/64."""
    d = WhiskerDesign(alpha=0.0)
    model = BeamModel(tube_I="solid", softening=NO_SOFTENING)
    P = 0.05
    I = math.pi * d.D**4 / 64.0
    delta = beam.deflection_at_contact(d, P, 1.0, 0.0, model)
    assert abs(delta / (P * d.L**3 / (3.0 * E * I)) - 1.0) < 1e-8
    # contact at a·L: the same formula with x_P = a L
    delta = beam.deflection_at_contact(d, P, 0.6, 0.0, model)
    assert abs(delta / (P * (0.6 * d.L) ** 3 / (3.0 * E * I)) - 1.0) < 1e-8
    # gauge: ε = r P (L - x_ss - e/2)/(E I)
    eps = beam.gauge_strain(d, P, 1.0, 0.0, model)
    assert eps == pytest.approx(d.D / 2 * P * (d.L - d.x_ss - d.e / 2) / (E * I), rel=1e-10)
    # sensitivity ε/δ = 3 r (L - x_g) / L³
    s = beam.sensitivity(d, 1.0, 0.0, model)
    assert s == pytest.approx(3 * d.D / 2 * (d.L - d.x_ss - d.e / 2) / d.L**3, rel=1e-10)


@pytest.mark.parametrize("tube_I", ["exact", "thin"])
def test_uniform_tube_piecewise_closed_form(tube_I):
    """α = 0 with the chamber: three uniform segments, each integrated exactly."""
    d = WhiskerDesign(alpha=0.0)
    model = BeamModel(tube_I=tube_I, softening=NO_SOFTENING)
    r, t = d.D / 2, d.t
    Is = math.pi * r**4 / 4
    It = math.pi * (r**4 - (r - t) ** 4) / 4 if tube_I == "exact" else math.pi / 8 * (2 * r - t) ** 3 * t
    P, a = 0.1, 0.8
    x_p = a * d.L
    exact = _piecewise_uniform_deflection([(0, d.c, E * Is), (d.c, d.l, E * It), (d.l, x_p, E * Is)], x_p, P)
    assert beam.deflection_at_contact(d, P, a, 0.0, model) == pytest.approx(exact, rel=1e-10)
    assert beam.gauge_strain(d, P, a, 0.0, model) == pytest.approx(r * P * (x_p - 7.0) / (E * It), rel=1e-10)


# ----------------------------------------------------------------------------- solid cone
@pytest.mark.parametrize("alpha", [2.862, 4.0, 6.0])
@pytest.mark.parametrize("a", [1.0, 0.6])
def test_solid_cone_matches_tapered_cantilever_closed_form(alpha, a):
    """Solid cone r(x) = r0 (1 - βx), β = tan α / r0, I = I0 (1 - βx)⁴, load P at x_P.

    Closed form (derived here; cf. the tapered-cantilever problems of Timoshenko & Gere,
    Mechanics of Materials, §9 'nonprismatic beams'): with u = 1 - βx, u_P = 1 - βx_P,

        δ = P/(E I0) ∫_0^{x_P} (x_P - x)² / (1 - βx)⁴ dx
          = P/(E I0 β³) ∫_{u_P}^1 (u - u_P)² u⁻⁴ du
          = P/(E I0 β³) [1/(3 u_P) - 1 + u_P - u_P²/3]
          = P x_P³ / (3 E I0 u_P)          since (1 - u)³/(3u) = 1/(3u) - 1 + u - u²/3.

    Limit β → 0: P x_P³ / (3 E I0), Euler-Bernoulli.
    """
    d = WhiskerDesign(alpha=alpha, L=50.0)
    model = BeamModel(tube_I="solid", softening=NO_SOFTENING)
    P = 0.2
    r0 = d.D / 2
    beta = math.tan(math.radians(alpha)) / r0
    I0 = math.pi * r0**4 / 4
    x_p = a * d.L
    u_p = 1 - beta * x_p
    closed = P * x_p**3 / (3 * E * I0 * u_p)
    # the bracketed form, evaluated independently
    closed2 = P / (E * I0 * beta**3) * (1 / (3 * u_p) - 1 + u_p - u_p**2 / 3)
    assert closed2 == pytest.approx(closed, rel=1e-9)
    assert abs(beam.deflection_at_contact(d, P, a, 0.0, model) / closed - 1.0) < 1e-10


# ----------------------------------------------------------------------------- thin tube
def test_thin_tube_error_default_design():
    """(8.4)/(8.3) - 1 = -t²/(d̄² + t²); at the gauge centre of the default design about -4.2 %."""
    d = WhiskerDesign()
    x = np.array([d.c, d.x_ss + d.e / 2, d.l])
    err = beam.thin_tube_relative_error(d, x)
    dbar = d.D - 2 * x * math.tan(math.radians(d.alpha)) - d.t
    np.testing.assert_allclose(err, -(d.t**2) / (dbar**2 + d.t**2), rtol=1e-12)
    np.testing.assert_allclose(err, beam.thin_tube_relative_error_formula(d, x), rtol=1e-12)
    # hand numbers: d̄ = 18 - 14 tan(2.862°) - 3 = 14.2999..., -9/(d̄² + 9)
    dbar7 = 18.0 - 14.0 * math.tan(math.radians(2.862)) - 3.0
    assert err[1] == pytest.approx(-9.0 / (dbar7**2 + 9.0), rel=1e-12)
    assert -0.0425 < err[1] < -0.0420
    # the thin tube is softer, so the gauge sensitivity rises (by a few %)
    s_exact = beam.sensitivity(d, 1.0, 0.0, BeamModel(tube_I="exact"))
    s_thin = beam.sensitivity(d, 1.0, 0.0, BeamModel(tube_I="thin"))
    assert 0.0 < s_thin / s_exact - 1.0 < 0.05


# ----------------------------------------------------------------------------- invariances
def test_sensitivity_independent_of_P_and_E():
    d = WhiskerDesign()
    s = beam.sensitivity(d, 1.0, 0.0)
    s2 = beam.sensitivity(d, 1.0, 0.0, BeamModel(E=7.3))
    assert s2 == pytest.approx(s, rel=1e-10)  # intact state: E cancels
    for Q in (0.0, 0.15):
        for a in (1.0, 0.5):
            r = [beam.gauge_strain(d, P, a, Q) / beam.deflection_at_contact(d, P, a, Q) for P in (1e-3, 0.5, 3.0)]
            np.testing.assert_allclose(r, r[0], rtol=1e-10)
            assert r[0] == pytest.approx(beam.sensitivity(d, a, Q), rel=1e-10)
    # deflection ∝ P / E
    d1 = beam.deflection_at_contact(d, 0.1, 1.0, 0.0, BeamModel(E=1.0))
    d2 = beam.deflection_at_contact(d, 0.3, 1.0, 0.0, BeamModel(E=2.0))
    assert d2 == pytest.approx(1.5 * d1, rel=1e-10)
    # calibration factor ξ multiplies
    assert beam.sensitivity(d, 1.0, 0.1, BeamModel(calibration=3.9)) == pytest.approx(3.9 * beam.sensitivity(d, 1.0, 0.1), rel=1e-12)


def test_sensitivity_trends_default_design():
    """Sensitivity rises with Q (thesis' validation) and with a trim.

    The beam model reproduces the rise with Q for a >= 0.6 only: at a = 0.45 the chamber
    extension moves the contact (at a·L_Q) outward by 0.45 Δl(l), which outweighs the
    softening above Q ≈ 0.1 MPa (a known limit of the model, recorded here).
    """
    d = WhiskerDesign()
    a = np.linspace(0.6, 1.0, 4)
    grid = beam.sensitivity_grid(d, a, [0.0, 0.1, 0.2])
    assert grid.shape == (4, 3)
    assert np.all(np.diff(grid, axis=1) > 0)
    s45 = beam.sensitivity_grid(d, [0.45], [0.1, 0.2])
    assert s45[0, 1] < s45[0, 0]
    assert np.all(np.diff(grid, axis=0) < 0)  # contact farther out: less strain per mm
    assert beam.sensitivity(d.trimmed(5.0)) > beam.sensitivity(d)
    assert grid[-1, 0] == pytest.approx(beam.sensitivity(d, 1.0, 0.0), rel=1e-12)


# ----------------------------------------------------------------------------- pressurised state
def test_extension_matches_closed_form():
    """Δl(l) = F/E₂ ∫_c^l dξ/A, A = π t (D - t - 2ξ tan α) ⇒ ∫ = ln[(D-t-2c tanα)/(D-t-2l tanα)]/(2π t tanα)."""
    d = WhiskerDesign()
    Q = 0.2
    geo = beam.pressurised_geometry(d, Q)
    ta = math.tan(math.radians(d.alpha))
    G = math.log((d.D - d.t - 2 * d.c * ta) / (d.D - d.t - 2 * d.l * ta)) / (2 * math.pi * d.t * ta)
    d_m = d.D - 2 * d.l * ta - 2 * d.t
    F = Q * math.pi * d_m**2 / 4
    k = -1.337 * Q + 0.9958
    assert geo.k == pytest.approx(k, rel=1e-14)
    assert geo.force == pytest.approx(F, rel=1e-12)
    assert geo.compliance == pytest.approx(G, rel=1e-12)
    assert geo.delta_l_end == pytest.approx(F * G / (k * E), rel=1e-12)
    assert beam.chamber_extension(d, Q) == pytest.approx(geo.delta_l_end, rel=1e-14)
    assert geo.length == pytest.approx(d.L + geo.delta_l_end, rel=1e-14)
    # Poisson thinning, thesis average at x = 2.5 and x = l (8.9)
    dt = 0.49 * geo.delta_l_end * 0.5 * (d.r_outer(2.5) + d.r_outer(d.l)) / (d.l - d.c)
    assert geo.thinning == pytest.approx(dt, rel=1e-12)
    # axial map: Δl profile integrates the stretch; position/material_coordinate are inverses
    stretch_int = integrate.quad(geo.stretch, d.c, d.l, epsabs=0, epsrel=1e-13)[0]
    assert stretch_int == pytest.approx(d.l - d.c + geo.delta_l_end, rel=1e-11)
    xi = np.array([1.0, 4.0, 9.3, 14.9, 30.0])
    np.testing.assert_allclose(geo.delta_l(9.3), integrate.quad(lambda s: geo.stretch(s) - 1, d.c, 9.3, epsrel=1e-13)[0], rtol=1e-10)
    for s in xi:
        assert geo.material_coordinate(geo.position(s)) == pytest.approx(s, abs=1e-11)
    # Q = 0 is the reference geometry
    g0 = beam.pressurised_geometry(d, 0.0)
    assert g0.delta_l_end == 0.0 and g0.length == d.L and g0.thinning == 0.0


def test_pressurised_uniform_tube_closed_form():
    """α = 0: A and λ constant, so the pressurised beam is three uniform segments
    [0, c] (E, solid), [c, l + Δl] (E₂ = kE, tube with t' = t - Δt), [l + Δl, x_P] (E, solid)."""
    d = WhiskerDesign(alpha=0.0)
    Q, P, a = 0.15, 0.1, 1.0
    for thinning in ("average", "local", "none"):
        model = BeamModel(wall_thinning=thinning)
        geo = beam.pressurised_geometry(d, Q, model)
        r = d.D / 2
        A = math.pi * (r**2 - (r - d.t) ** 2)
        F = Q * math.pi * (2 * (r - d.t)) ** 2 / 4
        E2 = (-1.337 * Q + 0.9958) * E
        dl = F * (d.l - d.c) / (E2 * A)
        assert geo.delta_l_end == pytest.approx(dl, rel=1e-12)
        dt = {"none": 0.0}.get(thinning, 0.49 * dl * r / (d.l - d.c))  # r_o constant: local = average
        tw = d.t - dt
        Is = math.pi * r**4 / 4
        It = math.pi * (r**4 - (r - tw) ** 4) / 4
        x_p = a * (d.L + dl)
        exact = _piecewise_uniform_deflection(
            [(0, d.c, E * Is), (d.c, d.l + dl, E2 * It), (d.l + dl, x_p, E * Is)], x_p, P)
        assert beam.deflection_at_contact(d, P, a, Q, model) == pytest.approx(exact, rel=1e-10)
        lam = 1 + dl / (d.l - d.c)
        mid = d.c + lam * (d.x_ss + d.e / 2 - d.c)  # current gauge centre
        assert beam.gauge_strain(d, P, a, Q, model) == pytest.approx(r * P * (x_p - mid) / (E2 * It), rel=1e-10)


def test_user_extension_and_softening_options():
    d = WhiskerDesign()
    table = ExtensionTable(Q=(0.0, 0.1, 0.2), delta_l=(0.0, 1.0, 3.0))
    geo = beam.pressurised_geometry(d, 0.15, BeamModel(extension=table))
    assert geo.delta_l_end == pytest.approx(2.0)
    assert geo.length == pytest.approx(d.L + 2.0)
    geo = beam.pressurised_geometry(d, 0.15, BeamModel(extension=lambda des, q: 10 * q))
    assert geo.delta_l_end == pytest.approx(1.5)
    assert beam.pressurised_geometry(d, 0.15, BeamModel(extension="none")).delta_l_end == 0.0
    # softening law configurable; normal mode without the intercept
    geo = beam.pressurised_geometry(d, 0.1, BeamModel(softening=LinearSoftening(-2.0, 1.0)))
    assert geo.k == pytest.approx(0.8) and geo.E2 == pytest.approx(0.8 * E)
    assert beam.pressurised_geometry(d, 0.0, BeamModel(soften_unpressurised=False)).k == 1.0
    assert beam.pressurised_geometry(d, 0.0).k == pytest.approx(0.9958)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda d: beam.sensitivity(d, 1.2), r"a = 1\.2 .*\(0, 1\]"),
        (lambda d: beam.sensitivity(d, 0.0), r"a = 0"),
        (lambda d: beam.sensitivity(d, 1.0, -0.1), r"Q = -0\.1"),
        (lambda d: beam.sensitivity(d, 1.0, 0.8), r"Q = 0\.8 .*softening"),
        (lambda d: beam.second_moment(d, 5.0, "hollow"), r"mode = 'hollow'"),
        (lambda d: BeamModel(tube_I="thick"), r"tube_I"),
        (lambda d: BeamModel(nu=0.7), r"BeamModel\.nu = 0\.7 .*\[0, 0\.5\]"),
        (lambda d: beam.pressurised_geometry(d, 0.3, BeamModel(extension=ExtensionTable((0.0, 0.2), (0.0, 1.0)))),
         r"Q = 0\.3 .*\[0, 0\.2\]"),
    ],
)
def test_bad_input_names_field_value_range(call, match):
    with pytest.raises(ValueError, match=match):
        call(WhiskerDesign())


def test_invalid_design_refused():
    with pytest.raises(ValueError, match="t"):
        beam.sensitivity(WhiskerDesign(t=9.0))
