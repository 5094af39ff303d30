"""Two-term Yeoh constants of the silicones in :data:`whisker_opt.experiment.rubber_laws.RUBBER_LAWS`,
fitted to the manufacturer's published uniaxial data points.

Data (Smooth-On technical bulletins of Dragon Skin™ 10 Medium / 30 and Ecoflex™ 00-30, ASTM D412
die C): the 100 % modulus σ₁₀₀ (nominal stress at stretch λ = 2), the tensile strength σ_b and the
elongation at break e_b (so λ_b = 1 + e_b). These are the only uniaxial points the sheets publish.
The sheets' 100 % moduli and elongations are also listed, e.g., in public material tables of soft-
robotics codes; the tensile strengths are quoted from the sheets as published (check them against
the current sheet before relying on the fit at large stretch).

Model (incompressible uniaxial tension of a Yeoh solid, W = C10 (I1 − 3) + C20 (I1 − 3)², Yeoh
1993; nominal stress P = ∂W/∂λ along the load)::

    I1 = λ² + 2/λ,     P(λ) = 2 (λ − λ⁻²) [C10 + 2 C20 (I1 − 3)]

Two points, two constants: the two equations are linear in (C10, C20) and are solved exactly
(an interpolating fit, not a least-squares one). Prints the constants shipped in
``RUBBER_LAWS`` and checks they reproduce both points.

Run: ``python3 -m benchmarks.studies.fit_rubber_tds``
"""

from __future__ import annotations

import argparse

import numpy as np

PSI = 6.894757293168361e-3  # MPa per psi

#: name: (σ100 [psi], tensile strength [psi], elongation at break [%]); Smooth-On technical bulletins
TDS = {
    "dragon_skin_30": (86.0, 500.0, 364.0),
    "dragon_skin_10": (22.0, 475.0, 1000.0),
    "ecoflex_00_30": (10.0, 200.0, 900.0),
}


def yeoh_uniaxial_nominal(lam, c10: float, c20: float):
    """P(λ) = 2 (λ − λ⁻²) [C10 + 2 C20 (I1 − 3)], I1 = λ² + 2/λ (incompressible uniaxial tension)."""
    lam = np.asarray(lam, dtype=float)
    i1 = lam**2 + 2.0 / lam
    return 2.0 * (lam - lam**-2) * (c10 + 2.0 * c20 * (i1 - 3.0))


def fit(s100_psi: float, sb_psi: float, eb_pct: float) -> tuple[float, float]:
    """(C10, C20) [MPa] through (λ = 2, σ100) and (λ_b, σ_b)."""
    lams = np.array([2.0, 1.0 + eb_pct / 100.0])
    P = np.array([s100_psi, sb_psi]) * PSI
    i1 = lams**2 + 2.0 / lams
    g = 2.0 * (lams - lams**-2)  # (2,)
    A = np.stack([g, g * 2.0 * (i1 - 3.0)], axis=1)  # (2, 2)
    c10, c20 = np.linalg.solve(A, P)
    return float(c10), float(c20)


def main(argv: list[str] | None = None) -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    from whisker_opt.experiment.rubber_laws import RUBBER_LAWS

    print(f"{'material':<16} {'C10 [MPa]':>10} {'C20 [MPa]':>11} {'mu [MPa]':>9} {'shipped C10, C20':>22} "
          f"{'P(2) [MPa]':>10} {'P(l_b) [MPa]':>12}")
    for name, (s100, sb, eb) in TDS.items():
        c10, c20 = fit(s100, sb, eb)
        shipped = RUBBER_LAWS[f"yeoh_{name}"].constants
        p2, pb = yeoh_uniaxial_nominal([2.0, 1.0 + eb / 100.0], *shipped)
        print(f"{name:<16} {c10:10.5f} {c20:11.3e} {2 * c10:9.4f} {shipped[0]:>10.5f}, {shipped[1]:.3e} "
              f"{p2:10.4f} {pb:12.4f}")


if __name__ == "__main__":
    main()
