"""VTU export of P2 tetrahedral meshes (VTK_QUADRATIC_TETRA) with point/cell fields."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from fem.mesh import TetMesh


def write_vtu(path: str | Path, mesh: TetMesh, point_data: dict | None = None, cell_data: dict | None = None,
              deformed: np.ndarray | None = None) -> Path:
    """Write ``mesh`` as a VTU file readable by ParaView and pyvista (atomically).

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

    Returns
    -------
    Path
        ``path``.
    """
    import meshio

    path = Path(path)
    pts = mesh.points if deformed is None else mesh.points + deformed
    pdata = {k: np.asarray(v) for k, v in (point_data or {}).items()}
    for k, v in pdata.items():
        if len(v) != mesh.n_nodes:
            raise ValueError(f"write_vtu: point_data[{k!r}] has {len(v)} rows, mesh has {mesh.n_nodes} nodes")
    cdata = {}
    for k, v in (cell_data or {}).items():
        v = np.asarray(v)
        if len(v) != mesh.n_elements:
            raise ValueError(f"write_vtu: cell_data[{k!r}] has {len(v)} rows, mesh has {mesh.n_elements} elements")
        cdata[k] = [v]
    m = meshio.Mesh(pts, [("tetra10", mesh.cells)], point_data=pdata, cell_data=cdata)
    path.parent.mkdir(parents=True, exist_ok=True)
    # a hidden temporary beside the target (never offered as a result), made complete and
    # durable before it takes the target's name: a kill leaves the old file or the new one
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        meshio.write(tmp, m, file_format="vtu")
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.chmod(tmp, default_file_mode())  # mkstemp creates 0600; results are ordinary files
        os.replace(tmp, path)
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
