"""CalculiX (``ccx``) as an independent peer solver for 10-node tet hyperelastic problems.

The in-house solver is cross-checked by running *the same mesh, material and loads*
through CalculiX: this module writes an Abaqus-style input deck (C3D10,
``*HYPERELASTIC, NEO HOOKE``, ``NLGEOM``, follower pressure ``*DLOAD``), runs ``ccx``
and parses the nodal displacements and reaction forces back into our node order.

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

CalculiX quirks found while pinning this driver (CalculiX 2.20, Debian build)
---------------------------------------------------------------------------
* Convergence (``checkconvergence.c``): an increment converges after >= 2 iterations
  when ``r_max <= R_n q`` and either ``c_max <= C_n du_max`` or an estimate of the next
  correction is small or ``c_max < 1e-8`` *absolute* (length units). The average force
  ``q`` is computed, not seeded, when ``q0`` is left blank (CalculiX's own default 0).
* ``.dat`` values have 7 significant digits (``1.234567E-02``); the ASCII ``.frd``
  only 6, so results are parsed from the ``.dat`` file. Three-digit exponents lose
  their ``E`` (``1.234567-100``), which :func:`parse_dat` handles.
* ``RF`` at unconstrained DOFs is the residual force (round-off, not zero). Loads on
  fully constrained nodes never appear in ``RF``; a model with no free DOF is not
  solved at all (zero output).
* ``*NODE PRINT/FILE, FREQUENCY=k`` still writes the end of the step.
* Failures: exit code 201 with ``*ERROR: solution seems to diverge`` (DIRECT) or
  ``increment size smaller than minimum``; exit code 255 when SPOOLES finds the
  matrix singular after a diverged iteration (``spooles.out``).
* CalculiX factors a *symmetric* system even with follower pressure: under
  compressive pressure Newton converges only linearly and a DIRECT step may
  diverge where a consistent tangent would not; use more increments or
  ``direct=False`` there.
"""

from __future__ import annotations

import logging
import math
import os
import re
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem import element

logger = logging.getLogger(__name__)

#: name of the CalculiX executable searched on PATH
CCX_EXECUTABLE = "ccx"

#: CalculiX input lines are read up to 132 characters; keep id lists well below that
_IDS_PER_LINE = 8


class CcxError(RuntimeError):
    """CalculiX failed, did not converge, or produced output that cannot be parsed.

    Attributes
    ----------
    workdir : Path or None
        Directory holding the deck and CalculiX's output files.
    log_tail : str
        Last lines of CalculiX's console output.
    """

    def __init__(self, message: str, workdir: Path | None = None, log_tail: str = "") -> None:
        full = message
        if workdir is not None:
            full += f" (workdir: {workdir})"
        if log_tail:
            full += "\n--- ccx log tail ---\n" + log_tail
        super().__init__(full)
        self.workdir = workdir
        self.log_tail = log_tail


def ccx_available() -> bool:
    """Whether the CalculiX executable ``ccx`` is on ``PATH``."""
    return shutil.which(CCX_EXECUTABLE) is not None


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


@dataclass(frozen=True, eq=False)
class CcxResult:
    """Output of :func:`run_ccx` at the end of the step (load factor 1).

    Attributes
    ----------
    displacements : ndarray, shape (n_nodes, 3)
        Nodal displacements in the input node order (NaN if not converged).
    reactions : ndarray, shape (n_nodes, 3) or None
        Nodal reaction forces ``RF`` (zero at unconstrained DOFs); None if not printed.
    wall_time : float
        Wall-clock seconds of the ``ccx`` process.
    converged : bool
        Whether the step finished at total time 1 without errors.
    n_increments : int
        Converged increments (from the ``.sta`` file).
    n_iterations : int
        Total Newton iterations over all attempts, including cut-back ones (from the
        ``.sta`` file).
    n_cutbacks : int
        Increment attempts that were abandoned and retried smaller (``direct=False``).
    workdir : Path
        Directory with the deck (``<job>.inp``) and CalculiX's output.
    log_path : Path
        CalculiX's console output.
    dat_path : Path
        The ``.dat`` file with the printed nodal results.
    """

    displacements: np.ndarray
    reactions: np.ndarray | None
    wall_time: float
    converged: bool
    n_increments: int
    n_iterations: int
    n_cutbacks: int
    workdir: Path
    log_path: Path
    dat_path: Path


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


# --------------------------------------------------------------------------- deck


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
        f.write("** whisker-opt peers.calculix deck: C3D10 neo-Hookean, NLGEOM, fixed increments\n")
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


# --------------------------------------------------------------------------- output

_HEADER = re.compile(r"^\s*(displacements|forces)\s*\(.*\)\s*for set\s+(\S+)\s+and time\s+(\S+)", re.I)
# Fortran drops the 'E' for three-digit exponents: 0.123456-100
_FORTRAN_EXP = re.compile(r"(?<=[0-9.])([+-]\d{3})$")


