"""Measurement files: a prototype's observations as CSV, read into frozen observation records.

A file holds one kind of observation, one per row, under a header line naming its columns (any
order). Lines that are empty or start with ``#`` are comments (cite the data's source there).
Units: mm, MPa, and the gauge's own unit for readings (calibrated strain, as ``scene.calibration``
makes the model's readings).

``extension`` (:class:`Extension`): the tip's axial extension after pressurising.
    required ``Q`` [MPa], ``dl`` [mm], ``sigma`` [mm]; optional ``trim`` [mm] (default 0), ``name``.
``response`` (:class:`Response`): a gauge reading ε at deflection δ, contact ratio a, pressure Q.
    required ``Q``, ``a``, ``delta`` [mm], ``eps``, ``sigma``; optional ``trim`` or ``length`` [mm]
    (the whisker's length L − Δ; default the intact whisker), ``ref_Q`` [MPa]: when given, ``eps``
    is the ratio ε(δ; Q)/ε(δ; ref_Q) of two readings of the same whisker at the same a and δ (a
    relative sensitivity, free of the gauge factor), ``name``.
``restore`` (:class:`Restore`): a reference whisker (``trim_ref`` or ``length_ref``, at ``Q_ref``)
    read at a, δ is matched by another (``trim`` or ``length``) at the pressure ``Q``; required
    ``Q_ref``, ``Q``, ``a``, ``delta``, ``sigma`` [MPa, the uncertainty of Q]; optional ``name``. Venting
    a trimmed whisker back to the intact response is ``trim_ref = 0, Q_ref = Q_i, trim = Δ, Q = Q_c``.

Every kind also takes the optional column ``specimens`` (1 or 2, default 1): how many specimens the observation
compares. 1 is one whisker measured twice (a ratio of its readings, a trimmed whisker against itself before the
cut); 2 is two whiskers made separately (a comparison between two prototypes), whose ``sigma`` must then include
the difference between two castings, not only the reading's. The fit weighs every row by its ``sigma`` alone; the
column is recorded with the observation and shown in the report, so the reader sees which σ carries that part.

Every malformed value is a :class:`MeasurementError` (a :class:`~whisker_opt.config.model.ConfigError`)
of one line naming the file, the data row (1 = the first row under the header), its line in the
file and the column: ``data/p3.csv: row 2 (line 5), column a: 1.5 is outside the allowed range (0, 1]``.

An uncertainty ``sigma`` lies in [:data:`SIGMA_MIN`, :data:`SIGMA_MAX`] (the unit of the measured
value): the fit divides each residual by it, so a σ of 1e-300 would make the weighted residuals
overflow and one of 1e300 would make the observation weigh nothing. A σ below
:data:`SIGMA_RELATIVE_WARN` times the measured value is allowed but warned about (no bench
measurement is that precise: a unit slip, surely).
"""

from __future__ import annotations

import csv
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Union

from whisker_opt.config.model import ConfigError


logger = logging.getLogger(__name__)

#: Smallest and largest uncertainty a row may state, in the unit of its measured value.
SIGMA_MIN, SIGMA_MAX = 1e-12, 1e3
#: Largest magnitude of a ratio of two readings (``eps`` of a row with ``ref_Q``); a strain lies in [-1, 1].
RATIO_MAX = 1e3
#: A sigma below this fraction of the measured value is warned about.
SIGMA_RELATIVE_WARN = 1e-6


class MeasurementError(ConfigError):
    """A measurement file that cannot be used; the one-line message names the file, row and column."""


@dataclass(frozen=True)
class Extension:
    """Axial extension ``dl`` [mm] of the whisker trimmed by ``trim`` [mm] at pressure ``Q`` [MPa]."""

    name: str
    where: str
    Q: float
    dl: float
    sigma: float
    trim: float = 0.0
    specimens: int = 1
    cut_columns: tuple = field(default=(), repr=False, compare=False)

    kind = "extension"

    @property
    def value(self) -> float:
        return self.dl

    @property
    def unit(self) -> str:
        return "mm"


