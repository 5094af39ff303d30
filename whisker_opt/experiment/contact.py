"""The contact of the deflection step: where the pusher touches and which nodes it moves.

The contact point is x = a·L_Q, with L_Q = L + Δl the pressurised length (or x = a·L
when the pusher stays where it stood before pressurisation). For a = 1 the contact is
the tip face. Off the tip it is a *band*: the nodes whose current axial position lies
within ``band_width``/2 of the contact point (:func:`contact_band`).

A structured (swept or mapped-template) mesh has node rings on axial stations, and a
ring at f·L moves to about f·L + Δl under pressure, not to a·L_Q = a(L + Δl). So the
scene checks after pressurising that a ring sits within :data:`CONTACT_TOL` of the
contact (:func:`place_contact`) and otherwise meshes again with the ring at the
reference fraction that lands there (:func:`place_contact_ring`). Fresh (fTetWild)
meshes have no rings: their band is the slab of nodes around the contact point.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from typing import Callable, TypeVar

import numpy as np

from geometry.mesh import MeshSizing, WhiskerMesh
from whisker_opt.experiment.gauge import GaugedMesh

logger = logging.getLogger(__name__)

#: Largest distance [mm] between the contact ring's current axial position and a·L_Q that
#: :func:`place_contact` accepts. The reading scales about as 1/x_c² at the contact
#: (the beam model of :mod:`whisker_opt.analysis.beam`, eqs. 8.5–8.6, gives
#: ε/δ ∝ (x_c − x_g)/x_c³ for a uniform beam), so 0.02 mm moves it by ≈ 0.1 % at
#: a = 0.5, L = 70.
CONTACT_TOL = 0.02

#: Meshes :func:`place_contact_ring` builds at most to place the contact ring (a < 1).
MAX_CONTACT_REMESH = 2


@dataclass(frozen=True)
class Contact:
    """Where the pusher touches the whisker.

    Attributes
    ----------
    a : float
        Contact ratio in (0, 1].
    length : float
        Whisker length L before pressurisation [mm].
    follows_extension : bool
        True: x = a·L_Q, the contact moves out with the extension (a = 1 is the tip
        face). False: x = a·L, the pusher stays where it stood before pressurisation.
    """

    a: float
    length: float
    follows_extension: bool = True

    @property
    def at_tip(self) -> bool:
        """The contact is the tip face (a = 1 following the extension)."""
        return self.a >= 1.0 and self.follows_extension

    def x(self, wm: WhiskerMesh, u: np.ndarray) -> float:
        """Contact point [mm]: a·L, or a·L_Q with L_Q = L + Δl and Δl the mean axial
        displacement of the tip face's nodes in ``u`` (shape (n_nodes, 3))."""
        if not self.follows_extension:
            return self.a * self.length
        return self.a * (self.length + float(u[wm.node_sets["tip"], 0].mean()))


class ContactPlacementError(ValueError):
    """No node lies where the contact pushes (e.g. a held pusher less than a ring spacing from the
    extended tip, where the swept mesher places no ring): the scene cannot be set up."""


def contact_band(wm: WhiskerMesh, u: np.ndarray, x_contact: float, width: float, at_tip: bool) -> np.ndarray:
    """Nodes whose current axial position lies within ``width``/2 of ``x_contact``.

    For ``at_tip`` the nodes of the tip face. On a structured (swept or template) mesh, of the
    node stations in the band only the one nearest ``x_contact`` (the ring
    :func:`place_contact_ring` put there). Raises :class:`ContactPlacementError` when the band
    holds no node or reaches the fixed base face.
    """
    if at_tip:
        # the tip face only: a slab of finite width would hold every node of the slab at the
        # same y and clamp the tip's rotation (measured on fTetWild meshes: gauge/beam ratio
        # 0.82 with the face, 0.98 with a 1 mm slab, 1.09 with 2 mm)
        return np.asarray(wm.node_sets["tip"], dtype=np.int64)
    xc = wm.mesh.points[:, 0] + u[:, 0]  # (n_nodes,)
    nodes = np.nonzero(np.abs(xc - x_contact) <= 0.5 * width)[0]
    if len(nodes) == 0:
        nearest = float(xc[np.argmin(np.abs(xc - x_contact))])
        raise ContactPlacementError(f"contact band of width {width} mm at x = {x_contact:.3f} mm holds no node "
                                    f"(nearest node at x = {nearest:.3f} mm)")
    on_base = np.intersect1d(nodes, np.asarray(wm.node_sets.get("base", ()), dtype=np.int64))
    if len(on_base):
        raise ContactPlacementError(
            f"contact band of width {width} mm at x = {x_contact:.3f} mm reaches the fixed base (x = 0): the "
            f"contact must be at least {0.5 * width:g} mm from the base (a larger scene.contact_ratio)")
    if not wm.report.method.startswith("fresh"):
        # a structured mesh pushes one node ring, the station nearest the contact: a ring placed
        # less than a band width from the tip face (a held pusher on a slightly extended whisker)
        # must not take the face with it, which would clamp the tip's rotation (see above)
        inv = _station_index(wm.mesh.points[nodes, 0], float(wm.mesh.points[:, 0].max()))
        if inv.max() > 0:
            gap = np.abs(np.bincount(inv, xc[nodes]) / np.bincount(inv) - x_contact)  # (n_levels,)
            nodes = nodes[inv == int(np.argmin(gap))]
    return nodes


