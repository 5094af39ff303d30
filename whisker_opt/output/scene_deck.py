"""A whisker's scene as a CalculiX/Abaqus input deck: the mesh, the fibres, the supports and the two steps.

:func:`write_scene_deck` writes, with the conventions of :mod:`whisker_opt.output.calculix_deck`
(node ``i`` is deck node ``i + 1``, element ``e`` deck element ``e + 1``, TET10 = C3D10 node order,
follower pressure ``*DLOAD ... P`` positive into the solid):

* the rubber as C3D10 (CalculiX) or C3D10H (Abaqus) elements with ``*HYPERELASTIC, NEO HOOKE`` (C10, D1),
  the written D1 named in the deck's header (Flavours, below);
* the fibres as axial springs (SPRINGA, stiffness k = E A / L₀ of each segment, sets ``FIBRE<k>`` of
  equal stiffness, :func:`spring_groups`) whose nodes are tied to
  their host tetrahedra by ``*EQUATION``: u_j − Σ_a N_a(ξ_j) u_a = 0 per direction, the embedding
  of the in-house solver. A spring's force k (ℓ − L₀) equals the in-house Saint Venant–Kirchhoff
  truss's E A (ℓ² − L₀²)/(2 L₀²) to first order in the fibre strain (ℓ/L₀ − 1, below 1e-3 in the
  scenes). CalculiX expands T3D2 trusses into 3-D elements held by nonlinear constraints, with which
  the deflection step did not converge; springs are not expanded;
* the base supports (``scene.base_support``) as ``*BOUNDARY`` at the model level;
* one static step in two phases of step time 1 (:func:`_phases`): *pressurise*, ``*DLOAD`` Q on the
  cavity faces (surface ``CAVITY``) ramped over [0, 1] and then held; *deflect*, the contact nodes (set
  ``CONTACT``) moved in y to −δ over [1, 2], x and z free. The contact nodes are held at u_y = 0
  while the whisker is pressurised (the in-house scene leaves them free and pushes from their
  pressurised u_y⁰, which is 0 on the symmetric whisker up to the mesh's asymmetry). The contact
  is the tip face (a = 1) or the node ring nearest a·L in the reference configuration (the
  in-house scene places it at the pressurised a·L_Q, known only once pressurised).

Outputs at the end of each phase (CalculiX): ``U`` and ``S`` to the ``.frd`` file; the total ``RF`` of ``BASE``
and ``CONTACT`` and the ``U`` of the ``CONTACT`` nodes to the ``.dat`` file (read back by
:func:`peers.calculix.read_scene_deck`). Abaqus: ``*OUTPUT`` of U, RF and S at the phase ends to the ``.odb``,
the totals of ``BASE`` and ``CONTACT`` printed every increment. Units: mm, N, MPa.

Flavours
--------
The scene's rubber is incompressible (D1 = 0), solved by the in-house mixed u–p formulation.

``abaqus``
    C3D10H, Abaqus's hybrid quadratic tetrahedron (an independent pressure per element, as the in-house
    P2/P0 solve), with the scene's own D1, 0 included (Abaqus Analysis User's Guide, "Solid (continuum)
    elements" and "Hyperelastic behavior of rubberlike materials": hybrid elements for incompressible
    hyperelastic materials). The cavity is loaded by ``*DSLOAD`` on its surface. Written to the keyword
    reference; not run here (no Abaqus at hand), and CalculiX does not read C3D10H.
``calculix``
    CalculiX has no hybrid elements: its C3D10 is a pure displacement element with four integration points
    (CalculiX User's Manual, "C3D10"), and D1 = 0 is replaced without a word by a compressible law (see
    :mod:`whisker_opt.output.calculix_deck`). The deck writes D1 = 2/(K/μ · μ) with
    K/μ = :data:`CALCULIX_BULK_RATIO` = 20 (ν = 0.475) unless asked otherwise. Two errors pull apart as K/μ
    changes: the element's volumetric locking (stiffer, growing with K/μ and shrinking as the mesh refines)
    and the compressibility itself (softer, growing as K/μ falls, independent of the mesh). At K/μ = 1000
    the locking dominates (coarse preset, intact at 0.2 MPa: Δl −5.3 %, contact force +13.6 % against the
    in-house mixed solve); at 20 the compressibility bounds what is left (the mixed solve at K/μ = 20: Δl
    +3.1 %, F −4.2 %), the two nearly cancel on the GA presets' meshes and the deck tends to that bound as
    the mesh refines. The measured agreement: docs/physics.md §15 and ``benchmarks/results/calculix_agreement.md``.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem import element
from whisker_opt.output.calculix_deck import _fmt, _write_id_lines, element_faces

logger = logging.getLogger(__name__)

#: Terms of an ``*EQUATION`` per line (CalculiX and Abaqus read at most four).
_TERMS_PER_LINE = 4
#: Shape-function weights below this are left out of a fibre node's ``*EQUATION``.
_WEIGHT_TOL = 1e-12


#: The deck flavours (``whisker-opt export --flavour``): the rubber's element and how its near-incompressibility
#: is written (module docstring, "Flavours").
FLAVOURS = ("calculix", "abaqus")
#: K/μ of the CalculiX flavour's compressible rubber, where the scene's D1 = 0 (module docstring, "Flavours").
CALCULIX_BULK_RATIO = 20.0


@dataclass(frozen=True)
class DeckOptions:
    """How the scene deck is written.

    Parameters
    ----------
    n_increments : int
        Initial (and largest) increment of each step is 1/``n_increments`` of it; CalculiX's
        automatic incrementation may cut back. >= 1.
    flavour : {'calculix', 'abaqus'}
        'calculix': C3D10 with a compressible rubber of K/μ = ``bulk_ratio`` where the scene's D1 = 0
        (CalculiX has no hybrid elements). 'abaqus': hybrid C3D10H with the scene's own D1 (0 is
        incompressible), output requested by ``*OUTPUT``; it does not run in CalculiX.
    bulk_ratio : float or None
        K/μ of the compressible rubber written for D1 = 0: D1 = 2/(bulk_ratio · μ), > 1. None: the flavour's
        own (:data:`CALCULIX_BULK_RATIO` for 'calculix', incompressible for 'abaqus').
    deflect : bool
        Write the deflection step after the pressurise step.
    """

    n_increments: int = 10
    flavour: str = "calculix"
    bulk_ratio: float | None = None
    deflect: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.n_increments, (int, np.integer)) and self.n_increments >= 1):
            raise ValueError(f"DeckOptions.n_increments: {self.n_increments!r}, expected an int >= 1")
        if self.flavour not in FLAVOURS:
            raise ValueError(f"DeckOptions.flavour: {self.flavour!r}, expected one of {', '.join(FLAVOURS)}")
        if self.bulk_ratio is not None and not self.bulk_ratio > 1:
            raise ValueError(f"DeckOptions.bulk_ratio: {self.bulk_ratio!r}, expected a number > 1 or None")

    @property
    def element(self) -> str:
        """The rubber's element type: C3D10 (CalculiX) or the hybrid C3D10H (Abaqus)."""
        return "C3D10H" if self.flavour == "abaqus" else "C3D10"

    @property
    def rubber_bulk_ratio(self) -> float | None:
        """K/μ written where the scene's D1 = 0; None: D1 = 0 itself (the hybrid element)."""
        if self.bulk_ratio is not None:
            return float(self.bulk_ratio)
        return None if self.flavour == "abaqus" else CALCULIX_BULK_RATIO


