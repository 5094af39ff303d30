"""Fresh tetrahedralisation of the whisker with fTetWild (pytetwild).

``pytetwild.tetrahedralize(vertices, faces, edge_length_abs=h_body, epsilon=eps,
bg_vertices, bg_tets, bg_values)``: the absolute ideal edge length is the body size;
the background mesh of :func:`geometry.sizing.background_mesh` lowers it to h(x) in the
cap and chamber wall. fTetWild returns linear tets whose boundary lies within the
envelope ``eps * bbox diagonal`` of the input surface, not on it (the caller projects
boundary nodes afterwards), and is not bit-for-bit reproducible between runs.

The output orientation is flipped to positive volumes
``det[x1 - x0, x2 - x0, x3 - x0] > 0`` (fem.mesh.orient_linear).

An optional hard ``timeout`` runs fTetWild in a forked child process (cheap on Linux:
no re-import) and kills it when the time is up.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import time

import numpy as np

from fem.mesh import orient_linear, signed_volumes_linear
from geometry.design import WhiskerDesign
from geometry.errors import GeometryError
from geometry.sizing import MeshSizing, background_mesh
from geometry.surface import closed_surface

logger = logging.getLogger(__name__)


class MeshingError(RuntimeError, GeometryError):
    """fTetWild failed, timed out or returned an unusable mesh."""


def _run_tetwild(kwargs: dict) -> tuple[np.ndarray, np.ndarray]:
    import pytetwild

    v, t = pytetwild.tetrahedralize(**kwargs)
    return np.asarray(v, dtype=np.float64), np.asarray(t, dtype=np.int64)


def _child(conn, kwargs: dict) -> None:  # pragma: no cover - runs in the child
    try:
        conn.send(("ok", _run_tetwild(kwargs)))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent
        conn.send(("error", repr(exc)))
    finally:
        conn.close()


def _with_timeout(kwargs: dict, timeout: float) -> tuple[np.ndarray, np.ndarray]:
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(child, kwargs), daemon=True)
    proc.start()
    child.close()
    try:
        if not parent.poll(timeout):
            raise MeshingError(f"fTetWild exceeded the timeout of {timeout:g} s")
        status, payload = parent.recv()
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join(1.0)
        parent.close()
    if status != "ok":
        raise MeshingError(f"fTetWild failed: {payload}")
    return payload


def tetrahedralize(
    design: WhiskerDesign,
    sizing: MeshSizing,
    num_threads: int = 0,
    timeout: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Linear tet mesh of the whisker (boundary not yet projected).

    Parameters
    ----------
    design : WhiskerDesign
    sizing : MeshSizing
    num_threads : int
        fTetWild threads (0 = all cores).
    timeout : float, optional
        Hard limit in seconds (forked child process); None runs in-process.

    Returns
    -------
    points : ndarray, shape (n, 3) float64
    tets : ndarray, shape (m, 4) int64, positively oriented
    """
    hw = sizing.wall_size(design)
    surf_p, surf_t = closed_surface(design, h=min(0.5, hw / 2.0), n_theta=96)
    bg_v, bg_t, bg_val = background_mesh(design, sizing)
    kwargs = dict(
        vertices=surf_p,
        faces=surf_t.astype(np.int32),
        edge_length_abs=float(sizing.body_size(design)),
        epsilon=float(sizing.epsilon),
        num_threads=int(num_threads),
        bg_vertices=bg_v,
        bg_tets=bg_t,
        bg_values=bg_val,
        quiet=True,
    )
    t0 = time.perf_counter()
    pts, tets = _run_tetwild(kwargs) if timeout is None else _with_timeout(kwargs, timeout)
    if len(tets) == 0:
        raise MeshingError(f"fTetWild returned no tets for {design.describe()}")
    tets = orient_linear(pts, tets)
    vol = signed_volumes_linear(pts, tets)
    if vol.min() <= 0:
        raise MeshingError(f"fTetWild returned {np.sum(vol <= 0)} degenerate tets for {design.describe()}")
    # drop unreferenced vertices (fTetWild normally returns none)
    used = np.unique(tets)
    if len(used) != len(pts):
        remap = -np.ones(len(pts), dtype=np.int64)
        remap[used] = np.arange(len(used))
        pts, tets = pts[used], remap[tets]
    logger.info(
        "fTetWild: %d vertices, %d tets in %.2f s (%s)", len(pts), len(tets), time.perf_counter() - t0, design.describe()
    )
    return np.ascontiguousarray(pts, dtype=np.float64), np.ascontiguousarray(tets, dtype=np.int64)
