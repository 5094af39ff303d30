"""One loaded state, ready to draw: the warped smooth surfaces, curved edges and outline.

The whisker surface is warped by the displacement (factor ``scale``) and drawn from its
6-node boundary triangles subdivided ``subdivision`` times, so curved faces stay curved
and no internal subdivision edges are drawn; the element edges are curved polylines
(:func:`boundary_edges`). The chamber cavity is its own surface component, found by
connectivity. The undeformed outline is the boundary of the reference section z = 0.

Every state knows the fidelity it was solved at, named in its panel's heading: the preset and its
f1 resolution (:func:`fidelity_text`, from the file's field data, else the run's ``config.yaml``);
a mesh without a solution (``whisker-opt mesh``) also its element count and wall layers
(:func:`mesh_text`). A deflected state gets the strain the push added over its scene's pressurised
state (:func:`whisker_opt.viewer.fields.add_strain_change`), the default colour field of a view
that shows a deflection (:func:`default_field`).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from whisker_opt.viewer.fields import (
    DISPLACEMENT_NAMES,
    STRAIN_CHANGE_FIELD,
    add_derived_fields,
    add_strain_change,
    cell_volumes,
    displacement_name,
    load_grid,
    quadratic_cells,
)
from whisker_opt.viewer.guard import ViewerError, require_pyvista
from whisker_opt.viewer.rubber import RunRubber, cap_end
from whisker_opt.viewer.rundir import RunContents, StateFile
from whisker_opt.viewer.sceneinfo import SceneInfo
from whisker_opt.wiring import INTACT, TRIMMED, UNCOMPENSATED

logger = logging.getLogger(__name__)

SCENE_TITLES = {
    INTACT: "intact",
    "uncompensated": "trimmed, uncompensated",
    UNCOMPENSATED: "trimmed, uncompensated",
    "vented": "trimmed, vented",
    "trimmed_vented": "trimmed, vented",
    "compensated": "trimmed, compensated",
}


@dataclass
class StateView:
    """One loaded state, ready to draw.

    Attributes
    ----------
    title : str
    grid : pyvista.UnstructuredGrid
        Reference grid with derived fields (:func:`whisker_opt.viewer.fields.add_derived_fields`).
    warped : pyvista.UnstructuredGrid
        ``grid`` with points moved by ``scale × displacement``.
    outer, cavity : pyvista.PolyData or None
        Smooth (subdivided P2) warped outer and cavity surfaces, carrying the point data.
    edges : pyvista.PolyData or None
        Curved element edges on the warped boundary.
    outline : pyvista.PolyData or None
        Undeformed outline: boundary of the reference section at ``z = cut_z`` (only
        when a displacement exists).
    displacement : str or None
    scale : float
    info : SceneInfo
    state : str
    path : Path or None
    cut_z : float
        The section / clipping plane ``z = cut_z`` (middle of the reference bounds; 0 for a whisker).
    fidelity : str or None
        ``preset coarse, f1 resolution ~2e-3`` (:func:`fidelity_text`); None when unknown.
    mesh_facts : str or None
        Element count and wall layers of a mesh shown without a solution (:func:`mesh_text`).
    """

    title: str
    grid: Any
    warped: Any
    outer: Any
    cavity: Any
    edges: Any
    outline: Any
    displacement: str | None
    scale: float
    info: SceneInfo
    state: str = ""
    path: Path | None = None
    cut_z: float = 0.0
    fidelity: str | None = None
    mesh_facts: str | None = None

    def field_range(self, name: str | None, comp: int | None = None,
                    percentile: float = 0.0) -> tuple[float, float] | None:
        """(min, max) of a field over the drawn surface, or its (p, 100 − p) percentiles
        when ``percentile`` = p > 0; None when absent."""
        if name is None:
            return None
        vals = []
        for s in (self.outer, self.cavity):
            if s is not None and s.n_points:
                a = s.point_data.get(name)
                if a is None:
                    a = s.cell_data.get(name)
                if a is not None:
                    vals.append(_scalar(np.asarray(a), comp))
        if not vals:
            return None
        v = np.concatenate(vals)
        v = v[np.isfinite(v)]
        if not len(v):
            return None
        if percentile > 0.0:
            lo, hi = np.percentile(v, [percentile, 100.0 - percentile])
            return float(lo), float(hi)
        return float(v.min()), float(v.max())


def _scalar(a: np.ndarray, comp: int | None) -> np.ndarray:
    if a.ndim == 2:
        return a[:, comp] if comp is not None else np.linalg.norm(a, axis=1)
    return a


def _surface_components(faces6: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Label 0 for the outer boundary component (largest bounding box), 1 for inner ones (cavities)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(points)
    a = faces6[:, [0, 1, 2]].ravel()
    b = faces6[:, [1, 2, 0]].ravel()
    g = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    face_lab = lab[faces6[:, 0]]
    comps = np.unique(face_lab)
    if len(comps) == 1:
        return np.zeros(len(faces6), dtype=int)
    diag = []
    for c in comps:
        p = points[np.unique(faces6[face_lab == c, :3])]
        diag.append(np.linalg.norm(p.max(0) - p.min(0)))
    outer = comps[int(np.argmax(diag))]
    return np.where(face_lab == outer, 0, 1)


def _tri6_surface(points: np.ndarray, faces6: np.ndarray, source, elem: np.ndarray, subdivision: int):
    """Subdivided PolyData of 6-node triangles with the source's point data and owning-cell data."""
    pv = require_pyvista()
    # copies, not views: handing one dataset's VTK-backed arrays to another corrupts the heap
    # (pyvista 0.49 / VTK 9.6, reproduced with MALLOC_CHECK_=3)
    tri = pv.UnstructuredGrid({pv.CellType.QUADRATIC_TRIANGLE: faces6}, np.array(points, dtype=float))
    for k in source.point_data.keys():
        tri.point_data[k] = np.array(source.point_data[k])
    for k in source.cell_data.keys():
        tri.cell_data[k] = np.array(source.cell_data[k])[elem]
    return tri.extract_surface(
        pass_pointid=False, pass_cellid=False, nonlinear_subdivision=subdivision, algorithm="dataset_surface"
    )


