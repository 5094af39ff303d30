"""Mesh sizing: target element edge lengths per region, and the background sizing field.

Target edge length as a function of the axial position x (the field is axisymmetric
and, inside the solid, depends on x only)::

    h(x) = h_cap                                   0 <= x < c        (cap)
    h(x) = h_wall                                  c <= x <= l       (chamber wall)
    h(x) = min(h_body, h_wall + g (x - l))         l < x             (body, graded)

with ``h_wall = t / wall_layers`` unless given absolutely, ``h_cap = cap_factor h_wall``
unless given, and ``g`` the grading (size growth per mm). fTetWild reads it from a
background tet mesh (``bg_vertices``, ``bg_tets``, ``bg_values``) and interpolates it
linearly inside each background tet; the background mesh here is a Kuhn-split
structured grid with an x-node at every region boundary.

The structured swept mesher (:mod:`geometry.swept`, also the shipped templates) reads
the same fields differently: ``round(wall_layers)`` radial element layers through the
wall, ``n_theta`` sectors around, chamber layers ``axial_pitch_fraction * fibre_pitch``
long (the embedded fibre helices stiffen the wall with the period of their pitch, and
the gauge reading converges with the axial layer size relative to it), a cap
of ``round(c / h_cap)`` layers and body layers graded from the chamber size by
``grading`` up to ``h_body`` (and at most ``min(1.5, 3 / n_wall) r_o(x)``), with node
rings at the gauge window ends and at ``contact_fractions`` of the length.

A note on "elements through the wall": for unstructured tets a radial line of length
t crosses about ``t / (0.27 h)`` elements (0.27 h = mean chord of a regular tet of edge
h, ``4 V / A``), i.e. ~3.7 x the number of edge lengths through the wall; in the swept
mesh each wall layer is a layer of prisms cut into 3 tets, so a line crosses 1-3 tets
per layer. The report gives both the crossing count and ``t / median radial extent``
of the wall elements (the layer count).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass

import numpy as np

from fem.mesh import orient_linear
from geometry.design import WhiskerDesign


#: Allowed absolute edge lengths [mm], closed ranges: of the chamber wall, the body and the cap (the run
#: file's ``fidelity.h_wall`` and ``fidelity.h_body`` take theirs from here).
H_WALL_RANGE = (0.05, 10.0)
H_BODY_RANGE = (0.05, 50.0)
H_CAP_RANGE = (0.05, 50.0)


@dataclass(frozen=True)
class MeshSizing:
    """Frozen element-size specification (mm).

    Parameters
    ----------
    wall_layers : float
        Target number of element edge lengths through the wall, ``h_wall = t / wall_layers``.
    h_wall : float or None
        Absolute chamber-wall edge length; overrides ``wall_layers`` (then no template
        mesh applies and ``method="auto"`` meshes afresh).
    h_cap : float or None
        Cap edge length; default ``cap_factor * h_wall``.
    cap_factor : float
        See ``h_cap``.
    h_body : float
        Largest edge length in the solid body/tip.
    grading : float
        Edge-length growth per mm of distance from the chamber end (dh/dx).
    n_theta : int
        Swept mesher (:mod:`geometry.swept`): angular sectors of the cross-section
        (even, >= 6). Unused by fTetWild.
    theta_grading : float
        Swept mesher: the sectors narrowed towards the gauge's side of the section by ``1 − theta_grading``
        and widened on the far side by ``1 + theta_grading`` (:func:`geometry.swept.graded_angles`), in
        [0, 0.9]; 0 (equal sectors) leaves the sizing's key as it was without the field.
    axial_pitch_fraction : float
        Swept mesher: axial layer size in the chamber as a fraction of the fibre pitch,
        ``dz = axial_pitch_fraction * design.fibre_pitch``.
    contact_fractions : tuple of float
        Swept mesher: fractions f of the (trimmed) length where the body gets a node
        ring (x = f L'), so a scene's contact band at a = f finds nodes; each in (0, 1).
    epsilon : float
        fTetWild envelope (maximum surface deviation) relative to the bounding-box
        diagonal; boundary nodes are projected onto the exact surfaces afterwards.
    name : str
        Preset name (for logs and template look-up).
    """

    wall_layers: float = 1.0
    h_wall: float | None = None
    h_cap: float | None = None
    cap_factor: float = 1.0
    h_body: float = 10.0
    grading: float = 0.5
    n_theta: int = 8
    theta_grading: float = 0.0
    axial_pitch_fraction: float = 0.5
    contact_fractions: tuple = (0.5, 0.75)
    epsilon: float = 1e-3
    name: str = "default"

    def __post_init__(self) -> None:
        checks = [
            ("wall_layers", self.wall_layers, 0.25, 20.0),
            ("cap_factor", self.cap_factor, 0.25, 10.0),
            ("h_body", self.h_body, *H_BODY_RANGE),
            ("grading", self.grading, 0.0, 10.0),
            ("epsilon", self.epsilon, 1e-5, 1e-2),
            ("axial_pitch_fraction", self.axial_pitch_fraction, 0.02, 5.0),
            ("theta_grading", self.theta_grading, 0.0, 0.9),
        ]
        fr = self.contact_fractions
        if not isinstance(fr, tuple):  # e.g. a list from JSON: keep the dataclass hashable
            object.__setattr__(self, "contact_fractions", tuple(fr))
        for f in self.contact_fractions:
            if not (isinstance(f, (int, float)) and 0.0 < f < 1.0):
                raise ValueError(f"MeshSizing.contact_fractions={self.contact_fractions!r}: each must be in (0, 1)")
        if not (isinstance(self.n_theta, int) and 6 <= self.n_theta <= 256 and self.n_theta % 2 == 0):
            raise ValueError(f"MeshSizing.n_theta={self.n_theta!r} must be an even integer in [6, 256]")
        for opt, rng in (("h_wall", H_WALL_RANGE), ("h_cap", H_CAP_RANGE)):
            if getattr(self, opt) is not None:
                checks.append((opt, getattr(self, opt), *rng))
        for name, val, lo, hi in checks:
            if not (isinstance(val, (int, float)) and lo <= val <= hi):
                raise ValueError(f"MeshSizing.{name}={val!r} outside the allowed range [{lo}, {hi}]")

    # ------------------------------------------------------------------ sizes
    def wall_size(self, design: WhiskerDesign) -> float:
        """``h_wall`` or ``t / wall_layers``."""
        return float(self.h_wall) if self.h_wall is not None else design.t / self.wall_layers

    def cap_size(self, design: WhiskerDesign) -> float:
        """``h_cap`` or ``cap_factor * h_wall``."""
        return float(self.h_cap) if self.h_cap is not None else self.cap_factor * self.wall_size(design)

    def body_size(self, design: WhiskerDesign) -> float:
        """``max(h_body, h_wall)``: the body is never finer than the wall."""
        return max(self.h_body, self.wall_size(design))

    def size_at(self, design: WhiskerDesign, x: np.ndarray) -> np.ndarray:
        """Target edge length h(x) of the module docstring, shape of ``x``."""
        x = np.asarray(x, dtype=float)
        hw, hc, hb = self.wall_size(design), self.cap_size(design), self.body_size(design)
        body = np.minimum(hb, hw + self.grading * np.maximum(x - design.l, 0.0))
        return np.where(x < design.c, hc, np.where(x <= design.l, hw, body))

    # ------------------------------------------------------------------ identity
    def as_dict(self) -> dict:
        """The fields by name; ``theta_grading`` only when not 0, so that keys of equal sectors are unchanged."""
        out = dataclasses.asdict(self)
        if not out["theta_grading"]:
            del out["theta_grading"]
        return out

    def key(self) -> str:
        """Stable hex digest of all fields (16 chars)."""
        return hashlib.sha256(json.dumps(self.as_dict(), sort_keys=True).encode()).hexdigest()[:16]

    def template_key(self) -> str | None:
        """Key of the relative sizing a template mesh reproduces, or None if not templatable.

        Mapping a template preserves the number of elements through the wall, so only
        sizings that are relative to t (``h_wall is None``) can be served by a template.
        """
        if self.h_wall is not None or self.h_cap is not None:
            return None
        rel = {k: v for k, v in self.as_dict().items() if k not in ("name", "epsilon")}
        return hashlib.sha256(json.dumps(rel, sort_keys=True).encode()).hexdigest()[:12]


def background_mesh(design: WhiskerDesign, sizing: MeshSizing) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Background tet mesh carrying h(x) for fTetWild.

    A structured grid over the bounding box (padded by 1 mm) with x-nodes at most
    ``min(1, h_wall)`` apart and at x = c and x = l exactly, 2 x 2 nodes across (h does
    not depend on y, z), each hexahedron split into 6 tets (Kuhn/Freudenthal split,
    conforming across cells).

    Returns
    -------
    bg_vertices : ndarray, shape (n, 3) float64
    bg_tets : ndarray, shape (m, 4) int32
    bg_values : ndarray, shape (n,) float64
    """
    d = design
    Lt = d.length
    hx = min(1.0, sizing.wall_size(d))
    knots = [-1.0, 0.0, d.c, d.l, Lt, Lt + 1.0]
    xs = [np.array([-1.0])]
    for a, b in zip(knots[:-1], knots[1:]):
        n = max(1, int(math.ceil((b - a) / hx)))
        xs.append(np.linspace(a, b, n + 1)[1:])
    xs = np.concatenate(xs)
    R = d.D / 2.0 + 1.0
    ys = np.array([-R, R])
    nx = len(xs)
    X, Y, Z = np.meshgrid(xs, ys, ys, indexing="ij")  # (nx, 2, 2)
    verts = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)

    def vid(i, j, k):
        return (i * 2 + j) * 2 + k

    # Kuhn split of the unit cube along the main diagonal 0 -> 7 (6 tets)
    cube = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]])
    kuhn = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]]
    tets = []
    for i in range(nx - 1):
        corner_ids = [vid(i + a, b, c) for a, b, c in cube]
        tets.extend([[corner_ids[v] for v in tet] for tet in kuhn])
    tets = orient_linear(verts, np.asarray(tets, dtype=np.int64)).astype(np.int32)
    vals = sizing.size_at(d, np.clip(verts[:, 0], 0.0, Lt))
    return verts, tets, vals.astype(np.float64)
