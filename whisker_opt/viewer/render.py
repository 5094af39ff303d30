"""Drawing states: the plotter, its panels, camera, colour range, and on-screen or PNG output.

Side-by-side views (:func:`render`) put one scene per panel with linked cameras: intact at
Q_i, trimmed uncompensated (``trimmed_uncompensated``: the trimmed whisker still at Q_i) and
trimmed vented (``trimmed`` at Q = 0, the GA's compensated state), each with its gauge
reading. :func:`interactive_plotter` steps through states (e.g. the solved deflections) with
a slider and the ``n`` / ``b`` keys.

Colour ranges (:func:`panel_clims`): by default each panel has its own range and scalar
bar (``clim_mode="panel"``), since the pressurised panels strain an order of magnitude more
than a vented one, which one shared range paints in a single colour; ``clim_mode="shared"``
gives all panels one range (one bar) to compare magnitudes. The bar titles carry the unit
and the mode; a footnote (:func:`colour_note`) says what the colours are and which
percentiles span the range, and a legend (:func:`add_legend`) names the markers.

All text is drawn in DejaVu Sans, shipped with matplotlib (:func:`text_font`): VTK's own
font draws ``[`` as ``(`` and has no Greek letters.

The chamber cavity is either revealed by a cut at ``z = 0`` (``cavity="clip"``) or seen
through a translucent outer surface (``cavity="translucent"``).
"""

from __future__ import annotations

import functools
import inspect
import logging
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from geometry.materials import FIBRE_DIAMETER
from whisker_opt.viewer.colours import _per_panel, panel_clims, panel_scopes
from whisker_opt.viewer.fields import field_names, resolve_field
from whisker_opt.viewer.guard import ViewerError, is_headless, require_pyvista
from whisker_opt.viewer.labels import (
    CAVITY_COLOUR,
    CONTACT_COLOUR,
    FIBRE_COLOURS,
    GAUGE_COLOUR,
    OUTLINE_COLOUR,
    _add_text,
    add_legend,
    bar_title,
    colour_note,
    legend_entries,
    panel_pixels,
    shown_text,
    use_font,
    wrap,
)
from whisker_opt.viewer.overlays import contact_point, fibre_lines, gauge_patch, panel_heading, text_lines
from whisker_opt.viewer.state import StateView, default_field

logger = logging.getLogger(__name__)

CAVITY_MODES = ("clip", "translucent", "hidden")
@functools.lru_cache(maxsize=1)
def _has_unique_bar() -> bool:
    """Whether pyvista's ``add_scalar_bar`` takes ``unique_bar`` (a bar per renderer)."""
    from pyvista.plotting.scalar_bars import ScalarBars

    return "unique_bar" in inspect.signature(ScalarBars.add_scalar_bar).parameters


def _clip(poly, on: bool, z: float = 0.0):
    if poly is None or not on or poly.n_points == 0:
        return poly
    return poly.clip(normal=(0.0, 0.0, 1.0), origin=(0.0, 0.0, z), invert=True)


def section_edges(sv: StateView):
    """The element edges on the cut ``z = cut_z``: the plane's intersection with each element's faces.

    The elements are taken with their corner nodes (straight edges; VTK would cut a 10-node tet
    into the pieces of its linear subdivision), at their warped positions, so every line drawn is
    an element boundary and the layers through the wall can be counted.

    Returns
    -------
    pyvista.PolyData or None
        None for a grid without quadratic tetrahedra.
    """
    from whisker_opt.viewer.fields import quadratic_cells

    pv = require_pyvista()
    cells = quadratic_cells(sv.grid)
    if not len(cells):
        return None
    linear = pv.UnstructuredGrid({pv.CellType.TETRA: cells[:, :4]}, np.array(sv.warped.points, dtype=float))
    sec = linear.slice(normal=(0.0, 0.0, 1.0), origin=(0.0, 0.0, sv.cut_z))
    return sec.extract_all_edges() if sec.n_points else None


