"""Words on the picture: fonts, wrapped titles, scalar-bar titles, the colour-range note and the legend."""

from __future__ import annotations

import functools
import logging
from pathlib import Path
from typing import Sequence

import numpy as np

from whisker_opt.viewer.fields import DISPLACEMENT_NAMES, MAGNITUDE_FIELD, MISES_FIELD, STRAIN_CHANGE_FIELD, STRAIN_FIELD
from whisker_opt.viewer.guard import require_pyvista
from whisker_opt.viewer.state import StateView

logger = logging.getLogger(__name__)

FIBRE_COLOURS = ("darkorange", "saddlebrown")  # alternate, so the interleaved helices of a double helix stand apart

GAUGE_COLOUR, CONTACT_COLOUR, OUTLINE_COLOUR, CAVITY_COLOUR = "gold", "red", "dimgrey", "lightskyblue"
_FIELD_WORDS = {STRAIN_FIELD: "axial log strain", MAGNITUDE_FIELD: "displacement", MISES_FIELD: "von Mises stress"}
_ASCII = {"δ": "delta", "ε": "eps", "≥": ">="}  # without a font that has them


@functools.lru_cache(maxsize=1)
def text_font() -> str | None:
    """Path of the TrueType font of the viewer's text: DejaVu Sans as shipped with matplotlib.

    Returns
    -------
    str or None
        None when it cannot be found; VTK's own font is used then, and Greek letters are
        spelt out (:func:`shown_text`).
    """
    try:
        import matplotlib
    except ImportError:
        return None
    path = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
    if not path.is_file():
        logger.info("%s not found: VTK's own font draws the text ('[' looks like '(')", path)
        return None
    return str(path)


def shown_text(text: str) -> str:
    """``text`` as drawn: unchanged with :func:`text_font`, else with δ, ε spelt out."""
    if text_font() is None:
        for k, v in _ASCII.items():
            text = text.replace(k, v)
    return text


def use_font(prop) -> None:
    """Draw a ``vtkTextProperty`` in :func:`text_font` (no-op without it)."""
    font = text_font()
    if font is not None and prop is not None:
        prop.SetFontFamily(4)  # VTK_FONT_FILE
        prop.SetFontFile(font)


def panel_pixels(plotter) -> tuple[int, int]:
    """(width, height) of one panel in pixels."""
    rows, cols = plotter.shape
    w, h = plotter.window_size
    return max(1, int(w) // cols), max(1, int(h) // rows)


def wrap(text: str, width: int) -> str:
    """Lines of ``text`` longer than ``width`` characters broken after ``", "`` or ``": "``
    (so that ``Q = 0.166 MPa`` stays whole), else at spaces.

    Parameters
    ----------
    text : str
    width : int
        Longest line [characters].

    Returns
    -------
    str
    """
    import re
    import textwrap

    out = []
    for line in text.split("\n"):
        cur = ""
        for c in (c for c in re.split(r"(?<=[,:]) ", line) if c):
            joined = f"{cur} {c}" if cur else c
            if len(joined) <= width:
                cur = joined
            elif len(c) <= width:
                out.append(cur)
                cur = c
            else:  # a long chunk: fill the current line, go on at spaces
                *full, cur = textwrap.wrap(joined, width)
                out += full
        out.append(cur)
    return "\n".join(out)


def _add_text(plotter, text: str, position, font_size: int, name: str):
    actor = plotter.add_text(shown_text(text), position=position, font_size=font_size, name=name)
    use_font(actor.GetTextProperty())
    return actor


def ordinal(x: float) -> str:
    """A percentile as an ordinal: ``1st``, ``2nd``, ``99th``, ``2.5th``.

    Parameters
    ----------
    x : float

    Returns
    -------
    str
    """
    if float(x).is_integer():
        n = int(x)
        suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
        return f"{n}{suffix}"
    return f"{x:g}th"


_SCOPE_WORDS = {"panel": "range of this panel", "shared": "same for all panels",
                "uniform": "uniform here: range\nof all panels"}


def bar_title(label: str, scope: str, width: int = 19) -> str:
    """Scalar-bar title: the field's label (with its unit) over whose range the bar shows.

    Parameters
    ----------
    label : str
        E.g. ``axial log strain LE_xx [-]``.
    scope : {'panel', 'shared', 'uniform'}
        From :func:`panel_scopes` (or a :data:`CLIM_MODES` entry).
    width : int
        Line length [characters] the label is wrapped to.

    Returns
    -------
    str
    """
    lines, cur = [], ""
    for w in label.split(" "):
        if cur and len(cur) + 1 + len(w) > width:
            lines.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}" if cur else w
    lines.append(cur)
    return "\n".join(lines) + "\n" + _SCOPE_WORDS[scope]


