"""The CalculiX/Abaqus input deck: a static hyperelastic problem (:class:`CcxCase`) and its writer.

:func:`write_deck` writes *the same mesh, material and loads* as the in-house solver
as an Abaqus-style input deck (C3D10, ``*HYPERELASTIC, NEO HOOKE``, ``NLGEOM``,
follower pressure ``*DLOAD``); :mod:`peers.calculix` runs it and reads the results, and
:mod:`whisker_opt.output.scene_deck` writes a whisker's scene with the same conventions and helpers.

Conventions (see :mod:`fem.element`)
------------------------------------
* Node order of a TET10 is VTK_QUADRATIC_TETRA, identical to Abaqus/CalculiX C3D10,
  so cells are written unchanged; node ``i`` (0-based) is CalculiX node ``i + 1`` and
  element ``e`` is CalculiX element ``e + 1``.
* Face labels 1..4 are the CalculiX surface labels S1..S4 and equal
  ``fem.element.FACES[label - 1]`` (pinned by ``tests/test_calculix.py``).
* Material: CalculiX's neo-Hookean strain energy (CalculiX User's Manual, sec.
  "Hyperelastic materials"; same as Abaqus) is
  ``W = C10 (I1_bar - 3) + (1/D1) (J - 1)^2``, shear modulus ``mu = 2 C10`` and bulk
  modulus ``K = 2 / D1``. CalculiX has no hybrid (mixed u-p) elements: C3D10H is
  unknown and ``D1 = 0`` silently falls back to a compressible law (nu = 0.475), so a
  small positive ``D1`` is required here.
* Pressure is a follower load on the deformed face; a positive value pushes *into* the
  solid (traction ``t = -p n`` with ``n`` the outward normal), like
  ``fem.problem.FollowerPressure``.
* Reaction forces ``RF`` as printed by CalculiX are the internal nodal forces at
  constrained degrees of freedom, i.e. the force the support exerts on the body.
  External loads acting directly on constrained nodes are *not* included in them.

Tolerances
----------
CalculiX's default Newton tolerances (``R_n = 5e-3`` of the average force) are far too
loose for a reference solution. :class:`CcxCase` tightens ``*CONTROLS,
PARAMETERS=FIELD`` and by default uses fixed increments (``*STATIC, DIRECT``), whose
divergence checks (``*CONTROLS, PARAMETERS=TIME INCREMENTATION``) are postponed so that
round-off-level residual noise cannot abort the step. A ``DIRECT`` increment cannot be
cut back: hard problems need more increments or ``CcxCase(direct=False)`` (automatic
incrementation with cut-backs, increment at most ``1 / n_increments``).
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem import element

logger = logging.getLogger(__name__)

#: CalculiX input lines are read up to 132 characters; keep id lists well below that
_IDS_PER_LINE = 8


@dataclass(frozen=True, eq=False)
class CcxCase:
    """A complete static hyperelastic problem for CalculiX.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
        Reference node coordinates.
    cells : ndarray, shape (n_elements, 10)
        TET10 connectivity (0-based, VTK_QUADRATIC_TETRA = C3D10 order).
    c10 : float
        Neo-Hookean ``C10 > 0`` (shear modulus ``mu = 2 C10``).
    d1 : float
        Neo-Hookean ``D1 > 0`` (bulk modulus ``K = 2 / D1``). CalculiX has no hybrid
        elements, so nearly incompressible rubber must be modelled with a small ``D1``
        (e.g. ``D1 = 2 / (1000 * mu)`` for ``K / mu = 1000``).
    boundary : tuple of (node_ids, component, value)
        Prescribed displacements: ``node_ids`` (k,) int (0-based), ``component`` in
        {0, 1, 2}, ``value`` the final displacement (0 = fixed). Ramped linearly over
        the step.
    pressures : tuple of (elem_ids, face_labels, value)
        Follower pressures: ``elem_ids`` (m,) int (0-based), ``face_labels`` (m,) int in
        1..4 (S1..S4 = ``fem.element.FACES[label - 1]``) or a single int for all,
        ``value`` the final pressure (positive pushes into the solid). Ramped linearly.
    n_increments : int
        Number of equal load increments, >= 1. With ``direct=True`` exactly these
        (``*STATIC, DIRECT``); otherwise the initial and largest increment is
        ``1 / n_increments`` and CalculiX may cut back.
    residual_tol : float
        ``R_n``: converged when the largest residual force is below this fraction of
        the average nodal force (CalculiX default 5e-3), in (0, 1).
    correction_tol : float
        ``C_n``: and the largest displacement correction is below this fraction of the
        largest displacement increment (CalculiX default 1e-2), in (0, 1).
    max_iterations : int
        Newton iterations allowed per increment (CalculiX ``I_C``, default 16), >= 4.
    print_reactions : bool
        Also print and parse nodal reaction forces ``RF``.
    direct : bool
        Fixed increments (default, reproducible reference). CalculiX cannot cut back a
        ``DIRECT`` increment, so a hard problem (large shear of a nearly incompressible
        block, say) needs enough increments or ``direct=False``: automatic
        incrementation with increment ``<= 1 / n_increments``, cutbacks down to
        ``min_increment`` and CalculiX's default divergence checks.
    min_increment : float
        Smallest increment (fraction of the step) for ``direct=False``, in (0, 1].
    """

    points: np.ndarray
    cells: np.ndarray
    c10: float
    d1: float
    boundary: tuple = ()
    pressures: tuple = ()
    n_increments: int = 10
    residual_tol: float = 1e-8
    correction_tol: float = 1e-8
    max_iterations: int = 40
    print_reactions: bool = True
    direct: bool = True
    min_increment: float = 1e-5

    def __post_init__(self) -> None:
        pts = np.ascontiguousarray(self.points, dtype=np.float64)
        cells = np.ascontiguousarray(self.cells, dtype=np.int64)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise ValueError(f"CcxCase.points: shape {pts.shape}, expected (n_nodes >= 1, 3)")
        if not np.all(np.isfinite(pts)):
            raise ValueError("CcxCase.points: contains non-finite coordinates")
        if cells.ndim != 2 or cells.shape[1] != 10 or len(cells) == 0:
            raise ValueError(f"CcxCase.cells: shape {cells.shape}, expected (n_elements >= 1, 10)")
        n = len(pts)
        if cells.min() < 0 or cells.max() >= n:
            raise ValueError(
                f"CcxCase.cells: node index range [{cells.min()}, {cells.max()}] outside [0, {n - 1}]"
            )
        if not (math.isfinite(self.c10) and self.c10 > 0):
            raise ValueError(f"CcxCase.c10: {self.c10!r}, expected a finite value > 0")
        if not (math.isfinite(self.d1) and self.d1 > 0):
            raise ValueError(
                f"CcxCase.d1: {self.d1!r}, expected a finite value > 0. CalculiX has no hybrid "
                "elements and silently replaces D1 = 0 by a compressible law (nu = 0.475); use a "
                f"small D1 instead, e.g. D1 = 2 / (1000 * mu) = {2.0 / (2000.0 * self.c10):.3g} "
                "for a bulk/shear modulus ratio of 1000"
            )
        if not (isinstance(self.n_increments, (int, np.integer)) and self.n_increments >= 1):
            raise ValueError(f"CcxCase.n_increments: {self.n_increments!r}, expected an int >= 1")
        for name in ("residual_tol", "correction_tol"):
            v = getattr(self, name)
            if not (0.0 < v < 1.0):
                raise ValueError(f"CcxCase.{name}: {v!r}, expected a value in (0, 1)")
        if not (0.0 < self.min_increment <= 1.0):
            raise ValueError(f"CcxCase.min_increment: {self.min_increment!r}, expected a value in (0, 1]")
        if not (isinstance(self.max_iterations, (int, np.integer)) and self.max_iterations >= 4):
            raise ValueError(f"CcxCase.max_iterations: {self.max_iterations!r}, expected an int >= 4")

        bcs = []
        for i, bc in enumerate(self.boundary):
            if len(bc) != 3:
                raise ValueError(f"CcxCase.boundary[{i}]: expected (node_ids, component, value), got {bc!r}")
            nodes = np.unique(np.asarray(bc[0], dtype=np.int64).ravel())
            comp, value = int(bc[1]), float(bc[2])
            if len(nodes) == 0:
                raise ValueError(f"CcxCase.boundary[{i}].node_ids: empty")
            if nodes.min() < 0 or nodes.max() >= n:
                raise ValueError(
                    f"CcxCase.boundary[{i}].node_ids: range [{nodes.min()}, {nodes.max()}] "
                    f"outside [0, {n - 1}]"
                )
            if comp not in (0, 1, 2):
                raise ValueError(f"CcxCase.boundary[{i}].component: {bc[1]!r}, expected 0, 1 or 2")
            if not math.isfinite(value):
                raise ValueError(f"CcxCase.boundary[{i}].value: {value!r}, expected a finite number")
            bcs.append((nodes, comp, value))
        object.__setattr__(self, "boundary", tuple(bcs))

        prs = []
        n_el = len(cells)
        for i, pr in enumerate(self.pressures):
            if len(pr) != 3:
                raise ValueError(
                    f"CcxCase.pressures[{i}]: expected (elem_ids, face_labels, value), got {pr!r}"
                )
            elems = np.asarray(pr[0], dtype=np.int64).ravel()
            labels = np.broadcast_to(np.asarray(pr[1], dtype=np.int64), elems.shape).copy()
            value = float(pr[2])
            if len(elems) == 0:
                raise ValueError(f"CcxCase.pressures[{i}].elem_ids: empty")
            if elems.min() < 0 or elems.max() >= n_el:
                raise ValueError(
                    f"CcxCase.pressures[{i}].elem_ids: range [{elems.min()}, {elems.max()}] "
                    f"outside [0, {n_el - 1}]"
                )
            if labels.min() < 1 or labels.max() > 4:
                raise ValueError(
                    f"CcxCase.pressures[{i}].face_labels: range [{labels.min()}, {labels.max()}] "
                    "outside [1, 4] (S1..S4)"
                )
            if not math.isfinite(value):
                raise ValueError(f"CcxCase.pressures[{i}].value: {value!r}, expected a finite number")
            prs.append((elems, labels, value))
        object.__setattr__(self, "pressures", tuple(prs))
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "cells", cells)

    @property
    def n_nodes(self) -> int:
        return len(self.points)


def element_faces(cells: np.ndarray, faces6: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Find the (element, face label) of each given 6-node face.

    Converts the face arrays used by the in-house solver (e.g.
    ``FollowerPressure.faces``) to CalculiX's element-face description.

    Parameters
    ----------
    cells : ndarray, shape (n_elements, 10)
    faces6 : ndarray, shape (n_faces, 6)
        Triangles whose corner nodes identify an element face (orientation ignored).

    Returns
    -------
    elem_ids : ndarray, shape (n_faces,)
        0-based element owning the face (the lowest element id if the face is interior).
    labels : ndarray, shape (n_faces,)
        Face labels 1..4 (S1..S4).

    Raises
    ------
    ValueError
        If a face is not a face of any element.
    """
    cells = np.asarray(cells, dtype=np.int64)
    faces6 = np.asarray(faces6, dtype=np.int64).reshape(-1, 6)
    keys = np.sort(cells[:, element.FACES[:, :3]], axis=2).reshape(-1, 3)  # (n_el*4, 3)
    order = np.lexsort(keys.T[::-1])
    sorted_keys = keys[order]
    query = np.sort(faces6[:, :3], axis=1)  # (n_f, 3)
    # lexicographic search via structured views
    dt = np.dtype([("a", np.int64), ("b", np.int64), ("c", np.int64)])
    sk = np.ascontiguousarray(sorted_keys).view(dt).ravel()
    qk = np.ascontiguousarray(query).view(dt).ravel()
    pos = np.searchsorted(sk, qk)
    pos_c = np.minimum(pos, len(sk) - 1)
    found = (pos < len(sk)) & np.all(sorted_keys[pos_c] == query, axis=1)
    if not np.all(found):
        bad = np.nonzero(~found)[0]
        raise ValueError(
            f"element_faces.faces6: {len(bad)} of {len(query)} faces are not element faces "
            f"(first: row {bad[0]}, corners {faces6[bad[0], :3].tolist()})"
        )
    flat = order[pos_c]
    return flat // 4, flat % 4 + 1