def add_state(
    plotter,
    sv: StateView,
    field: tuple[str | None, str, int | None],
    clim: tuple[float, float] | None = None,
    cmap: str = "coolwarm",
    cavity: str = "clip",
    show_edges: bool = True,
    show_outline: bool = True,
    show_fibres: bool = True,
    show_gauge: bool = True,
    show_contact: bool = True,
    show_text: bool = True,
    prefix: str = "",
    show_scalar_bar: bool = True,
    bar_title: str | None = None,
    own_bar: bool = False,
) -> None:
    """Draw one state into the plotter's current renderer (actors named ``prefix + part``).

    Parameters
    ----------
    plotter : pyvista.Plotter
    sv : StateView
    field : tuple
        ``(array, label, component)`` from :func:`resolve_field`.
    clim : (float, float), optional
        Colour range (this panel's, or shared between panels: :func:`panel_clims`).
    cavity : {'clip', 'translucent', 'hidden'}
        ``clip`` removes the half z > 0 (the cut shows the wall section and the cavity, with the
        element edges on it when ``show_edges``: :func:`section_edges`), ``translucent`` shows the
        outer surface at 35 % opacity over the cavity.
    show_scalar_bar : bool
        Draw the scalar bar in this panel.
    bar_title : str, optional
        Scalar-bar title (default: the field's label, :func:`bar_title`).
    own_bar : bool
        The bar and its range belong to this panel only; otherwise pyvista merges the bars of
        the same title (and their ranges) across panels.
    """
    if cavity not in CAVITY_MODES:
        raise ViewerError(f"cavity={cavity!r}: must be one of {CAVITY_MODES}")
    clip = cavity == "clip"
    mesh_kw = _mesh_style(plotter, field, clim, cmap, show_scalar_bar, bar_title, own_bar)
    outer = _clip(sv.outer, clip, sv.cut_z)
    opacity = 0.35 if cavity == "translucent" and sv.cavity is not None else 1.0
    if outer is not None and outer.n_points:
        plotter.add_mesh(outer, opacity=opacity, name=prefix + "outer", **mesh_kw)
    if clip:
        sec = sv.warped.slice(normal=(0.0, 0.0, 1.0), origin=(0.0, 0.0, sv.cut_z))
        if sec.n_points:
            plotter.add_mesh(sec, name=prefix + "section", **dict(mesh_kw, smooth_shading=False, show_scalar_bar=False))
        if show_edges:
            cut = section_edges(sv)
            if cut is not None and cut.n_points:
                plotter.add_mesh(cut, color="black", opacity=0.45, line_width=1, name=prefix + "section_edges")
    if sv.cavity is not None and cavity != "hidden":
        cav = _clip(sv.cavity, clip, sv.cut_z)
        if cav is not None and cav.n_points:
            plotter.add_mesh(cav, color=CAVITY_COLOUR, opacity=0.6 if clip else 1.0, smooth_shading=True,
                             name=prefix + "cavity")
    if show_edges and sv.edges is not None:
        ed = _clip(sv.edges, clip, sv.cut_z)
        if ed is not None and ed.n_points:
            plotter.add_mesh(ed, color="black", opacity=0.2, line_width=1, name=prefix + "edges")
    if show_outline and sv.outline is not None and sv.outline.n_points:
        plotter.add_mesh(sv.outline, color=OUTLINE_COLOUR, line_width=2, name=prefix + "outline")
    _add_markers(plotter, sv, clip, prefix, show_fibres, show_gauge, show_contact)
    if show_text:
        dtxt, gtxt = text_lines(sv)
        # wide enough to leave the gauge text beside it (~9 px a character at 11 pt)
        _add_text(plotter, wrap(panel_heading(sv), max(24, int(0.56 * panel_pixels(plotter)[0] / 9))),
                  "upper_left", 11, prefix + "title")
        if dtxt:
            _add_text(plotter, dtxt, "lower_left", 8, prefix + "design")
        if gtxt:
            _add_text(plotter, gtxt, "upper_right", 9, prefix + "gauge_text")
    if mesh_kw["show_scalar_bar"]:
        for bar in plotter.scalar_bars.values():
            use_font(bar.GetTitleTextProperty())
            use_font(bar.GetLabelTextProperty())