def deck_d1(c10: float, d1: float, bulk_ratio: float | None) -> float:
    """D1 written to the deck: ``d1`` when > 0, else 2/(bulk_ratio · μ) with μ = 2 C10 (K = 2/D1); 0 when
    ``bulk_ratio`` is None (incompressible, for a hybrid element)."""
    if d1 > 0 or bulk_ratio is None:
        return float(d1)
    return 2.0 / (bulk_ratio * 2.0 * c10)


def deck_refusal(spec) -> str | None:
    """Why the deck cannot hold the scene ``spec`` (one line naming the key, its value and what the deck
    writes), or None when it can.

    The deck writes the neo-Hookean rubber, the embedded fibres (springs tied into the rubber) and the
    'embedded' wall law (or a law that is the identity, c ≡ 1). A wall law changes the chamber wall's
    stiffness about the pressurised state (:func:`whisker_opt.wall.law.apply_law`: a scaled rubber with
    the pressurised stress frozen), which a deck's material, fixed for the whole analysis, cannot state;
    the smeared winding is an anisotropic term of the wall that the deck's isotropic hyperelastic
    material cannot hold either.
    """
    if spec.rubber != "neo_hookean" or spec.cap_rubber not in ("same", spec.rubber):
        return (f"material.rubber: {spec.rubber!r} (cap_rubber {spec.cap_rubber!r}); the CalculiX/Abaqus deck "
                "writes the neo-Hookean law only (rubber: neo_hookean, cap_rubber: same)")
    if spec.cap_joint != "tied":
        return (f"material.cap_joint: {spec.cap_joint!r}; the CalculiX/Abaqus deck writes one rubber for the "
                "whole body, not a cap scaled by its joint (cap_joint: tied)")
    if spec.fibre_model != "embedded":
        return (f"material.fibre_model: {spec.fibre_model!r}; the CalculiX/Abaqus deck writes the embedded fibres "
                "only (springs tied into the rubber; fibre_model: embedded)")
    if spec.base_support == "compliant":
        return ("scene.base_support: 'compliant'; the CalculiX/Abaqus deck writes the base's displacement sets "
                "only, not its elastic supports (base_support: clamped, sliding, axial or grip)")
    if spec.gauge_patch != "none":
        return (f"scene.gauge_patch: {spec.gauge_patch!r}; the CalculiX/Abaqus deck writes the bare surface under "
                "the gauge only, not a sheet bonded on it (gauge_patch: none)")
    if not spec.law.identity:
        law = f" (c(Q) = 1 + {spec.wall_slope:g}·Q)" if spec.wall_law == "calibrated" else ""
        return (f"material.wall_law: {spec.wall_law!r}{law}; the CalculiX/Abaqus deck writes "
                "the 'embedded' wall law only (a wall law changes the wall's stiffness about the pressurised "
                "state, which the deck's material cannot)")
    return None