@dataclass(frozen=True)
class Response:
    """Gauge reading ``eps`` at ``delta`` [mm], contact ratio ``a``, pressure ``Q`` [MPa], trim ``trim`` [mm];
    with ``ref_Q`` the ratio of that reading to the one at ``ref_Q``."""

    name: str
    where: str
    Q: float
    a: float
    delta: float
    eps: float
    sigma: float
    trim: float = 0.0
    ref_Q: float | None = None
    specimens: int = 1
    cut_columns: tuple = field(default=(), repr=False, compare=False)

    kind = "response"

    @property
    def value(self) -> float:
        return self.eps

    @property
    def unit(self) -> str:
        return "-" if self.ref_Q is not None else "strain"


@dataclass(frozen=True)
class Restore:
    """The whisker trimmed by ``trim`` reads at pressure ``Q`` [MPa] as the one trimmed by ``trim_ref`` at
    ``Q_ref`` does (contact ratio ``a``, deflection ``delta`` [mm]); ``sigma`` is the uncertainty of Q."""

    name: str
    where: str
    trim_ref: float
    Q_ref: float
    trim: float
    Q: float
    a: float
    delta: float
    sigma: float
    specimens: int = 1
    cut_columns: tuple = field(default=(), repr=False, compare=False)

    kind = "restore"

    @property
    def value(self) -> float:
        return self.Q

    @property
    def unit(self) -> str:
        return "MPa"


Observation = Union[Extension, Response, Restore]


def cut_column(ob: Observation, attribute: str) -> str:
    """The column of the file that gave the trim ``attribute`` (``trim`` or ``trim_ref``) of an observation:
    that column itself, or ``length``/``length_ref`` (the whisker's length ``design.L - trim``)."""
    return dict(ob.cut_columns).get(attribute, attribute)

#: (low, high, low open, high open, unit) of each column; None = unbounded on that side.
_RANGES: dict[str, tuple] = {
    "Q": (0.0, 1.0, False, False, "MPa"), "Q_ref": (0.0, 1.0, False, False, "MPa"),
    "ref_Q": (0.0, 1.0, False, False, "MPa"),
    "dl": (-100.0, 100.0, False, False, "mm"), "a": (0.0, 1.0, True, False, "-"),
    "delta": (0.0, None, True, False, "mm"), "eps": (-1.0, 1.0, False, False, ""),
    "sigma": (SIGMA_MIN, SIGMA_MAX, False, False, "in the unit of the measured value"),
    "trim": (0.0, None, False, True, "mm"), "trim_ref": (0.0, None, False, True, "mm"),
    "length": (0.0, None, True, False, "mm"), "length_ref": (0.0, None, True, False, "mm"),
    "specimens": (1.0, 2.0, False, False, "(1: one whisker measured twice, 2: two whiskers made separately)"),
}
#: Required and optional columns of each kind.
COLUMNS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "extension": (("Q", "dl", "sigma"), ("trim", "name", "specimens")),
    "response": (("Q", "a", "delta", "eps", "sigma"), ("trim", "length", "ref_Q", "name", "specimens")),
    "restore": (("Q_ref", "Q", "a", "delta", "sigma"), ("trim_ref", "length_ref", "trim", "length", "name",
                                                        "specimens")),
}


def _interval(lo, hi, lo_open, hi_open, unit) -> str:
    left = "(-inf" if lo is None else ("(" if lo_open else "[") + f"{lo:g}"
    right = "inf)" if hi is None else f"{hi:g}" + (")" if hi_open else "]")
    return f"{left}, {right}" + (f" {unit}" if unit and unit != "-" else "")


def _a(word: str) -> str:
    return ("an " if word[0] in "aeiou" else "a ") + word