def boundary_edges(points: np.ndarray, faces6: np.ndarray, n_seg: int = 4):
    """Curved element edges of 6-node boundary triangles as polylines.

    Each edge (a, m, b) is the quadratic ``x(s) = (1-s)(1-2s) a + 4s(1-s) m + s(2s-1) b``
    sampled at ``n_seg + 1`` points; shared edges are drawn once.

    Returns
    -------
    pyvista.PolyData
    """
    pv = require_pyvista()
    e = np.concatenate([faces6[:, [0, 3, 1]], faces6[:, [1, 4, 2]], faces6[:, [2, 5, 0]]])  # (3 n_f, 3)
    key = np.sort(e[:, [0, 2]], axis=1)
    _, idx = np.unique(key, axis=0, return_index=True)
    e = e[idx]
    s = np.linspace(0.0, 1.0, n_seg + 1)
    Na, Nm, Nb = (1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)  # (n_seg+1,)
    P = np.einsum("s,ei->esi", Na, points[e[:, 0]]) + np.einsum("s,ei->esi", Nm, points[e[:, 1]]) \
        + np.einsum("s,ei->esi", Nb, points[e[:, 2]])  # (n_e, n_seg+1, 3)
    n_e = len(e)
    ids = np.arange(n_e * (n_seg + 1)).reshape(n_e, n_seg + 1)
    lines = np.hstack([np.full((n_e, 1), n_seg + 1), ids]).ravel()
    return pv.PolyData(P.reshape(-1, 3), lines=lines)


_PRESSURISED = ("pressurised", "pressurized", "inflated")


