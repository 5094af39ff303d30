"""VTK output: TET10 meshes (VTK_QUADRATIC_TETRA) and line meshes as VTU with point, cell and
field data, and ``.pvd`` collections that step through them.

Every file is written atomically (:func:`atomic_write`) with the mode of an ordinary new file
(:func:`default_file_mode`, ``0o644`` under the umask ``022``).

The VTU files are written by meshio and stay readable by meshio, VTK, ParaView and pyvista.
Two VTK features that meshio does not write are added to its output:

* field data (``<FieldData>``, the data set's metadata): numbers as ``Int64``/``Float64``
  arrays, text as a ``UInt8`` array of the UTF-8 bytes of each string followed by a NUL byte
  (:func:`encode_text`). A ``UInt8`` entry is text and nothing else is: :func:`field_values`
  (or :func:`decode_text` on one entry) turns the entries back into numbers and strings. meshio
  (5.3) reads numeric arrays only and stops the interpreter on a VTK string array
  (``<Array type="String">``), so none is written; VTK, pyvista and ParaView read the bytes as
  numbers. :func:`decode_text` also reads the string arrays of older files, as pyvista returns them;
* component names (the ``ComponentName<i>`` attributes of a data array), which ParaView
  shows in its component menus, e.g. ``XX`` … ``XZ`` of a symmetric tensor.
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

from fem.mesh import TetMesh

def write_vtu(path: str | Path, mesh: TetMesh, point_data: dict | None = None, cell_data: dict | None = None,
              deformed: np.ndarray | None = None, field_data: Mapping | None = None,
              component_names: Mapping[str, Sequence[str]] | None = None) -> Path:
    """Write ``mesh`` as a VTU file readable by meshio, ParaView and pyvista (atomically).

    The file is written to a hidden temporary file in the same folder (``.<name>.<random>.tmp``),
    flushed to disk and renamed over ``path``, so a kill at any instant leaves either no file
    (or the previous one) or the complete new one. Its mode is that of any new file under the
    umask (:func:`default_file_mode`).

    Parameters
    ----------
    path : path-like
    mesh : TetMesh
    point_data : dict of name -> ndarray (n_nodes, ...)
    cell_data : dict of name -> ndarray (n_elements, ...)
    deformed : ndarray (n_nodes, 3) or None
        If given, the points written are ``mesh.points + deformed`` (reference
        coordinates are still available as the ``displacement`` field if supplied).
    field_data : mapping of name -> value, optional
        Metadata of the data set (:func:`field_array`): a number, a string, a sequence of
        numbers or of strings.
    component_names : mapping of array name -> sequence of str, optional
        Names of the components of multi-component point or cell arrays.

    Returns
    -------
    Path
        ``path``.
    """
    pts = mesh.points if deformed is None else mesh.points + deformed
    return write_grid(path, pts, [("tetra10", mesh.cells)], point_data, cell_data, field_data, component_names)


def write_lines_vtu(path: str | Path, points: np.ndarray, segments: np.ndarray, point_data: dict | None = None,
                    cell_data: dict | None = None, field_data: Mapping | None = None) -> Path:
    """Write line segments (VTK_LINE cells) as a VTU file, atomically (see :func:`write_vtu`).

    Parameters
    ----------
    path : path-like
    points : ndarray, shape (n, 3)
    segments : ndarray, shape (m, 2)
        Point pairs, one cell each.
    point_data : dict of name -> ndarray (n, ...)
    cell_data : dict of name -> ndarray (m, ...)
    field_data : mapping, optional
        As for :func:`write_vtu`.

    Returns
    -------
    Path
    """
    segments = np.asarray(segments, dtype=np.int64).reshape(-1, 2)
    return write_grid(path, points, [("line", segments)], point_data, cell_data, field_data)


def write_grid(path: str | Path, points: np.ndarray, cells: list, point_data: dict | None = None,
               cell_data: dict | None = None, field_data: Mapping | None = None,
               component_names: Mapping[str, Sequence[str]] | None = None) -> Path:
    """Write an unstructured grid of one or more meshio cell blocks as a VTU file, atomically.

    Parameters
    ----------
    path : path-like
    points : ndarray, shape (n, 3)
    cells : list of (str, ndarray)
        meshio cell blocks, e.g. ``[("tetra10", cells)]``.
    point_data : dict of name -> ndarray (n, ...)
    cell_data : dict of name -> ndarray (total cells, ...)
        One row per cell of all blocks in order.
    field_data : mapping, optional
        Metadata (:func:`field_array`).
    component_names : mapping of array name -> sequence of str, optional

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        An array whose length is not the number of points or cells.
    """
    import meshio

    path = Path(path)
    points = np.asarray(points, dtype=float)
    n_cells = sum(len(c) for _, c in cells)
    pdata = {k: np.asarray(v) for k, v in (point_data or {}).items()}
    for k, v in pdata.items():
        if len(v) != len(points):
            raise ValueError(f"write_vtu: point_data[{k!r}] has {len(v)} rows, mesh has {len(points)} nodes")
    bounds = np.cumsum([0] + [len(c) for _, c in cells])
    cdata = {}
    for k, v in (cell_data or {}).items():
        v = np.asarray(v)
        if len(v) != n_cells:
            raise ValueError(f"write_vtu: cell_data[{k!r}] has {len(v)} rows, mesh has {n_cells} elements")
        cdata[k] = [v[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    m = meshio.Mesh(points, list(cells), point_data=pdata, cell_data=cdata)

    def produce(tmp: str) -> None:
        meshio.write(tmp, m, file_format="vtu")
        if field_data or component_names:
            _add_vtk_extras(tmp, field_data or {}, component_names or {})

    return atomic_write(path, produce)


def write_pvd(path: str | Path, datasets: Sequence[tuple]) -> Path:
    """Write a ParaView collection (``.pvd``) of data sets at time steps, atomically.

    ParaView opens it as one source whose time steps are ``timestep`` (its time slider and
    the "next frame" button step through them in increasing order)::

        <VTKFile type="Collection" version="0.1">
          <Collection>
            <DataSet timestep="0" part="0" file="intact_pressurised.vtu"/>
            ...

    Parameters
    ----------
    path : path-like
    datasets : sequence of (timestep, file), (timestep, file, part) or (timestep, file, part, name)
        Files relative to the ``.pvd`` file's folder (absolute paths are made relative when
        inside it); written in the given order. The data sets of one ``part`` form a block of
        ParaView's multiblock output, labelled ``name`` when given.

    Returns
    -------
    Path
    """
    path = Path(path)
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for item in datasets:
        t, f = float(item[0]), Path(item[1])
        part = int(item[2]) if len(item) > 2 else 0
        if f.is_absolute():
            try:
                f = f.resolve().relative_to(path.parent.resolve())
            except ValueError:
                pass
        attrs = {"timestep": repr(t), "group": "", "part": str(part), "file": f.as_posix()}
        if len(item) > 3:
            attrs["name"] = str(item[3])
        ET.SubElement(coll, "DataSet", **attrs)
    ET.indent(root)
    text = '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
    return atomic_write(path, lambda tmp: Path(tmp).write_text(text))


def read_pvd(path: str | Path) -> list[tuple[float, str, int]]:
    """The ``(timestep, file, part)`` entries of a ``.pvd`` collection, in file order."""
    root = ET.parse(Path(path)).getroot()
    return [(float(d.get("timestep", "0")), d.get("file", ""), int(d.get("part", "0")))
            for d in root.iter("DataSet")]


# ------------------------------------------------------------------------------ field data
def encode_text(strings: str | Sequence[str]) -> np.ndarray:
    """Strings as a ``uint8`` array: the UTF-8 bytes of each, each followed by a NUL byte.

    Parameters
    ----------
    strings : str or sequence of str

    Returns
    -------
    ndarray of uint8, shape (n_bytes,)
    """
    if isinstance(strings, str):
        strings = [strings]
    data = b"".join(s.encode("utf-8") + b"\0" for s in strings)
    return np.frombuffer(data, dtype=np.uint8).copy()


def decode_text(array) -> list[str]:
    """The strings of a text field-data entry: the bytes of :func:`encode_text` (how text is written), or
    a string array as pyvista reads it from an older file.

    Parameters
    ----------
    array : array-like of str, or of uint8

    Returns
    -------
    list of str
    """
    arr = np.asarray(array)
    if arr.dtype.kind in "US" or arr.dtype == object:
        return [str(v) for v in arr.ravel()]
    data = np.asarray(array, dtype=np.uint8).tobytes()
    parts = data.split(b"\0")
    if parts and parts[-1] == b"":
        parts = parts[:-1]
    return [p.decode("utf-8") for p in parts]


def field_values(field_data: Mapping) -> dict:
    """The field data of a file as written: each text entry (``UInt8``) as its list of strings
    (:func:`decode_text`), every other entry as a 1-D array.

    Parameters
    ----------
    field_data : mapping of name -> array-like
        As meshio (``mesh.field_data``) or pyvista (``grid.field_data``) reads it.

    Returns
    -------
    dict of name -> list of str or ndarray
    """
    out = {}
    for name, value in field_data.items():
        arr = np.asarray(value)
        out[str(name)] = decode_text(arr) if arr.dtype == np.uint8 or arr.dtype.kind in "US" or \
            arr.dtype == object else arr.ravel()
    return out


def field_array(value) -> np.ndarray:
    """A field-data value as the array written: text -> :func:`encode_text` (uint8, the only uint8
    entries); bools and integers -> int64; other numbers -> float64.

    Parameters
    ----------
    value : number, str, or sequence of numbers or of str

    Returns
    -------
    ndarray, shape (n,)
    """
    if isinstance(value, str) or (isinstance(value, (list, tuple)) and value and all(isinstance(v, str)
                                                                                       for v in value)):
        return encode_text(value)
    arr = np.atleast_1d(np.asarray(value))
    if arr.dtype.kind in "biu":
        return arr.astype(np.int64).ravel()
    return arr.astype(np.float64).ravel()


def _data_array(parent: ET.Element, name: str, arr: np.ndarray) -> None:
    vtk_type = {"u": "UInt8", "i": "Int64", "f": "Float64"}[arr.dtype.kind]
    da = ET.SubElement(parent, "DataArray", type=vtk_type, Name=name, NumberOfTuples=str(len(arr)), format="ascii")
    da.text = " ".join(f"{x:.17g}" if arr.dtype.kind == "f" else str(x) for x in arr.tolist())


def _add_vtk_extras(file: str | Path, field_data: Mapping, component_names: Mapping[str, Sequence[str]]) -> None:
    """Add ``<FieldData>`` and ``ComponentName<i>`` attributes to a VTU file written by meshio."""
    tree = ET.parse(file)
    grid = tree.getroot().find("UnstructuredGrid")
    if grid is None:
        raise ValueError(f"{file}: no UnstructuredGrid element")
    if field_data:
        fd = ET.Element("FieldData")
        for name, value in field_data.items():
            _data_array(fd, str(name), field_array(value))
        grid.insert(0, fd)
    for section in ("PointData", "CellData"):
        for da in grid.iter(section):
            for arr in da.findall("DataArray"):
                for i, comp in enumerate(component_names.get(arr.get("Name"), ())):
                    arr.set(f"ComponentName{i}", str(comp))
    tree.write(file, encoding="utf-8", xml_declaration=True)


# ------------------------------------------------------------------------------ files
def atomic_write(path: str | Path, produce: Callable[[str], object]) -> Path:
    """Make ``path`` by ``produce(tmp)`` writing a hidden temporary beside it, then renaming.

    The temporary (``.<name>.<random>.tmp``, never offered as a result) is made complete and
    durable (fsync) before it takes the target's name: a kill leaves the old file or the new
    one. The file gets :func:`default_file_mode`.

    Parameters
    ----------
    path : path-like
    produce : callable
        ``produce(tmp_path_str)`` writes the whole file.

    Returns
    -------
    Path

    Raises
    ------
    OSError
        The file cannot be written (a full disk, no permission): the error names ``path`` (a
        failed write names no file of its own), and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        produce(tmp)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.chmod(tmp, default_file_mode())  # mkstemp creates 0600; results are ordinary files
        os.replace(tmp, path)
    except OSError as exc:
        if exc.filename is None and exc.errno is not None:  # e.g. ENOSPC from a write
            raise type(exc)(exc.errno, exc.strerror or os.strerror(exc.errno), str(path)) from None
        raise
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def default_file_mode() -> int:
    """Mode of a newly created ordinary file under the process umask (``0o644`` under ``022``).

    Read from ``/proc/self/status`` where available, so that the umask is never changed,
    even briefly; elsewhere it is read by setting and restoring it.
    """
    umask = None
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    umask = int(line.split()[1], 8)
                    break
    except (OSError, ValueError, IndexError):
        umask = None
    if umask is None:
        umask = os.umask(0o022)
        os.umask(umask)
    return 0o666 & ~umask
