"""Helpers shared by the benchmark scripts (not a benchmark itself): designs from genes, the
scene spec of a preset, step statistics, failure classes, and CSV and markdown tables.

Imported as ``benchmarks.common`` (run the scripts as modules from the repository root).
"""

from __future__ import annotations

import csv
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from geometry.design import WhiskerDesign
from geometry.materials import RUBBER_C10
from geometry.mesh import MeshSizing
from whisker_opt.experiment.fidelity import PRESETS
from whisker_opt.config.optimiser import GenesConfig
from whisker_opt import genes
from whisker_opt.genes import GENE_NAMES
from whisker_opt.experiment.spec import SceneSpec

#: GA box of the genes, ``{name: (lo, hi)}`` in :data:`GENE_NAMES` order.
GENE_BOX: dict[str, tuple[float, float]] = dict(zip(GENE_NAMES, GenesConfig().bounds()))

#: Shear modulus of the default rubber, μ = 2 C10 [MPa].
MU = 2 * RUBBER_C10
#: D1 of a compressible rubber with K/μ = 1000 (K = 2/D1) [1/MPa].
D1_K1000 = 2.0 / (1000.0 * MU)


def design_from_genes(alpha: float, l: float, t: float, trim: float = 0.0,  # noqa: E741
                      base: WhiskerDesign = WhiskerDesign(), **changes) -> WhiskerDesign:
    """The base design with the geometric genes (:func:`whisker_opt.genes.design_from_genes`), the
    trim and any other design ``changes`` replaced (not validated)."""
    d = genes.design_from_genes(base, {"alpha": alpha, "l": l, "t": t}, trim)
    return replace(d, **changes) if changes else d


def preset_spec(design: WhiskerDesign, preset: str, **overrides) -> SceneSpec:
    """SceneSpec of a fidelity preset: its mesh sizing, step counts, template/swept mesh ('auto').

    ``overrides`` are any other :class:`whisker_opt.experiment.spec.SceneSpec` fields (Q, d1, ...).
    """
    p = PRESETS[preset]
    kw = dict(sizing=p.sizing, n_pressure_steps=p.n_pressure_steps,
              n_deflection_steps=p.n_deflection_steps, mesh_method="auto")
    kw.update(overrides)
    return SceneSpec(design, **kw)


def report_stats(reports) -> dict:
    """Totals over step reports: converged increments, cut-backs, Newton iterations, min J."""
    min_js = [r.min_j for r in reports if np.isfinite(r.min_j)]
    return {
        "increments": int(sum(r.n_increments for r in reports)),
        "cutbacks": int(sum(r.n_cutbacks for r in reports)),
        "iterations": int(sum(r.iterations for r in reports)),
        "min_j": float(min(min_js)) if min_js else float("nan"),
    }


def classify_exception(exc: BaseException) -> str:
    """Failure status of a scene exception, as the GA's evaluator classifies it.

    Mirrors :class:`whisker_opt.optimise.evaluator.SceneEvaluator`: InvalidDesignError ->
    ``invalid_geometry``, SolveFailed -> ``solve_failed``, meshing -> ``mesh_failed``,
    anything else -> ``error``.
    """
    from fem.newton import SolveFailed
    from geometry.design import InvalidDesignError
    from whisker_opt.optimise.evaluator import _is_mesh_error

    if isinstance(exc, InvalidDesignError):
        return "invalid_geometry"
    if isinstance(exc, SolveFailed):
        return "solve_failed"
    return "mesh_failed" if _is_mesh_error(exc) else "error"


def fmt(v) -> str:
    """Compact cell text for CSV/markdown (floats to 6 significant digits)."""
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (float, np.floating)):
        return "nan" if math.isnan(v) else f"{float(v):.6g}"
    return str(v)


def append_csv(path: Path, row: dict, fields: list[str]) -> None:
    """Append one row (writing the header first if the file is new), flushed at once."""
    new = not path.exists() or path.stat().st_size == 0
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        if new:
            w.writeheader()
        w.writerow({k: fmt(row.get(k, "")) for k in fields})
        f.flush()


def read_csv(path: Path) -> list[dict]:
    """Rows of a CSV written by :func:`append_csv` (strings), [] if missing."""
    if not path.exists():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def markdown_table(rows: list[dict], cols: list[str]) -> str:
    """A GitHub markdown table of ``rows`` restricted to ``cols``."""
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(fmt(r.get(c, "")) for c in cols) + " |" for r in rows]
    return "\n".join(lines)
