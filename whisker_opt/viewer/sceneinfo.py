"""What is known about a scene besides its meshes: design, pressure, trim, contact, gauge
and its readings, read from a ``scenes.json`` entry (:mod:`whisker_opt.output.scenes` writes
them). Every fact is optional.

Deflection states ``<scene>_delta_<δ>.vtu`` (δ in mm) sit between ``pressurised`` (δ = 0)
and ``deflected`` (the last increment); :meth:`SceneInfo.delta_of` maps a state name to
its δ and :meth:`SceneInfo.reading` to the gauge reading there.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from whisker_opt.viewer.guard import ViewerError

DELTA_TOL = 0.0051
"""Tolerance [mm] matching a requested or file-name δ to a solved one (file names carry δ to 0.01 mm)."""


@dataclass(frozen=True)
class GaugeSpot:
    """Where the gauge sits on the outer cone (reference coordinates).

    Attributes
    ----------
    x_ss : float
        Axial start [mm].
    e : float
        Axial length [mm].
    half_angle_deg : float
        Angular half-width about +y [deg].
    """

    x_ss: float
    e: float
    half_angle_deg: float = 20.0


@dataclass(frozen=True)
class SceneInfo:
    """Optional facts about one scene (all may be missing).

    Attributes
    ----------
    name : str
    design : dict or None
        :meth:`geometry.design.WhiskerDesign.as_dict` of the scene's design.
    Q : float or None
        Chamber pressure [MPa].
    trim : float or None
        Trimmed length [mm].
    contact_x : float or None
        Axial position of the contact in the pressurised configuration [mm].
    gauge : GaugeSpot or None
    delta : tuple of float
        Solved deflections [mm].
    eps : tuple of float
        Gauge readings at ``delta`` [-].
    delta_l : float or None
        Axial extension by the pressure [mm].
    length_q : float or None
        Length after pressurisation [mm].
    notes : dict
        Other facts shown as text (e.g. genes, f1, F_p of an evaluation).
    """

    name: str
    design: dict | None = None
    Q: float | None = None
    trim: float | None = None
    contact_x: float | None = None
    gauge: GaugeSpot | None = None
    delta: tuple[float, ...] = ()
    eps: tuple[float, ...] = ()
    delta_l: float | None = None
    length_q: float | None = None
    notes: dict = field(default_factory=dict)

    def delta_of(self, state: str) -> float | None:
        """Deflection δ [mm] of a state: 0 for the pressurised state, δ parsed from names like
        ``delta_1.50`` (snapped to a solved δ within :data:`DELTA_TOL`), the last solved δ for
        ``deflected``/``final``; None when unknown (and for the reference state)."""
        s = state.lower()
        if s in ("pressurised", "pressurized", "inflated"):
            return 0.0
        if s in ("deflected", "final"):
            return self.delta[-1] if self.delta else None
        d = number_in(s) if ("delta" in s or s.startswith("d")) else None
        if d is None:
            return None
        if self.delta:
            k = int(np.argmin(np.abs(np.asarray(self.delta) - d)))
            if abs(self.delta[k] - d) <= DELTA_TOL:
                return self.delta[k]
        return d

    def reading(self, state: str) -> tuple[float, float] | None:
        """(δ, ε) shown for a state (δ from :meth:`delta_of`, ε interpolated in the solved
        readings); None when unknown."""
        if not self.delta or len(self.delta) != len(self.eps):
            return None
        d = self.delta_of(state)
        if d is None or not (self.delta[0] - DELTA_TOL <= d <= self.delta[-1] + DELTA_TOL):
            return None
        return d, float(np.interp(d, self.delta, self.eps))


def finite_float(v: Any) -> float | None:
    """``float(v)`` when that is a finite number, else None (metadata may hold anything)."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def number_in(s: str) -> float | None:
    """The first number in a name (``delta_1.50`` -> 1.5, ``d1p5`` -> 1.5), None when there is none."""
    m = re.search(r"[-+]?\d+(?:[.p]\d+)?(?:e[-+]?\d+)?", s)
    if not m:
        return None
    return finite_float(m.group(0).replace("p", "."))


