"""Public entry point: a tagged, quadratic, boundary-conforming whisker mesh.

``build_mesh(design, sizing, method, cache_dir)`` returns a :class:`WhiskerMesh`:

* ``method="fresh"``: fTetWild tetrahedralisation of the analytic surface with the
  sizing field (:mod:`geometry.tetrahedralize`), seconds per mesh, not reproducible
  bit for bit;
* ``method="template"``: a shipped template mesh of a nearby reference design mapped
  region by region onto the design (:mod:`geometry.template`), tens of milliseconds,
  deterministic; raises :class:`TemplateError` when no template serves the sizing or
  the mapped mesh fails the quality gate;
* ``method="swept"``: a structured swept mesh built directly for the design
  (:mod:`geometry.swept`), deterministic, tens of milliseconds, with the same
  structure as the shipped templates (which are swept meshes of reference designs);
* ``method="auto"``: the template path when a template serves the sizing and the
  mapped mesh passes the quality gate, else the swept mesh if it passes the gate,
  else a fresh tetrahedralisation.

Both paths then upgrade to TET10 with the boundary on the exact surfaces
(:mod:`geometry.quadratic`), tag node/face sets, locate the fibres
(:mod:`geometry.tagging`) and measure the mesh (:mod:`geometry.quality`).
"""

from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from fem.mesh import TetMesh
from geometry.design import WhiskerDesign
from geometry.errors import GeometryError
from geometry.fibres import FibrePath
from geometry.locate import PointLocator
from geometry.quadratic import QuadraticMesh, upgrade
from geometry.quality import MeshReport, make_report
from geometry.sizing import MeshSizing
from geometry.tagging import face_sets as _face_sets
from geometry.tagging import locate_fibres, node_sets as _node_sets

logger = logging.getLogger(__name__)

FORMAT_VERSION = 1
METHODS = ("auto", "fresh", "template", "swept")


class TemplateError(RuntimeError, GeometryError):
    """No template serves this sizing, or the mapped template failed the quality gate."""


@dataclass(frozen=True)
class QualityGate:
    """Acceptance thresholds for a mapped template mesh (else ``auto`` meshes afresh).

    Attributes
    ----------
    min_radius_ratio : float
        Smallest allowed straight-tet radius ratio ``3 r_in / R_circ``.
    min_jacobian_ratio : float
        Smallest allowed TET10 ``min det J / max det J``.
    max_volume_error : float
        Largest allowed relative volume error.
    min_wall_crossings : int or None
        Smallest allowed count of elements crossed by a radial line through the wall;
        None: the number of structured wall layers the sizing asks for,
        ``max(1, round(wall_layers))`` (a radial line crosses at least one element per
        layer; 3 for unstructured fTetWild meshes, where a layer is not defined).
    """

    min_radius_ratio: float = 0.08
    min_jacobian_ratio: float = 0.25
    max_volume_error: float = 0.005
    min_wall_crossings: int | None = None

    def required_crossings(self, sizing: MeshSizing | None = None, design: WhiskerDesign | None = None) -> int:
        """The wall-crossing threshold (see ``min_wall_crossings``)."""
        if self.min_wall_crossings is not None:
            return int(self.min_wall_crossings)
        if sizing is None:
            return 1
        if sizing.h_wall is not None and design is not None:
            return max(1, round(design.t / sizing.h_wall))
        return max(1, round(sizing.wall_layers))

    def failures(self, r: MeshReport, sizing: MeshSizing | None = None, design: WhiskerDesign | None = None) -> list[str]:
        out = []
        need = self.required_crossings(sizing, design)
        if r.quality_min < self.min_radius_ratio:
            out.append(f"radius ratio {r.quality_min:.3g} < {self.min_radius_ratio}")
        if r.jacobian_ratio_min < self.min_jacobian_ratio:
            out.append(f"Jacobian ratio {r.jacobian_ratio_min:.3g} < {self.min_jacobian_ratio}")
        if abs(r.volume_error) > self.max_volume_error:
            out.append(f"|volume error| {abs(r.volume_error):.3g} > {self.max_volume_error}")
        if r.elements_through_wall < need:
            out.append(f"wall crossings {r.elements_through_wall} < {need}")
        return out


