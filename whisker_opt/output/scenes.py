"""Solved scenes on disk: VTU files per kept state, their fibres, a ``.pvd`` collection per
scene, and the ``scenes.json`` entry of each scene.

Files of scene ``<scene>`` (:func:`write_scene_files`):

``<scene>_<state>.vtu``
    The TET10 mesh in its reference configuration with the state's fields
    (:func:`state_fields`); states ``pressurised`` (δ = 0), ``delta_<δ>`` (every solved
    deflection increment but the last) and ``deflected`` (the last increment).
``<scene>_<state>_fibres.vtu``
    The fibre helices as 2-node line cells (the truss segments of the solve) at their
    reference positions with their displacement (:func:`fibre_fields`); none when the
    design has no fibres.
``<scene>.pvd``, ``<scene>_fibres.pvd``
    ParaView collections of those files in deflection order, time step = δ [mm].
``scenes.pvd``
    One collection of every scene of the result (:func:`write_result_collection`): each scene's
    solid and fibres are a block (``part``) named after it, time step = δ [mm].

Points are reference coordinates; ParaView's *Warp By Vector* with ``displacement`` shows
the deformed whisker. Every VTU carries its metadata as field data
(:func:`scene_metadata`). The viewer (:mod:`whisker_opt.viewer`) reads what this module
writes.
"""

from __future__ import annotations

import contextlib
import logging
import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem import post
from fem.material import von_mises_stress

logger = logging.getLogger(__name__)

#: Stem suffix of the fibre files: ``<scene>_<state>_fibres.vtu`` beside ``<scene>_<state>.vtu``.
FIBRE_SUFFIX = "_fibres"

#: Cell tags of the ``region`` array, by the element centroid's reference x.
REGION_CAP, REGION_CHAMBER, REGION_BODY = 1, 2, 3

#: Bits of the ``gauge_element`` cell array.
GAUGE_LINE_HOST, GAUGE_CENTROID_ELEMENT = 1, 2

#: Units of the point and cell arrays of a state's VTU (``-`` for pure numbers and tags).
STATE_UNITS = {
    "displacement": "mm", "displacement_magnitude": "mm", "log_strain": "-", "log_strain_axial": "-",
    "cauchy_stress": "MPa", "von_mises": "MPa", "on_cavity": "-", "on_base": "-", "on_outer": "-",
    "in_contact_band": "-", "in_gauge": "-", "mixed_pressure": "MPa", "region": "-", "gauge_element": "-",
    "J": "-", "principal_stretches": "-",
}
#: Units of the arrays of a fibre VTU.
FIBRE_UNITS = {"displacement": "mm", "displacement_magnitude": "mm", "fibre": "-", "fibre_log_strain": "-",
               "fibre_force": "N"}
#: Node sets of :class:`geometry.mesh.WhiskerMesh` written as 0/1 point arrays.
NODE_SET_TAGS = {"on_cavity": "cavity", "on_base": "base", "on_outer": "outer"}


@dataclass(frozen=True)
class SceneFiles:
    """The files :func:`write_scene_files` wrote for one scene.

    Attributes
    ----------
    states : list of Path
        ``<scene>_<state>.vtu``, in deflection order.
    fibres : list of Path
        ``<scene>_<state>_fibres.vtu``, same order (empty without fibres).
    pvd : Path
        ``<scene>.pvd``.
    fibres_pvd : Path or None
        ``<scene>_fibres.pvd``.
    deltas : list of float
        δ [mm] of each state.
    """

    states: list
    fibres: list
    pvd: Path
    fibres_pvd: Path | None
    deltas: list