def _mesh_style(plotter, field: tuple[str | None, str, int | None], clim, cmap: str, show_scalar_bar: bool,
                bar_title: str | None, own_bar: bool) -> dict[str, Any]:
    """The ``add_mesh`` keywords of the body's surfaces: the field, its colour range and scalar bar
    (placed to leave room for its title), or a plain colour without a field (see :func:`add_state`)."""
    name, label, comp = field
    mesh_kw: dict[str, Any] = dict(smooth_shading=True, show_scalar_bar=name is not None and show_scalar_bar)
    if name is not None:
        title = bar_title or label
        w_px = panel_pixels(plotter)[0]
        half_title = 4.0 * max(len(ln) for ln in title.split("\n"))  # ~ half its width at 12 pt [px]
        bar_kw: dict[str, Any] = dict(title=title, n_labels=5, fmt="%.3g", vertical=True,
                                      position_x=min(0.88, 1.0 - 0.025 - (half_title + 6.0) / w_px),
                                      position_y=0.2, width=0.05, height=0.56, title_font_size=12,
                                      label_font_size=11)
        if own_bar:
            if _has_unique_bar():
                bar_kw["unique_bar"] = True
            else:  # older pyvista: a title of its own (trailing spaces do not show)
                bar_kw["title"] = title + " " * (plotter.renderers.active_index + 1)
        mesh_kw.update(scalars=name, component=comp, cmap=cmap, clim=clim, scalar_bar_args=bar_kw)
    else:
        mesh_kw.update(color="lightsteelblue")
    return mesh_kw


def _add_markers(plotter, sv: StateView, clip: bool, prefix: str, show_fibres: bool, show_gauge: bool,
                 show_contact: bool) -> None:
    """The fibres (tubes, cut with the body), the gauge patch (whole: it is a marker) and the contact
    point with the push's direction."""
    if show_fibres:
        r_tube = 0.5 * float((sv.info.design or {}).get("fibre_diameter", FIBRE_DIAMETER) or FIBRE_DIAMETER)
        for k, line in enumerate(fibre_lines(sv)):
            line = _clip(line, clip, sv.cut_z)
            if line is not None and line.n_points:
                plotter.add_mesh(line.tube(radius=r_tube, n_sides=10), color=FIBRE_COLOURS[k % len(FIBRE_COLOURS)],
                                 name=f"{prefix}fibre{k}")
    if show_gauge:
        patch = gauge_patch(sv)  # drawn whole even when the body is cut: it is a marker
        if patch is not None and patch.n_points:
            plotter.add_mesh(patch, color=GAUGE_COLOUR, name=prefix + "gauge")
            plotter.add_mesh(patch.extract_feature_edges(boundary_edges=True, feature_edges=False,
                                                         manifold_edges=False, non_manifold_edges=False),
                             color="black", line_width=3, name=prefix + "gauge_outline")
    if show_contact:
        cp = contact_point(sv)
        if cp is not None:
            size = 0.04 * sv.grid.length
            pv = require_pyvista()
            plotter.add_mesh(pv.Sphere(radius=0.3 * size, center=cp), color=CONTACT_COLOUR, name=prefix + "contact")
            plotter.add_mesh(pv.Arrow(start=cp + np.array([0.0, 2.5 * size, 0.0]), direction=(0.0, -1.0, 0.0),
                                      scale=2.2 * size), color=CONTACT_COLOUR, name=prefix + "contact_arrow")


def _layout(views: Sequence[StateView], layout: str) -> tuple[int, int]:
    n = len(views)
    if layout == "auto":
        b = np.array(views[0].warped.bounds).reshape(3, 2)
        ext = b[:, 1] - b[:, 0]
        layout = "rows" if ext[0] > 1.8 * max(ext[1], ext[2], 1e-12) else "columns"
    if layout == "rows":
        return n, 1
    if layout == "columns":
        return 1, n
    raise ViewerError(f"layout={layout!r}: must be 'auto', 'rows' or 'columns'")


def default_window_size(shape: tuple[int, int]) -> tuple[int, int]:
    """Window size for a panel grid: 1400 × 460 per row, 640 × 620 per column."""
    rows, cols = shape
    if cols == 1:
        return 1400, max(480, 440 * rows)
    return 640 * cols, 620