def _field_value(grid, name: str):
    """The first value of a field-data entry of the grid (the first string of a text entry,
    :func:`fem.io.field_values`), or None."""
    from fem.io import field_values

    fd = getattr(grid, "field_data", None)
    if fd is None or name not in fd:
        return None
    value = field_values({name: fd[name]})[name]
    if isinstance(value, list):
        return value[0] if value else None
    return value[0].item() if value.size else None


def fidelity_text(grid, config: Mapping[str, Any] | None = None) -> str | None:
    """``preset coarse, f1 resolution ~2e-3`` of a state: the preset stored with the file
    (``fidelity_preset``, ``calibration_xi``), else the ``fidelity`` section of the run's config
    (:func:`whisker_opt.output.plots.fidelity_label`); None when neither names a preset."""
    from whisker_opt.config.model import FidelityConfig
    from whisker_opt.experiment.fidelity import PRESET_NAMES, RESOLUTION_CALIBRATION, describe, f1_resolution
    from whisker_opt.output.plots import fidelity_label

    preset, xi = _field_value(grid, "fidelity_preset"), _field_value(grid, "calibration_xi")
    scene = (config or {}).get("scene") if isinstance((config or {}).get("scene"), Mapping) else {}
    try:
        xi = float(xi if xi is not None else scene.get("calibration", RESOLUTION_CALIBRATION))
    except (TypeError, ValueError):
        xi = RESOLUTION_CALIBRATION
    if preset in PRESET_NAMES:
        return fidelity_label({"preset": preset, "f1_resolution": f1_resolution(preset, xi)})
    section = (config or {}).get("fidelity")
    if isinstance(section, Mapping):
        try:
            return fidelity_label(describe(FidelityConfig.model_validate(dict(section)), xi))
        except ValueError:
            return None
    return None


def mesh_text(grid, path: Path | None = None) -> str:
    """Element count and wall layers of a mesh: ``936 elements (10-node tets), 1 wall layer (a radial
    line through the wall crosses 3 elements, median)``; the layers from the file's field data or the
    ``mesh_report.json`` beside it (left out when neither has them)."""
    import json

    n = int(grid.n_cells)
    text = f"{n} elements (10-node tets)" if len(quadratic_cells(grid)) == n else f"{n} elements"
    layers, median = _field_value(grid, "wall_layers"), _field_value(grid, "elements_through_wall_median")
    report = path.with_name("mesh_report.json") if path is not None else None
    if layers is None and report is not None and report.is_file():
        try:
            rep = json.loads(report.read_text())
            layers, median = rep.get("wall_layers"), rep.get("elements_through_wall_median")
        except (OSError, ValueError, AttributeError):
            layers = None
    if layers is not None:
        text += f", {float(layers):g} wall layer{'s' if float(layers) != 1 else ''}"
        if median is not None:
            text += f" (a radial line through the wall crosses {float(median):g} elements, median)"
    return text


def default_field(views: Sequence["StateView"]) -> str | None:
    """The colour field when none is asked for: the strain the push added
    (:data:`~whisker_opt.viewer.fields.STRAIN_CHANGE_FIELD`) when every view has it and one shows a
    deflection, so that the pressurised panels show the push, not the pressure's strain; else None
    (:func:`~whisker_opt.viewer.fields.resolve_field`'s default, the total strain)."""
    if views and all(STRAIN_CHANGE_FIELD in v.grid.point_data for v in views) \
            and any(v.state.lower() not in _PRESSURISED for v in views):
        return STRAIN_CHANGE_FIELD
    return None