def ordered_states(res) -> list[tuple[str, float, object]]:
    """``(state name, δ [mm], State)`` of a result's kept states in deflection order.

    ``pressurised`` at δ = 0, ``delta_<δ>`` at its δ, ``deflected`` at the last solved δ
    (``res.delta[-1]``, else the largest ``delta_<δ>``); a ``delta_<δ>`` that is the
    ``deflected`` state itself is left out (written once, as ``deflected``). δ read from a
    name (two decimals) is replaced by the nearest solved δ of ``res.delta`` when within 0.005 mm.

    Raises
    ------
    ValueError
        No states kept, or a state name of another kind.
    """
    if not res.states:
        raise ValueError("no states kept; solve the scene with run_scene(..., keep_states=True)")
    solved = np.asarray(getattr(res, "delta", ()), dtype=float)
    last = res.states.get("deflected")
    out, named = [], []
    for name, st in res.states.items():
        if name == "pressurised":
            out.append((name, 0.0, st))
            continue
        if name == "deflected":
            continue
        m = re.fullmatch(r"delta_([-+]?\d+(?:\.\d*)?)", name)
        if m is None:
            raise ValueError(f"state {name!r}: not 'pressurised', 'deflected' or 'delta_<mm>'")
        d = float(m.group(1))
        if solved.size and np.min(np.abs(solved - d)) <= 0.005:
            d = float(solved[np.argmin(np.abs(solved - d))])
        named.append(d)
        if st is not last:
            out.append((name, d, st))
    if last is not None:
        out.append(("deflected", float(solved[-1]) if solved.size else max(named, default=0.0), last))
    return sorted(out, key=lambda t: (t[1], t[0] == "deflected"))


# ------------------------------------------------------------------------------ tags
def element_centroids(mesh) -> np.ndarray:
    """Reference centroids ``X(ξ = ¼, ¼, ¼)`` of TET10 elements, shape (n_el, 3)."""
    from fem import element

    N = element.shape_functions(np.full((1, 3), 0.25))[0]  # (10,)
    return np.einsum("a,eai->ei", N, mesh.points[mesh.cells])  # (n_el, 3)


def region_tags(mesh, design) -> np.ndarray:
    """``region`` of each element: cap (x < c), chamber wall (c <= x < l), body/tip (x >= l).

    By the reference x of the element centroid (:func:`element_centroids`) against the
    design's c and l; values :data:`REGION_CAP`, :data:`REGION_CHAMBER`, :data:`REGION_BODY`.

    Returns
    -------
    ndarray of int32, shape (n_el,)
    """
    x = element_centroids(mesh)[:, 0]  # (n_el,)
    return np.where(x < design.c, REGION_CAP, np.where(x < design.l, REGION_CHAMBER, REGION_BODY)).astype(np.int32)


def _flag(n: int, index) -> np.ndarray:
    out = np.zeros(n, dtype=np.int32)
    out[np.asarray(index, dtype=np.int64)] = 1
    return out


def scene_tags(res) -> tuple[dict, dict]:
    """Point and cell tags of a scene (the same in every state).

    Point arrays (0/1): ``on_cavity``, ``on_base``, ``on_outer`` (the mesh's node sets),
    ``in_contact_band`` (the nodes pushed in the deflection step,
    :func:`whisker_opt.experiment.contact.contact_band` of the pressurised state),
    ``in_gauge`` (the nodes of the ``gauge_element`` cells). Cell arrays: ``region``
    (:func:`region_tags`), ``gauge_element`` (bit 1: hosts a point of the line gauge, bit 2:
    the element of the centroid reading; :func:`whisker_opt.experiment.gauge.locate_gauge`).
    Tags whose source a result lacks are left out.

    Returns
    -------
    point_tags, cell_tags : dict of name -> ndarray of int32
    """
    wm, spec = res.mesh, getattr(res, "spec", None)
    mesh = wm.mesh
    n, n_el = mesh.n_nodes, mesh.n_elements
    sets = getattr(wm, "node_sets", None) or {}
    points = {tag: _flag(n, sets[key]) for tag, key in NODE_SET_TAGS.items() if key in sets}
    cells = {}
    design = spec.design if spec is not None else getattr(wm, "design", None)
    if design is not None:
        cells["region"] = region_tags(mesh, design)
    if spec is not None and sets:
        from whisker_opt.experiment.contact import contact_band
        from whisker_opt.experiment.gauge import locate_gauge
        from whisker_opt.experiment.scene import scene_contact

        u1 = res.states["pressurised"].u
        contact = scene_contact(spec)
        points["in_contact_band"] = _flag(n, contact_band(wm, u1, contact.x(wm, u1), spec.band_width,
                                                          contact.at_tip))
        gauge = locate_gauge(wm, design)
        ge = np.zeros(n_el, dtype=np.int32)
        ge[gauge.host_elements] |= GAUGE_LINE_HOST
        ge[gauge.centroid_element] |= GAUGE_CENTROID_ELEMENT
        cells["gauge_element"] = ge
        points["in_gauge"] = _flag(n, np.unique(mesh.cells[ge > 0]))
    return points, cells