def _set_camera(plotter, view: str, margin: float = 0.85, reserve_right: float = 0.16) -> None:
    """Point the current renderer's camera and fit the visible props.

    ``iso`` looks from +z turned 25° about y and x, ``xy`` from +z. The props fill
    ``margin`` of the panel height and of its width less the right-hand strip
    ``reserve_right`` (a fraction of the width, kept free for the scalar bar).
    """
    if view == "xy":
        plotter.view_xy()
    elif view == "iso":
        plotter.view_xy()
        plotter.camera.azimuth = -25
        plotter.camera.elevation = 25
    else:
        raise ViewerError(f"camera view={view!r}: must be 'iso' or 'xy'")
    ren = plotter.renderer
    b = ren.ComputeVisiblePropBounds()
    ren.ResetCamera(b)
    cam = ren.GetActiveCamera()

    def view_extent() -> tuple[float, float, float, float]:
        xs, ys = [], []
        for x in b[0:2]:
            for y in b[2:4]:
                for z in b[4:6]:
                    ren.SetWorldPoint(x, y, z, 1.0)
                    ren.WorldToView()
                    vx, vy, _ = ren.GetViewPoint()
                    xs.append(vx)
                    ys.append(vy)
        return min(xs), max(xs), min(ys), max(ys)

    x0, x1, y0, y1 = view_extent()  # view coordinates, the panel is [-1, 1]²
    half_w = (1.0 - reserve_right)  # usable width [-1, 1 - 2 reserve_right] has half-width 1 - reserve_right
    zx = margin * half_w / max(0.5 * (x1 - x0), 1e-12)
    zy = margin / max(0.5 * (y1 - y0), 1e-12)
    z = min(zx, zy)
    if np.isfinite(z) and z > 0:
        cam.Zoom(z)
        cam.SetWindowCenter(reserve_right, 0.0)  # shift the image left by the reserved strip


def make_plotter(views: Sequence[StateView], off_screen: bool, window_size: tuple[int, int] | None = None,
                 layout: str = "auto"):
    """A Plotter with one renderer per view (linked cameras)."""
    pv = require_pyvista()
    if not views:
        raise ViewerError("nothing to draw: no states selected")
    shape = _layout(views, layout)
    ws = tuple(window_size) if window_size else default_window_size(shape)
    if off_screen and is_headless():
        logger.info("no display (DISPLAY/WAYLAND_DISPLAY unset): rendering off-screen")
    p = pv.Plotter(shape=shape, off_screen=off_screen, window_size=list(ws), border=False)
    p.set_background("white")
    # no depth peeling: with VTK 9.6 on EGL it drops translucent layers altogether
    return p