def fibre_equations(cells: np.ndarray, host: np.ndarray, xi: np.ndarray, first_node: int) -> list[list[tuple]]:
    """The embedding of fibre nodes: for node j (deck id ``first_node + j``, 0-based) and each direction,
    ``[(j, dof, 1), (a, dof, −N_a(ξ_j)) for the host's nodes a]`` with weights below 1e-12 left out.

    Returns
    -------
    list of list of (node (0-based), dof (1..3), coefficient)
    """
    N = element.shape_functions(np.asarray(xi, dtype=float))  # (n, 10)
    out = []
    for j, (e, w) in enumerate(zip(host, N)):
        keep = np.abs(w) > _WEIGHT_TOL
        nodes, weights = cells[e][keep], w[keep]
        for dof in (1, 2, 3):
            out.append([(first_node + j, dof, 1.0)] + [(int(a), dof, -float(c)) for a, c in zip(nodes, weights)])
    return out


def spring_groups(points: np.ndarray, segments: np.ndarray, ea: float) -> list[tuple[float, np.ndarray]]:
    """Segments grouped by their spring stiffness k = E A / L₀ [N/mm], rounded to 7 significant digits
    (a relative error below 5e-8; the chords of a helix on a cone differ in length by ~1e-4).

    Returns
    -------
    list of (k, segment indices)
    """
    L0 = np.linalg.norm(points[segments[:, 1]] - points[segments[:, 0]], axis=1)  # (m,)
    k = np.array([float(f"{v:.7g}") for v in ea / L0])  # (m,)
    values, inverse = np.unique(k, return_inverse=True)
    return [(float(v), np.nonzero(inverse.ravel() == i)[0]) for i, v in enumerate(values)]


def _write_equations(f, equations: list) -> None:
    f.write("*EQUATION\n")
    for terms in equations:
        f.write(f"{len(terms)}\n")
        for k in range(0, len(terms), _TERMS_PER_LINE):
            f.write(", ".join(f"{n + 1}, {d}, {_fmt(c)}" for n, d, c in terms[k: k + _TERMS_PER_LINE]) + "\n")


def _supports(wm, spec) -> list[tuple[str, np.ndarray, tuple]]:
    """``(set name, nodes, directions 1..3)`` of the base supports
    (as :func:`whisker_opt.experiment.scene.base_dirichlet`)."""
    from whisker_opt.experiment.scene import base_dirichlet

    return [(f"BASE{i}" if i else "BASE", np.asarray(d.nodes), tuple(c + 1 for c in d.components))
            for i, d in enumerate(base_dirichlet(wm, spec))]


def _contact_nodes(wm, spec) -> np.ndarray:
    """The contact nodes: the tip face (a = 1) or the band at a·L in the reference configuration."""
    from whisker_opt.experiment.contact import contact_band
    from whisker_opt.experiment.scene import scene_contact

    contact = scene_contact(spec)
    u0 = np.zeros_like(wm.mesh.points)
    return contact_band(wm, u0, contact.a * spec.design.length, spec.band_width, contact.at_tip)