@dataclass(frozen=True)
class WhiskerMesh:
    """A tagged TET10 whisker mesh.

    Attributes
    ----------
    mesh : fem.mesh.TetMesh
    node_sets : dict[str, ndarray (n,)]
        'base', 'cavity', 'outer', 'tip', 'gauge' (+ 'cavity_wall', 'cavity_start', 'cavity_end').
    face_sets : dict[str, ndarray (n_f, 6)]
        Same names; outward tri6 faces.
    fibres : tuple[FibrePath, ...]
    design : WhiskerDesign
    report : MeshReport
    sizing : MeshSizing
    """

    mesh: TetMesh
    node_sets: dict
    face_sets: dict
    fibres: tuple
    design: WhiskerDesign
    report: MeshReport
    sizing: MeshSizing = field(default_factory=MeshSizing)

    # ------------------------------------------------------------------ storage
    def save(self, path: str | Path) -> Path:
        """Write everything to one compressed ``.npz`` (reload with :meth:`load`)."""
        path = Path(path)
        arrays: dict[str, np.ndarray] = {
            "format_version": np.array(FORMAT_VERSION),
            "points": self.mesh.points,
            "cells": self.mesh.cells,
            "design_json": np.array(json.dumps(self.design.as_dict())),
            "sizing_json": np.array(json.dumps(self.sizing.as_dict())),
            "report_json": np.array(json.dumps(self.report.as_dict())),
            "n_fibres": np.array(len(self.fibres)),
        }
        for k, v in self.node_sets.items():
            arrays[f"node_set__{k}"] = v
        for k, v in self.face_sets.items():
            arrays[f"face_set__{k}"] = v
        for i, f in enumerate(self.fibres):
            arrays[f"fibre{i}__points"] = f.points_ref
            arrays[f"fibre{i}__hosts"] = f.host_elements
            arrays[f"fibre{i}__xi"] = f.local_coords
            arrays[f"fibre{i}__segments"] = f.segments
            arrays[f"fibre{i}__phase"] = np.array(f.phase)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp.npz")
        try:
            np.savez_compressed(tmp, **arrays)
            tmp.replace(path)
        except OSError as exc:  # a full disk: no half-written file stays, and the error names the file
            tmp.unlink(missing_ok=True)
            if exc.filename is None and exc.errno is not None:
                raise type(exc)(exc.errno, exc.strerror or os.strerror(exc.errno), str(path)) from None
            raise
        return path

    @classmethod
    def load(cls, path: str | Path) -> "WhiskerMesh":
        """Read a mesh written by :meth:`save`."""
        with np.load(Path(path), allow_pickle=False) as z:
            ver = int(z["format_version"])
            if ver != FORMAT_VERSION:
                raise ValueError(f"{path}: mesh format_version={ver}, this code reads {FORMAT_VERSION}")
            design = WhiskerDesign.from_dict(json.loads(str(z["design_json"])))
            sizing = MeshSizing(**json.loads(str(z["sizing_json"])))
            report = MeshReport(**json.loads(str(z["report_json"])))
            nodes = {k[len("node_set__"):]: z[k] for k in z.files if k.startswith("node_set__")}
            faces = {k[len("face_set__"):]: z[k] for k in z.files if k.startswith("face_set__")}
            fibres = tuple(
                FibrePath(
                    z[f"fibre{i}__points"],
                    z[f"fibre{i}__hosts"],
                    z[f"fibre{i}__xi"],
                    z[f"fibre{i}__segments"],
                    float(z[f"fibre{i}__phase"]),
                )
                for i in range(int(z["n_fibres"]))
            )
            mesh = TetMesh(z["points"], z["cells"])
        return cls(mesh, nodes, faces, fibres, design, report, sizing)


# ---------------------------------------------------------------------- assembly
#: Longest fibre segment [mm] (see :func:`finish_mesh`).
FIBRE_DS_MAX = 0.75


def finish_mesh(
    design: WhiskerDesign,
    sizing: MeshSizing,
    qm: QuadraticMesh,
    method: str,
    t_start: float,
    fibre_ds_factor: float = 0.5,
) -> WhiskerMesh:
    """Tag, locate fibres and measure a boundary-conforming TET10 mesh."""
    faces = _face_sets(design, qm)
    nodes = _node_sets(faces)
    locator = PointLocator(qm.points, qm.cells)
    h_wall = sizing.wall_size(design)
    # fibre segments: half the wall element size, at most FIBRE_DS_MAX so the polyline's
    # length stays within 1e-3 of the helix whatever the rubber mesh (the fibres carry
    # the chamber's axial stiffness; a 1.5 mm chord on the default mesh lost 1.8e-3)
    fibres = locate_fibres(design, locator, ds=min(fibre_ds_factor * h_wall, FIBRE_DS_MAX))
    report = make_report(
        design, qm.points, qm.cells, faces["cavity"], locator, h_wall, method, time.perf_counter() - t_start,
        jac_ratio=qm.jacobian_ratio, off_surface=(qm.n_unprojected, qm.max_unprojected_offset),
    )
    return WhiskerMesh(TetMesh(qm.points, qm.cells), nodes, faces, fibres, design, report, sizing)


#: Wall layers the fTetWild path always gets (at least 3 quadratic elements through the wall).
FRESH_MIN_WALL_LAYERS = 3.0


def fresh_sizing(sizing: MeshSizing) -> MeshSizing:
    """The sizing fTetWild meshes with: ``wall_layers`` raised to :data:`FRESH_MIN_WALL_LAYERS`.

    The structured swept/template meshes reach the gauge accuracy of the presets with
    one layer of P2 elements through the wall (:meth:`MeshSizing.preset`); unstructured
    fTetWild tets are not aligned with the wall, so the fresh path keeps the resolution
    of the fTetWild path. An absolute ``h_wall`` given by the user is kept as is.
    """
    if sizing.h_wall is None and sizing.wall_layers < FRESH_MIN_WALL_LAYERS:
        return replace(sizing, wall_layers=FRESH_MIN_WALL_LAYERS)
    return sizing


