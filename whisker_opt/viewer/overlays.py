"""What a view draws on top of the whisker: the gauge footprint, the contact point, the fibre
helices and the panel text.

* The gauge footprint ``x_ss <= x <= x_ss + e``, ``|angle from +y| <= gauge_half_angle_deg``
  on the outer cone (:func:`gauge_patch`).
* The contact point on the +y generator (:func:`contact_point`).
* The fibre helices (:mod:`geometry.fibres`) mapped by the interpolated displacement
  (:func:`fibre_lines`).
* The design parameters, the scene (Q, trim) and the gauge reading as text (:func:`text_lines`).
* The panel heading in words: the scene, its pressure and trim, the state, the fidelity preset and
  its f1 resolution, and for a bare mesh its element count and wall layers (:func:`panel_heading`).

The gauge reading ε is counted from contact onset (δ = 0, the pressurised state), as the
optimiser reads it; the colour fields are totals from the unloaded, unpressurised mesh. The
gauge text says so.
"""

from __future__ import annotations

import logging

import numpy as np

from whisker_opt.viewer.guard import require_pyvista
from whisker_opt.viewer.sceneinfo import SceneInfo, finite_float
from whisker_opt.viewer.state import SCENE_TITLES, StateView, displaced, scene_title
from whisker_opt.wiring import INTACT, UNCOMPENSATED

logger = logging.getLogger(__name__)


def design_of(design: dict | None):
    """The :class:`geometry.design.WhiskerDesign` of a scene's design metadata; None when absent
    or not usable (e.g. written by another version)."""
    if not design:
        return None
    try:
        from geometry.design import WhiskerDesign

        return WhiskerDesign.from_dict(design)
    except Exception as exc:  # noqa: BLE001 - metadata may be from another version
        logger.info("design metadata not usable (%s)", exc)
        return None


def radius_at(sv: StateView, x: np.ndarray, design) -> np.ndarray:
    """Outer radius at reference axial positions: the design's cone, else the widest reference node near x."""
    if design is not None:
        return np.asarray(design.r_outer(x), dtype=float)
    X = np.asarray(sv.grid.points)
    r = np.hypot(X[:, 1], X[:, 2])
    out = []
    h = 0.02 * (X[:, 0].max() - X[:, 0].min()) + 1e-12
    for xi in np.atleast_1d(x):
        sel = np.abs(X[:, 0] - xi) <= h
        out.append(r[sel].max() if sel.any() else r.max())
    return np.asarray(out)


def gauge_patch(sv: StateView, n_x: int = 12, n_phi: int = 12):
    """The gauge footprint (warped) as a PolyData patch, or None without gauge metadata."""
    pv = require_pyvista()
    g = sv.info.gauge
    if g is None:
        return None
    design = design_of(sv.info.design)
    x = np.linspace(g.x_ss, g.x_ss + g.e, n_x)
    phi = np.radians(np.linspace(-g.half_angle_deg, g.half_angle_deg, n_phi))
    xx, pp = np.meshgrid(x, phi, indexing="ij")
    r = radius_at(sv, xx.ravel(), design).reshape(xx.shape)
    ref = np.stack([xx, r * np.cos(pp), r * np.sin(pp)], axis=-1).reshape(-1, 3)
    # sample just inside the boundary (the P2 surface interpolates the cone)
    inward = ref * np.array([1.0, 0.995, 0.995])
    cur = displaced(sv, inward) + (ref - inward)
    grid = pv.StructuredGrid(*(cur[:, k].reshape(n_x, n_phi) for k in range(3)))
    return grid.extract_surface(algorithm="dataset_surface")


def contact_point(sv: StateView) -> np.ndarray | None:
    """Current position of the contact point on the +y generator, or None when unknown.

    ``contact_x`` is the contact's axial position in the pressurised configuration; its
    reference position is taken as ``contact_x - Δl`` clipped to the whisker length.
    """
    cx = sv.info.contact_x
    if cx is None:
        return None
    X = np.asarray(sv.grid.points)
    x_ref = float(np.clip(cx - (sv.info.delta_l or 0.0), X[:, 0].min(), X[:, 0].max()))
    design = design_of(sv.info.design)
    r = float(radius_at(sv, np.array([x_ref]), design)[0])
    ref = np.array([[x_ref, r, 0.0]])
    return displaced(sv, ref * np.array([1.0, 0.995, 1.0]))[0] + np.array([0.0, 0.005 * r, 0.0])


def fibre_lines(sv: StateView, ds: float = 0.5) -> list:
    """Warped fibre helices (:func:`geometry.fibres.sample_helix`) as PolyData lines; [] without a design."""
    pv = require_pyvista()
    design = design_of(sv.info.design)
    if design is None or int(design.n_fibres) == 0:
        return []
    from geometry.fibres import fibre_phases, sample_helix

    out = []
    for ph in fibre_phases(design):
        pts = displaced(sv, sample_helix(design, ph, ds))
        out.append(pv.lines_from_points(pts))
    return out