def prepare_state(
    source,
    info: SceneInfo | None = None,
    state: str = "",
    displacement: str | None = None,
    scale: float = 1.0,
    subdivision: int = 2,
    edges: bool = True,
    rubber: RunRubber | None = None,
    onset=None,
    config: Mapping[str, Any] | None = None,
) -> StateView:
    """Load a state and build its surfaces.

    Parameters
    ----------
    source : path-like or pyvista.UnstructuredGrid
        A VTU file written by :func:`fem.io.write_vtu` (reference points + a displacement
        array) or a grid.
    info : SceneInfo, optional
    state : str
        State name (title, gauge reading).
    displacement : str, optional
        Point array to warp by (default: the first of
        :data:`whisker_opt.viewer.fields.DISPLACEMENT_NAMES`).
    scale : float
        Displacement magnification (1 = true scale).
    subdivision : int
        Subdivisions of each curved boundary triangle (0 = straight).
    edges : bool
        Build the curved element edges.
    rubber : RunRubber, optional
        The run's rubber (:func:`whisker_opt.viewer.rubber.run_rubber`): the law that computes
        ``von_mises`` when the file stores none (:func:`whisker_opt.viewer.fields.add_derived_fields`;
        the cap's end from :func:`whisker_opt.viewer.rubber.cap_end`).
    onset : path-like or pyvista.UnstructuredGrid, optional
        The scene's pressurised state: adds the strain the push added
        (:func:`whisker_opt.viewer.fields.add_strain_change`; zero for that state itself).
    config : mapping, optional
        The run's ``config.yaml``: the fidelity of a file that does not store it (:func:`fidelity_text`).

    Returns
    -------
    StateView

    Raises
    ------
    FileNotFoundError, ViewerError
    """
    require_pyvista()
    if not (math.isfinite(scale) and scale >= 0):
        raise ViewerError(f"scale={scale!r}: must be a finite number >= 0")
    path = None
    if isinstance(source, (str, Path)):
        path = Path(source)
        grid = load_grid(path)
    else:
        grid = source.copy()
    where = str(path) if path else "grid"
    info = info or SceneInfo(name=path.stem if path else "grid")
    disp = displacement_name(grid, displacement, where)
    if disp is None:
        logger.info("%s: no displacement array (looked for %s); drawn undeformed", where, DISPLACEMENT_NAMES)
    law = None if rubber is None else functools.partial(rubber.law, c=cap_end(grid, info.design))
    add_derived_fields(grid, disp, law)
    if onset is not None and disp is not None:
        if state.lower() in _PRESSURISED:
            base = grid
        else:
            base = load_grid(onset) if isinstance(onset, (str, Path)) else onset.copy()
            add_derived_fields(base, displacement_name(base, None, str(onset)), None)
        if not add_strain_change(grid, base):
            logger.info("%s: the pressurised state %s does not match its mesh; no strain change", where, onset)
    vol = cell_volumes(grid)
    if np.any(vol <= 0):
        logger.warning("%s: %d of %d cells have non-positive VTK volume (inverted or misordered nodes)",
                       where, int((vol <= 0).sum()), len(vol))
    warped = grid.warp_by_vector(disp, factor=scale) if disp else grid.copy()
    outer, cavity, edge_poly = _surfaces(grid, warped, subdivision, edges)
    zb = grid.bounds
    cut_z = 0.5 * (zb[4] + zb[5])
    outline = None
    if disp:
        sec = grid.slice(normal=(0.0, 0.0, 1.0), origin=(0.0, 0.0, cut_z))
        if sec.n_points:
            outline = sec.extract_feature_edges(boundary_edges=True, feature_edges=False, manifold_edges=False,
                                                non_manifold_edges=False)
    title = scene_title(info) + (f" · {state_title(info, state)}" if state else "")
    return StateView(title, grid, warped, outer, cavity, edge_poly, outline, disp, float(scale), info, state, path,
                     cut_z, fidelity_text(grid, config), None if disp else mesh_text(grid, path))


def _surfaces(grid, warped, subdivision: int, edges: bool) -> tuple:
    """(outer surface, cavity surface or None, element edges or None) of a deformed grid.

    Quadratic cells give curved six-node faces split into the outer and the cavity components;
    linear tets give VTK's own surface (no cavity told apart).
    """
    cells = quadratic_cells(grid)
    if len(cells):
        from fem.mesh import boundary_faces

        elem, _, f6 = boundary_faces(cells)
        lab = _surface_components(f6, np.asarray(grid.points))
        outer = _tri6_surface(warped.points, f6[lab == 0], warped, elem[lab == 0], subdivision)
        cavity = None
        if np.any(lab == 1):
            cavity = _tri6_surface(warped.points, f6[lab == 1], warped, elem[lab == 1], subdivision)
        edge_poly = boundary_edges(np.asarray(warped.points), f6[lab == 0]) if edges else None
    else:  # linear tets: VTK's own surface
        outer = warped.extract_surface(pass_pointid=False, pass_cellid=False, algorithm="dataset_surface")
        cavity, edge_poly = None, (outer.extract_all_edges() if edges else None)
    return outer, cavity, edge_poly


