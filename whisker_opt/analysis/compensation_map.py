"""The compensation map: the vent pressure Q(Δ, a) over trims Δ and contact ratios a, and its lookup.

A whisker trimmed by Δ and struck at contact ratio a reads as the intact one at Q_i struck at the
same a when its chamber is vented to Q(Δ, a). Each cell is the compensation of one trim
(:func:`whisker_opt.analysis.compensation.fe_compensation`, ``method='root'``, the method of the
table ``whisker-opt compensate`` writes) with the response at that a:

    s(Q) = mean_k (ε_trim(Q, a, δ_k) - ε_o(a, δ_k)),   ε_o(a) = ε_intact(Q_i, a, ·),

Q the root of s bracketed by [0, Q_i] (Brent), or the end point with the smaller mean gap
g(Q) = mean_k |ε_trim(Q, a, δ_k) - ε_o(a, δ_k)| when s keeps one sign on [0, Q_i] (the cell is
then *at a bound*: 'lower' Q = 0, vent fully, or 'upper' Q = Q_i). The recovery rate is that of
:func:`~whisker_opt.analysis.compensation.curve_measures` on the curve means. docs/physics.md §7.

Cost (:func:`solve_map`)
    Every cell runs the same search as its independent solve (both ends of [0, Q_i], then Brent),
    so the cell's decision (root or bound) is the same. A warm start that brackets each cell's
    search from its neighbours' Q (linear extrapolation in Δ) was measured on the beam model and
    dropped: it took more responses than Brent on [0, Q_i] (``benchmarks/results/compensation_map.md``;
    Brent's first secant step from the two ends already lands close on a near-linear s(Q)). What makes the map
    cheap is on the response's side: the grid is solved trim by trim, so an FE response shares
    the pressurised state of one (Δ, Q) across contact ratios and starts Newton from a
    neighbouring pressure (:class:`whisker_opt.compensation.WarmPressurise`).

Lookup (:meth:`CompensationMap.vent_pressure`)
    Bilinear in (Δ, a) on the rectilinear grid:

        Q(Δ, a) = (1-t)(1-u) Q_{i,j} + t(1-u) Q_{i+1,j} + (1-t)u Q_{i,j+1} + t u Q_{i+1,j+1},
        t = (Δ - Δ_i)/(Δ_{i+1} - Δ_i),  u = (a - a_j)/(a_{j+1} - a_j),

    exact at the nodes. Cells at a bound enter with their clipped Q (0 or Q_i: the best pressure
    the chamber can give there), so the interpolant stays in [0, Q_i];
    :meth:`CompensationMap.near_bound` says whether a corner of the enclosing cell is at a bound.
    Trims or contact ratios outside the grid are refused (:class:`MapRangeError`).
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar, Mapping

import numpy as np

from geometry.design import WhiskerDesign
from whisker_opt.analysis.beam import _check_range
from whisker_opt.analysis.compensation import DEFAULT_DELTAS, Scalar, fe_compensation

logger = logging.getLogger(__name__)

#: ``response(design, Q, a, deltas) -> ε(δ)``: the gauge reading at contact ratio a.
MapResponseFn = Callable[[WhiskerDesign, float, float, np.ndarray], np.ndarray]

#: Slack [mm, -] of the grid's range check in the lookup (rounding of stored values).
RANGE_SLACK = 1e-9


class MapRangeError(ValueError):
    """A lookup outside the map's grid, or a map that cannot be read; one line naming the argument,
    its value and the allowed range."""


def map_trims(trim_max: float, step: float) -> list[float]:
    """The map's trims: 0, step, 2·step, …, trim_max (the last step may be shorter) [mm]."""
    dmax = _check_range("trim_max", trim_max, 0.0, None, lo_open=True)
    step = _check_range("step", step, 0.0, None, lo_open=True)
    n = int(math.floor(dmax / step + 1e-9))
    trims = [i * step for i in range(n + 1)]
    return trims + [dmax] if dmax - trims[-1] > 1e-9 else trims


def check_contact_ratios(a_values) -> np.ndarray:
    """Contact ratios of a map: at least two distinct values in (0, 1], returned sorted."""
    a = np.unique(np.asarray(a_values, dtype=float))
    if a.size < 2 or not np.all(np.isfinite(a)) or a[0] <= 0.0 or a[-1] > 1.0:
        raise ValueError(f"contact ratios a = {list(map(float, np.atleast_1d(a_values)))}: need at least two "
                         f"distinct values in (0, 1]")
    return a