def _station_index(X: np.ndarray, length: float) -> np.ndarray:
    """Index (n,) of the axial station of each reference x in ``X``: equal x rounded to 1e-9 of the
    length share a station, numbered in increasing x."""
    key = np.round(X / (1e-9 * max(length, 1.0))).astype(np.int64)
    return np.unique(key, return_inverse=True)[1].ravel()


def station_positions(wm: WhiskerMesh, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axial node stations of a structured mesh: reference X_k and mean current x_k.

    Nodes are grouped by reference x (rounded to 1e-9 of the length); ``x_k = X_k + ū_x``
    with ū_x the mean axial displacement of the station's nodes.
    """
    X = wm.mesh.points[:, 0]
    inv = _station_index(X, float(X.max()))
    cnt = np.bincount(inv).astype(float)
    Xk = np.bincount(inv, X) / cnt  # (n_stations,)
    xk = Xk + np.bincount(inv, u[:, 0]) / cnt  # (n_stations,)
    return Xk, xk


def place_contact(wm: WhiskerMesh, u: np.ndarray, x_contact: float, a: float) -> tuple[float, float]:
    """Does a node ring of this structured mesh sit at the contact, and where should one be?

    Parameters
    ----------
    wm : WhiskerMesh
        A swept or mapped-template mesh (node rings on axial stations).
    u : ndarray, shape (n_nodes, 3)
        Displacement after pressurisation (zeros when Q = 0).
    x_contact : float
        Contact point a·L_Q [mm].
    a : float
        Contact ratio (the ``contact_fractions`` entry to replace).

    Returns
    -------
    error : float
        Distance [mm] from ``x_contact`` to the nearest station's current position.
    fraction : float
        The reference fraction f = X/L whose station lands on the contact,
        X + ū_x(X) = x_contact, with ū_x interpolated linearly between stations (the
        body beyond the chamber only translates, so this is exact there up to the
        meshes' difference in Δl).
    """
    Xk, xk = station_positions(wm, u)
    error = float(np.min(np.abs(xk - x_contact)))
    X_new = float(np.interp(x_contact, xk, Xk))  # x(X) is increasing: invert by interpolation
    L = wm.design.length
    f = X_new / L
    if not 0 < f < 1:
        raise ValueError(f"contact ratio a = {a}: the contact x = {x_contact:.3f} mm maps to the reference "
                         f"fraction {f:.4f}, outside (0, 1)")
    return error, f


def _placed_sizing(sizing: MeshSizing, a: float, f: float) -> MeshSizing:
    """``sizing`` with the contact fraction nearest to ``a`` replaced by ``f``."""
    fr = list(sizing.contact_fractions)
    if fr:
        fr[int(np.argmin(np.abs(np.asarray(fr) - a)))] = f
    else:
        fr = [f]
    return replace(sizing, contact_fractions=tuple(fr))


P = TypeVar("P")


def place_contact_ring(contact: Contact, gm: GaugedMesh, pressurised: P, sizing: MeshSizing,
                       remesh: Callable[[MeshSizing, str], GaugedMesh],
                       pressurise: Callable[[GaugedMesh], P]) -> tuple[GaugedMesh, P]:
    """Mesh again until a node ring sits at the pressurised contact point.

    Nothing to do for a contact at the tip face or on a fresh (ring-less) mesh. Otherwise,
    while the nearest station is more than :data:`CONTACT_TOL` from the contact point
    (:func:`place_contact`), or the mesh is a mapped template, mesh again (swept) with the
    preset's contact fraction nearest to a replaced by the fraction that lands on the
    contact, and pressurise again; at most :data:`MAX_CONTACT_REMESH` times.

    Parameters
    ----------
    contact : Contact
    gm : GaugedMesh
        The scene's mesh, pressurised.
    pressurised : P
        The pressurisation of ``gm.wm``: anything whose ``state`` is the pressurised
        :class:`fem.state.State`.
    sizing : MeshSizing
        The sizing ``gm`` was built with.
    remesh : callable
        ``remesh(sizing, method) -> GaugedMesh``.
    pressurise : callable
        ``pressurise(gm) -> P``.

    Returns
    -------
    gm, pressurised
        The mesh the deflection runs on and its pressurisation (the inputs when no new
        mesh was needed).
    """
    if contact.at_tip or gm.wm.report.method.startswith("fresh"):
        return gm, pressurised
    for attempt in range(MAX_CONTACT_REMESH + 1):
        wm, u = gm.wm, pressurised.state.u
        x_contact = contact.x(wm, u)
        error, f = place_contact(wm, u, x_contact, contact.a)
        # a mapped template is replaced even when a ring fits, so that every pressure of an
        # off-tip study runs on the same swept family (template and swept meshes of the
        # default preset differ by ~1 % in the a = 0.5 reading, as large as the effect of Q)
        if error <= CONTACT_TOL and not wm.report.method.startswith("template"):
            break
        if attempt == MAX_CONTACT_REMESH:
            logger.warning("contact ring %.3f mm from a·L_Q = %.3f mm after %d re-meshes (tolerance %g mm)",
                           error, x_contact, attempt, CONTACT_TOL)
            break
        sizing = _placed_sizing(sizing, contact.a, f)
        logger.info("contact a = %g: nearest node ring %.3f mm from a·L_Q = %.3f mm; meshing with the ring "
                    "at f = %.6f", contact.a, error, x_contact, f)
        gm = remesh(sizing, "swept")  # the structured family (a template cannot carry a new ring)
        pressurised = pressurise(gm)
    return gm, pressurised