# ------------------------------------------------------------------------------ fields
def state_fields(mesh, state, problem=None) -> tuple[dict, dict]:
    """Point and cell arrays of one solved state.

    Point arrays: ``displacement`` u [mm] (n, 3); ``displacement_magnitude`` |u| [mm];
    ``log_strain``, the Eulerian log strain ln V = ½ ln(F Fᵀ) (n, 6) in VTK's order XX, YY,
    ZZ, XY, YZ, XZ; ``log_strain_axial`` its XX [-]; ``cauchy_stress`` σ [MPa] (n, 6), same
    order, of the constitutive law of the problem that solved the state, with its mixed pressure
    (:func:`fem.post.problem_strain_stress`: the scene's rubber, and under a wall law its scaled
    moduli and frozen stress, the stress the Newton solve balanced); ``von_mises`` [MPa] of that σ.
    Nodal values: F averaged over the elements sharing a node, the element pressures likewise
    (:func:`fem.post.nodal_strain_stress`). Cell array ``mixed_pressure`` [MPa]: the element
    pressure unknown p of the u–p formulation, the mean stress tr σ / 3, positive in tension
    (left out for the 'displacement' formulation, whose pressure is no unknown). Point arrays ``J`` = det F
    and ``principal_stretches`` λ₁ ≥ λ₂ ≥ λ₃ (n, 3), the square roots of the eigenvalues of F Fᵀ, from
    the nodal F (:func:`fem.post.nodal_deformation_gradient`; NaN at nodes of no element).

    Parameters
    ----------
    mesh : fem.mesh.TetMesh
    state : fem.state.State
        ``u`` (n_nodes, 3) and ``p`` (n_el,).
    problem : fem.problem.Problem, optional
        The problem that solved ``state`` (:meth:`whisker_opt.experiment.scene.SceneResult.problem_of`):
        its material, frozen stresses and formulation; without it the stress arrays are left out.

    Returns
    -------
    point_data, cell_data : dict of name -> ndarray
    """
    u = np.asarray(state.u, dtype=float)
    formulation = getattr(problem, "formulation", "mixed")
    pdata = {"displacement": u, "displacement_magnitude": np.linalg.norm(u, axis=1)}
    F, used = post.nodal_deformation_gradient(mesh.points, mesh.cells, u)  # (k, 3, 3)
    pdata["J"] = post.spread_to_nodes(np.linalg.det(F), used)
    b = np.einsum("kij,klj->kil", F, F)  # (k, 3, 3)  F Fᵀ
    pdata["principal_stretches"] = post.spread_to_nodes(np.sqrt(np.clip(np.linalg.eigvalsh(b)[:, ::-1], 0, None)), used)
    cdata = {}
    if formulation == "mixed":
        cdata["mixed_pressure"] = np.asarray(state.p, dtype=float)
    if problem is not None:
        le, sigma = post.problem_strain_stress(problem, u, state.p)
        pdata["log_strain"] = post.symmetric_components(le)
        pdata["log_strain_axial"] = le[:, 0, 0]
        pdata["cauchy_stress"] = post.symmetric_components(sigma)
        pdata["von_mises"] = von_mises_stress(sigma)
    else:
        le = post.spread_to_nodes(post.eulerian_log_strain(F), used)
        pdata["log_strain"] = post.symmetric_components(le)
        pdata["log_strain_axial"] = le[:, 0, 0]
    return pdata, cdata