def draw(plotter, views: Sequence[StateView], field, clim, camera: str = "iso", prefix: str = "",
         clim_mode: str = "shared", scopes: Sequence[str] | None = None, **kw) -> None:
    """Draw the views into the plotter's panels (row-major), sharing the camera.

    Parameters
    ----------
    plotter : pyvista.Plotter
    views : sequence of StateView
    field : tuple
        ``(array, label, component)``.
    clim : (float, float) or sequence of them or None
        One colour range for every panel, or one per panel (:func:`panel_clims`).
    camera : {'iso', 'xy'}
    prefix : str
        Actor-name prefix; given, this prefix's actors are removed first (a redraw).
    clim_mode : {'shared', 'panel'}
        ``panel``: a scalar bar (and range) of its own in every panel; ``shared``: one bar,
        in the first panel. The bar title says which (:func:`bar_title`).
    scopes : sequence of str, optional
        Per panel, from :func:`panel_scopes` (default: ``clim_mode`` for every panel).
    **kw
        Passed to :func:`add_state`.
    """
    rows, cols = plotter.shape
    if prefix:  # redraw: drop this prefix's actors (a part may be absent in the new state)
        for ren in plotter.renderers:
            for name in [n for n in ren.actors if str(n).startswith(prefix)]:
                ren.remove_actor(name, render=False)
    clims = _per_panel(clim, len(views))
    own = clim_mode == "panel"
    scopes = list(scopes) if scopes is not None else [clim_mode] * len(views)
    for i, sv in enumerate(views):
        plotter.subplot(i // cols, i % cols)
        title = bar_title(field[1], scopes[i]) if field[0] is not None else None
        add_state(plotter, sv, field, clim=clims[i], prefix=f"{prefix}{i}:", show_scalar_bar=own or i == 0,
                  bar_title=title, own_bar=own, **kw)
    if not prefix:
        plotter.subplot(0, 0)
        _set_camera(plotter, camera)
        if len(views) > 1:
            plotter.link_views()


def annotate(plotter, views: Sequence[StateView], field, clim_mode: str, percentile: float,
             uniform: bool = False, **kw) -> None:
    """The figure's legend (first panel, lower right) and colour footnote (last panel, lower right).

    Parameters
    ----------
    plotter : pyvista.Plotter
    views : sequence of StateView
        Every state shown (for which markers exist).
    field : tuple
    clim_mode : {'panel', 'shared'}
    percentile : float
    uniform : bool
        Some panel's field is uniform (:func:`colour_note`).
    **kw
        The :func:`add_state` switches (``show_gauge``, ``cavity``, ...); a marker that is
        not drawn is not listed.
    """
    rows, cols = plotter.shape
    keys = ("show_outline", "show_fibres", "show_gauge", "show_contact", "cavity")
    entries = legend_entries(views, **{k: kw[k] for k in keys if k in kw})
    w_px, h_px = panel_pixels(plotter)
    # under half the panel (~6.5 px a character at 8 pt), beside the design text; one line up, above it
    note = wrap(colour_note(field, clim_mode, percentile, uniform), max(30, int(0.5 * w_px / 6.5)))
    last = min(len(views), rows * cols) - 1
    plotter.subplot(0, 0)
    # 290 px wide, 21 px a line, left of the scalar bar, above the design text (and the note)
    n_under = 1 + (note.count("\n") + 2 if note and last == 0 else 0)
    size = (min(0.6, 290.0 / w_px), min(0.5, 21.0 * len(entries) / h_px))
    add_legend(plotter, entries, position=(max(0.01, 0.84 - size[0]), (6.0 + 14.0 * n_under) / h_px), size=size)
    if note:
        plotter.subplot(last // cols, last % cols)
        _add_text(plotter, note + "\n ", "lower_right", 8, "colour_note")
    plotter.subplot(0, 0)


def render(
    views: Sequence[StateView],
    field: str | None = None,
    screenshot: str | Path | None = None,
    off_screen: bool | None = None,
    window_size: tuple[int, int] | None = None,
    layout: str = "auto",
    camera: str = "iso",
    cmap: str = "coolwarm",
    clim_percentile: float = 1.0,
    clim_mode: str = "panel",
    **kw,
):
    """Render views side by side (same camera) on screen or to a PNG.

    Parameters
    ----------
    views : sequence of StateView
    field : str, optional
        See :func:`resolve_field` (resolved on the first view); default :func:`default_field`: the
        strain the push added when the views show a deflection, else the total axial strain.
    screenshot : path-like, optional
        Write the image there (off-screen) and return its path.
    off_screen : bool, optional
        Default: True when ``screenshot`` is given or no display exists.
    window_size : (int, int), optional
    layout : {'auto', 'rows', 'columns'}
    camera : {'iso', 'xy'}
    clim_percentile : float
        Colour range over the (p, 100 − p) percentiles of the field (0 = full range);
        see :func:`shared_clim`.
    clim_mode : {'panel', 'shared'}
        Each panel its own colour range and bar (default), or one for all
        (:func:`panel_clims`).
    **kw
        Passed to :func:`add_state` (``cavity``, ``show_edges``, ...).

    Returns
    -------
    Path or pyvista.Plotter
        The screenshot path, or the (already shown and closed) plotter.
    """
    if off_screen is None:
        off_screen = screenshot is not None or is_headless()
    field = default_field(views) if field is None else field
    f = resolve_field(views[0].grid, field, str(views[0].path or views[0].title)) if views else (None, "", None)
    for v in views[1:]:  # every panel must hold the field
        if f[0] is not None and f[0] not in field_names(v.grid):
            raise ViewerError(f"{v.path or v.title}: no field {f[0]!r}; available fields: {field_names(v.grid)}")
    panels = [[v] for v in views]
    clims = panel_clims(panels, f, clim_percentile, clim_mode)
    scopes = panel_scopes(panels, f, clim_percentile, clim_mode)
    p = make_plotter(views, off_screen, window_size, layout)
    draw(p, views, f, clims, camera=camera, cmap=cmap, clim_mode=clim_mode, scopes=scopes, **kw)
    annotate(p, views, f, clim_mode, clim_percentile, uniform="uniform" in scopes, **kw)
    if screenshot is not None:
        out = Path(screenshot)
        out.parent.mkdir(parents=True, exist_ok=True)
        p.screenshot(str(out))
        p.close()
        logger.info("screenshot written to %s", out)
        return out
    p.show()
    return p


def interactive_plotter(
    series: Sequence[Sequence[StateView]],
    field: str | None = None,
    off_screen: bool = False,
    window_size: tuple[int, int] | None = None,
    layout: str = "auto",
    camera: str = "iso",
    start: int | None = None,
    step_values: Sequence[float] | None = None,
    clim_percentile: float = 1.0,
    clim_mode: str = "panel",
    **kw,
) -> tuple[Any, Callable[[int], None]]:
    """A plotter that steps through states with a slider and the keys ``n`` / ``b``.

    Parameters
    ----------
    series : sequence of sequence of StateView
        ``series[k]`` are the panels shown at step k (e.g. every scene at its k-th state,
        or every scene at the k-th deflection).
    start : int, optional
        Initial step (default the last).
    step_values : sequence of float, optional
        The deflection δ [mm] of each step: the slider then runs over δ and snaps to the
        nearest step (default: over the step index).
    clim_mode : {'panel', 'shared'}
        Each panel its own colour range over all its steps (default), or one range for all
        panels and steps (:func:`panel_clims`).

    Returns
    -------
    plotter, set_step
        ``set_step(k)`` redraws step k (also what the slider and keys call).
    """
    if not series or not series[0]:
        raise ViewerError("nothing to draw: no states selected")
    if any(len(step) != len(series[0]) for step in series):
        raise ViewerError(f"every step must show {len(series[0])} panels, got {[len(step) for step in series]}")
    all_views = [v for step in series for v in step]
    field = default_field(all_views) if field is None else field
    f = resolve_field(series[-1][0].grid, field, str(series[-1][0].path or series[-1][0].title))
    panels = [[step[i] for step in series] for i in range(len(series[0]))]
    clims = panel_clims(panels, f, clim_percentile, clim_mode)
    scopes = panel_scopes(panels, f, clim_percentile, clim_mode)
    p = make_plotter(series[0], off_screen, window_size, layout)
    current = {"k": len(series) - 1 if start is None else int(start)}

    def set_step(k: float) -> None:
        k = int(round(k)) % len(series)
        current["k"] = k
        draw(p, series[k], f, clims, camera=camera, prefix="s:", clim_mode=clim_mode, scopes=scopes, **kw)
        p.render()

    draw(p, series[current["k"]], f, clims, camera=camera, prefix="s:", clim_mode=clim_mode, scopes=scopes, **kw)
    annotate(p, all_views, f, clim_mode, clim_percentile, uniform="uniform" in scopes, **kw)
    p.subplot(0, 0)
    _set_camera(p, camera)
    if len(series[0]) > 1:
        p.link_views()
    if len(series) > 1:
        # in the first panel, clear of the heading (upper left) and the gauge text (upper right):
        # between them in a wide panel, below them in a narrow one
        wide = panel_pixels(p)[0] >= 1000
        ends = dict(pointa=(0.42, 0.93), pointb=(0.72, 0.93)) if wide else dict(pointa=(0.1, 0.76),
                                                                                 pointb=(0.7, 0.76))
        if step_values is not None:
            if len(step_values) != len(series):
                raise ViewerError(f"step_values: {len(step_values)} values for {len(series)} steps")
            vals = np.asarray(step_values, dtype=float)
            w = p.add_slider_widget(lambda v: set_step(int(np.argmin(np.abs(vals - v)))), [vals[0], vals[-1]],
                                    value=vals[current["k"]], title=shown_text("push δ [mm] (n / b keys)"),
                                    fmt="%.2f", style="modern", **ends)
        else:
            w = p.add_slider_widget(set_step, [0, len(series) - 1], value=current["k"], title="state (n / b keys)",
                                    fmt="%.0f", style="modern", **ends)
        rep = w.GetRepresentation()
        use_font(rep.GetTitleProperty())
        use_font(rep.GetLabelProperty())
        p.add_key_event("n", lambda: set_step(current["k"] + 1))
        p.add_key_event("b", lambda: set_step(current["k"] - 1))
    return p, set_step