# --------------------------------------------------------------------------- the map
@dataclass(frozen=True, eq=False)
class CompensationMap:
    """Vent pressure Q over trims × contact ratios, as a controller stores it.

    Attributes
    ----------
    trims : ndarray, shape (n_t,)
        Increasing trims Δ [mm], the first 0.
    a : ndarray, shape (n_a,)
        Increasing contact ratios [-].
    Q : ndarray, shape (n_t, n_a)
        Vent pressure [MPa]; Q_i on the row Δ = 0.
    recovery_rate, compensation_error : ndarray, shape (n_t, n_a)
        Measures [%] on the curve means (NaN on the row Δ = 0: nothing to recover).
    gap_before, gap_after : ndarray, shape (n_t, n_a)
        Mean |ε - ε_o| over δ, at Q_i and at Q [calibrated strain].
    at_bound : ndarray of str, shape (n_t, n_a)
        'lower' (Q = 0), 'upper' (Q = Q_i) or '' (a root inside); '' on the row Δ = 0.
    n_responses : ndarray of int, shape (n_t, n_a)
        Response evaluations the cell's search made (memo hits of an FE runner included).
    Q_i : float
        Intact pressure [MPa].
    design : dict
        The intact design's parameters (:meth:`geometry.design.WhiskerDesign.as_dict`).
    deltas : ndarray
        Deflection samples [mm].
    scalar : str
        Scalar of the recovery measures ('mean').
    xatol : float
        Tolerance of the root search on Q [MPa].
    fidelity : dict
        The FE preset (empty for another response, e.g. the beam model).
    """

    trims: np.ndarray
    a: np.ndarray
    Q: np.ndarray
    recovery_rate: np.ndarray
    compensation_error: np.ndarray
    gap_before: np.ndarray
    gap_after: np.ndarray
    at_bound: np.ndarray
    n_responses: np.ndarray
    Q_i: float
    design: dict
    deltas: np.ndarray
    scalar: str = "mean"
    xatol: float = 1e-4
    fidelity: dict = field(default_factory=dict)

    #: File names of a stored map (:func:`whisker_opt.output.compensation.write_map`).
    FILES: ClassVar[dict[str, str]] = {"csv": "compensation_map.csv", "json": "compensation_map.json",
                                       "png": "compensation_map.png"}

    def __post_init__(self) -> None:
        shape = (np.size(self.trims), np.size(self.a))
        for name in ("Q", "recovery_rate", "compensation_error", "gap_before", "gap_after", "at_bound",
                     "n_responses"):
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"CompensationMap.{name}: shape {np.shape(getattr(self, name))}, expected {shape} "
                                 f"(trims × a)")
        for name, v in (("trims", self.trims), ("a", self.a)):
            if np.size(v) < 2 or np.any(np.diff(v) <= 0):
                raise ValueError(f"CompensationMap.{name} = {list(map(float, v))}: need at least two increasing values")

    @property
    def design_text(self) -> str:
        """The design in one line: ``α = 2.862°, l = 15 mm, t = 3 mm, L = 70 mm``."""
        d = self.design
        return (f"α = {d.get('alpha', float('nan')):g}°, l = {d.get('l', float('nan')):g} mm, "
                f"t = {d.get('t', float('nan')):g} mm, L = {d.get('L', float('nan')):g} mm")

    # ---------------------------------------------------------------- lookup
    def _locate(self, name: str, x: float, grid: np.ndarray, unit: str) -> tuple[int, float]:
        """(i, t): grid[i] <= x <= grid[i+1], t = (x - grid[i])/(grid[i+1] - grid[i]) in [0, 1]."""
        try:
            x = float(x)
        except (TypeError, ValueError):
            raise MapRangeError(f"{name} = {x!r}: not a number; allowed range [{grid[0]:g}, {grid[-1]:g}]{unit}") \
                from None
        if not (grid[0] - RANGE_SLACK <= x <= grid[-1] + RANGE_SLACK):  # also refuses NaN
            raise MapRangeError(f"{name} = {x:g}: outside the map's range [{grid[0]:g}, {grid[-1]:g}]{unit}")
        x = min(max(x, float(grid[0])), float(grid[-1]))
        i = int(np.clip(np.searchsorted(grid, x, side="right") - 1, 0, grid.size - 2))
        return i, (x - grid[i]) / (grid[i + 1] - grid[i])

    def vent_pressure(self, trim: float, a: float) -> float:
        """Q [MPa] at trim Δ [mm] and contact ratio a, bilinear in (Δ, a) (module docstring).

        Raises
        ------
        MapRangeError
            ``trim`` or ``a`` outside the grid (one line: argument, value, range).
        """
        i, t = self._locate("trim", trim, self.trims, " mm")
        j, u = self._locate("a", a, self.a, "")
        q = self.Q
        return float((1 - t) * (1 - u) * q[i, j] + t * (1 - u) * q[i + 1, j] + (1 - t) * u * q[i, j + 1]
                     + t * u * q[i + 1, j + 1])

    def near_bound(self, trim: float, a: float) -> bool:
        """Whether a corner of the grid cell holding (Δ, a) with a non-zero weight is at a bound."""
        i, t = self._locate("trim", trim, self.trims, " mm")
        j, u = self._locate("a", a, self.a, "")
        w = np.array([[(1 - t) * (1 - u), (1 - t) * u], [t * (1 - u), t * u]])
        corners = self.at_bound[i:i + 2, j:j + 2] != ""
        corners[0, :] &= self.trims[i] > 0  # the row Δ = 0 is trivially at Q_i
        return bool(np.any(corners & (w > 0)))

    # ---------------------------------------------------------------- disk
    def as_dict(self) -> dict[str, Any]:
        """JSON-ready content (the file ``compensation_map.json``; NaN written as null)."""
        return {
            "kind": "compensation_map", "trims_mm": self.trims.tolist(), "a": self.a.tolist(),
            "Q_MPa": self.Q.tolist(), "recovery_rate_pct": self.recovery_rate.tolist(),
            "compensation_error_pct": self.compensation_error.tolist(), "gap_before": self.gap_before.tolist(),
            "gap_after": self.gap_after.tolist(), "at_bound": self.at_bound.tolist(),
            "n_responses": self.n_responses.tolist(), "Q_i_MPa": self.Q_i, "design": dict(self.design),
            "deltas_mm": self.deltas.tolist(), "scalar": self.scalar, "xatol_MPa": self.xatol,
            "fidelity": dict(self.fidelity),
            "lookup": "bilinear in (trim, a); cells at a bound enter with their clipped Q (0 or Q_i); "
                      "outside the grid refused",
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> CompensationMap:
        """The inverse of :meth:`as_dict` (null read as NaN)."""
        def grid(key: str, dtype=float) -> np.ndarray:
            return np.array([[np.nan if v is None else v for v in row] for row in d[key]], dtype=dtype)

        return cls(trims=np.asarray(d["trims_mm"], dtype=float), a=np.asarray(d["a"], dtype=float),
                   Q=grid("Q_MPa"), recovery_rate=grid("recovery_rate_pct"),
                   compensation_error=grid("compensation_error_pct"), gap_before=grid("gap_before"),
                   gap_after=grid("gap_after"), at_bound=np.array(d["at_bound"], dtype=object).astype(str),
                   n_responses=np.asarray(d["n_responses"], dtype=int), Q_i=float(d["Q_i_MPa"]),
                   design=dict(d["design"]), deltas=np.asarray(d["deltas_mm"], dtype=float),
                   scalar=str(d.get("scalar", "mean")), xatol=float(d.get("xatol_MPa", 1e-4)),
                   fidelity=dict(d.get("fidelity") or {}))

    @classmethod
    def load(cls, path: str | Path) -> CompensationMap:
        """Read a map: ``compensation_map.json`` or the results directory holding it.

        Raises
        ------
        FileNotFoundError
            No such file, or the directory holds no ``compensation_map.json``.
        MapRangeError
            The file is not a compensation map (one line naming the file).
        """
        p = Path(path)
        if p.is_dir():
            p = p / cls.FILES["json"]
        if not p.is_file():
            raise FileNotFoundError(f"{path}: no compensation map here (expected {cls.FILES['json']} or a directory "
                                    f"holding it; `whisker-opt compensate CONFIG --map` writes one)")
        try:
            d = json.loads(p.read_text())
            if d.get("kind") != "compensation_map":
                raise KeyError("kind")
            return cls.from_dict(d)
        except (ValueError, KeyError, TypeError, AttributeError, RecursionError) as exc:
            raise MapRangeError(f"{p}: not a readable compensation map ({type(exc).__name__}: {exc})") from None


# --------------------------------------------------------------------------- solving
@dataclass
class _Cell:
    Q: float
    recovery_rate: float
    compensation_error: float
    gap_before: float
    gap_after: float
    at_bound: str
    n_responses: int


def _intact_response(response: MapResponseFn, intact: WhiskerDesign, Q_i: float, a: float, ds: np.ndarray,
                     journal) -> np.ndarray:
    """The intact target ε_o(δ) at contact ratio ``a``: read back from ``journal`` or solved (and recorded)."""
    key = f"intact {a!r}"
    stored = journal.get(key) if journal is not None else None
    if stored is not None:
        return np.asarray(stored, dtype=float)
    eps = np.asarray(response(intact, Q_i, a, ds), dtype=float)
    if journal is not None:
        journal.record(key, eps.tolist())
    return eps


def solve_map(design: WhiskerDesign, Q_i: float, trims, a_values, response: MapResponseFn, *, deltas=None,
              scalar: Scalar = "mean", xatol: float = 1e-4, maxiter: int = 60, by: str = "trim",
              fidelity: Mapping[str, Any] | None = None, on_cell=None, journal=None) -> CompensationMap:
    """The compensation map Q(Δ, a) on trims × contact ratios.

    Parameters
    ----------
    design : WhiskerDesign
        The whisker (its ``trimmed(0)`` form is the intact target).
    Q_i : float
        Intact pressure [MPa] > 0.
    trims : sequence of float
        Increasing trims [mm], the first 0 (e.g. :func:`map_trims`).
    a_values : sequence of float
        Contact ratios, at least two in (0, 1].
    response : callable
        ``response(design, Q, a, deltas) -> ε`` (an FE scene, or the beam model
        ``BeamResponse(a=a)(design, Q, deltas)``).
    deltas : array_like, optional
        Deflection samples [mm]; default :data:`~whisker_opt.analysis.compensation.DEFAULT_DELTAS`.
    scalar, xatol, maxiter
        As in :func:`~whisker_opt.analysis.compensation.fe_compensation`.
    by : {'trim', 'a'}
        Order of the cells: 'trim' (row by row: every contact ratio of one trim, then the next
        trim; the order in which an FE response can share pressurised states) or 'a' (column
        by column, as independent tables per contact ratio). The cells are the same either way:
        each is ``fe_compensation(..., method='root')``.
    fidelity : mapping, optional
        Recorded in the map.
    on_cell : callable, optional
        ``on_cell(trim, a, cell_dict)`` after each solved cell (progress, logging).
    journal : whisker_opt.output.journal.StudyJournal, optional
        The finished work of a stopped map: the intact responses and cells stored there are read
        back instead of solved, and every newly solved one is recorded.

    Returns
    -------
    CompensationMap
    """
    Q_i = _check_range("Q_i", Q_i, 0.0, None, lo_open=True)
    if by not in ("trim", "a"):
        raise ValueError(f"by = {by!r}: allowed 'trim', 'a'")
    _check_range("xatol", xatol, 0.0, Q_i, lo_open=True)
    tr = [float(t) for t in trims]
    if len(tr) < 2 or tr[0] != 0.0 or any(b <= c for c, b in zip(tr, tr[1:])):
        raise ValueError(f"trims = {tr}: need at least two increasing values starting at 0 mm")
    a = check_contact_ratios(a_values)
    design.trimmed(tr[-1]).validate()  # refuse early if the largest cut reaches the chamber
    ds = np.asarray(DEFAULT_DELTAS if deltas is None else deltas, dtype=float)
    intact = design.trimmed(0.0)
    cells: dict[tuple[int, int], _Cell] = {}
    eps_o = {j: _intact_response(response, intact, Q_i, float(aj), ds, journal) for j, aj in enumerate(a)}

    def record(k: int, j: int, cell: _Cell) -> None:
        cells[k, j] = cell
        if on_cell is not None:
            on_cell(tr[k], float(a[j]), cell.__dict__)

    def solve(k: int, j: int) -> None:
        aj = float(a[j])
        key = f"cell {tr[k]!r} {aj!r}"
        stored = journal.get(key) if journal is not None else None
        if stored is not None:
            record(k, j, _Cell(**stored))
            return
        if tr[k] == 0.0:
            record(k, j, _Cell(Q_i, float("nan"), float("nan"), 0.0, 0.0, "upper", 0))
            return
        r = fe_compensation(design, Q_i, tr[k], lambda d, q, x: response(d, q, aj, x), ds, scalar=scalar,
                            method="root", xatol=xatol, maxiter=maxiter, eps_target=eps_o[j])
        cell = _Cell(float(r.Q), float(r.recovery_rate), float(r.compensation_error), float(r.gap_before),
                     float(r.gap_after), r.at_bound or "", int(r.n_evaluations))
        if journal is not None:
            journal.record(key, dict(cell.__dict__))
        record(k, j, cell)

    order = ([(k, j) for k in range(len(tr)) for j in range(a.size)] if by == "trim"
             else [(k, j) for j in range(a.size) for k in range(len(tr))])
    for k, j in order:
        solve(k, j)

    def grid(name: str, dtype=float) -> np.ndarray:
        return np.array([[getattr(cells[k, j], name) for j in range(a.size)] for k in range(len(tr))], dtype=dtype)

    cmap = CompensationMap(
        trims=np.asarray(tr), a=a, Q=grid("Q"), recovery_rate=grid("recovery_rate"),
        compensation_error=grid("compensation_error"), gap_before=grid("gap_before"), gap_after=grid("gap_after"),
        at_bound=grid("at_bound", object).astype(str), n_responses=grid("n_responses", int), Q_i=Q_i,
        design=intact.as_dict(), deltas=ds, scalar=scalar, xatol=float(xatol), fidelity=dict(fidelity or {}))
    if np.any(np.diff(cmap.Q, axis=0) > xatol):
        logger.info("compensation map not monotone in Δ at every a: Q = %s",
                       np.array2string(cmap.Q, precision=4))
    return cmap