class _Rows:
    """The data rows of one file, with the place of every value for messages."""

    def __init__(self, path: Path, kind: str, shown: str) -> None:
        self.path, self.kind, self.shown = path, kind, shown
        required, optional = COLUMNS[kind]
        lines = self._lines()
        data = [(i, ln) for i, ln in enumerate(lines, 1) if ln.strip() and not ln.lstrip().startswith("#")]
        if not data:
            raise self.error(f"empty file: expected a header line with the columns {', '.join(required)} "
                             f"of {_a(kind)} file, then one row per observation")
        (head_line, head), rows = data[0], data[1:]
        self.header = [c.strip() for c in next(csv.reader([head]))]
        for k, col in enumerate(self.header):
            if col not in required + optional:
                raise self.error(f"header (line {head_line}), column {k + 1}: unknown column {col!r}; {_a(kind)} file "
                                 f"has the columns {', '.join(required)} and optionally {', '.join(optional)}")
            if self.header.count(col) > 1:
                raise self.error(f"header (line {head_line}): column {col!r} appears twice")
        missing = [c for c in required if c not in self.header]
        if missing:
            raise self.error(f"header (line {head_line}): missing column {missing[0]!r} ({_a(kind)} file has the "
                             f"columns {', '.join(required)} and optionally {', '.join(optional)})")
        for a, b in (("trim", "length"), ("trim_ref", "length_ref")):
            if a in self.header and b in self.header:
                raise self.error(f"header (line {head_line}): give {a!r} or {b!r}, not both")
        if not rows:
            raise self.error(f"no data rows under the header (line {head_line})")
        self.rows = []
        for n, (line_no, text) in enumerate(rows, 1):
            cells = [c.strip() for c in next(csv.reader([text]))]
            if len(cells) != len(self.header):
                raise self.error(f"row {n} (line {line_no}): {len(cells)} cells for the {len(self.header)} columns "
                                 f"{', '.join(self.header)}")
            self.rows.append((n, line_no, dict(zip(self.header, cells))))

    def _lines(self) -> list[str]:
        try:
            if not self.path.exists():
                raise self.error("no such measurement file")
            if not self.path.is_file():
                raise self.error("not a regular file (a measurement file is a CSV text file)")
            raw = self.path.read_bytes()
        except OSError as exc:
            raise self.error(f"cannot be read ({exc.strerror or exc})") from None
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            line = raw.count(b"\n", 0, exc.start) + 1
            raise self.error(f"not UTF-8 text (byte 0x{raw[exc.start]:02x} on line {line}); a measurement file is "
                             "CSV text") from None
        if "\x00" in text:
            raise self.error("not a text file (it holds NUL bytes); a measurement file is CSV text")
        return text.splitlines()

    def error(self, what: str) -> MeasurementError:
        return MeasurementError(f"{self.shown}: {what}".replace("\n", " "))

    def number(self, n: int, line: int, row: dict, col: str, default: float | None = None,
               lo=None, hi=None, lo_open=False, hi_open=False, unit=None) -> float | None:
        """The value of column ``col`` in a row, checked against its range (:data:`_RANGES` unless given)."""
        text = row.get(col, "")
        if text == "":
            if col in COLUMNS[self.kind][0]:
                raise self.error(f"row {n} (line {line}), column {col}: empty; a number is required")
            return default
        try:
            if "_" in text:  # float() reads 1_155 as 1155
                raise ValueError(text)
            x = float(text)
        except ValueError:
            raise self.error(f"row {n} (line {line}), column {col}: {text!r} is not a number"
                             + (" (no '_' between digits)" if "_" in text else "")) from None
        if not math.isfinite(x):
            raise self.error(f"row {n} (line {line}), column {col}: not a finite number (got {text})")
        r_lo, r_hi, r_lo_open, r_hi_open, r_unit = _RANGES[col]
        if lo is None and hi is None:
            lo, hi, lo_open, hi_open, unit = r_lo, r_hi, r_lo_open, r_hi_open, r_unit
        ok = (lo is None or (x > lo if lo_open else x >= lo)) and (hi is None or (x < hi if hi_open else x <= hi))
        if not ok:
            raise self.error(f"row {n} (line {line}), column {col}: {text} is outside the allowed range "
                             f"{_interval(lo, hi, lo_open, hi_open, unit if unit is not None else r_unit)}")
        return x

    def trim(self, n: int, line: int, row: dict, suffix: str, length_L: float) -> float:
        """The trim of a row from its ``trim``/``length`` column (``suffix`` '' or '_ref'); 0 when neither."""
        if f"length{suffix}" in row and row[f"length{suffix}"] != "":
            length = self.number(n, line, row, f"length{suffix}", lo=0.0, hi=length_L, lo_open=True,
                                 unit=f"mm (design.L = {length_L:g})")
            return float(length_L - length)
        return float(self.number(n, line, row, f"trim{suffix}", default=0.0, lo=0.0, hi=length_L, hi_open=True,
                                 unit=f"mm (design.L = {length_L:g})"))


