"""Template meshes: shipped fTetWild meshes of reference designs, mapped onto new designs.

Fresh tetrahedralisation costs seconds and is not reproducible, so the GA maps a
stored template instead. A template holds the linear mesh of a reference design T
(vertices already projected onto T's exact surfaces), its tets and the patch id of
each boundary face. For a design N the vertices are moved by a continuous,
piecewise-smooth map that takes every patch of T onto the same patch of N:

*Axial*, piecewise linear per region (cap, chamber split at the gauge window
``x_ss .. x_ss + e``, body split at the contact knots ``f L'``)::

    x' = x c'/c                                     0 <= x <= c
    x' = c' + (x - c)(l' - c')/(l - c)               c <= x <= l   (per sub-interval)
    x' = l' + (x - l)(L'_N - l')/(L'_T - l)          l <= x <= L'_T

*Radial*, at fixed angle, with the core radius
``r_core(x) = r_i(x)`` on [c, l] and fractions of ``r_o(x)`` in the cap and body
(:func:`geometry.swept.core_radius`, continuous in x)::

    r' = r r'_core(x') / r_core(x)                                     r <= r_core(x)
    r' = r'_core + (r - r_core)(r'_o(x') - r'_core)/(r_o(x) - r_core)  r >= r_core(x)

so the cavity cone, both cavity end discs, the outer cone, base and tip map onto
themselves and the number of elements through the wall is preserved. The TET10
mesh is then built from the mapped vertices with straight interior edges and mid-edge
nodes re-snapped onto the curved surfaces (:func:`geometry.quadratic.upgrade`).

Templates are bucketed by wall thickness and cone angle (the two shape parameters
that change element aspect ratios most: ``t'/t`` squeezes the wall radially and
``r_o(L')`` the tip), one set per templatable sizing; the nearest template is
picked by ``|ln(t'/t)| + |ln(r'_tip/r_tip)| + 0.5 |ln((l'-c')/(l-c))|``.
The shipped templates are structured swept meshes (:mod:`geometry.swept`; fTetWild
templates can still be made with ``make_template(..., method="fresh")``).
Regenerate them with ``python3 -m whisker_opt.experiment.fidelity`` (the application's presets).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from geometry.design import WhiskerDesign
from geometry.sizing import MeshSizing

logger = logging.getLogger(__name__)

TEMPLATE_DIR = Path(__file__).with_name("templates")

#: reference designs of the shipped templates (GA box alpha in [2.5, 6], t in [2, 6],
#: l in [10, 15], L in {70, 60..65}); other parameters at their defaults
TEMPLATE_ALPHAS = (3.3, 5.0)
TEMPLATE_TS = (2.4, 3.6, 5.2)
TEMPLATE_L_CHAMBER = 12.5


@dataclass(frozen=True)
class Template:
    """One stored template mesh (see module docstring)."""

    name: str
    design: WhiskerDesign
    sizing_key: str
    sizing_name: str
    points: np.ndarray  # (n_v, 3) float64
    tets: np.ndarray  # (n_el, 4) int64
    face_class: np.ndarray  # (n_f,) int64
    structured: bool = False  # a swept mesh: cylindrical mid-edge nodes (geometry.quadratic)

    @cached_property
    def topology(self) -> tuple:
        """TET10 connectivity, edges and boundary faces (:func:`geometry.quadratic.mesh_topology`),
        computed once per loaded template: the map moves vertices only, so every mesh mapped from
        this template shares them."""
        from geometry.quadratic import mesh_topology

        return mesh_topology(self.points, self.tets)


def template_designs() -> list[WhiskerDesign]:
    """The reference designs of the template grid."""
    return [
        WhiskerDesign(alpha=a, t=t, l=TEMPLATE_L_CHAMBER) for a in TEMPLATE_ALPHAS for t in TEMPLATE_TS
    ]


def save_template(path: Path, tpl: Template) -> None:
    """Write a template ``.npz`` (float64 points, int32 tets, int8 classes)."""
    np.savez_compressed(
        path,
        name=np.array(tpl.name),
        design_json=np.array(json.dumps(tpl.design.as_dict())),
        sizing_key=np.array(tpl.sizing_key),
        sizing_name=np.array(tpl.sizing_name),
        points=tpl.points,
        tets=tpl.tets.astype(np.int32),
        face_class=tpl.face_class.astype(np.int8),
        structured=np.array(bool(tpl.structured)),
    )


def load_template(path: Path) -> Template:
    with np.load(path, allow_pickle=False) as z:
        return Template(
            name=str(z["name"]),
            design=WhiskerDesign.from_dict(json.loads(str(z["design_json"]))),
            sizing_key=str(z["sizing_key"]),
            sizing_name=str(z["sizing_name"]),
            points=np.asarray(z["points"], dtype=np.float64),
            tets=np.asarray(z["tets"], dtype=np.int64),
            face_class=np.asarray(z["face_class"], dtype=np.int64),
            structured=bool(z["structured"]) if "structured" in z.files else False,
        )


@lru_cache(maxsize=4)
def load_templates(directory: str = str(TEMPLATE_DIR)) -> tuple[Template, ...]:
    """All templates in ``directory`` (cached per process)."""
    files = sorted(Path(directory).glob("*.npz"))
    return tuple(load_template(f) for f in files)


def available_sizings(directory: str = str(TEMPLATE_DIR)) -> list[str]:
    return sorted({t.sizing_name for t in load_templates(directory)})


def template_distance(a: WhiskerDesign, b: WhiskerDesign) -> float:
    """``|ln(t_a/t_b)| + |ln(r_tip,a / r_tip,b)| + 0.5 |ln((l_a - c_a)/(l_b - c_b))|``."""
    return (
        abs(math.log(a.t / b.t))
        + abs(math.log(a.r_outer(a.length) / b.r_outer(b.length)))
        + 0.5 * abs(math.log((a.l - a.c) / (b.l - b.c)))
    )


def select_template(design: WhiskerDesign, sizing: MeshSizing, directory: str = str(TEMPLATE_DIR)) -> Template | None:
    """Nearest template serving ``sizing`` (same :meth:`MeshSizing.template_key`), or None."""
    key = sizing.template_key()
    if key is None:
        return None
    cands = [t for t in load_templates(directory) if t.sizing_key == key]
    if not cands:
        return None
    return min(cands, key=lambda t: template_distance(design, t.design))


# ---------------------------------------------------------------------- the map
def _core_radius(d: WhiskerDesign, x: np.ndarray) -> np.ndarray:
    """``r_core(x)``: cavity radius on [c, l], constant fractions of r_o outside."""
    from geometry.swept import core_radius

    return core_radius(d, x)


def map_axial(
    src: WhiskerDesign, dst: WhiskerDesign, x: np.ndarray, contact_fractions: tuple[float, ...] = ()
) -> np.ndarray:
    """Piecewise-linear axial map with knots (0, c, [x_ss, x_ss + e,] l, [f L',] L') -> (0, c', ..., L'').

    The gauge and contact knots are used when both designs have the same ones
    (:func:`geometry.swept.axial_knots`), so a gauge window made of whole element layers
    stays one and a node ring at a contact position ``f L'`` stays at ``f L''``.
    """
    from geometry.swept import axial_knots

    ks, kd = axial_knots(src, contact_fractions), axial_knots(dst, contact_fractions)
    if len(ks) != len(kd):
        ks, kd = axial_knots(src), axial_knots(dst)
    if len(ks) != len(kd):
        ks = [0.0, src.c, src.l, src.length]
        kd = [0.0, dst.c, dst.l, dst.length]
    return _pwl(x, ks, kd)


def _pwl(x: np.ndarray, xs: list[float], ys: list[float]) -> np.ndarray:
    """Piecewise-linear map through (xs, ys), extrapolating linearly beyond the ends."""
    x = np.asarray(x, dtype=float)
    i = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, len(xs) - 2)
    xs, ys = np.asarray(xs), np.asarray(ys)
    return ys[i] + (x - xs[i]) * (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i])


def map_points(
    src: WhiskerDesign, dst: WhiskerDesign, points: np.ndarray, contact_fractions: tuple[float, ...] = ()
) -> np.ndarray:
    """Apply the region-wise map of the module docstring to points of ``src``, shape (n, 3)."""
    x = points[:, 0]
    r = np.hypot(points[:, 1], points[:, 2])
    xn = map_axial(src, dst, x, contact_fractions)
    rc, ro = _core_radius(src, x), src.r_outer(x)
    rcn, ron = _core_radius(dst, xn), dst.r_outer(xn)
    inner = r <= rc
    with np.errstate(divide="ignore", invalid="ignore"):
        r_in = r * rcn / rc
        r_out = rcn + (r - rc) * (ron - rcn) / (ro - rc)
    rn = np.where(inner, r_in, r_out)
    scale = np.where(r > 0, rn / np.where(r > 0, r, 1.0), 0.0)
    return np.stack([xn, points[:, 1] * scale, points[:, 2] * scale], axis=1)


def map_template(
    tpl: Template, design: WhiskerDesign, contact_fractions: tuple[float, ...] = ()
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mapped vertices, tets and boundary-face classes for ``design``.

    ``contact_fractions``: those of the template's sizing (axial knots kept in place).
    """
    return map_points(tpl.design, design, tpl.points, contact_fractions), tpl.tets, tpl.face_class


# ---------------------------------------------------------------------- generation
def make_template(design: WhiskerDesign, sizing: MeshSizing, num_threads: int = 0, method: str = "swept") -> Template:
    """Mesh ``design`` (swept, or fTetWild with ``method="fresh"``) and keep the projected linear mesh."""
    from fem.mesh import boundary_faces, p1_to_p2
    from geometry import boundary as bd
    from geometry.quadratic import _project_safely

    if method == "swept":
        from geometry.swept import build_swept

        pts, tets = build_swept(design, sizing)
    elif method != "fresh":
        raise ValueError(f"make_template: method={method!r}, allowed ('swept', 'fresh')")
    # fTetWild leaves the boundary within its envelope; projecting a vertex onto the exact surface can invert
    # a flat tet under it. Then retry with a tighter envelope (fTetWild is not deterministic either).
    eps = sizing.epsilon
    for attempt in range(4 if method == "fresh" else 1):
        if method == "fresh":
            from geometry.tetrahedralize import tetrahedralize

            pts, tets = tetrahedralize(design, dataclasses.replace(sizing, epsilon=eps), num_threads=num_threads)
        pts, tets = _renumber(pts, tets)
        _, cells, _ = p1_to_p2(pts, tets)
        _, _, faces6 = boundary_faces(cells)
        cls = bd.classify_faces(design, pts, faces6[:, :3])
        pts, n_unproj, _ = _project_safely(design, pts, tets, faces6[:, :3], cls)
        if not n_unproj:
            break
        logger.warning("template for %s: %d vertices could not be projected (epsilon %.2g, attempt %d)",
                       design.describe(), n_unproj, eps, attempt + 1)
        eps = max(1e-5, 0.5 * eps)
    if n_unproj:
        raise RuntimeError(f"template for {design.describe()}: {n_unproj} vertices could not be projected")
    name = f"{sizing.name}_a{design.alpha:g}_t{design.t:g}"
    return Template(name, design, sizing.template_key(), sizing.name, pts, tets, cls, structured=(method == "swept"))


def _renumber(pts: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sort vertices by x and tets by their smallest vertex (smaller, better-compressing files)."""
    order = np.lexsort((pts[:, 2], pts[:, 1], np.round(pts[:, 0], 6)))
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    tets = inv[tets]
    tets = tets[np.lexsort((tets[:, 3], tets[:, 2], tets[:, 1], tets.min(axis=1)))]
    return pts[order], tets


def generate_templates(
    sizings: tuple[MeshSizing, ...], out_dir: Path = TEMPLATE_DIR, num_threads: int = 0
) -> list[Path]:
    """(Re)generate the template grid for the given sizings (seconds per sizing).

    The application's presets call this with their sizings
    (``python3 -m whisker_opt.experiment.fidelity``).
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for sizing in sizings:
        for d in template_designs():
            tpl = make_template(d, sizing, num_threads=num_threads)
            path = out_dir / f"{tpl.name}.npz"
            save_template(path, tpl)
            logger.info("template %s: %d vertices, %d tets, %.0f kB", tpl.name, len(tpl.points), len(tpl.tets),
                        path.stat().st_size / 1e3)
            paths.append(path)
    load_templates.cache_clear()
    return paths
