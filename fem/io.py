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

    Parameters
    ----------
    path : path-like
    mesh : TetMesh
    point_data : dict of name -> ndarray (n_nodes, ...) 
    cell_data : dict of name -> ndarray (n_elements, ...)
    deformed : ndarray (n_nodes, 3) or None
        If given, the points written are ``mesh.points + deformed`` (reference
        coordinates are still available as the ``displacement`` field if supplied).
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
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".vtu")
    os.close(fd)
    try:
        meshio.write(tmp, m, file_format="vtu")
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