def read_measurements(path: str | Path, kind: str, *, length_L: float, max_delta: float | None = None,
                      shown: str | None = None) -> list[Observation]:
    """The observations of one measurement file.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    kind : {'extension', 'response', 'restore'}
        What it holds (see the module docstring for the columns).
    length_L : float
        The intact length ``design.L`` [mm]: a ``length`` column becomes the trim ``L - length``, and a
        trim must leave a whisker (``0 <= trim < L``).
    max_delta : float, optional
        Largest deflection [mm] a row may ask for; None = no limit.
    shown : str, optional
        How the file is named in messages (default ``str(path)``).

    Returns
    -------
    list of Extension, Response or Restore
        In file order; an unnamed row is named ``<file stem>:<row>``.

    Raises
    ------
    MeasurementError
        The file cannot be read, is empty, lacks a column, has an unknown one, or a value is not a
        finite number in its column's range; the message names the file, the row and the column.
    """
    if kind not in COLUMNS:
        raise ValueError(f"kind = {kind!r}: allowed {', '.join(map(repr, COLUMNS))}")
    path = Path(path)
    rows = _Rows(path, kind, shown or str(path))
    out: list[Observation] = []
    for n, line, row in rows.rows:
        name = row.get("name") or f"{path.stem}:{n}"
        where = f"{rows.shown}: row {n} (line {line})"
        cuts = tuple((f"trim{sfx}", f"length{sfx}") for sfx in ("", "_ref") if row.get(f"length{sfx}", "") != "")

        def num(col: str, **kw) -> float:
            return rows.number(n, line, row, col, **kw)

        def specimens() -> int:
            x = rows.number(n, line, row, "specimens", default=1.0)
            if x != int(x):
                raise rows.error(f"row {n} (line {line}), column specimens: {row['specimens']} is not 1 or 2 (how "
                                 "many specimens the observation compares)")
            return int(x)

        def delta() -> float:
            if max_delta is None:
                return num("delta")
            return num("delta", lo=0.0, hi=max_delta, lo_open=True, unit="mm (the scene's largest deflection)")

        if kind == "extension":
            out.append(Extension(name, where, Q=num("Q"), dl=num("dl"), sigma=num("sigma"),
                                 trim=rows.trim(n, line, row, "", length_L), specimens=specimens(), cut_columns=cuts))
        elif kind == "response":
            ref = rows.number(n, line, row, "ref_Q", default=None) if "ref_Q" in row else None
            eps = num("eps") if ref is None else num("eps", lo=-RATIO_MAX, hi=RATIO_MAX,
                                                      unit="(a ratio of two readings, with ref_Q)")
            out.append(Response(name, where, Q=num("Q"), a=num("a"), delta=delta(), eps=eps,
                                sigma=num("sigma"), trim=rows.trim(n, line, row, "", length_L), ref_Q=ref,
                                specimens=specimens(), cut_columns=cuts))
        else:
            out.append(Restore(name, where, trim_ref=rows.trim(n, line, row, "_ref", length_L), Q_ref=num("Q_ref"),
                               trim=rows.trim(n, line, row, "", length_L), Q=num("Q"), a=num("a"), delta=delta(),
                               sigma=num("sigma"), specimens=specimens(), cut_columns=cuts))
    for ob in out:
        if ob.sigma < SIGMA_RELATIVE_WARN * abs(ob.value):
            logger.warning("%s, column sigma: %g is %.1e of the measured value %g: a relative uncertainty below %g, "
                           "which no bench measurement reaches; the fit will follow this observation alone (is sigma "
                           "in the unit of the value?)", ob.where, ob.sigma, ob.sigma / abs(ob.value), ob.value,
                           SIGMA_RELATIVE_WARN)
    return out


def check_names(observations: Iterable[Observation]) -> None:
    """Refuse two observations of the same name (held-out observations are named)."""
    seen: dict[str, str] = {}
    for ob in observations:
        if ob.name in seen:
            raise MeasurementError(f"{ob.where}, column name: {ob.name!r} is already the name of {seen[ob.name]}; "
                                   "names must be unique")
        seen[ob.name] = ob.where