def text_lines(sv: StateView) -> tuple[str, str]:
    """(design text, gauge text) of a panel.

    The design text lists α, l, t, L, the trim, Q, the scene's notes (f1, F_p, ...) and the
    displacement magnification; the gauge text the reading at the state's δ, that it is
    counted from contact onset (:data:`GAUGE_ZERO_NOTE`), and the axial extension by the
    pressure.
    """
    info = sv.info
    parts = []
    d = info.design
    if d:
        for key, label, unit in (("alpha", "alpha", " deg"), ("l", "l", ""), ("t", "t", ""), ("L", "L", "")):
            if finite_float(d.get(key)) is not None:
                parts.append(f"{label}={float(d[key]):.4g}{unit}")
        parts[-1:] = [parts[-1] + " mm"] if parts else []
    if info.trim is not None:
        parts.append(f"trim={info.trim:.3g} mm")
    if info.Q is not None:
        parts.append(f"Q={info.Q:.4g} MPa")
    for k, v in info.notes.items():
        if k == "genes" and isinstance(v, dict) and not d:
            parts.append(", ".join(f"{g}={float(x):.4g}" for g, x in v.items()))
        elif finite_float(v) is not None:
            parts.append(f"{k}={float(v):.4g}")
    if sv.scale != 1.0 and sv.displacement:
        parts.append(f"displacement x{sv.scale:g}")
    reading = info.reading(sv.state) if sv.state else None
    lines = []
    if reading is not None:
        lines += [f"gauge ε = {reading[1]:.5g} at δ = {reading[0]:.3g} mm", GAUGE_ZERO_NOTE]
    if info.delta_l is not None and sv.state.lower() not in ("reference", "undeformed"):
        lines.append(f"extension by the pressure: {info.delta_l:.4g} mm")
    return ", ".join(parts), "\n".join(lines)


GAUGE_ZERO_NOTE = "ε counted from contact onset (δ = 0)"
"""Under a gauge reading: ε is the change since contact onset, unlike the colour field."""

_PRESSURISED = ("pressurised", "pressurized", "inflated")


def scene_heading(info: SceneInfo) -> str:
    """The scene in words: its role, how much was trimmed off and its chamber pressure.

    E.g. ``Trimmed, uncompensated: tip cut off by Δ = 5 mm, chamber pressure still Q = 0.166 MPa``
    or ``Intact: full length, chamber pressure Q = 0.166 MPa``; unknown facts are left out.

    Parameters
    ----------
    info : SceneInfo

    Returns
    -------
    str
    """
    role = scene_title(info)
    parts = []
    if info.trim is not None:
        parts.append("full length, not trimmed" if info.trim == 0 else f"tip cut off by Δ = {info.trim:.3g} mm")
    elif info.name == INTACT:
        parts.append("full length, not trimmed")
    if info.Q is not None:
        if info.Q == 0:
            parts.append("chamber vented (Q = 0 MPa)")
        else:
            still = " still" if role == SCENE_TITLES[UNCOMPENSATED] else ""
            parts.append(f"chamber pressure{still} Q = {info.Q:.3g} MPa")
    role = role[:1].upper() + role[1:]
    return f"{role}: {', '.join(parts)}" if parts else role


def state_heading(info: SceneInfo, state: str) -> str:
    """A state in words, with its deflection δ [mm] when known.

    ``pressurised, not yet pushed (δ = 0)``, ``at rest: not pressurised, not pushed (δ = 0)``
    for the pressurised state of a scene at Q = 0, ``deflected: contact pushed sideways by
    δ = 2 mm``; other names unchanged.

    Parameters
    ----------
    info : SceneInfo
    state : str

    Returns
    -------
    str
    """
    s = state.lower()
    if s in ("reference", "undeformed"):
        return "undeformed mesh (no load)"
    if s in _PRESSURISED:
        if info.Q == 0:
            return "at rest: not pressurised, not pushed (δ = 0)"
        return "pressurised, not yet pushed (δ = 0)"
    d = info.delta_of(state)
    if d is not None:
        return f"deflected: contact pushed sideways by δ = {d:.3g} mm"
    if s in ("deflected", "final"):
        return "deflected: contact pushed sideways (last step)"
    return state


def panel_heading(sv: StateView) -> str:
    """Heading of a panel: :func:`scene_heading`, below it :func:`state_heading`, for a mesh shown
    without a solution its element count and wall layers, and last the fidelity preset with its f1
    resolution (:attr:`StateView.fidelity`; ``fidelity preset not recorded`` when unknown).

    Parameters
    ----------
    sv : StateView

    Returns
    -------
    str
    """
    lines = [scene_heading(sv.info)]
    if sv.state:
        lines.append(state_heading(sv.info, sv.state))
    if sv.mesh_facts:
        lines.append(sv.mesh_facts)
    lines.append(sv.fidelity or "fidelity preset not recorded")
    return "\n".join(lines)