def fibre_fields(wm, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict, dict] | None:
    """The fibres of a mesh as line segments with their displacement.

    Points: the reference fibre polylines of ``wm.fibres``, one after another. Point
    arrays ``displacement`` (interpolated in the host elements, :func:`fem.query.displacement_at`)
    [mm], ``displacement_magnitude`` [mm], ``fibre`` (index of the helix); cell arrays
    ``fibre``, ``fibre_log_strain`` = ln(ℓ/L) of each segment, ℓ and L its current and
    reference lengths [-], and ``fibre_force`` [N], the axial force of the in-house truss
    (:mod:`fem.truss`, Saint Venant–Kirchhoff): N = E_f A E ℓ/L with E = (ℓ² − L²)/(2 L²),
    positive in tension (E_f, A of the mesh's design).

    Returns
    -------
    (points (n, 3), segments (m, 2), point_data, cell_data), or None without fibres.
    """
    from fem.query import displacement_at

    fibres = tuple(getattr(wm, "fibres", ()) or ())
    if not fibres:
        return None
    offsets = np.cumsum([0] + [len(f.points_ref) for f in fibres])
    X = np.vstack([f.points_ref for f in fibres])  # (n, 3)
    disp = np.vstack([displacement_at(wm.mesh, u, f.host_elements, f.local_coords) for f in fibres])  # (n, 3)
    seg = np.vstack([f.segments + o for f, o in zip(fibres, offsets[:-1])])  # (m, 2)
    fid_pt = np.repeat(np.arange(len(fibres), dtype=np.int32), np.diff(offsets))  # (n,)
    x = X + disp
    L0 = np.linalg.norm(X[seg[:, 1]] - X[seg[:, 0]], axis=1)  # (m,)
    ell = np.linalg.norm(x[seg[:, 1]] - x[seg[:, 0]], axis=1)  # (m,)
    pdata = {"displacement": disp, "displacement_magnitude": np.linalg.norm(disp, axis=1), "fibre": fid_pt}
    cdata = {"fibre": fid_pt[seg[:, 0]], "fibre_log_strain": np.log(ell / L0)}
    design = getattr(wm, "design", None)
    if design is not None:
        green = (ell**2 - L0**2) / (2.0 * L0**2)  # (m,)
        cdata["fibre_force"] = design.fibre_E * design.fibre_area * green * ell / L0
    return X, seg, pdata, cdata


def scene_metadata(name: str, state: str, delta: float, spec=None) -> dict:
    """Field data of a state's VTU files: what was solved, with the units in the names.

    ``scene``, ``state`` (text); ``TimeValue`` and ``delta_mm``: δ of the state [mm]
    (ParaView takes ``TimeValue`` as the time of a lone file); with a spec also ``Q_MPa``,
    ``trim_mm``, ``contact_ratio``, ``contact_at``, ``C10_MPa``, ``D1_per_MPa``,
    ``calibration_xi``, ``formulation``, ``wall_law`` and ``wall_slope_per_MPa`` (the chamber wall's
    law, :mod:`whisker_opt.wall.law`), ``fidelity_preset`` (the mesh sizing's name when it is a
    preset's) and ``design_<name>`` for every design parameter. Text is written as UTF-8 bytes
    (``UInt8``), which meshio reads as well as VTK; :func:`fem.io.field_values` decodes it.
    :func:`write_scene_files` adds the state's forces (:func:`state_forces`).
    """
    meta: dict = {"scene": name, "state": state, "TimeValue": float(delta), "delta_mm": float(delta)}
    if spec is None:
        return meta
    from whisker_opt.experiment.fidelity import PRESET_NAMES

    meta.update({"Q_MPa": float(spec.Q), "trim_mm": float(spec.design.trim), "contact_ratio": float(spec.contact_ratio),
                 "contact_at": spec.contact_at, "C10_MPa": float(spec.c10), "D1_per_MPa": float(spec.d1),
                 "calibration_xi": float(spec.calibration), "formulation": spec.formulation,
                 "wall_law": spec.wall_law, "wall_slope_per_MPa": float(spec.wall_slope)})
    preset = getattr(spec.sizing, "name", None)
    if preset in PRESET_NAMES:
        meta["fidelity_preset"] = preset
    meta.update({f"design_{k}": v for k, v in spec.design.as_dict().items() if isinstance(v, (int, float))})
    return meta


def state_forces(res, delta: float) -> dict:
    """Field data of the forces at the solved deflection ``delta``: ``contact_force_N`` (the pusher's
    force in −y) and ``base_reaction_N`` (x, y, z) [N]; empty when the result holds no forces."""
    force = getattr(res, "contact_force", None)
    if force is None:
        return {}
    i = int(np.argmin(np.abs(np.asarray(res.delta) - delta)))
    return {"contact_force_N": float(force[i]), "base_reaction_N": np.asarray(res.base_reaction[i], dtype=float)}


#: Units of the design fields that are not user parameters (:func:`geometry.design.parameter`).
_PLAIN_DESIGN_UNITS = {"trim": "mm", "gauge_half_angle_deg": "deg", "tip_clearance": "mm"}


