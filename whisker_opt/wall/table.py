"""The stored wall-law table: what pressure does to the chamber wall, per mechanism and wall geometry.

Written by ``benchmarks/studies/wall_law.py`` from converged wall cells (:mod:`whisker_opt.wallcell.cell`) and
shipped as package data (``whisker_opt/wall/data/wall_law.json``). Each entry holds, at the table's
pressures Q [MPa]: the bending stiffness EI [N mm², whole tube, per reference length], the axial strain
ε_z, the outer surface's radial growth at the ring and at mid-gap [mm] and the gauge transfer g (mean,
min and max over the gauge's position). The file's ``provenance`` names the code version, the command,
the cell's resolution and each variant's mechanism, so a result can be traced to what produced it.

Lookups interpolate linearly over (r_i, t) inside the table's points (Delaunay triangles) and refuse a
point outside them with a message naming the range.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import cached_property
from importlib import resources
from pathlib import Path

import numpy as np

QUANTITIES = ("EI", "ez", "g", "g_min", "g_max", "ur_ring", "ur_gap")
FORMAT = 1


def default_path() -> Path:
    """The table shipped with the package."""
    return Path(str(resources.files("whisker_opt.wall") / "data" / "wall_law.json"))


@dataclass(frozen=True, eq=False)
class WallTable:
    """A loaded table (see the module docstring)."""

    pressures: tuple[float, ...]
    entries: tuple[dict, ...]
    provenance: dict

    @classmethod
    def load(cls, path: str | Path | None = None) -> "WallTable":
        path = Path(path) if path is not None else default_path()
        try:
            data = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"wall-law table {path}: cannot be read ({exc})") from exc
        if data.get("format") != FORMAT:
            raise ValueError(f"wall-law table {path}: format {data.get('format')!r}, this version reads {FORMAT}")
        return cls(tuple(data["pressures"]), tuple(data["entries"]), data.get("provenance", {}))

    def save(self, path: str | Path) -> None:
        """Write atomically (a temporary file renamed over the target)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps({"format": FORMAT, "pressures": list(self.pressures), "provenance": self.provenance,
                                   "entries": list(self.entries)}, indent=1))
        tmp.replace(path)

    @property
    def variants(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(e["variant"] for e in self.entries))

    def points(self, variant: str) -> list[dict]:
        """The entries of one variant."""
        out = [e for e in self.entries if e["variant"] == variant]
        if not out:
            raise ValueError(f"wall law {variant!r}: not in the table; allowed {', '.join(self.variants)}")
        return out

    def ratio(self, variant: str, r_i: float, t: float) -> np.ndarray:
        """EI(Q)/EI(0) at the table's pressures for a wall (r_i, t) [mm]."""
        ei = self.lookup(variant, "EI", r_i, t)
        return ei / ei[0]

    def lookup(self, variant: str, quantity: str, r_i: float, t: float) -> np.ndarray:
        """``quantity`` at the table's pressures, interpolated linearly over (r_i, t)."""
        if quantity not in QUANTITIES:
            raise ValueError(f"wall-law quantity {quantity!r}: allowed {', '.join(QUANTITIES)}")
        pts = self.points(variant)
        exact = [e for e in pts if math.isclose(e["r_i"], r_i, abs_tol=1e-9) and math.isclose(e["t"], t, abs_tol=1e-9)]
        if exact:
            return np.asarray(exact[0][quantity], float)
        interp = self._interpolators(variant)[quantity]
        v = interp([[r_i, t]])[0]
        if not np.all(np.isfinite(v)):
            raise ValueError(f"wall (r_i, t) = ({r_i:.4g}, {t:.4g}) mm: outside the {variant!r} table, "
                             f"{self.span(variant)}")
        return v

    def span(self, variant: str) -> str:
        """The walls and pressures a variant covers, in words: its points' ranges of r_i, t and r_i + t
        (the outer radius; the table's walls lie between its lines, not only in the r_i × t box) and the
        pressures."""
        pts = self.points(variant)
        ri, ts = (np.array([e[k] for e in pts], float) for k in ("r_i", "t"))
        ro = ri + ts
        return (f"whose walls span r_i {ri.min():.4g}..{ri.max():.4g} mm, t {ts.min():.4g}..{ts.max():.4g} mm and "
                f"r_i + t {ro.min():.4g}..{ro.max():.4g} mm (inside the hull of its points), at Q "
                f"{self.pressures[0]:g}..{self.pressures[-1]:g} MPa")

    @cached_property
    def _cache(self) -> dict:
        return {}

    def _interpolators(self, variant: str) -> dict:
        if variant not in self._cache:
            from scipy.interpolate import LinearNDInterpolator

            pts = self.points(variant)
            xy = np.array([[e["r_i"], e["t"]] for e in pts])
            self._cache[variant] = {q: LinearNDInterpolator(xy, np.array([e[q] for e in pts], float))
                                    for q in QUANTITIES}
        return self._cache[variant]
