"""``compliant``: the cap joined to the body through a compliant bond layer, smeared through the cap's thickness.

The prototype's cap is a separate layer of Dragon Skin 30 moulded onto the chamber end around the air hose, and
the gauge's neighbourhood was covered by silicone glue; where the cap meets the body there may be a bond layer
softer than either part (a thin layer of silicone glue, or a weak interphase of two castings). Such a layer of
stiffness per area k_j = ``material.cap_joint_k`` [N/mm³] (μ_j/h_j of a layer of shear modulus μ_j and
thickness h_j) acts in series with the cap of thickness c = ``design.c`` through which the base holds the body.

The idealisation (a joint smeared over the cap): the cap's moduli are scaled by s so that a slab of the
scaled cap is as compliant through its thickness as the cap and the joint in series,

    c / (E_cap s) = c / E_cap + 1 / k_j   ⇒   s = 1 / (1 + E_cap / (k_j c)),   E_cap = 3 μ_cap,

μ_cap the cap law's initial shear modulus (an incompressible rubber; the bulk term is not scaled, so the layer
stays nearly incompressible, as a silicone glue is). Exact for a uniform stress through the cap's thickness (a
bar in tension: a test checks the series extension); the cap's in-plane stiffness is lowered by the same s,
which a thin joint would not do, so the mechanism is an upper bound on a joint of that k_j. One k_j for the
normal and the shear compliance: a thin bonded layer is much stiffer in compression (Gent & Lindley 1959) than in
shear, so the shear value μ_j/h_j is the one to give.

Range of k_j (an **estimate**; no measurement of the prototype's joint exists): a silicone adhesive layer of
μ_j ≈ 0.2-0.5 MPa (room-temperature-vulcanising silicones, shore 20A-40A; Gent 2001, *Engineering with
Rubber*, ch. 1) and h_j ≈ 0.05-0.5 mm gives k_j ≈ 0.4-10 N/mm³; the default, 2 N/mm³, is μ_j = 0.3 MPa over
0.15 mm. At k_j → ∞ the joint is the ``tied`` cap (a test checks it).
"""

from __future__ import annotations

from typing import Mapping

NAME = "compliant"
ORDER = 1
DESCRIPTION = "the cap joined through a compliant bond layer of stiffness cap_joint_k per area, smeared over the cap"
PARAMETERS: tuple[str, ...] = ("cap_joint_k",)

#: Default stiffness per area of the joint [N/mm³]: μ_j = 0.3 MPa over h_j = 0.15 mm (docstring).
K_DEFAULT = 2.0
#: Estimated range of a silicone-glue joint [N/mm³] (docstring).
K_ESTIMATE: tuple[float, float] = (0.4, 10.0)
#: What the run file allows [N/mm³]: (lower bound, excluded; upper bound).
K_RANGE: tuple[float, float] = (0.0, 1e4)


def factor(values: Mapping[str, float], c: float, mu: float) -> float:
    """s = 1 / (1 + 3 μ_cap / (k_j c)) (docstring); ``values['cap_joint_k']`` = k_j [N/mm³], ``c`` [mm] the cap's
    thickness, ``mu`` [MPa] its law's initial shear modulus."""
    k = float(values["cap_joint_k"])
    if not (k > 0.0 and c > 0.0 and mu > 0.0):
        raise ValueError(f"cap joint 'compliant': k_j = {k}, c = {c}, μ = {mu}; each must be > 0")
    return 1.0 / (1.0 + 3.0 * mu / (k * c))
