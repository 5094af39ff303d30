"""The named mechanisms of the chamber wall: how the fibre is bonded, what the rubber is, what the fibre is.

A :class:`WallMechanism` is one variant of the wall cell (:mod:`whisker_opt.wallcell.cell`); every field is a
modelling choice with its data source:

bond
    ``bonded``: fibre and rubber share their nodes (a perfect bond, the thesis' FE idealisation).
    ``sliding``: the fibre slides freely along its own axis (the hoop) against the rubber, its section
    held in the rubber's trench (frictionless, normal contact kept): the thesis wound the fibre in a
    trench "without twisting or tightening" and coated it over; silicone bonds poorly to polymer fibres
    unless primed. ``layer``: a compliant interface layer of ``layer_thickness`` and
    ``layer_shear_modulus`` around the fibre (a weak or partly debonded interphase).
rubber, rubber_outer
    The body's law (``neo_hookean`` with ``c10``, the thesis' FE value C10 = 0.14 MPa, or another law of
    :data:`whisker_opt.experiment.rubber_laws.RUBBER_LAWS`, by name); ``rubber_outer`` the coat outside the
    fibre radius (``same`` = the body's): the thesis moulded an inner layer, wound the fibre, then coated it.
section, fibre_law, fibre_modulus, fibre_poisson
    ``round`` (the fibre as made) or ``square`` of equal area (the 3-D cell's section); ``band``: the ring's
    E_f A_f spread along the hoop over a band of the square's width the whole length of the cell (a sleeve,
    a cross-check of the 3-D cell). ``solid``: the
    section is an isotropic compressible solid of E_f, ν_f (small-strain limit of a neo-Hookean law).
    ``hoop``: rubber carrying E_f along the hoop only (one mean fibre strain per element), as the 3-D
    reference cell modelled it. ``none``: the section is rubber (the bare tube, a check). E_f = 31 067 MPa is the thesis' FE value (an aramid's, per its source);
    :data:`NYLON_MODULUS` a nylon 6,6 monofilament's.
fibre_offset
    Distance of the fibre's centre from the cavity [mm]; None keeps the design's fibre radius (mid-wall by
    default). The thesis wound the fibre in a trench of the inner layer; its depth is not stated.
thrust, plane
    Definitions, not physics: the closed-end thrust on the current cavity area (``current``) or on the
    reference one, and the end plane rotated about current or reference positions. ``reference`` for both
    reproduces the 3-D reference cell's loading (:mod:`whisker_opt.wallcell.cell`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from geometry.materials import FIBRE_MODULUS, FIBRE_POISSON, RUBBER_C10

#: Young's modulus of a drawn nylon 6,6 monofilament [MPa]: Callister & Rethwisch, *Materials Science and
#: Engineering*, Appendix B, give 1 590–3 790 MPa for nylon 6,6 (ν = 0.39); a drawn monofilament sits in the
#: upper part of that range. The thesis' FE value 31 067 MPa, ν = 0.36, is an aramid fibre's.
NYLON_MODULUS = 3000.0
NYLON_POISSON = 0.39
#: The thesis' FE fibre: E = 31 067 MPa, ν = 0.36 (:mod:`geometry.materials`).
THESIS_FIBRE_MODULUS = FIBRE_MODULUS
THESIS_FIBRE_POISSON = FIBRE_POISSON

BONDS = ("bonded", "sliding", "layer")
SECTIONS = ("round", "square", "band")
FIBRE_LAWS = ("solid", "hoop", "none")
THRUSTS = ("current", "reference")


@dataclass(frozen=True)
class WallMechanism:
    """One variant of the wall's physics (see the module docstring for each field's source)."""

    name: str = "bonded"
    bond: str = "bonded"
    layer_thickness: float = 0.05
    layer_shear_modulus: float = 0.028
    rubber: str = "neo_hookean"
    rubber_outer: str = "same"
    c10: float = RUBBER_C10
    section: str = "round"
    fibre_law: str = "solid"
    fibre_modulus: float = THESIS_FIBRE_MODULUS
    fibre_poisson: float = THESIS_FIBRE_POISSON
    thrust: str = "current"
    plane: str = "current"
    fibre_offset: float | None = None

    def __post_init__(self) -> None:
        for field, value, allowed in (("bond", self.bond, BONDS), ("section", self.section, SECTIONS),
                                      ("fibre_law", self.fibre_law, FIBRE_LAWS), ("thrust", self.thrust, THRUSTS),
                                      ("plane", self.plane, THRUSTS)):
            if value not in allowed:
                raise ValueError(f"WallMechanism.{field}={value!r}: allowed {', '.join(allowed)}")
        for field, value, lo, hi in (("layer_thickness", self.layer_thickness, 1e-4, 1.0),
                                     ("layer_shear_modulus", self.layer_shear_modulus, 1e-5, 1e3),
                                     ("c10", self.c10, 1e-6, 10.0), ("fibre_modulus", self.fibre_modulus, 1.0, 1e6),
                                     ("fibre_poisson", self.fibre_poisson, 0.0, 0.49)):
            if not (isinstance(value, (int, float)) and lo <= value <= hi):
                raise ValueError(f"WallMechanism.{field}={value!r} outside [{lo}, {hi}]")
        if self.fibre_offset is not None and not 0.0 < self.fibre_offset < 50.0:
            raise ValueError(f"WallMechanism.fibre_offset={self.fibre_offset!r} outside (0, 50) mm")
        if self.section == "band" and self.fibre_law != "hoop":
            raise ValueError("WallMechanism.section='band' needs fibre_law='hoop'")

    def with_(self, **changes) -> "WallMechanism":
        return replace(self, **changes)


def _variants() -> dict[str, WallMechanism]:
    base = WallMechanism()
    out = [
        base,
        base.with_(name="sliding", bond="sliding"),
        base.with_(name="layer", bond="layer"),
        base.with_(name="nylon", fibre_modulus=NYLON_MODULUS, fibre_poisson=NYLON_POISSON),
        base.with_(name="sliding_nylon", bond="sliding", fibre_modulus=NYLON_MODULUS, fibre_poisson=NYLON_POISSON),
        base.with_(name="square", section="square"),
        base.with_(name="hoop", section="square", fibre_law="hoop"),
        base.with_(name="fibre_inner", fibre_offset=0.29),
        base.with_(name="yeoh_ds30", rubber="yeoh_dragon_skin_30"),
        base.with_(name="yeoh_ds10", rubber="yeoh_dragon_skin_10"),
        base.with_(name="ecoflex", rubber="yeoh_ecoflex_00_30"),
    ]
    return {m.name: m for m in out}


#: The variants of the wall-law study, by name (read-only use).
VARIANTS: dict[str, WallMechanism] = _variants()
