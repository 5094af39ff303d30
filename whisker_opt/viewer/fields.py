"""The arrays a view is coloured by: reading a VTU grid and adding derived point fields.

By default a view shows the axial logarithmic strain ``LE_xx = (½ ln(F Fᵀ))_xx`` (the
Eulerian Hencky strain, Abaqus' LE11), else the displacement magnitude, or any array
stored in the VTU, and the von Mises stress. A deflected state also gets the strain the push
added, ``LE_xx`` of the state minus ``LE_xx`` of its scene's pressurised state at the same node
(:data:`STRAIN_CHANGE_FIELD`, :func:`add_strain_change`): zeroed at contact onset as the gauge
reading is, so the pressurised panels show the push rather than the pressure's own strain. Stored arrays are shown as stored; what an
older file lacks is computed by :mod:`fem.post` and, for a stress, by the run's own law
(:mod:`whisker_opt.viewer.rubber`); this module only puts the numbers on the grid.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from fem import post
from whisker_opt.viewer.guard import ViewerError, require_pyvista

DISPLACEMENT_NAMES = ("displacement", "u", "U", "disp", "Displacement", "DISP")
STRAIN_FIELD = "axial_log_strain"
MAGNITUDE_FIELD = "displacement_magnitude"
MISES_FIELD = "von_mises"
STRAIN_CHANGE_FIELD = "axial_log_strain_change"
STORED_STRAIN_NAMES = ("axial_log_strain", "log_strain_axial", "le11", "le_xx", "log_strain_xx", "lexx")
FIELD_ALIASES = {
    "strain": STRAIN_FIELD,
    "axial_strain": STRAIN_FIELD,
    "log_strain": STRAIN_FIELD,
    "le11": STRAIN_FIELD,
    "le_xx": STRAIN_FIELD,
    "displacement": MAGNITUDE_FIELD,
    "magnitude": MAGNITUDE_FIELD,
    "|u|": MAGNITUDE_FIELD,
    "mises": MISES_FIELD,
    "stress": MISES_FIELD,
    "von_mises_stress": MISES_FIELD,
    "strain_change": STRAIN_CHANGE_FIELD,
    "change": STRAIN_CHANGE_FIELD,
    "push": STRAIN_CHANGE_FIELD,
    "since_onset": STRAIN_CHANGE_FIELD,
    "deflected-pressurised": STRAIN_CHANGE_FIELD,
}
FIELD_LABELS = {
    STRAIN_FIELD: "axial log strain LE_xx [-]",
    MAGNITUDE_FIELD: "displacement magnitude [mm]",
    MISES_FIELD: "von Mises stress [MPa]",
    STRAIN_CHANGE_FIELD: "axial log strain added by the push (deflected − pressurised) [-]",
}
"""Scalar-bar titles of the derived fields, each with its unit (no ``|``: VTK's text renderer
drops it and garbles the line)."""
FIELD_UNITS = {
    STRAIN_FIELD: "-",
    MAGNITUDE_FIELD: "mm",
    MISES_FIELD: "MPa",
    STRAIN_CHANGE_FIELD: "-",
    "X_ref": "mm",
    "pressure": "MPa",  # the hydrostatic pressure of the mixed u-p elements (older result files)
    "mixed_pressure": "MPa",  # the same, as written now (mean stress, positive in tension)
    "cauchy_stress": "MPa",
    "log_strain": "-",
    **{name: "mm" for name in DISPLACEMENT_NAMES},
    **{name: "-" for name in STORED_STRAIN_NAMES},
}
"""Units of the derived and the known stored arrays (the FE works in mm, N, MPa)."""


def load_grid(path: str | Path):
    """Read a VTU file as a pyvista ``UnstructuredGrid``.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ViewerError
        It cannot be read or holds no tetrahedra (the message names the path).
    """
    pv = require_pyvista()
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such VTU file")
    with path.open("rb") as fh:
        head = fh.read(512).lstrip()
    if not (head.startswith(b"<?xml") or head.startswith(b"<VTKFile")):
        raise ViewerError(f"{path}: not a VTU file (no XML VTKFile header)")
    with warnings.catch_warnings(record=True) as caught, pv.vtk_verbosity("off"):
        warnings.simplefilter("always")
        try:
            grid = pv.read(path)
        except Exception as exc:  # noqa: BLE001 - VTK raises various types
            raise ViewerError(f"{path}: cannot read as VTU ({exc})") from None
    if not isinstance(grid, pv.UnstructuredGrid) or grid.n_cells == 0:
        why = "; ".join(str(w.message).splitlines()[0] for w in caught)
        n = f", {grid.n_cells} cells" if hasattr(grid, "n_cells") else ""
        raise ViewerError(
            f"{path}: not a readable VTU unstructured grid with cells (got {type(grid).__name__}{n})"
            + (f"; reader: {why}" if why else "")
        )
    types = set(np.unique(grid.celltypes).tolist())
    if not types & {int(pv.CellType.QUADRATIC_TETRA), int(pv.CellType.TETRA)}:
        raise ViewerError(
            f"{path}: no tetrahedra (VTK cell types {sorted(types)}; need 24 = quadratic tetra or 10 = tetra)"
        )
    return grid


def cell_volumes(grid) -> np.ndarray:
    """Signed VTK volumes of the cells (VTK's own node ordering), shape (n_cells,).

    An inverted or misordered 10-node tet (e.g. Gmsh's edge order) gives a negative or
    wrong volume; compare with :func:`fem.mesh.volumes`.
    """
    return np.asarray(grid.compute_cell_sizes(length=False, area=False, volume=True)["Volume"])


def displacement_name(grid, requested: str | None = None, where: str = "grid") -> str | None:
    """Name of the point displacement array: ``requested``, else the first of
    :data:`DISPLACEMENT_NAMES` present (3-component), else None.

    Raises
    ------
    ViewerError
        ``requested`` is not a 3-component point array (lists the arrays).
    """
    if requested:
        arr = grid.point_data.get(requested)
        if arr is None or np.ndim(arr) != 2 or np.shape(arr)[1] != 3:
            raise ViewerError(
                f"{where}: displacement array {requested!r} not found as a 3-component point array; "
                f"point arrays: {list(grid.point_data.keys())}"
            )
        return requested
    for name in DISPLACEMENT_NAMES:
        arr = grid.point_data.get(name)
        if arr is not None and np.ndim(arr) == 2 and np.shape(arr)[1] == 3:
            return name
    return None


def quadratic_cells(grid) -> np.ndarray:
    """The (n, 10) connectivity of the grid's quadratic tetrahedra (VTK = fem TET10 order)."""
    pv = require_pyvista()
    cells = grid.cells_dict.get(int(pv.CellType.QUADRATIC_TETRA), np.zeros((0, 10), np.int64))
    return np.asarray(cells, dtype=np.int64)


def add_derived_fields(grid, disp: str | None, law=None) -> None:
    """Add ``X_ref``, ``displacement_magnitude``, ``axial_log_strain`` and ``von_mises`` point
    arrays in place, each the array the solver stored when the file has it.

    The stored ``displacement_magnitude`` and ``von_mises`` are shown as stored, a stored axial
    strain (:data:`STORED_STRAIN_NAMES`) as ``axial_log_strain``; only what a file lacks is
    computed, on quadratic tets: |u|, the strain (:func:`fem.post.eulerian_log_strain`, xx
    component), and the von Mises stress of the run's own law
    (:meth:`fem.material.IsochoricI1Material.von_mises` at the nodes, with p = 0: the
    pressure drops out of the deviator of every Ī1 law). No constitutive quantity is derived
    from anything but that law. Nodes outside every cell get NaN.

    Parameters
    ----------
    grid : pyvista.UnstructuredGrid
    disp : str or None
        The displacement point array.
    law : callable, optional
        ``law(points, cells)``: the run's law (:class:`fem.material.IsochoricI1Material`, one
        row per cell for a cap of another rubber) on the reference points and the
        :func:`quadratic_cells` of the grid, or None; called only when no ``von_mises`` is
        stored (:meth:`whisker_opt.viewer.rubber.RunRubber.law`). Without it a file that
        stores no stress shows none.
    """
    grid.point_data["X_ref"] = np.asarray(grid.points, dtype=float).copy()
    if disp is None:
        return
    u = np.asarray(grid.point_data[disp], dtype=float)
    if MAGNITUDE_FIELD not in grid.point_data:
        grid.point_data[MAGNITUDE_FIELD] = np.linalg.norm(u, axis=1)
    cells = quadratic_cells(grid)
    stored = [k for k in grid.point_data.keys() if k.lower() in STORED_STRAIN_NAMES]
    if stored and stored[0] != STRAIN_FIELD:
        grid.point_data[STRAIN_FIELD] = np.array(grid.point_data[stored[0]], dtype=float)
    need_mises = law is not None and MISES_FIELD not in grid.point_data
    if not len(cells) or (stored and not need_mises):
        return
    F, used = post.nodal_deformation_gradient(grid.points, cells, u)
    if not stored:
        grid.point_data[STRAIN_FIELD] = post.spread_to_nodes(post.eulerian_log_strain(F)[:, 0, 0], used)
    material = law(np.asarray(grid.points, dtype=float), cells) if need_mises else None
    if material is not None:
        grid.point_data[MISES_FIELD] = post.spread_to_nodes(material.at_nodes(cells, used).von_mises(F, 0.0), used)


def add_strain_change(grid, onset) -> bool:
    """Add :data:`STRAIN_CHANGE_FIELD`, this state's axial log strain minus that of ``onset`` (the
    scene's pressurised state, on the same mesh) node by node, in place.

    Parameters
    ----------
    grid : pyvista.UnstructuredGrid
        With :data:`STRAIN_FIELD` (:func:`add_derived_fields`).
    onset : pyvista.UnstructuredGrid
        The pressurised state, with :data:`STRAIN_FIELD`.

    Returns
    -------
    bool
        False (nothing added) when either lacks the strain or the meshes differ in their nodes.
    """
    a, b = grid.point_data.get(STRAIN_FIELD), onset.point_data.get(STRAIN_FIELD)
    if a is None or b is None or grid.n_points != onset.n_points \
            or not np.allclose(np.asarray(grid.points), np.asarray(onset.points), atol=1e-9, rtol=0.0):
        return False
    grid.point_data[STRAIN_CHANGE_FIELD] = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    return True


def field_names(grid) -> list[str]:
    """Fields a view can be coloured by: derived ones first, then stored point and cell arrays."""
    names = [n for n in (STRAIN_FIELD, STRAIN_CHANGE_FIELD, MAGNITUDE_FIELD, MISES_FIELD) if n in grid.point_data]
    skip = {"X_ref", "vtkOriginalPointIds", "vtkOriginalCellIds", *names}
    names += [k for k in grid.point_data.keys() if k not in skip]
    names += [k for k in grid.cell_data.keys() if k not in skip and k not in names]
    return names


def resolve_field(grid, requested: str | None, where: str = "grid") -> tuple[str | None, str, int | None]:
    """(array name, label, component) for colouring; ``None`` array = plain colour.

    ``requested`` may be an alias (``strain``, ``LE11``, ``displacement``, ``|u|``), an
    array name (vectors are shown by magnitude) or ``name:x`` / ``name:0`` for a component.
    The default is the axial log strain, else the displacement magnitude, else the first
    stored array.

    Raises
    ------
    ViewerError
        Unknown field, naming it and listing the available ones.
    """
    available = field_names(grid)
    if requested is None:
        if not available:
            return None, "", None
        name = available[0]
        return name, field_label(name, None, _array(grid, name)), None
    if requested.lower() in ("none", "solid", ""):
        return None, "", None
    comp = None
    base = requested
    m = re.match(r"^(.+?)[:\[]([xyz012])\]?$", requested)
    if m and m.group(1) in available:
        base, c = m.group(1), m.group(2)
        comp = "xyz".index(c) if c in "xyz" else int(c)
    base = FIELD_ALIASES.get(base.lower(), base) if base not in available else base
    if base not in available:
        raise ViewerError(
            f"{where}: no field {requested!r}; available fields: {available} (or aliases {sorted(FIELD_ALIASES)})"
        )
    arr = _array(grid, base)
    if comp is not None and (np.ndim(arr) != 2 or comp >= np.shape(arr)[1]):
        raise ViewerError(f"{where}: field {base!r} has no component {comp} (shape {np.shape(arr)})")
    return base, field_label(base, comp, arr), comp


def _array(grid, name: str):
    arr = grid.point_data.get(name)
    return grid.cell_data.get(name) if arr is None else arr


def field_unit(name: str) -> str:
    """Unit of an array (:data:`FIELD_UNITS`), ``"unit unknown"`` for other stored arrays."""
    return FIELD_UNITS.get(name) or FIELD_UNITS.get(name.lower()) or "unit unknown"


def field_label(name: str, comp: int | None = None, arr=None) -> str:
    """Scalar-bar title of an array, always with its unit in brackets.

    Parameters
    ----------
    name : str
        Array name.
    comp : int, optional
        Component shown (``displacement, y component [mm]``).
    arr : array-like, optional
        The array; a vector shown whole is labelled as its magnitude (``displacement magnitude [mm]``).

    Returns
    -------
    str
    """
    if name in FIELD_LABELS and comp is None:
        return FIELD_LABELS[name]
    unit = f" [{field_unit(name)}]"
    if comp is not None:
        return f"{name}, {'xyz'[comp] + ' component' if comp < 3 else f'component {comp}'}{unit}"
    if arr is not None and np.ndim(arr) == 2 and np.shape(arr)[1] > 1:
        return f"{name} magnitude{unit}"
    return name + unit