def _fmt(x: float) -> str:
    """Float text that fits CalculiX's 20-character fields.

    The shortest round-tripping text when it fits; otherwise 13 significant digits
    (relative rounding ≤ 5e-13). ``repr`` of e.g. −1.4473103847089728e-15 has 23
    characters and CalculiX rejects the deck.
    """
    s = repr(float(x))
    return s if len(s) <= 20 else f"{float(x):.13g}"


def _write_id_lines(f, ids: np.ndarray) -> None:
    ids = np.asarray(ids, dtype=np.int64) + 1
    for k in range(0, len(ids), _IDS_PER_LINE):
        f.write(", ".join(str(v) for v in ids[k : k + _IDS_PER_LINE]) + "\n")


def write_deck(case: CcxCase, path: str | os.PathLike) -> Path:
    """Write ``case`` as a CalculiX input deck.

    Parameters
    ----------
    case : CcxCase
    path : path-like
        Output file; CalculiX requires the ``.inp`` suffix, which is added if missing.

    Returns
    -------
    Path
        The written deck.

    Notes
    -----
    Node ``i`` and element ``e`` are written as CalculiX ids ``i + 1`` and ``e + 1``.
    Keywords used: ``*NODE``, ``*ELEMENT, TYPE=C3D10``, ``*NSET``, ``*SURFACE,
    TYPE=ELEMENT``, ``*MATERIAL``, ``*HYPERELASTIC, NEO HOOKE``, ``*SOLID SECTION``,
    ``*STEP, NLGEOM, INC``, ``*STATIC, DIRECT``, ``*CONTROLS``, ``*BOUNDARY``,
    ``*DLOAD`` (``P``), ``*NODE PRINT`` (U, RF) and ``*NODE FILE`` (U).
    """
    path = Path(path)
    if path.suffix != ".inp":
        path = path.with_name(path.name + ".inp")
    n_inc = int(case.n_increments)
    dt = 1.0 / n_inc
    with open(path, "w") as f:
        f.write("** whisker-opt CalculiX deck: C3D10 neo-Hookean, NLGEOM, fixed increments\n")
        f.write("*HEADING\nwhisker-opt peer check\n")
        f.write("*NODE, NSET=NALL\n")
        for i, (x, y, z) in enumerate(case.points):
            f.write(f"{i + 1}, {_fmt(x)}, {_fmt(y)}, {_fmt(z)}\n")
        f.write("*ELEMENT, TYPE=C3D10, ELSET=EALL\n")
        for e, c in enumerate(case.cells + 1):
            f.write(f"{e + 1}, " + ", ".join(str(v) for v in c) + "\n")
        for i, (nodes, _, _) in enumerate(case.boundary):
            f.write(f"*NSET, NSET=NBC{i}\n")
            _write_id_lines(f, nodes)
        for i, (elems, labels, _) in enumerate(case.pressures):
            f.write(f"*SURFACE, NAME=SPRESS{i}, TYPE=ELEMENT\n")
            for e, lab in zip(elems + 1, labels):
                f.write(f"{e}, S{lab}\n")
        f.write("*MATERIAL, NAME=RUBBER\n*HYPERELASTIC, NEO HOOKE\n")
        f.write(f"{_fmt(case.c10)}, {_fmt(case.d1)}\n")
        f.write("*SOLID SECTION, ELSET=EALL, MATERIAL=RUBBER\n")
        if case.direct:
            # INC: maximum number of increments; DIRECT uses exactly n_inc of them
            f.write(f"*STEP, NLGEOM, INC={n_inc + 10}\n")
            f.write("*STATIC, DIRECT\n")
            f.write(f"{_fmt(dt)}, 1.0\n")
        else:
            max_inc = n_inc + int(math.ceil(1.0 / case.min_increment)) + 10
            f.write(f"*STEP, NLGEOM, INC={min(max_inc, 10**7)}\n")
            f.write("*STATIC\n")
            f.write(f"{_fmt(dt)}, 1.0, {_fmt(min(case.min_increment, dt))}, {_fmt(dt)}\n")
        # FIELD: R_n, C_n, q0, q_u, R_p, eps, C_eps, R_l (CalculiX manual, *CONTROLS).
        # q0 and q_u blank (read as 0): the average force is always computed, never seeded
        # with 0.01, which would accept any residual of a tiny-load problem. R_p (used
        # after I_P iterations, default 0.02) and C_eps (zero-flux case) are tightened too.
        f.write("*CONTROLS, PARAMETERS=FIELD\n")
        f.write(
            f"{_fmt(case.residual_tol)}, {_fmt(case.correction_tol)}, , , {_fmt(case.residual_tol)}, "
            f"{_fmt(case.residual_tol)}, {_fmt(case.correction_tol)}, {_fmt(min(1e-8, case.residual_tol))}\n"
        )
        # TIME INCREMENTATION: I_0, I_R, I_P, I_C, I_L, I_G, I_S, I_A, I_J, I_T
        it = int(case.max_iterations)
        f.write("*CONTROLS, PARAMETERS=TIME INCREMENTATION\n")
        if case.direct:
            # late divergence/log-convergence checks so round-off noise near a tight
            # tolerance does not abort a fixed-increment (DIRECT) step, which cannot
            # be cut back
            f.write(f"{it}, {it}, {it + 1}, {it}, 10, 4, 0, 5, 0, 0\n")
        else:
            # CalculiX defaults (divergence check after 4, log check after 8) so that
            # diverging increments are cut back early; I_P past I_C keeps R_n in force
            f.write(f"4, 8, {it + 1}, {it}, 10, 4, 0, {20}, 0, 0\n")
        if case.boundary:
            f.write("*BOUNDARY\n")
            for i, (_, comp, value) in enumerate(case.boundary):
                f.write(f"NBC{i}, {comp + 1}, {comp + 1}, {_fmt(value)}\n")
        if case.pressures:
            f.write("*DLOAD\n")
            for i, (_, _, value) in enumerate(case.pressures):
                f.write(f"SPRESS{i}, P, {_fmt(value)}\n")
        outputs = "U, RF" if case.print_reactions else "U"
        # output only at the end of the step (it is always written there)
        freq = n_inc if case.direct else 10**6
        f.write(f"*NODE PRINT, NSET=NALL, FREQUENCY={freq}\n{outputs}\n")
        f.write(f"*NODE FILE, FREQUENCY={freq}\nU\n")
        f.write("*END STEP\n")
    logger.debug("wrote CalculiX deck %s (%d nodes, %d elements)", path, case.n_nodes, len(case.cells))
    return path