def _to_float(tok: str) -> float:
    try:
        return float(tok)
    except ValueError:
        fixed = _FORTRAN_EXP.sub(r"E\1", tok)
        return float(fixed)


def parse_dat(path: str | os.PathLike, n_nodes: int) -> dict[str, tuple[float, np.ndarray]]:
    """Parse the last printed displacement and force blocks of a CalculiX ``.dat`` file.

    Parameters
    ----------
    path : path-like
        The ``.dat`` file.
    n_nodes : int
        Number of nodes; values of nodes that are not printed stay NaN.

    Returns
    -------
    dict
        ``{"U": (time, (n_nodes, 3)), "RF": (time, (n_nodes, 3))}`` for the blocks present
        (the last block of each kind).

    Raises
    ------
    CcxError
        If a data line cannot be parsed.
    """
    out: dict[str, tuple[float, np.ndarray]] = {}
    key = None
    rows: list[tuple[int, float, float, float]] = []
    t = math.nan

    def flush() -> None:
        if key is None:
            return
        arr = np.full((n_nodes, 3), np.nan)
        if rows:
            ids = np.array([r[0] for r in rows], dtype=np.int64) - 1
            vals = np.array([r[1:] for r in rows], dtype=np.float64)
            ok = (ids >= 0) & (ids < n_nodes)
            arr[ids[ok]] = vals[ok]
        out[key] = (t, arr)

    with open(path) as f:
        for lineno, line in enumerate(f, 1):
            m = _HEADER.match(line)
            if m:
                flush()
                key = "U" if m.group(1).lower() == "displacements" else "RF"
                t = _to_float(m.group(3))
                rows = []
                continue
            if key is None:
                continue
            parts = line.split()
            if not parts:
                continue
            if len(parts) != 4 or not parts[0].isdigit():
                # another kind of block (totals, stresses, ...) ends this one
                flush()
                key = None
                continue
            try:
                rows.append((int(parts[0]), *(_to_float(p) for p in parts[1:])))
            except ValueError as exc:
                raise CcxError(f"parse_dat: cannot parse line {lineno} of {path}: {line!r}") from exc
    flush()
    return out


def _parse_sta(path: Path) -> tuple[int, int, int, float]:
    """Parse a ``.sta`` file.

    Returns converged increments, Newton iterations of all attempts, cut-back
    attempts (``ATT`` marked ``U``) and the total time of the last converged increment.
    """
    n_inc = n_it = n_cut = 0
    t_end = 0.0
    if not path.exists():
        return 0, 0, 0, 0.0
    for line in path.read_text(errors="replace").splitlines():
        parts = line.split()
        if len(parts) < 7 or not (parts[0].isdigit() and parts[1].isdigit() and parts[3].isdigit()):
            continue
        if parts[2].isdigit():
            try:
                t_end = _to_float(parts[4])
            except ValueError:
                continue
            n_inc += 1
        elif parts[2].rstrip("U").isdigit():
            n_cut += 1
        else:
            continue
        n_it += int(parts[3])
    return n_inc, n_it, n_cut, t_end


def _tail(path: Path, n_lines: int = 30) -> str:
    if not path.exists():
        return ""
    lines = path.read_text(errors="replace").splitlines()
    return "\n".join(lines[-n_lines:])