def _fresh(design: WhiskerDesign, sizing: MeshSizing, num_threads: int, timeout: float | None) -> WhiskerMesh:
    from geometry.tetrahedralize import tetrahedralize

    sizing = fresh_sizing(sizing)
    t0 = time.perf_counter()
    pts, tets = tetrahedralize(design, sizing, num_threads=num_threads, timeout=timeout)
    qm = upgrade(design, pts, tets)
    return finish_mesh(design, sizing, qm, "fresh", t0)


def _template(design: WhiskerDesign, sizing: MeshSizing, gate: QualityGate) -> WhiskerMesh:
    from geometry import template as tpl

    t0 = time.perf_counter()
    found = tpl.select_template(design, sizing)
    if found is None:
        raise TemplateError(
            f"no template mesh for sizing {sizing.name!r} (template_key={sizing.template_key()}); "
            f"available: {tpl.available_sizings()}"
        )
    pts, tets, face_class = tpl.map_template(found, design, sizing.contact_fractions)
    qm = upgrade(design, pts, tets, face_class=face_class, cylindrical=found.structured,
                 topology=found.topology)
    wm = finish_mesh(design, sizing, qm, f"template:{found.name}", t0)
    fails = gate.failures(wm.report, sizing, design)
    if fails:
        raise TemplateError(f"mapped template {found.name} fails the quality gate: {'; '.join(fails)}")
    return wm


def _swept(design: WhiskerDesign, sizing: MeshSizing) -> WhiskerMesh:
    from geometry.swept import build_swept

    t0 = time.perf_counter()
    pts, tets = build_swept(design, sizing)
    qm = upgrade(design, pts, tets, cylindrical=True)
    return finish_mesh(design, sizing, qm, "swept", t0)


def cache_path(cache_dir: str | Path, design: WhiskerDesign, sizing: MeshSizing, method: str) -> Path:
    """``cache_dir / mesh-<design key>-<sizing key>-<method>.npz``."""
    return Path(cache_dir) / f"mesh-v{FORMAT_VERSION}-{design.key()}-{sizing.key()}-{method}.npz"


def build_mesh(
    design: WhiskerDesign,
    sizing: MeshSizing | None = None,
    method: str = "auto",
    cache_dir: str | Path | None = None,
    *,
    num_threads: int = 0,
    timeout: float | None = None,
    gate: QualityGate | None = None,
) -> WhiskerMesh:
    """Mesh a whisker design (see module docstring).

    Parameters
    ----------
    design : WhiskerDesign
        Validated first: :class:`~geometry.design.InvalidDesignError` for impossible designs.
    sizing : MeshSizing, optional
        Default ``MeshSizing()``.
    method : {'auto', 'fresh', 'template', 'swept'}
    cache_dir : path, optional
        When given, meshes are stored as ``.npz`` keyed by (design, sizing, method) and
        reused.
    num_threads : int
        fTetWild threads for fresh meshes (0 = all cores).
    timeout : float, optional
        Hard limit [s] on a fresh tetrahedralisation (forked child process).
    gate : QualityGate, optional
        Acceptance thresholds of mapped templates.

    Returns
    -------
    WhiskerMesh
    """
    if method not in METHODS:
        raise ValueError(f"build_mesh: method={method!r}, allowed {METHODS}")
    sizing = sizing or MeshSizing()
    gate = gate or QualityGate()
    design.validate()
    cpath = cache_path(cache_dir, design, sizing, method) if cache_dir is not None else None
    if cpath is not None and cpath.is_file():
        try:
            wm = WhiskerMesh.load(cpath)
            logger.debug("mesh cache hit %s", cpath)
            return wm
        except Exception as exc:  # noqa: BLE001 - a corrupt cache entry is rebuilt
            logger.warning("ignoring unreadable cache entry %s: %s", cpath, exc)
    if method == "fresh":
        wm = _fresh(design, sizing, num_threads, timeout)
    elif method == "template":
        wm = _template(design, sizing, gate)
    elif method == "swept":
        wm = _swept(design, sizing)
    else:
        try:
            wm = _template(design, sizing, gate)
        except TemplateError as exc:
            logger.info("template path not used (%s); building a swept mesh", exc)
            wm = _swept(design, sizing)
            fails = gate.failures(wm.report, sizing, design)
            if fails:
                logger.warning("swept mesh fails the quality gate (%s); meshing afresh", "; ".join(fails))
                wm = _fresh(design, sizing, num_threads, timeout)
    logger.info(
        "mesh %s: %d nodes, %d elements, vol err %.2e, q_min %.3f, %s, %.2f s",
        design.describe(),
        wm.report.n_nodes,
        wm.report.n_elements,
        wm.report.volume_error,
        wm.report.quality_min,
        wm.report.method,
        wm.report.seconds,
    )
    if cpath is not None:
        try:
            wm.save(cpath)
        except OSError as exc:  # the cache is an optimisation: a full or read-only disk must not fail the mesh
            logger.warning("mesh not cached (%s: %s); continuing without the cache", exc.filename or cpath,
                           exc.strerror or exc)
    return wm
