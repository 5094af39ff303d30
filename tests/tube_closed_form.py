"""The closed-end thick tube of incompressible neo-Hookean rubber under internal pressure (exact, by quadrature).

Kinematics r² = a² + (R² − A²)/λ (axial stretch λ); radial equilibrium gives
P = ∫_a^b μ(λθ² − λr²) dr/r, and the closed end sets the wall's axial force to P π a²
(Ogden, *Non-linear Elastic Deformations*, §5.3). Used by the harmonic-solid and wall-cell tests.
"""

from __future__ import annotations

import math

from scipy.integrate import quad
from scipy.optimize import brentq


def closed_end_tube(lam_a: float, A: float, B: float, mu: float) -> tuple[float, float]:
    """(P, λ) of the closed-end tube A < R < B at cavity stretch ``lam_a``."""
    def state(lam):
        a = lam_a * A
        b = math.sqrt(a * a + (B * B - A * A) / lam)

        def stretches(r):
            R = math.sqrt(A * A + lam * (r * r - a * a))
            lt = r / R
            return lt, 1.0 / (lam * lt)

        def hoop(r):
            lt, lr = stretches(r)
            return mu * (lt**2 - lr**2) / r

        P = quad(hoop, a, b, epsabs=1e-13, epsrel=1e-12)[0]

        def szz(r):  # σ_zz = σ_rr + μ(λ² − λr²), σ_rr(r) = −P + ∫_a^r (σθθ − σrr)/r
            _, lr = stretches(r)
            srr = -P + quad(hoop, a, r, epsabs=1e-13, epsrel=1e-12)[0]
            return (srr + mu * (lam**2 - lr**2)) * 2 * math.pi * r

        return P, quad(szz, a, b, epsabs=1e-12, epsrel=1e-11)[0] - P * math.pi * a * a

    lam = brentq(lambda v: state(v)[1], 0.5, 4.0, xtol=1e-14)
    return state(lam)[0], lam