def run_ccx(
    case: CcxCase,
    workdir: str | os.PathLike | None = None,
    threads: int = 1,
    timeout: float | None = None,
    job: str = "job",
    raise_on_failure: bool = True,
    cleanup: bool = False,
) -> CcxResult:
    """Write the deck of ``case``, run CalculiX and read the final nodal results.

    Parameters
    ----------
    case : CcxCase
    workdir : path-like, optional
        Directory for the deck and output (created if missing). Default: a new
        temporary directory, which is kept so the logs stay available.
    threads : int
        Threads for CalculiX (``OMP_NUM_THREADS`` and ``CCX_NPROC_*``), >= 1.
    timeout : float, optional
        Seconds before the ``ccx`` process is killed (raises :class:`CcxError`).
    job : str
        Job name (deck ``<job>.inp``); letters, digits, ``_`` and ``-`` only.
    raise_on_failure : bool
        If True (default) raise :class:`CcxError` when CalculiX fails or does not
        converge; if False return a result with ``converged=False`` and NaN fields.
    cleanup : bool
        Delete ``workdir`` after a converged run (for benchmarks running many
        solves; the paths in the result then no longer exist). Failed runs are kept.

    Returns
    -------
    CcxResult

    Raises
    ------
    CcxError
        ``ccx`` missing, killed by the timeout, exited with an error, did not reach
        the end of the step, or printed unparsable results.
    """
    if not ccx_available():
        raise CcxError(f"run_ccx: executable {CCX_EXECUTABLE!r} not found on PATH")
    if not (isinstance(threads, (int, np.integer)) and threads >= 1):
        raise ValueError(f"run_ccx.threads: {threads!r}, expected an int >= 1")
    if not re.fullmatch(r"[A-Za-z0-9_-]+", job):
        raise ValueError(f"run_ccx.job: {job!r}, expected letters, digits, '_' or '-'")
    if timeout is not None and not timeout > 0:
        raise ValueError(f"run_ccx.timeout: {timeout!r}, expected > 0 seconds or None")

    wd = Path(tempfile.mkdtemp(prefix="ccx_")) if workdir is None else Path(workdir)
    wd.mkdir(parents=True, exist_ok=True)
    for suffix in (".dat", ".sta", ".frd", ".cvg"):
        (wd / f"{job}{suffix}").unlink(missing_ok=True)
    write_deck(case, wd / f"{job}.inp")
    log_path = wd / f"{job}.log"
    dat_path = wd / f"{job}.dat"

    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "CCX_NPROC_EQUATION_SOLVER", "CCX_NPROC_RESULTS", "CCX_NPROC_STIFFNESS"):
        env[var] = str(int(threads))
    exe = shutil.which(CCX_EXECUTABLE)
    logger.info(
        "running CalculiX: %d nodes, %d elements, %d increments, %d thread(s) in %s",
        case.n_nodes, len(case.cells), case.n_increments, threads, wd,
    )
    t0 = time.perf_counter()
    with open(log_path, "w") as log:
        try:
            proc = subprocess.run(
                [exe, "-i", job], cwd=wd, env=env, stdout=log, stderr=subprocess.STDOUT,
                timeout=timeout, check=False,
            )
            rc = proc.returncode
        except subprocess.TimeoutExpired:
            wall = time.perf_counter() - t0
            raise CcxError(
                f"run_ccx: ccx killed after timeout={timeout} s (ran {wall:.1f} s)", wd, _tail(log_path)
            ) from None
    wall = time.perf_counter() - t0

    log_text = log_path.read_text(errors="replace")
    n_inc, n_it, n_cut, t_end = _parse_sta(wd / f"{job}.sta")
    problems = []
    if rc != 0:
        problems.append(f"exit code {rc}")
    if "*ERROR" in log_text:
        lines = log_text.splitlines()
        k = next(i for i, ln in enumerate(lines) if "*ERROR" in ln)
        msg = " ".join(ln.strip() for ln in lines[k : k + 2] if ln.strip())
        problems.append(f"reported {msg!r}")
    if "Job finished" not in log_text:
        problems.append("no 'Job finished' in the log")
    if not abs(t_end - 1.0) < 1e-6:
        problems.append(f"step reached total time {t_end:g} of 1")

    n = case.n_nodes
    disp = np.full((n, 3), np.nan)
    reac = np.full((n, 3), np.nan) if case.print_reactions else None
    if not problems:
        blocks = parse_dat(dat_path, n) if dat_path.exists() else {}
        if "U" not in blocks:
            problems.append(f"no displacement block in {dat_path.name}")
        else:
            t_u, disp = blocks["U"]
            if not abs(t_u - 1.0) < 1e-6:
                problems.append(f"last printed displacements at time {t_u:g}, expected 1")
            if np.isnan(disp).any():
                problems.append(f"{int(np.isnan(disp).any(axis=1).sum())} nodes missing or NaN in U")
        if case.print_reactions:
            if "RF" not in blocks:
                problems.append(f"no reaction-force block in {dat_path.name}")
            else:
                reac = blocks["RF"][1]

    converged = not problems
    if not converged:
        spooles = wd / "spooles.out"
        if spooles.exists() and spooles.read_text(errors="replace").strip():
            problems.append(f"spooles.out: {spooles.read_text(errors='replace').strip()[:200]!r}")
        msg = f"run_ccx: CalculiX did not converge or failed: {'; '.join(problems)}"
        if case.direct:
            msg += (
                f". A DIRECT increment cannot be cut back: raise n_increments "
                f"(now {case.n_increments}) or use CcxCase(direct=False)"
            )
        if raise_on_failure:
            raise CcxError(msg, wd, _tail(log_path))
        logger.warning("%s (workdir %s)", msg, wd)
        disp = np.full((n, 3), np.nan)
        reac = np.full((n, 3), np.nan) if case.print_reactions else None
    else:
        logger.info(
            "CalculiX finished in %.2f s: %d increments, %d iterations, %d cut-backs",
            wall, n_inc, n_it, n_cut,
        )
        if cleanup:
            shutil.rmtree(wd, ignore_errors=True)
    return CcxResult(
        displacements=disp, reactions=reac, wall_time=wall, converged=converged,
        n_increments=n_inc, n_iterations=n_it, n_cutbacks=n_cut,
        workdir=wd, log_path=log_path, dat_path=dat_path,
    )