def design_units(design) -> dict:
    """Units of the ``design_<name>`` field data, from the parameters' declarations."""
    from geometry.design import user_parameters

    units = {f"design_{k}": u for k, u in _PLAIN_DESIGN_UNITS.items()}
    units.update({f"design_{f.name}": f.metadata["unit"] for f in user_parameters(type(design))})
    return units


def units_text(arrays, meta: dict, spec=None, table: dict | None = None) -> list[str]:
    """The ``units`` field data: ``"<array>=<unit>"`` for every point, cell and numeric field array."""
    table = {**STATE_UNITS, **(table or {}), "TimeValue": "mm", "delta_mm": "mm", "Q_MPa": "MPa", "trim_mm": "mm",
             "contact_ratio": "-", "C10_MPa": "MPa", "D1_per_MPa": "1/MPa", "calibration_xi": "-",
             "contact_force_N": "N", "base_reaction_N": "N", "wall_slope_per_MPa": "1/MPa"}
    if spec is not None:
        table.update(design_units(spec.design))
    names = [*arrays, *(k for k, v in meta.items() if not isinstance(v, str))]
    return [f"{k}={table.get(k, 'unknown')}" for k in names]


# ------------------------------------------------------------------------------ writing
def write_scene_files(out: Path, name: str, res) -> SceneFiles:
    """Write a scene result's states, fibres and ``.pvd`` collections into ``out`` (see the module).

    Parameters
    ----------
    out : Path
    name : str
        Scene name (file prefix).
    res : whisker_opt.experiment.scene.SceneResult
        Solved with ``keep_states=True``.

    Returns
    -------
    SceneFiles
    """
    from fem.io import write_lines_vtu, write_pvd, write_vtu

    try:
        states = ordered_states(res)
    except ValueError as exc:
        raise ValueError(f"scene {name!r}: {exc}") from None
    out = Path(out)
    spec = getattr(res, "spec", None)
    problem_of = getattr(res, "problem_of", lambda state: None)
    mesh = res.mesh.mesh
    point_tags, cell_tags = scene_tags(res)
    comps = {"log_strain": post.SYMMETRIC_COMPONENTS, "cauchy_stress": post.SYMMETRIC_COMPONENTS}
    vtus, fibre_paths = [], []
    for state_name, delta, st in states:
        pdata, cdata = state_fields(mesh, st, problem_of(state_name))
        pdata.update(point_tags)
        cdata.update(cell_tags)
        meta = scene_metadata(name, state_name, delta, spec)
        meta.update(state_forces(res, delta))
        meta["units"] = units_text([*pdata, *cdata], meta, spec)
        vtus.append(write_vtu(out / f"{name}_{state_name}.vtu", mesh, point_data=pdata, cell_data=cdata,
                              field_data=meta, component_names=comps))
        fib = fibre_fields(res.mesh, st.u)
        if fib is not None:
            X, seg, fp, fc = fib
            fmeta = scene_metadata(name, state_name, delta, spec)
            fmeta["units"] = units_text([*fp, *fc], fmeta, spec, FIBRE_UNITS)
            fibre_paths.append(write_lines_vtu(out / f"{name}_{state_name}{FIBRE_SUFFIX}.vtu", X, seg, fp, fc, fmeta))
    deltas = [d for _, d, _ in states]
    pvd = write_pvd(out / f"{name}.pvd", [(d, p.name) for d, p in zip(deltas, vtus)])
    fpvd = (write_pvd(out / f"{name}{FIBRE_SUFFIX}.pvd", [(d, p.name) for d, p in zip(deltas, fibre_paths)])
            if fibre_paths else None)
    logger.debug("scene %s: %d state VTU(s), %d fibre VTU(s), %s", name, len(vtus), len(fibre_paths), pvd)
    return SceneFiles(vtus, fibre_paths, pvd, fpvd, deltas)