def scene_info_from_dict(name: str, d: Mapping[str, Any], defaults: Mapping[str, Any] | None = None) -> SceneInfo:
    """Build a :class:`SceneInfo` from one ``scenes.json`` entry (tolerant of missing keys).

    Recognised keys: ``design`` (dict), ``Q`` or ``Q_MPa``, ``trim``, ``contact_x``,
    ``gauge`` ({x_ss, e, half_angle_deg}), ``solved_delta_mm`` or ``delta``, ``eps_<gauge_variant>``
    (e.g. ``eps_centroid``; ``eps_line`` when the entry has no such key) or ``eps``, ``delta_l_mm``,
    ``length_q_mm``; ``defaults`` may give ``contact_ratio``.

    Parameters
    ----------
    name : str
        The scene's name.
    d : mapping
        The entry.
    defaults : mapping, optional
        Facts of the run that an entry may leave out (``contact_ratio``).

    Returns
    -------
    SceneInfo
    """
    defaults = defaults or {}
    design = d.get("design") if isinstance(d.get("design"), dict) else None
    trim = finite_float(d.get("trim", design.get("trim") if design else None))
    gauge = None
    g = d.get("gauge")
    if isinstance(g, Mapping) and finite_float(g.get("x_ss")) is not None and finite_float(g.get("e")) is not None:
        gauge = GaugeSpot(float(g["x_ss"]), float(g["e"]), finite_float(g.get("half_angle_deg")) or
                          (finite_float(design.get("gauge_half_angle_deg")) if design else None) or 20.0)
    elif design and finite_float(design.get("x_ss")) is not None and finite_float(design.get("e")) is not None:
        gauge = GaugeSpot(float(design["x_ss"]), float(design["e"]),
                          finite_float(design.get("gauge_half_angle_deg")) or 20.0)
    delta = d.get("solved_delta_mm", d.get("delta")) or ()
    chosen = f"eps_{d.get('gauge_variant')}"  # the run's reading, e.g. eps_centroid; eps_line otherwise
    eps_key = chosen if chosen in d else "eps_line"
    eps = d.get(eps_key, d.get("eps")) or ()
    try:
        delta = tuple(float(x) for x in delta)
        eps = tuple(float(x) for x in eps)
    except (TypeError, ValueError):
        delta, eps = (), ()
    length_q = finite_float(d.get("length_q_mm"))
    if length_q is None and design and finite_float(design.get("L")) is not None:
        length_q = float(design["L"]) - (trim or 0.0) + (finite_float(d.get("delta_l_mm")) or 0.0)
    contact_x = finite_float(d.get("contact_x"))
    ratio = finite_float(d.get("contact_ratio", defaults.get("contact_ratio")))
    if ratio is None and design:  # the SceneConfig default: contact at the tip
        ratio = 1.0
    if contact_x is None and ratio is not None and length_q is not None:
        contact_x = ratio * length_q
    notes = {k: d[k] for k in ("genes", "f1", "F_p", "eval_id", "status") if k in d}
    return SceneInfo(
        name=name,
        design=design,
        Q=finite_float(d.get("Q", d.get("Q_MPa", d.get("Q_i")))),
        trim=trim,
        contact_x=contact_x,
        gauge=gauge,
        delta=delta,
        eps=eps,
        delta_l=finite_float(d.get("delta_l_mm", d.get("delta_l"))),
        length_q=length_q,
        notes=notes,
    )


def read_json(path: Path) -> Any:
    """Parse a JSON file.

    Raises
    ------
    ViewerError
        Not valid JSON (the message names the path).
    """
    try:
        return json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise ViewerError(f"{path}: not valid JSON ({exc})") from None


def read_scenes_json(path: Path, defaults: Mapping[str, Any] | None = None) -> dict[str, SceneInfo]:
    """The scenes of a ``scenes.json`` file: every top-level entry that is a mapping.

    Parameters
    ----------
    path : Path
    defaults : mapping, optional
        See :func:`scene_info_from_dict`.

    Returns
    -------
    dict of str -> SceneInfo

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    ViewerError
        Not JSON, or its top level is not a mapping.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such scenes file")
    data = read_json(path)
    if not isinstance(data, dict):
        raise ViewerError(f"{path}: top level must be a mapping of scene name -> facts, got {type(data).__name__}")
    return {k: scene_info_from_dict(k, v, defaults) for k, v in data.items() if isinstance(v, dict)}