def colour_note(field: tuple[str | None, str, int | None], mode: str = "panel", percentile: float = 0.0,
                uniform: bool = False) -> str:
    """Footnote on what the colours show and how their range is set (empty without a field).

    The colour fields are totals from the unloaded, unpressurised mesh, while the gauge
    readings are counted from contact onset (:data:`whisker_opt.viewer.overlays.GAUGE_ZERO_NOTE`);
    the strain added by the push (:data:`~whisker_opt.viewer.fields.STRAIN_CHANGE_FIELD`) is
    counted from contact onset as the reading is.

    Parameters
    ----------
    field : tuple
        ``(array, label, component)``.
    mode : {'panel', 'shared'}
    percentile : float
    uniform : bool
        Some panel's field is uniform (it shows the range of all panels).

    Returns
    -------
    str
        Two lines (three for the strain added by the push).
    """
    name, label, _ = field
    if name is None:
        return ""
    words = _FIELD_WORDS.get(name)
    if words is None and name in DISPLACEMENT_NAMES:
        words = label.split(" [")[0]
    what = (f"colours: total {words} from the unloaded state (not zeroed at contact onset)" if words
            else f"colours: {label} as stored in the mesh file")
    if name == STRAIN_CHANGE_FIELD:
        what = ("colours: axial log strain added by the push, this state's minus the pressurised state's\n"
                "(zeroed at contact onset, as the gauge reading; in a vented panel equal to the total)")
    scope = "one for all panels" if mode == "shared" else (
        "each panel its own (a uniform one: that of all)" if uniform else "each panel its own")
    span = (f"{ordinal(percentile)}–{ordinal(100.0 - percentile)} percentile (beyond: end colours)"
            if percentile > 0 else "full range, minimum to maximum")
    return f"{what}\ncolour range: {scope}, {span}"


def legend_entries(views: Sequence[StateView], show_outline: bool = True, show_fibres: bool = True,
                   show_gauge: bool = True, show_contact: bool = True, cavity: str = "clip") -> list[tuple[str, str]]:
    """(label, colour) of the markers the views draw, for :func:`add_legend`.

    Parameters
    ----------
    views : sequence of StateView
    show_outline, show_fibres, show_gauge, show_contact, cavity
        The :func:`add_state` switches: a marker that is not drawn is not listed.

    Returns
    -------
    list of (str, str)
    """
    out = []
    if show_gauge and any(v.info.gauge is not None for v in views):
        out.append(("strain gauge (where ε is read)", GAUGE_COLOUR))
    if show_contact and any(v.info.contact_x is not None for v in views):
        out.append(("contact point, push direction", CONTACT_COLOUR))
    if show_outline and any(v.outline is not None for v in views):
        out.append(("undeformed outline (section z = 0)", OUTLINE_COLOUR))
    if show_fibres and any(int((v.info.design or {}).get("n_fibres", 0) or 0) > 0 for v in views):
        out.append(("reinforcing fibres", FIBRE_COLOURS[0]))
    if cavity != "hidden" and any(v.cavity is not None for v in views):
        out.append(("pressure chamber (cavity)", CAVITY_COLOUR))
    return out


def _symbol(kind: str, colour: str):
    """A legend symbol centred on the origin (as the legend box places them), coloured by
    its own RGB cell data."""
    pv = require_pyvista()
    if kind == "arrow":  # pointing down, as the contact arrow
        xy = [[-0.2, 1], [0.2, 1], [0.2, -0.1], [0.6, -0.1], [0, -1], [-0.6, -0.1], [-0.2, -0.1]]
    elif kind == "line":
        xy = [[-1, -0.15], [1, -0.15], [1, 0.15], [-1, 0.15]]
    else:
        xy = [[-0.8, -0.8], [0.8, -0.8], [0.8, 0.8], [-0.8, 0.8]]
    pts = np.c_[np.array(xy, dtype=float), np.zeros(len(xy))]
    poly = pv.PolyData(pts, faces=[len(xy), *range(len(xy))]).triangulate()
    rgb = np.array(pv.Color(colour).int_rgb, dtype=np.uint8)
    poly.cell_data["rgb"] = np.tile(rgb, (poly.n_cells, 1))
    poly.cell_data.active_scalars_name = "rgb"
    return poly


def add_legend(plotter, entries: Sequence[tuple[str, str]], position: tuple[float, float] = (0.6, 0.03),
               size: tuple[float, float] = (0.25, 0.3), name: str = "legend"):
    """A small legend of the markers in the current panel: coloured symbols, black text.

    Parameters
    ----------
    plotter : pyvista.Plotter
    entries : sequence of (str, str)
        (label, colour), e.g. from :func:`legend_entries`.
    position, size : (float, float)
        Lower-left corner and size, as fractions of the panel.
    name : str
        Actor name.

    Returns
    -------
    vtkLegendBoxActor or None
        None without entries.
    """
    if not entries:
        return None
    from vtkmodules.vtkRenderingAnnotation import vtkLegendBoxActor

    kinds = {CONTACT_COLOUR: "arrow", OUTLINE_COLOUR: "line", FIBRE_COLOURS[0]: "line"}
    leg = vtkLegendBoxActor()
    leg.SetNumberOfEntries(len(entries))
    for k, (label, colour) in enumerate(entries):
        leg.SetEntry(k, _symbol(kinds.get(colour, "square"), colour), shown_text(label), (0.0, 0.0, 0.0))
    leg.ScalarVisibilityOn()  # symbols in their own colours, text in black
    prop = leg.GetEntryTextProperty()
    prop.SetColor(0.0, 0.0, 0.0)
    prop.SetShadow(False)
    use_font(prop)
    leg.UseBackgroundOn()
    leg.SetBackgroundColor(1.0, 1.0, 1.0)
    leg.SetBackgroundOpacity(0.85)
    leg.BorderOff()
    leg.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    leg.GetPositionCoordinate().SetValue(*position)
    leg.GetPosition2Coordinate().SetCoordinateSystemToNormalizedViewport()
    leg.GetPosition2Coordinate().SetValue(*size)
    plotter.add_actor(leg, reset_camera=False, name=name, pickable=False)
    return leg
