"""The whisker design: every geometric and fibre parameter, and its checks.

Geometry, a truncated cone along +x, base face at x = 0::

    r_o(x) = D/2 - x tan(alpha)          outer radius,           0 <= x <= L - trim
    r_i(x) = r_o(x) - t                  cavity radius,          c <= x <= l

Region 1 (0..c) is a solid cap, region 2 (c..l) a conical tube with a flat-ended
cavity, region 3 (l..L - trim) a solid cone. A trimmed whisker is the same design
with its tip cut at ``length = L - trim``.

Fibres: ``n_fibres`` helices of pitch ``fibre_pitch`` over c..l, evenly
rotated (2 fibres = double helix, second rotated by 180 deg), at the radius

    r_f(x) = r_i(x) + fibre_radius_frac * t

(0 = on the cavity surface, 0.5 = mid-wall, 1 = on the outer surface).

:meth:`WhiskerDesign.validate` refuses designs that are not a whisker, raising
:class:`InvalidDesignError` (a ``ValueError``) whose one-line message names every
violated relation with the parameters and their values.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass

import numpy as np

from geometry.errors import GeometryError
from geometry.materials import FIBRE_DIAMETER, FIBRE_MODULUS, FIBRE_POISSON


class InvalidDesignError(ValueError, GeometryError):
    """A parameter set that does not describe a whisker.

    Attributes
    ----------
    violations : tuple[str, ...]
        One entry per violated relation, each naming the parameters and their values.
    parameters : tuple[str, ...]
        Names of all parameters involved in a violation (sorted, unique).
    """

    def __init__(self, violations: list[str], parameters: set[str]) -> None:
        self.violations = tuple(violations)
        self.parameters = tuple(sorted(parameters))
        super().__init__("invalid whisker design: " + "; ".join(violations))


def parameter(default, unit: str, doc: str, choices: tuple | None = None, key: str | None = None,
              listed: str | None = None, **bounds: float):
    """A dataclass field a user sets: its default, unit, meaning and allowed values, declared once.

    The sections of a run file (:mod:`whisker_opt.config.model`) are generated from the fields
    declared with it (:func:`user_parameters`), and the configuration reference from those.

    Parameters
    ----------
    default : float, int or str
    unit : str
        ``"-"`` for a pure number, ``""`` for a word.
    doc : str
        One line: what the parameter is.
    choices : tuple of str, optional
        The allowed words of a text parameter.
    key : str, optional
        The run-file key, when it differs from the field name.
    listed : str, optional
        Words that stand for ``choices`` in a reference, where the choices are a registry that grows
        (e.g. "a registered rubber law, listed by ..."): the reference then stays true as names are added.
    **bounds : float
        ``gt``, ``ge``, ``lt``, ``le``: the allowed range of a number.
    """
    meta = {"unit": unit, "doc": doc, "bounds": dict(bounds), "choices": choices, "key": key, "listed": listed}
    return dataclasses.field(default=default, metadata=meta)


def user_parameters(cls) -> tuple:
    """The fields of dataclass ``cls`` declared with :func:`parameter`, in declaration order."""
    return tuple(f for f in dataclasses.fields(cls) if "unit" in f.metadata)


def parameter_violations(obj) -> list[str]:
    """One line per field of dataclass instance ``obj`` declared with :func:`parameter` whose value leaves
    its declared range or choices, e.g. ``SceneSpec.deflection=0.0: must be > 0 and <= 30``."""
    ops = {"gt": (lambda v, b: v > b, ">"), "ge": (lambda v, b: v >= b, ">="),
           "lt": (lambda v, b: v < b, "<"), "le": (lambda v, b: v <= b, "<=")}
    out = []
    for f in user_parameters(type(obj)):
        v, meta = getattr(obj, f.name), f.metadata
        if meta["choices"] is not None:
            if v not in meta["choices"]:
                out.append(f"{type(obj).__name__}.{f.name}={v!r}: must be "
                           f"{' or '.join(map(repr, meta['choices']))}")
        elif meta["bounds"] and not all(ops[k][0](v, b) for k, b in meta["bounds"].items()):
            rng = " and ".join(f"{ops[k][1]} {b:g}" for k, b in meta["bounds"].items())
            out.append(f"{type(obj).__name__}.{f.name}={v!r}: must be {rng}")
    return out


@dataclass(frozen=True)
class WhiskerDesign:
    """Frozen parameter set of one whisker (mm, degrees, MPa).

    Parameters
    ----------
    D : float
        Base outer diameter at x = 0.
    L : float
        Intact whisker length.
    alpha : float
        Cone half-angle in degrees (the gene ``alpha``); ``r_o(x) = D/2 - x tan(alpha)``.
    c : float
        Cap thickness; the cavity starts at x = c.
    l : float
        x where the cavity ends.
    t : float
        Radial wall thickness of the chamber.
    x_ss : float
        Axial position of the gauge's start (from the base).
    e : float
        Axial gauge length; the gauge covers ``x_ss <= x <= x_ss + e``.
    trim : float
        Length cut off the tip (Δ); the whisker's length is ``L - trim``.
    fibre_radius_frac : float
        Fibre radius inside the wall, ``r_f = r_i + frac * t``.
    fibre_pitch : float
        Axial advance of each helix per turn.
    fibre_diameter : float
        Fibre diameter (truss cross-section ``pi d^2 / 4``).
    n_fibres : int
        Number of helices, phase-shifted by ``2 pi k / n_fibres``.
    fibre_E, fibre_nu : float
        Linear elastic fibre constants (nu is informative for a truss).
    gauge_half_angle_deg : float
        Angular half-width of the gauge footprint on the +y side, measured from +y
        about the x axis.
    tip_clearance : float
        Minimum solid length between the cavity end and the (trimmed) tip,
        ``length - l >= tip_clearance``: the cut must stay well clear of the chamber.
    """

    D: float = parameter(18.0, "mm", "base outer diameter at x = 0", gt=0, le=100)
    L: float = parameter(70.0, "mm", "intact whisker length", gt=0, le=500)
    alpha: float = parameter(2.862, "deg", "cone half-angle α; outer radius r_o(x) = D/2 − x tan α", ge=0, lt=45)
    c: float = parameter(2.0, "mm", "cap thickness; the chamber starts at x = c", gt=0, le=50)
    l: float = parameter(15.0, "mm", "x where the chamber ends", gt=0, le=200)  # noqa: E741  (the thesis' symbol)
    t: float = parameter(3.0, "mm", "chamber wall thickness (radial)", gt=0, le=50)
    x_ss: float = parameter(6.0, "mm", "gauge start, measured from the base", ge=0, le=200)
    e: float = parameter(2.0, "mm", "gauge grid length (axial)", gt=0, le=50)
    trim: float = 0.0
    fibre_radius_frac: float = parameter(0.5, "-", "fibre radius inside the wall: 0 = cavity, 1 = outer surface",
                                         ge=0, le=1)
    fibre_pitch: float = parameter(3.0, "mm", "helix pitch", gt=0, le=100)
    fibre_diameter: float = parameter(FIBRE_DIAMETER, "mm", "fibre diameter", gt=0, le=5)
    n_fibres: int = parameter(2, "-", "number of helices, evenly rotated", ge=0, le=8)
    fibre_E: float = parameter(FIBRE_MODULUS, "MPa", "fibre Young's modulus", gt=0, le=1e6)
    fibre_nu: float = parameter(FIBRE_POISSON, "-", "fibre Poisson ratio (recorded; a truss has no lateral strain, so the "
                                "solve does not use it)", ge=0, lt=0.5)
    gauge_half_angle_deg: float = 20.0
    tip_clearance: float = 5.0

    # ------------------------------------------------------------------ derived
    @property
    def length(self) -> float:
        """Actual (possibly trimmed) length ``L - trim``."""
        return self.L - self.trim

    @property
    def tan_alpha(self) -> float:
        return math.tan(math.radians(self.alpha))

    def r_outer(self, x):
        """Outer radius ``r_o(x) = D/2 - x tan(alpha)`` (scalar or array)."""
        r = self.D / 2.0 - np.asarray(x, dtype=float) * self.tan_alpha
        return float(r) if r.ndim == 0 else r

    def r_inner(self, x):
        """Cavity radius ``r_i(x) = r_o(x) - t``; only meaningful on ``[c, l]``."""
        return self.r_outer(x) - self.t

    def r_fibre(self, x):
        """Fibre helix radius ``r_f(x) = r_i(x) + fibre_radius_frac * t``."""
        return self.r_inner(x) + self.fibre_radius_frac * self.t

    @property
    def fibre_area(self) -> float:
        """Fibre cross-section ``pi d^2 / 4``."""
        return math.pi * self.fibre_diameter**2 / 4.0

    def trimmed(self, delta: float) -> "WhiskerDesign":
        """The same design with ``delta`` cut off the intact tip (``trim = delta``)."""
        return dataclasses.replace(self, trim=float(delta))

    def replace(self, **changes) -> "WhiskerDesign":
        """A copy with some fields changed (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)

    def describe(self) -> str:
        """Short one-line summary, e.g. for logs and CLI output."""
        return (
            f"WhiskerDesign(alpha={self.alpha:g} deg, l={self.l:g}, t={self.t:g}, "
            f"L={self.L:g}, trim={self.trim:g}, D={self.D:g}, c={self.c:g})"
        )

    def key(self) -> str:
        """Stable hex digest of all fields (for caches): sha256 of sorted JSON, 16 chars."""
        blob = json.dumps({k: float(v) for k, v in self.as_dict().items()}, sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    # ------------------------------------------------------------------ checks
    def violations(self) -> tuple[list[str], set[str]]:
        """All violated relations (messages) and the parameters they involve."""
        msgs: list[str] = []
        names: set[str] = set()

        def bad(cond: bool, params: tuple[str, ...], relation: str) -> None:
            if cond:
                vals = ", ".join(f"{p}={getattr(self, p):g}" for p in params)
                msgs.append(f"{relation} violated ({vals})")
                names.update(params)

        for p in ("D", "L", "c", "l", "t", "e", "fibre_pitch", "fibre_diameter", "fibre_E", "tip_clearance"):
            v = getattr(self, p)
            bad(not (math.isfinite(v) and v > 0), (p,), f"{p} > 0")
        for p in ("trim", "x_ss", "fibre_nu"):
            v = getattr(self, p)
            bad(not (math.isfinite(v) and v >= 0), (p,), f"{p} >= 0")
        bad(not (0.0 <= self.alpha < 45.0), ("alpha",), "0 <= alpha < 45")
        bad(not (0.0 <= self.fibre_radius_frac <= 1.0), ("fibre_radius_frac",), "0 <= fibre_radius_frac <= 1")
        bad(not (self.fibre_nu < 0.5), ("fibre_nu",), "fibre_nu < 0.5")
        bad(
            not (float(self.n_fibres).is_integer() and 0 <= self.n_fibres <= 16),
            ("n_fibres",),
            "n_fibres integer in [0, 16]",
        )
        bad(not (0.0 < self.gauge_half_angle_deg <= 90.0), ("gauge_half_angle_deg",), "0 < gauge_half_angle_deg <= 90")
        if msgs:  # sizes themselves are wrong: the relations below would only repeat it
            return msgs, names
        bad(self.l <= self.c, ("c", "l"), "c < l (cavity from x=c to x=l)")
        length = self.length
        bad(
            length - self.l < self.tip_clearance,
            ("L", "trim", "l", "tip_clearance"),
            f"L - trim - l >= tip_clearance (cut at x={length:g} must stay clear of the chamber end)",
        )
        tip = self.r_outer(length)
        bad(tip <= 0, ("D", "alpha", "L", "trim"), f"tip radius D/2 - (L - trim) tan(alpha) = {tip:.4g} > 0")
        ri_l = self.r_inner(self.l)
        bad(
            ri_l <= 0,
            ("D", "alpha", "l", "t"),
            f"cavity radius at x=l, D/2 - l tan(alpha) - t = {ri_l:.4g} > 0 (no cavity/wall left)",
        )
        bad(
            not (self.c <= self.x_ss and self.x_ss + self.e <= self.l),
            ("x_ss", "e", "c", "l"),
            "c <= x_ss and x_ss + e <= l (gauge inside the chamber region)",
        )
        bad(self.fibre_diameter >= self.t, ("fibre_diameter", "t"), "fibre_diameter < t (fibre fits in the wall)")
        return msgs, names

    def validate(self) -> "WhiskerDesign":
        """Raise :class:`InvalidDesignError` listing every violated relation; return self."""
        msgs, names = self.violations()
        if msgs:
            raise InvalidDesignError(msgs, names)
        return self

    @property
    def is_valid(self) -> bool:
        return not self.violations()[0]

    @classmethod
    def from_dict(cls, data: dict) -> "WhiskerDesign":
        """A design from :meth:`as_dict` output (``alpha_deg``, the former name of ``alpha``, is read too)."""
        fields = {f.name for f in dataclasses.fields(cls)}
        data = dict(data)
        if "alpha_deg" in data and "alpha" not in data:  # templates and results written before the rename
            data["alpha"] = data.pop("alpha_deg")
        unknown = set(data) - fields
        if unknown:
            raise ValueError(f"WhiskerDesign: unknown field(s) {sorted(unknown)}; allowed {sorted(fields)}")
        kw = dict(data)
        if "n_fibres" in kw:
            kw["n_fibres"] = int(kw["n_fibres"])
        return cls(**kw)
