"""``yeoh_<silicone>``: two-term Yeoh laws of named silicones, W = C10 (Ī1 − 3) + C20 (Ī1 − 3)² (Yeoh 1993).

Each law has its own constants (C10, C20) [MPa]; the material section's C10 is not read, its D1 is. Each pair
passes exactly through the two uniaxial points of the manufacturer's technical bulletin (Smooth-On,
ASTM D412): the 100 % modulus at λ = 2 and the tensile strength at the elongation at break; fitted by
``benchmarks/studies/fit_rubber_tds.py`` (which prints these numbers), from Dragon Skin 30: σ100 = 86 psi,
500 psi at 364 %; Dragon Skin 10 Medium: 22 psi, 475 psi at 1000 %; Ecoflex 00-30 (the Shore 00-30 grade):
10 psi, 200 psi at 900 %. The energy is the solver's :class:`fem.material.Yeoh` (docs/physics.md §1).
"""

from __future__ import annotations

ORDER = 1  # place in the registry

#: The fits of the manufacturer's technical bulletin.
_TDS = "Smooth-On technical bulletin (ASTM D412), fit by benchmarks/studies/fit_rubber_tds.py"

#: The registered names: ``name -> ((C10, C20) [MPa], source)``.
LAWS: dict[str, tuple[tuple[float, ...], str]] = {
    "yeoh_dragon_skin_30": ((0.14514, 6.0678e-3), _TDS),
    "yeoh_dragon_skin_10": ((0.041520, 4.5462e-4), _TDS),
    "yeoh_ecoflex_00_30": ((0.018663, 2.5902e-4), _TDS),
}


def make(constants: tuple, c10: float, d1: float):
    """W = Σ_k C_k0 (Ī1 − 3)^k with the law's own constants (C10, C20, ...) = ``constants``
    (:class:`fem.material.Yeoh`); ``c10`` is not read."""
    from fem.material import Yeoh

    return Yeoh(tuple(constants), d1)
