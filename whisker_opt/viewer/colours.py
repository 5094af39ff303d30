"""Colour ranges of the panels: each panel its own (default) or one shared by all."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from whisker_opt.viewer.fields import STRAIN_FIELD
from whisker_opt.viewer.guard import ViewerError
from whisker_opt.viewer.state import StateView


CLIM_MODES = ("panel", "shared")
"""Colour-range modes: each panel its own range and bar, or one range for all panels."""
def _data_range(views: Sequence[StateView], field: tuple[str | None, str, int | None],
                percentile: float) -> tuple[float, float] | None:
    """(lo, hi) of the field over the views, each spanning its (p, 100 − p) percentiles."""
    if not (0.0 <= percentile < 50.0):
        raise ViewerError(f"clim percentile={percentile!r} outside the allowed range [0, 50)")
    name, _, comp = field
    rngs = [r for r in (v.field_range(name, comp, percentile) for v in views) if r is not None]
    if not rngs:
        return None
    return min(r[0] for r in rngs), max(r[1] for r in rngs)


def shared_clim(views: Sequence[StateView], field: tuple[str | None, str, int | None],
                percentile: float = 0.0) -> tuple[float, float] | None:
    """One colour range over all views; symmetric about 0 for a strain that changes sign.

    ``percentile`` = p > 0 spans each view's (p, 100 − p) percentiles instead of its
    extremes: the whisker's strain range is set by a few nodes at the cavity's corners
    (LE_xx ≈ ±0.7 at Q = 0.2 MPa) while the gauge region bends to ~0.05, which a full
    range paints in one colour. Values beyond the range saturate.
    """
    rng = _data_range(views, field, percentile)
    if rng is None:
        return None
    lo, hi = rng
    if field[0] == STRAIN_FIELD and lo < 0 < hi:
        m = max(-lo, hi)
        lo, hi = -m, m
    if hi <= lo:
        hi = lo + (abs(lo) * 1e-6 or 1e-12)
    return lo, hi


def panel_clims(panels: Sequence[Sequence[StateView]], field: tuple[str | None, str, int | None],
                percentile: float = 0.0, mode: str = "panel") -> list[tuple[float, float] | None]:
    """The colour range of each panel.

    Parameters
    ----------
    panels : sequence of sequence of StateView
        ``panels[i]`` are the states panel i shows (one in a screenshot; each step of the
        slider in a window, so that its colours stay comparable from step to step).
    field : tuple
        ``(array, label, component)`` from :func:`resolve_field`.
    percentile : float
        See :func:`shared_clim`.
    mode : {'panel', 'shared'}
        ``panel``: each panel the :func:`shared_clim` of its own states; a panel whose field
        is uniform (e.g. a vented whisker at δ = 0: no strain at all) takes the range of all
        panels, in which its value is placed truthfully. ``shared``: all panels the range of
        all states.

    Returns
    -------
    list of (float, float) or None
        One per panel; None without the field.
    """
    everything = shared_clim([v for views in panels for v in views], field, percentile)
    scopes = panel_scopes(panels, field, percentile, mode)
    return [shared_clim(views, field, percentile) if sc == "panel" else everything
            for views, sc in zip(panels, scopes)]


def panel_scopes(panels: Sequence[Sequence[StateView]], field: tuple[str | None, str, int | None],
                 percentile: float = 0.0, mode: str = "panel") -> list[str]:
    """Whose colour range each panel shows (:func:`panel_clims`).

    Parameters
    ----------
    panels, field, percentile, mode
        As for :func:`panel_clims`.

    Returns
    -------
    list of str
        ``panel`` (its own), ``uniform`` (its field is uniform: the range of all panels) or
        ``shared`` (``mode="shared"``), one per panel.
    """
    if mode not in CLIM_MODES:
        raise ViewerError(f"clim mode={mode!r}: must be one of {CLIM_MODES}")
    if mode == "shared":
        return ["shared"] * len(panels)
    out = []
    for views in panels:
        rng = _data_range(views, field, percentile)
        out.append("panel" if rng is None or rng[1] > rng[0] else "uniform")
    return out


def _per_panel(clim, n: int) -> list:
    """``clim`` as one range per panel: a single (lo, hi) or None is repeated n times."""
    if clim is None or (len(clim) == 2 and all(np.isscalar(c) for c in clim)):
        return [clim] * n
    if len(clim) != n:
        raise ViewerError(f"{len(clim)} colour ranges for {n} panels")
    return list(clim)
