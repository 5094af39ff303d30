"""Analytical beam model of the whisker: a fast, small-deflection cross-check.

The whisker is an Euler-Bernoulli cantilever along +x, clamped at the base x = 0 and
loaded by a point force P (in -y) at the contact x_P = a·L_Q. All integrals are done
numerically (``scipy.integrate.quad`` piecewise between the breakpoints c, l and the
contact), so any (α, l, t, L) of :class:`geometry.design.WhiskerDesign` works.

Equations (docs/physics.md, "Beam model")
---------------------------------
Bending moment (statics of the cantilever)::

    M(x) = P (x_P - x)        for x <= x_P,  0 beyond                         (8.1)

Second moments, d = 2 r_o(x)::

    solid regions (0..c, l..L):   I = π d⁴ / 64                                (8.2)
    chamber (c..l), exact tube:   I = π (d_o⁴ - d_i⁴) / 64,  d_i = d_o - 2 t   (8.3)
    chamber, thesis' thin tube:   I = (π/8) d̄³ t,  d̄ = d_o - t                 (8.4)

(8.3) = (π/8) t d̄ (d̄² + t²) exactly, so (8.4)/(8.3) - 1 = -t² / (d̄² + t²).

Deflection at the contact by Castigliano's second theorem::

    δ = ∫_0^{x_P} M (∂M/∂P) / (E_k I(x)) dx = P ∫_0^{x_P} (x_P - x)² / (E_k I) dx   (8.5)

Gauge strain (Hooke, small curvature), on the outer surface y = r_o, averaged over the
gauge x_ss..x_ss+e::

    ε(x) = y M(x) / (E₂ I₂(x)),     ε̄ = (1/e) ∫_{x_ss}^{x_ss+e} ε dx           (8.6)

so ε/δ depends only on geometry, contact position and the modulus *ratio* E₂/E.

Pressurised state (Q > 0)::

    F = Q π d_m² / 4,  d_m = 2 r_i(l)  (cavity diameter at the chamber end)   (8.7)
    Δl(ξ) = (F / E₂) ∫_c^ξ dη / A(η),  A = π (d_o² - d_i²) / 4,  c <= ξ <= l    (8.8)
    every point beyond l shifts by Δl(l); L_Q = L - Δ + Δl(l)
    Δt(x) = ν Δl(l) r_o(x) / (l - c)   (Poisson wall thinning)                 (8.9)
    E₂(Q) = k(Q) E,   k(Q) = -1.337 Q + 0.9958  (Q in MPa)                      (8.10)

The thesis used a single wall thinning, the mean of (8.9) at x = 2.5 and x = l
(``wall_thinning='average'``, the default); ``'local'`` applies (8.9) pointwise and
``'none'`` ignores it. The fibres block radial growth, so the outer radius is kept and
the cavity widens: t' = t - Δt (a modelling choice: the thesis' (8.4) is written in
d_o and t).

Implementation: the integrals are written in the material (reference) coordinate ξ.
A material point ξ sits at x(ξ) = ξ + Δl(ξ) with the axial stretch
λ(ξ) = dx/dξ = 1 + F / (E₂ A(ξ)) in the chamber (1 elsewhere), so (8.5) becomes
``δ = P ∫_0^{ξ_P} (x_P - x(ξ))² λ(ξ) / (E_k I(ξ)) dξ`` and (8.6) the λ-weighted mean
over the material gauge span (the gauge is bonded to the material). With Q = 0 this is
exactly (8.5)-(8.6). Sections keep the radii of their material point (plus (8.9)).

Normal mode = Q = 0; pressurised (compensation) mode = Q > 0. By default the fitted law
(8.10) is applied at every Q, also Q = 0 (k(0) = 0.9958), so that ε/δ is continuous in
Q; ``BeamModel(soften_unpressurised=False)`` uses E₂ = E at Q = 0 instead.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Callable, Literal, Sequence, Union

import numpy as np
from numpy.polynomial import Chebyshev
from scipy import integrate, optimize

from geometry.design import WhiskerDesign
from geometry.materials import RUBBER_C10

logger = logging.getLogger(__name__)

#: Neo-Hookean small-strain Young's modulus E = 3 μ = 6 C10 of the rubber's C10 (:mod:`geometry.materials`).
DEFAULT_E = 3.0 * (2 * RUBBER_C10)

TubeMode = Literal["exact", "thin", "solid"]
ExtensionFn = Callable[[WhiskerDesign, float], float]


# --------------------------------------------------------------------------- checks
def _check_range(name: str, value: float, lo: float | None = None, hi: float | None = None,
                 lo_open: bool = False, hi_open: bool = False) -> float:
    """Return ``float(value)`` or raise ValueError naming field, value and allowed range."""
    v = float(value)
    ok = math.isfinite(v)
    if ok and lo is not None:
        ok = v > lo if lo_open else v >= lo
    if ok and hi is not None:
        ok = v < hi if hi_open else v <= hi
    if not ok:
        left = "-inf" if lo is None else f"{lo:g}"
        right = "inf" if hi is None else f"{hi:g}"
        lb = "(" if (lo_open or lo is None) else "["
        rb = ")" if (hi_open or hi is None) else "]"
        raise ValueError(f"{name} = {value!r} out of range: allowed {lb}{left}, {right}{rb}")
    return v


# --------------------------------------------------------------------------- laws
@dataclass(frozen=True)
class LinearSoftening:
    """Pressure softening of the chamber modulus, ``k(Q) = slope·Q + intercept``.

    Default: the thesis' fit on the first prototype, k(Q) = -1.337 Q + 0.9958 (Q in MPa).

    Parameters
    ----------
    slope : float
        dk/dQ [1/MPa].
    intercept : float
        k(0) [-].
    """

    slope: float = -1.337
    intercept: float = 0.9958

    def __call__(self, Q: float) -> float:
        """k(Q); raises ValueError if the law gives k <= 0 (no stiffness left)."""
        k = self.slope * float(Q) + self.intercept
        if not k > 0.0:
            qmax = -self.intercept / self.slope if self.slope < 0 else float("inf")
            raise ValueError(
                f"Q = {Q!r} MPa out of range of the softening law k(Q) = {self.slope:g} Q + {self.intercept:g}: "
                f"k = {k:.4g} must be > 0, i.e. Q < {qmax:.4g}"
            )
        return k


#: E₂ = E at every pressure.
NO_SOFTENING = LinearSoftening(slope=0.0, intercept=1.0)


@dataclass(frozen=True)
class ExtensionTable:
    """Axial chamber extension Δl(l) as a function of Q, e.g. from FE runs.

    Linear interpolation in Q; Q outside the sampled range is refused.

    Parameters
    ----------
    Q : tuple of float
        Increasing pressures [MPa].
    delta_l : tuple of float
        Extensions Δl(l) [mm] at those pressures.
    """

    Q: tuple[float, ...]
    delta_l: tuple[float, ...]

    def __post_init__(self) -> None:
        q = np.asarray(self.Q, dtype=float)
        d = np.asarray(self.delta_l, dtype=float)
        if q.ndim != 1 or q.size < 1 or q.shape != d.shape:
            raise ValueError(f"ExtensionTable: Q and delta_l must be 1-D of equal length (got {q.shape}, {d.shape})")
        if np.any(np.diff(q) <= 0) or not np.all(np.isfinite(q)) or not np.all(np.isfinite(d)):
            raise ValueError(f"ExtensionTable: Q = {self.Q} must be finite and strictly increasing")

    def __call__(self, design: WhiskerDesign, Q: float) -> float:
        _check_range("Q", Q, self.Q[0], self.Q[-1])
        return float(np.interp(Q, self.Q, self.delta_l))


@dataclass(frozen=True)
class BeamModel:
    """Options of the analytical beam model.

    Parameters
    ----------
    tube_I : {'exact', 'thin', 'solid'}
        Chamber second moment: exact tube (8.3), thesis' thin tube (8.4), or 'solid'
        (the chamber treated as a solid section, (8.2); for verification).
    E : float
        Young's modulus of the rubber [MPa]; default 3 μ = 0.84. It cancels in ε/δ.
    nu : float
        Poisson's ratio used for the wall thinning (8.9); the thesis used 0.49.
    softening : callable
        k(Q), E₂ = k(Q) E (8.10). Any ``Callable[[float], float]``; default :class:`LinearSoftening`.
    soften_unpressurised : bool
        If False, E₂ = E exactly at Q = 0 (a 'normal mode' without the fit's intercept).
    extension : 'model' | 'none' | callable
        Δl(l): 'model' = (8.7)-(8.8); 'none' = 0; or ``f(design, Q) -> Δl(l)`` [mm], e.g. an
        :class:`ExtensionTable` from FE. A user Δl(l) is distributed over the chamber like (8.8).
    wall_thinning : {'average', 'local', 'none'}
        (8.9): mean of Δt at ``thinning_x0`` and l (thesis), pointwise, or off.
    thinning_x0 : float
        First point of the thesis' average [mm] (2.5).
    calibration : float
        Factor ξ applied by :func:`sensitivity` (3.9 for the FE strains, ``scene.calibration``); default 1.
    epsrel : float
        Relative tolerance of ``quad``.
    """

    tube_I: TubeMode = "exact"
    E: float = DEFAULT_E
    nu: float = 0.49
    softening: Callable[[float], float] = LinearSoftening()
    soften_unpressurised: bool = True
    extension: Union[str, ExtensionFn] = "model"
    wall_thinning: Literal["average", "local", "none"] = "average"
    thinning_x0: float = 2.5
    calibration: float = 1.0
    epsrel: float = 1e-12

    def __post_init__(self) -> None:
        if self.tube_I not in ("exact", "thin", "solid"):
            raise ValueError(f"BeamModel.tube_I = {self.tube_I!r}: allowed 'exact', 'thin', 'solid'")
        _check_range("BeamModel.E", self.E, 0.0, None, lo_open=True)
        _check_range("BeamModel.nu", self.nu, 0.0, 0.5)
        if not callable(self.softening):
            raise ValueError(f"BeamModel.softening = {self.softening!r}: must be callable Q -> k(Q)")
        if not (callable(self.extension) or self.extension in ("model", "none")):
            raise ValueError(f"BeamModel.extension = {self.extension!r}: allowed 'model', 'none' or f(design, Q) -> mm")
        if self.wall_thinning not in ("average", "local", "none"):
            raise ValueError(f"BeamModel.wall_thinning = {self.wall_thinning!r}: allowed 'average', 'local', 'none'")
        _check_range("BeamModel.thinning_x0", self.thinning_x0, 0.0, None)
        _check_range("BeamModel.calibration", self.calibration, 0.0, None, lo_open=True)
        _check_range("BeamModel.epsrel", self.epsrel, 1e-15, 1e-3)

    # convenience delegates --------------------------------------------------
    def geometry(self, design: WhiskerDesign, Q: float = 0.0) -> "PressurisedGeometry":
        return pressurised_geometry(design, Q, self)

    def deflection_at_contact(self, design: WhiskerDesign, P: float, a: float, Q: float = 0.0) -> float:
        return deflection_at_contact(design, P, a, Q, model=self)

    def gauge_strain(self, design: WhiskerDesign, P: float, a: float, Q: float = 0.0) -> float:
        return gauge_strain(design, P, a, Q, model=self)

    def sensitivity(self, design: WhiskerDesign, a: float = 1.0, Q: float = 0.0) -> float:
        return sensitivity(design, a, Q, model=self)


DEFAULT_MODEL = BeamModel()


# --------------------------------------------------------------------------- sections
def second_moment(design: WhiskerDesign, x, mode: TubeMode = "exact", wall=None):
    """Second moment of area I(x) [mm⁴] of the section at reference position x.

    Solid for x < c and x > l, (8.2) ``π d⁴/64``; on the chamber c <= x <= l the tube of
    (8.3) ``π (d_o⁴ - d_i⁴)/64`` (mode 'exact'), (8.4) ``(π/8) d̄³ t``, d̄ = d_o - t
    (mode 'thin'), or solid (mode 'solid'). 

    Parameters
    ----------
    design : WhiskerDesign
    x : float or array_like
        Reference axial positions [mm].
    mode : {'exact', 'thin', 'solid'}
    wall : float, array_like or None
        Wall thickness to use in the chamber (broadcast with x); default ``design.t``.

    Returns
    -------
    float or ndarray
        I(x), same shape as x.
    """
    if mode not in ("exact", "thin", "solid"):
        raise ValueError(f"mode = {mode!r}: allowed 'exact', 'thin', 'solid'")
    xa = np.asarray(x, dtype=float)
    ro = np.asarray(design.r_outer(xa), dtype=float)  # (...)
    solid = np.pi * ro**4 / 4.0  # π d⁴/64 with d = 2 r_o
    if mode == "solid":
        out = solid
    else:
        w = np.broadcast_to(np.asarray(design.t if wall is None else wall, dtype=float), xa.shape)
        ri = ro - w
        if mode == "exact":
            tube = np.pi * (ro**4 - ri**4) / 4.0  # π (d_o⁴ - d_i⁴)/64
        else:
            dbar = 2.0 * ro - w  # d̄ = d_o - t
            tube = np.pi / 8.0 * dbar**3 * w
        in_chamber = (xa >= design.c) & (xa <= design.l)
        out = np.where(in_chamber, tube, solid)
    return float(out) if out.ndim == 0 else out


def thin_tube_relative_error(design: WhiskerDesign, x, wall=None):
    """Relative error of the thin-tube second moment, ``I_thin / I_exact - 1``.

    Computed from :func:`second_moment`. Closed form (see module docstring):
    ``-t² / (d̄² + t²)`` with d̄ = 2 r_o(x) - t; see :func:`thin_tube_relative_error_formula`.
    """
    return second_moment(design, x, "thin", wall) / second_moment(design, x, "exact", wall) - 1.0


def thin_tube_relative_error_formula(design: WhiskerDesign, x):
    """Closed form ``-t² / (d̄² + t²)``, d̄ = d_o - t, of (8.4)/(8.3) - 1.

    From d_o⁴ - d_i⁴ = (d_o - d_i)(d_o + d_i)(d_o² + d_i²) = 2t · 2d̄ · 2(d̄² + t²).
    """
    dbar = 2.0 * np.asarray(design.r_outer(x), dtype=float) - design.t
    out = -design.t**2 / (dbar**2 + design.t**2)
    return float(out) if np.ndim(out) == 0 else out


# --------------------------------------------------------------------------- pressurised geometry
@dataclass(frozen=True, eq=False)
class PressurisedGeometry:
    """The beam geometry of one design at pressure Q.

    All positions ``xi`` are material (reference) coordinates of the unpressurised whisker;
    ``position(xi)`` gives the pressurised axial position.

    Attributes
    ----------
    design, model : WhiskerDesign, BeamModel
    Q : float
        Chamber pressure [MPa].
    k, E2 : float
        Softening factor and chamber modulus E₂ = k E [MPa] (8.10).
    force : float
        Axial force on the chamber end F = Q π d_m²/4 [N] (8.7).
    cavity_diameter : float
        d_m = 2 r_i(l) [mm].
    compliance : float
        ∫_c^l dξ / A(ξ) [1/mm] (8.8).
    delta_l_end : float
        Chamber extension Δl(l) [mm].
    length : float
        Pressurised length L_Q = L - Δ + Δl(l) [mm].
    thinning : float
        Uniform wall thinning Δt [mm] ('average' or 'none'); NaN for 'local'.
    """

    design: WhiskerDesign
    model: BeamModel
    Q: float
    k: float
    E2: float
    force: float
    cavity_diameter: float
    compliance: float
    delta_l_end: float
    length: float
    thinning: float
    _profile: Chebyshev = field(repr=False)

    # ----- axial map
    def _area(self, xi):
        """Chamber wall area A = π (r_o² - r_i²) with the unpressurised t (8.8)."""
        ro = np.asarray(self.design.r_outer(xi), dtype=float)
        ri = ro - self.design.t
        return np.pi * (ro**2 - ri**2)

    def delta_l(self, xi):
        """Δl(ξ) (8.8): 0 for ξ <= c, Δl(l)·g(ξ)/g(l) on the chamber, Δl(l) beyond l."""
        d = self.design
        xa = np.asarray(xi, dtype=float)
        if self.delta_l_end == 0.0:
            return np.zeros_like(xa) if xa.ndim else 0.0
        g = self._profile(np.clip(xa, d.c, d.l)) / self.compliance
        out = self.delta_l_end * np.clip(g, 0.0, 1.0)
        out = np.where(xa <= d.c, 0.0, np.where(xa >= d.l, self.delta_l_end, out))
        return float(out) if out.ndim == 0 else out

    def stretch(self, xi):
        """Axial stretch λ = dx/dξ = 1 + Δl(l) / (g(l) A(ξ)) in the chamber, 1 elsewhere."""
        d = self.design
        xa = np.asarray(xi, dtype=float)
        lam = 1.0 + self.delta_l_end / (self.compliance * self._area(xa))
        out = np.where((xa >= d.c) & (xa <= d.l), lam, 1.0)
        return float(out) if out.ndim == 0 else out

    def position(self, xi):
        """Pressurised position x(ξ) = ξ + Δl(ξ)."""
        out = np.asarray(xi, dtype=float) + self.delta_l(xi)
        return float(out) if out.ndim == 0 else out

    def material_coordinate(self, x: float) -> float:
        """Inverse of :meth:`position` (scalar)."""
        d = self.design
        x = float(x)
        if x <= d.c or self.delta_l_end == 0.0:
            return x
        if x >= d.l + self.delta_l_end:
            return x - self.delta_l_end
        return float(optimize.brentq(lambda s: self.position(s) - x, d.c, d.l, xtol=1e-14, rtol=1e-14))

    # ----- sections
    def wall(self, xi):
        """Chamber wall thickness t' = t - Δt (8.9)."""
        d = self.design
        if self.model.wall_thinning == "local":
            return d.t - self.model.nu * self.delta_l_end * np.asarray(d.r_outer(xi)) / (d.l - d.c)
        return d.t - self.thinning + 0.0 * np.asarray(xi, dtype=float)

    def second_moment(self, xi):
        """I(ξ) with the model's tube mode and the thinned wall."""
        return second_moment(self.design, xi, self.model.tube_I, self.wall(xi))

    def modulus(self, xi):
        """E_k: E₂ on the chamber c <= ξ <= l, E elsewhere."""
        d = self.design
        xa = np.asarray(xi, dtype=float)
        out = np.where((xa >= d.c) & (xa <= d.l), self.E2, self.model.E)
        return float(out) if out.ndim == 0 else out

    def flexural_rigidity(self, xi):
        """E_k I(ξ) [N mm²]."""
        return self.modulus(xi) * self.second_moment(xi)

    @property
    def breakpoints(self) -> tuple[float, float]:
        """Material section changes (c, l) where the integrands are not smooth."""
        return (self.design.c, self.design.l)


def pressurised_geometry(design: WhiskerDesign, Q: float = 0.0, model: BeamModel | None = None) -> PressurisedGeometry:
    """Build the beam geometry of ``design`` at chamber pressure Q.

    Parameters
    ----------
    design : WhiskerDesign
        Validated on entry (its ``trim`` sets the length L - Δ).
    Q : float
        Pressure [MPa], >= 0 and within the softening law's range.
    model : BeamModel, optional

    Returns
    -------
    PressurisedGeometry
    """
    model = DEFAULT_MODEL if model is None else model
    design.validate()
    Q = _check_range("Q", Q, 0.0, None)
    d = design
    k = float(model.softening(Q)) if (Q > 0.0 or model.soften_unpressurised) else 1.0
    _check_range("k(Q) (softening)", k, 0.0, None, lo_open=True)
    E2 = k * model.E
    d_m = 2.0 * float(d.r_inner(d.l))
    force = Q * math.pi * d_m**2 / 4.0  # (8.7)

    def inv_area(xi):
        ro = np.asarray(d.r_outer(xi), dtype=float)
        return 1.0 / (np.pi * (ro**2 - (ro - d.t) ** 2))

    # g(ξ) = ∫_c^ξ dη/A(η): Chebyshev interpolant of the analytic 1/A, integrated exactly;
    # g(l) cross-checked against quad.
    profile = Chebyshev.interpolate(inv_area, deg=40, domain=[d.c, d.l]).integ(lbnd=d.c)
    G, _ = integrate.quad(lambda s: float(inv_area(s)), d.c, d.l, epsabs=0.0, epsrel=1e-13)
    if abs(profile(d.l) - G) > 1e-9 * G:  # pragma: no cover - 1/A is analytic on [c, l]
        logger.warning("chamber compliance profile inaccurate: Chebyshev %.15g vs quad %.15g", profile(d.l), G)

    if model.extension == "model":
        dl = force * G / E2  # (8.8) at ξ = l
    elif model.extension == "none":
        dl = 0.0
    else:
        dl = float(model.extension(design, Q))
        if not math.isfinite(dl) or dl <= -(d.l - d.c):
            raise ValueError(f"extension(design, Q={Q:g}) = {dl!r} mm: allowed finite > -(l - c) = {-(d.l - d.c):g}")

    if model.wall_thinning == "average":  # thesis: mean of (8.9) at x = 2.5 and x = l
        dt = model.nu * dl * 0.5 * (d.r_outer(model.thinning_x0) + d.r_outer(d.l)) / (d.l - d.c)
    elif model.wall_thinning == "local":
        dt = float("nan")
    else:
        dt = 0.0
    dt_max = dt if model.wall_thinning != "local" else model.nu * dl * d.r_outer(d.c) / (d.l - d.c)
    if not d.t - dt_max > 0.0:
        raise ValueError(
            f"Q = {Q:g} MPa thins the wall t = {d.t:g} mm by {dt_max:.4g} mm (Poisson): "
            f"no wall left; allowed Q with Δt < t"
        )
    geo = PressurisedGeometry(
        design=d, model=model, Q=Q, k=k, E2=E2, force=force, cavity_diameter=d_m, compliance=G,
        delta_l_end=dl, length=d.length + dl, thinning=dt, _profile=profile,
    )
    logger.debug("beam geometry %s Q=%g: k=%.4g F=%.4g N dl=%.4g mm L_Q=%.4g", d.describe(), Q, k, force, dl, geo.length)
    return geo


def chamber_extension(design: WhiskerDesign, Q: float, model: BeamModel | None = None) -> float:
    """Chamber extension Δl(l) [mm] at pressure Q, (8.7)-(8.8) or the model's user Δl."""
    return pressurised_geometry(design, Q, model).delta_l_end


# --------------------------------------------------------------------------- integrators
def _segments(lo: float, hi: float, breakpoints: Sequence[float]) -> list[tuple[float, float]]:
    pts = sorted({lo, hi, *[float(b) for b in breakpoints if lo < b < hi]})
    return list(zip(pts[:-1], pts[1:]))


def castigliano_deflection(
    x_load: float,
    flexural_rigidity: Callable[[float], float],
    P: float = 1.0,
    *,
    breakpoints: Sequence[float] = (),
    position: Callable[[float], float] | None = None,
    stretch: Callable[[float], float] | None = None,
    xi_load: float | None = None,
    epsrel: float = 1e-12,
) -> float:
    """Deflection under a point load of a clamped beam, Castigliano's theorem.

    ``δ = ∫_0^{ξ_P} M (∂M/∂P) / EI dx = P ∫_0^{ξ_P} (x_P - x(ξ))² λ(ξ) / EI(ξ) dξ``

    Parameters
    ----------
    x_load : float
        Load position x_P (current coordinate) [mm].
    flexural_rigidity : callable
        EI(ξ) [N mm²], scalar in, scalar out.
    P : float
        Load [N].
    breakpoints : sequence of float
        Points where EI is not smooth (``quad`` is run piecewise between them).
    position, stretch : callable, optional
        x(ξ) and λ(ξ) = dx/dξ; identity and 1 by default.
    xi_load : float, optional
        Material coordinate of the load; default ``x_load``.
    epsrel : float
        ``quad`` relative tolerance.

    Returns
    -------
    float
        δ [mm].
    """
    P = _check_range("P", P)
    xi_p = float(x_load if xi_load is None else xi_load)
    _check_range("x_load", x_load, 0.0, None, lo_open=True)
    pos = position if position is not None else (lambda s: s)
    lam = stretch if stretch is not None else (lambda s: 1.0)

    def f(s):
        arm = x_load - pos(s)
        return arm * arm * lam(s) / flexural_rigidity(s)

    total = 0.0
    for lo, hi in _segments(0.0, xi_p, breakpoints):
        val, err = integrate.quad(f, lo, hi, epsabs=0.0, epsrel=epsrel, limit=200)
        total += val
    return P * total


def mean_surface_strain(
    x_load: float,
    flexural_rigidity: Callable[[float], float],
    y: Callable[[float], float],
    span: tuple[float, float],
    P: float = 1.0,
    *,
    position: Callable[[float], float] | None = None,
    stretch: Callable[[float], float] | None = None,
    epsrel: float = 1e-12,
) -> float:
    """Bending strain at distance y from the neutral axis, averaged over a material span.

    ``ε(ξ) = y(ξ) M(ξ) / EI(ξ)``, ``M = P max(x_P - x(ξ), 0)``;
    ``ε̄ = ∫ ε λ dξ / ∫ λ dξ`` over ``span`` (the mean over the current gauge length).
    """
    P = _check_range("P", P)
    x0, x1 = float(span[0]), float(span[1])
    if not x1 > x0:
        raise ValueError(f"span = {span!r}: need span[0] < span[1]")
    pos = position if position is not None else (lambda s: s)
    lam = stretch if stretch is not None else (lambda s: 1.0)

    def f(s):
        return y(s) * max(x_load - pos(s), 0.0) * lam(s) / flexural_rigidity(s)

    num = sum(integrate.quad(f, lo, hi, epsabs=0.0, epsrel=epsrel, limit=200)[0] for lo, hi in _segments(x0, x1, ()))
    den = integrate.quad(lam, x0, x1, epsabs=0.0, epsrel=epsrel, limit=200)[0]
    return P * num / den


# --------------------------------------------------------------------------- the whisker
def _contact(geo: PressurisedGeometry, a: float) -> tuple[float, float]:
    a = _check_range("a", a, 0.0, 1.0, lo_open=True)
    x_p = a * geo.length
    return x_p, geo.material_coordinate(x_p)


def deflection_at_contact(design: WhiskerDesign, P: float, a: float, Q: float = 0.0,
                          model: BeamModel | None = None) -> float:
    """Deflection δ [mm] at the contact x_P = a·L_Q under the load P [N].

    Parameters
    ----------
    design : WhiskerDesign
    P : float
        Contact force [N].
    a : float
        Contact ratio in (0, 1]; a = 1 is the (pressurised) tip.
    Q : float
        Chamber pressure [MPa]; 0 = normal mode.
    model : BeamModel, optional
    """
    geo = pressurised_geometry(design, Q, model)
    return _deflection(geo, P, a)


def _deflection(geo: PressurisedGeometry, P: float, a: float) -> float:
    x_p, xi_p = _contact(geo, a)
    return castigliano_deflection(
        x_p, geo.flexural_rigidity, P, breakpoints=geo.breakpoints, position=geo.position,
        stretch=geo.stretch, xi_load=xi_p, epsrel=geo.model.epsrel,
    )


def gauge_strain(design: WhiskerDesign, P: float, a: float, Q: float = 0.0,
                 model: BeamModel | None = None) -> float:
    """Uncalibrated gauge strain ε̄ (8.6) for the load P [N] at x_P = a·L_Q.

    y = r_o (outer surface, the +y side stretches when pushed in -y), E₂ I₂ of the chamber,
    mean over the material gauge span [x_ss, x_ss + e]. Positive for P > 0.
    """
    geo = pressurised_geometry(design, Q, model)
    return _gauge(geo, P, a)


def _gauge(geo: PressurisedGeometry, P: float, a: float) -> float:
    d = geo.design
    x_p, _ = _contact(geo, a)
    return mean_surface_strain(
        x_p, geo.flexural_rigidity, d.r_outer, (d.x_ss, d.x_ss + d.e), P,
        position=geo.position, stretch=geo.stretch, epsrel=geo.model.epsrel,
    )


def sensitivity(design: WhiskerDesign, a: float = 1.0, Q: float = 0.0, model: BeamModel | None = None) -> float:
    """Gauge sensitivity ``ξ · ε̄ / δ`` [1/mm] at contact ratio a and pressure Q.

    Independent of P and of E (only E₂/E = k(Q) enters). ξ = ``model.calibration``
    (1 by default; ``scene.calibration`` = 3.9 for the FE strains).
    """
    geo = pressurised_geometry(design, Q, model)
    return geo.model.calibration * _gauge(geo, 1.0, a) / _deflection(geo, 1.0, a)


def sensitivity_grid(design: WhiskerDesign, a_values, Q_values, model: BeamModel | None = None) -> np.ndarray:
    """ε/δ on the grid a × Q, shape ``(len(a_values), len(Q_values))`` (one geometry per Q)."""
    a_arr = np.atleast_1d(np.asarray(a_values, dtype=float))
    q_arr = np.atleast_1d(np.asarray(Q_values, dtype=float))
    out = np.empty((a_arr.size, q_arr.size))  # (n_a, n_Q)
    for j, q in enumerate(q_arr):
        geo = pressurised_geometry(design, q, model)
        for i, a in enumerate(a_arr):
            out[i, j] = geo.model.calibration * _gauge(geo, 1.0, a) / _deflection(geo, 1.0, a)
    return out


@dataclass(frozen=True)
class BeamResponse:
    """The beam model as a response function ``(design, Q, deltas) -> ε(δ)`` (linear in δ).

    Stand-in for the FE scene in :mod:`whisker_opt.analysis.compensation`: ``ε = S(design, a, Q) · δ``.
    """

    model: BeamModel = DEFAULT_MODEL
    a: float = 1.0

    def __call__(self, design: WhiskerDesign, Q: float, deltas) -> np.ndarray:
        return sensitivity(design, self.a, Q, self.model) * np.asarray(deltas, dtype=float)


@dataclass(frozen=True)
class BeamSensitivity:
    """The beam model as a sensitivity function ``(design, a, Q) -> ε/δ`` (for comparisons)."""

    model: BeamModel = DEFAULT_MODEL

    def __call__(self, design: WhiskerDesign, a: float, Q: float) -> float:
        return sensitivity(design, a, Q, self.model)