def _phases(f, spec, options: DeckOptions) -> None:
    """One ``*STEP`` of step time 1 per phase, pressurise (Q > 0) then deflect: the pressure ramped on
    [0, 1] by amplitude ``APRESS`` and held, the contact's u_y ramped on the last unit by ``ADEFL``;
    output at the end of each phase (``*TIME POINTS``).

    One step with amplitudes, not two steps: CalculiX (2.20) diverged at the start of a second step
    after a follower-pressure step on the same model, down to increments of 1e-4 of the step."""
    pressure, deflect = spec.Q > 0, options.deflect
    total = float(pressure + deflect)
    n_inc = int(options.n_increments)
    dt = 1.0 / n_inc
    if pressure:
        f.write(f"*AMPLITUDE, NAME=APRESS\n0.0, 0.0, 1.0, 1.0, {_fmt(total)}, 1.0\n")
    if deflect:
        start = 1.0 if pressure else 0.0
        f.write(f"*AMPLITUDE, NAME=ADEFL\n0.0, 0.0, {_fmt(start)}, 0.0, {_fmt(total)}, 1.0\n" if pressure
                else "*AMPLITUDE, NAME=ADEFL\n0.0, 0.0, 1.0, 1.0\n")
    ends = ", ".join(_fmt(t) for t in np.arange(1.0, total + 0.5))
    f.write(f"*TIME POINTS, NAME=PHASES\n{ends}\n")
    f.write("** ---------------------------------------------------------------- "
            + " then ".join(n for n, on in (("pressurise", pressure), ("deflect", deflect)) if on) + "\n")
    f.write(f"*STEP, NLGEOM, INC={int(10 * n_inc * total) + 100}\n*STATIC\n")
    f.write(f"{_fmt(dt)}, {_fmt(total)}, 1e-05, {_fmt(dt)}\n")
    if pressure:  # Abaqus loads a surface by *DSLOAD; CalculiX reads a surface in *DLOAD too
        f.write(f"*{'DSLOAD' if options.flavour == 'abaqus' else 'DLOAD'}, AMPLITUDE=APRESS\nCAVITY, P, {_fmt(spec.Q)}\n")
    if deflect:
        f.write(f"*BOUNDARY, AMPLITUDE=ADEFL\nCONTACT, 2, 2, {_fmt(-spec.deflection)}\n")
    if options.flavour == "abaqus":  # Abaqus: time points on *OUTPUT (the .odb), totals printed every increment
        f.write("*OUTPUT, FIELD, TIME POINTS=PHASES\n*NODE OUTPUT\nU, RF\n*ELEMENT OUTPUT, ELSET=RUBBER\nS\n")
        f.write("*OUTPUT, HISTORY, TIME POINTS=PHASES\n*NODE OUTPUT, NSET=CONTACT\nU, RF\n")
        for name in ("BASE", "CONTACT"):
            f.write(f"*NODE PRINT, NSET={name}, TOTALS=ONLY\nRF\n")
    else:
        f.write("*NODE FILE, TIME POINTS=PHASES\nU\n*EL FILE, TIME POINTS=PHASES\nS\n")
        for name in ("BASE", "CONTACT"):
            f.write(f"*NODE PRINT, NSET={name}, TOTALS=ONLY, TIME POINTS=PHASES\nRF\n")
        f.write("*NODE PRINT, NSET=CONTACT, TIME POINTS=PHASES\nU\n")
    f.write("*END STEP\n")


def _d1_note(spec, options: DeckOptions) -> str:
    """The header's word on D1: how the scene's D1 = 0 was written."""
    if spec.d1 > 0:
        return ""
    k = options.rubber_bulk_ratio
    if k is None:
        return " (incompressible, the hybrid element's pressure)"
    return f" (the scene's D1 = 0 written as K/mu = {k:g}, nu = {(3 * k - 2) / (6 * k + 2):.4f})"