def load_views(
    contents: RunContents,
    group: str,
    scenes: Sequence[str] | None = None,
    state: str | None = None,
    notes: Mapping[str, Any] | None = None,
    files: Sequence[StateFile] | None = None,
    **kw,
) -> list[StateView]:
    """:func:`prepare_state` for one state of each selected scene of a group.

    Parameters
    ----------
    contents : RunContents
    group : str
    scenes : sequence of str, optional
        Default: every scene of the group.
    state : str, optional
        See :meth:`RunContents.select`.
    notes : mapping, optional
        Added to each scene's text.
    files : sequence of StateFile, optional
        The states to load (overrides ``group``, ``scenes`` and ``state``), e.g. from
        :meth:`RunContents.select_delta`.
    **kw
        Passed to :func:`prepare_state` (``rubber`` and ``config`` default to the run's,
        :attr:`RunContents.rubber`, :attr:`RunContents.config`); each state's ``onset`` is its scene's
        pressurised state when the group has one.

    Returns
    -------
    list of StateView
    """
    out = []
    kw.setdefault("rubber", contents.rubber)
    kw.setdefault("config", contents.config)
    for f in (contents.select(group, scenes, state) if files is None else files):
        info = contents.info(f.group, f.scene)
        if notes:
            info = dataclasses.replace(info, notes={**info.notes, **notes})
        onset = next((x.path for x in contents.states(f.group, f.scene) if x.state.lower() in _PRESSURISED), None)
        out.append(prepare_state(f.path, info=info, state=f.state, onset=onset, **kw))
    return out


def scene_title(info: SceneInfo) -> str:
    """A scene's role as a panel title: ``intact``, ``trimmed, uncompensated`` (trimmed, still
    at Q_i), ``trimmed, vented`` (a trimmed scene at Q = 0), else the scene name."""
    if info.name in SCENE_TITLES:
        return SCENE_TITLES[info.name]
    if info.name == TRIMMED and info.Q == 0.0:
        return "trimmed, vented"
    return info.name


def state_title(info: SceneInfo, state: str) -> str:
    """A state as a panel title: ``delta_2.00`` becomes ``delta = 2 mm``, the pressurised state
    of a scene at Q = 0 ``not pressurised (Q = 0)``; other names unchanged."""
    if state.lower() in ("pressurised", "pressurized", "inflated") and info.Q == 0.0:
        return "not pressurised (Q = 0)"
    if state.lower().startswith("delta"):
        d = info.delta_of(state)
        if d is not None:
            return f"delta = {d:.3g} mm"
    return state


def displaced(sv: StateView, points_ref: np.ndarray) -> np.ndarray:
    """Current positions of reference points: ``X + scale · u(X)`` with u interpolated in the
    grid (VTK probe, quadratic shape functions); points outside take the nearest node's u."""
    pv = require_pyvista()
    X = np.asarray(points_ref, dtype=float).reshape(-1, 3)
    if sv.displacement is None or len(X) == 0:
        return X.copy()
    probe = pv.PolyData(X).sample(sv.grid, tolerance=1e-6 * sv.grid.length)
    u = np.array(probe.point_data[sv.displacement], dtype=float)
    ok = np.asarray(probe.point_data.get("vtkValidPointMask", np.ones(len(X))), dtype=bool)
    if not ok.all():
        idx = [sv.grid.find_closest_point(x) for x in X[~ok]]
        u[~ok] = np.asarray(sv.grid.point_data[sv.displacement])[idx]
    return X + sv.scale * u