def scene_entry(spec, res, gauge_variant: str = "line", **extra) -> dict:
    """The ``scenes.json`` entry of a solved scene (read by :mod:`whisker_opt.viewer`).

    Parameters
    ----------
    spec : whisker_opt.experiment.spec.SceneSpec
    res : whisker_opt.experiment.scene.SceneResult
    gauge_variant : {'line', 'centroid'}
        Which gauge reading the curves use.
    **extra
        Further keys (e.g. ``wall_s``, ``genes``).
    """
    entry = {
        "design": spec.design.as_dict(),
        "Q_MPa": spec.Q,
        "trim": spec.design.trim,
        "delta_l_mm": res.delta_l,
        "length_q_mm": res.length_q,
        "contact_ratio": spec.contact_ratio,
        "contact_at": spec.contact_at,
        "contact_x": res.contact_x,
        "wall_law": spec.wall_law,
        "wall_slope_per_MPa": spec.wall_slope,
        "radial_growth_mm": res.radial_growth,
        "solved_delta_mm": res.delta.tolist(),
        **{f"eps_{reading}": eps.tolist() for reading, eps in res.eps.items()},  # eps_line, eps_centroid, ...
        "gauge_variant": gauge_variant,
    }
    if getattr(res, "contact_force", None) is not None:
        entry["contact_force_N"] = res.contact_force.tolist()
        entry["base_reaction_N"] = res.base_reaction.tolist()
        entry["contact_stiffness_N_per_mm"] = res.contact_stiffness
        entry["contact_stiffness_definition"] = "secant over the first solved step, F(delta_1)/delta_1"
    entry["timings_s"] = {k: round(v, 4) for k, v in res.timings.items()}
    if res.mesh is not None:
        entry["mesh"] = res.mesh.report.as_dict()
    entry["reports"] = [r.as_dict() if hasattr(r, "as_dict") else str(r) for r in res.reports]
    entry.update(extra)
    return entry


#: The collection of every scene of a result.
RESULT_PVD = "scenes.pvd"


def write_result_collection(out: Path, files: dict) -> Path:
    """``scenes.pvd``: one ParaView collection of every scene's files, each scene's solid and fibres a
    named block (``part`` k, ``name`` the scene, ``<scene>_fibres``), time step = δ [mm].

    Parameters
    ----------
    out : Path
    files : dict of scene name -> SceneFiles
    """
    from fem.io import write_pvd

    entries, part = [], 0
    for name, sf in files.items():
        for paths, label in ((sf.states, name), (sf.fibres, f"{name}{FIBRE_SUFFIX}")):
            if paths:
                entries += [(d, p.name, part, label) for d, p in zip(sf.deltas, paths)]
                part += 1
    return write_pvd(Path(out) / RESULT_PVD, entries)


#: Attribute naming the scene on an exception that :func:`solve_scenes` lets through.
FAILED_NAME = "scene_name"


def solve_scenes(out: Path, specs: dict, gauge_variant: str = "line", **extra) -> tuple[dict, dict]:
    """Solve scenes keeping their states; write their files into ``out`` (:func:`write_scene_files`) and
    last the collection of them all (:func:`write_result_collection`).

    Parameters
    ----------
    out : Path
        Created when missing.
    specs : dict of str -> whisker_opt.experiment.spec.SceneSpec
        Scene name -> spec, solved in order.
    gauge_variant : {'line', 'centroid'}
    **extra
        Added to every ``scenes.json`` entry.

    Returns
    -------
    results : dict of str -> SceneResult
    entries : dict of str -> dict
        ``scenes.json`` entries (:func:`scene_entry`, with ``wall_s``).
    """
    from whisker_opt.experiment.scene import run_scene

    out.mkdir(parents=True, exist_ok=True)
    results, entries, files = {}, {}, {}
    for name, spec in specs.items():
        t0 = time.perf_counter()
        try:
            res = run_scene(spec, keep_states=True)
        except Exception as exc:
            if getattr(exc, FAILED_NAME, None) is None:
                with contextlib.suppress(AttributeError):
                    setattr(exc, FAILED_NAME, name)  # which scene, beside the spec and step run_scene left
            raise
        wall = time.perf_counter() - t0
        files[name] = write_scene_files(out, name, res)
        results[name] = res
        entries[name] = scene_entry(spec, res, gauge_variant, wall_s=round(wall, 3), **extra)
        logger.info("scene %s: Q=%.4g MPa, trim=%.4g mm, eps(deflection)=%.6g, %.2f s", name, spec.Q,
                    spec.design.trim, res.eps["line"][-1], wall)
    write_result_collection(out, files)
    return results, entries