def write_scene_deck(path: str | os.PathLike, spec, wm, options: DeckOptions = DeckOptions()) -> Path:
    """Write the scene ``spec`` on the mesh ``wm`` as a CalculiX/Abaqus deck (see the module).

    Parameters
    ----------
    path : path-like
        The deck; ``.inp`` is added when missing. Written atomically.
    spec : whisker_opt.experiment.spec.SceneSpec
        Design, pressure Q, deflection δ, contact, supports, rubber (neo-Hookean only).
    wm : geometry.mesh.WhiskerMesh
        A mesh of ``spec.design`` (its fibres are written when it has any).
    options : DeckOptions

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        A scene the deck cannot hold (:func:`deck_refusal`): a rubber other than the neo-Hookean one, the
        smeared fibres, a wall law other than 'embedded' or a base on elastic supports.
    """
    from fem.io import atomic_write

    refusal = deck_refusal(spec)
    if refusal:
        raise ValueError(refusal)
    path = Path(path)
    if path.suffix != ".inp":
        path = path.with_name(path.name + ".inp")
    mesh, d = wm.mesh, spec.design
    n = mesh.n_nodes
    fibres = tuple(getattr(wm, "fibres", ()) or ())
    supports = _supports(wm, spec)
    contact = _contact_nodes(wm, spec)
    d1 = deck_d1(spec.c10, spec.d1, options.rubber_bulk_ratio)
    cav_el, cav_lab = element_faces(mesh.cells, wm.face_sets["cavity"]) if spec.Q > 0 else (None, None)

    def produce(tmp: str) -> None:
        with open(tmp, "w") as f:
            f.write(f"** whisker-opt scene deck ({options.flavour}): {options.element} neo-Hookean rubber, SPRINGA "
                    "fibres tied by *EQUATION, NLGEOM\n")
            f.write(f"** design: {d.describe()}, trim {d.trim:g} mm; units mm, N, MPa\n")
            f.write(f"** scene: Q = {spec.Q:g} MPa, deflection {spec.deflection:g} mm in -y at a = "
                    f"{spec.contact_ratio:g}, base {spec.base_support}\n")
            f.write(f"** rubber: C10 = {spec.c10:g} MPa, D1 = {_fmt(d1)} 1/MPa"
                    + _d1_note(spec, options) + "\n")
            f.write("*HEADING\nwhisker-opt scene\n*NODE, NSET=NALL\n")
            for i, (x, y, z) in enumerate(mesh.points):
                f.write(f"{i + 1}, {_fmt(x)}, {_fmt(y)}, {_fmt(z)}\n")
            fibre_first, pts, segs, eqs = n, [], [], []
            for fp in fibres:
                for j, (x, y, z) in enumerate(fp.points_ref):
                    f.write(f"{fibre_first + j + 1}, {_fmt(x)}, {_fmt(y)}, {_fmt(z)}\n")
                pts.append(np.asarray(fp.points_ref, dtype=float))
                segs.append(np.asarray(fp.segments) + fibre_first)
                eqs += fibre_equations(mesh.cells, fp.host_elements, fp.local_coords, fibre_first)
                fibre_first += len(fp.points_ref)
            groups = spring_groups(np.vstack(pts), np.vstack(segs) - n, d.fibre_E * d.fibre_area) if segs else []
            all_segs = np.vstack(segs) if segs else np.zeros((0, 2), dtype=np.int64)
            f.write(f"*ELEMENT, TYPE={options.element}, ELSET=RUBBER\n")
            for e, c in enumerate(mesh.cells + 1):
                f.write(f"{e + 1}, " + ", ".join(str(v) for v in c) + "\n")
            for i, (_, idx) in enumerate(groups):
                f.write(f"*ELEMENT, TYPE=SPRINGA, ELSET=FIBRE{i}\n")
                for k in idx:
                    f.write(f"{mesh.n_elements + k + 1}, {all_segs[k, 0] + 1}, {all_segs[k, 1] + 1}\n")
            for name, nodes, _ in supports:
                f.write(f"*NSET, NSET={name}\n")
                _write_id_lines(f, nodes)
            f.write("*NSET, NSET=CONTACT\n")
            _write_id_lines(f, contact)
            if cav_el is not None:
                f.write("*SURFACE, NAME=CAVITY, TYPE=ELEMENT\n")
                for e, lab in zip(cav_el + 1, cav_lab):
                    f.write(f"{e}, S{lab}\n")
            f.write(f"*MATERIAL, NAME=RUBBER\n*HYPERELASTIC, NEO HOOKE\n{_fmt(spec.c10)}, {_fmt(d1)}\n")
            f.write("*SOLID SECTION, ELSET=RUBBER, MATERIAL=RUBBER\n")
            for i, (k, _) in enumerate(groups):
                f.write(f"*SPRING, ELSET=FIBRE{i}\n\n{_fmt(k)}\n")
            if eqs:
                _write_equations(f, eqs)
            f.write("*BOUNDARY\n")
            for name, _, dirs in supports:
                for c in dirs:
                    f.write(f"{name}, {c}, {c}, 0.0\n")
            if spec.Q > 0 or options.deflect:
                _phases(f, spec, options)

    atomic_write(path, produce)
    logger.info("wrote %s (%d nodes, %d elements, %d fibre nodes)", path, n, mesh.n_elements,
                sum(len(fp.points_ref) for fp in fibres))
    return path
