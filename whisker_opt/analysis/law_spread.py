"""The model-form spread of a design: its f1 and recovery rate under each wall law.

The chamber wall's law under pressure (:mod:`whisker_opt.wall.law`) is the least certain part of the
model, and a design's compensation rests on it. For each design this module re-evaluates the three
scenes of a genome (intact at Q_i, trimmed at Q_i, trimmed and vented; :func:`whisker_opt.wiring.design_scene_specs`)
under each available law at the run's own preset, and reports

* f1 = mean |ε_intact − ε_trimmed| (docs/physics.md §4), and
* the recovery rate of the vent (docs/physics.md §7, ``robustness.recovery_scalar`` of the config),

and whether the compensation **survives every law**: the recovery rate is at least
:data:`SURVIVES_RECOVERY` under each of them (venting undoes at least half of what the trim did). A law that
cannot be evaluated for a design (a wall outside the stored table, a failed solve) is reported with its
reason and counts as not surviving.

The available laws (:func:`available_laws`) are ``embedded`` and the stored table's laws, plus the run's
own law when it is ``calibrated`` (with its fitted slope).
"""

from __future__ import annotations

import logging
import time
from typing import Any, Mapping, Sequence

from whisker_opt.genes import GENE_NAMES, genome_of, run_genome

logger = logging.getLogger(__name__)

#: Recovery rate [%] a design's vent must reach under every wall law for its compensation to "survive".
SURVIVES_RECOVERY = 50.0


def columns(gene_names: Sequence[str] = GENE_NAMES) -> tuple[str, ...]:
    """The columns of the spread's rows and CSV: the design, the law, the genome ``gene_names`` (each gene by
    its key, :func:`whisker_opt.genes.run_genome` of the run), then f1, the recovery rate and the status."""
    return ("design", "law", *gene_names, "f1", "recovery_rate", "status", "reason", "time_s")


#: The columns of a run of the default genome.
COLUMNS = columns()


def available_laws(cfg) -> tuple[str, ...]:
    """The wall laws a spread evaluates for ``cfg``: its own first, then every other law that needs no
    parameter (``calibrated`` only when the run's own law is, with the run's slope)."""
    from whisker_opt.wall.law import WALL_LAW_NAMES

    own = cfg.material.wall_law
    return (own,) + tuple(n for n in WALL_LAW_NAMES if n != own and n != "calibrated")


def law_spread(cfg, designs: Sequence[Mapping[str, float]], laws: Sequence[str] | None = None,
               on_scene=None) -> list[dict[str, Any]]:
    """f1 and the recovery rate of each design under each law (see the module docstring).

    Parameters
    ----------
    cfg : whisker_opt.config.model.WhiskerConfig
        The run's config (its preset, trim, scene settings and own law).
    designs : sequence of mapping
        The genes of the run's genome (:func:`whisker_opt.genes.run_genome` of ``cfg``: ``alpha``, ``l``,
        ``t``, ``Q_i`` and any added gene); each design is solved with every one of them.
    laws : sequence of str, optional
        Default :func:`available_laws`.
    on_scene : callable, optional
        ``on_scene()`` after each solved scene (progress).

    Returns
    -------
    list of dict
        One row per (design, law), :func:`columns` of the genome (``design`` is the 1-based index).

    Raises
    ------
    ValueError
        A design lacks a gene of the genome (one line naming it).
    """
    import numpy as np

    import whisker_opt.wiring as wiring
    from whisker_opt.analysis.compensation import curve_measures
    from whisker_opt.experiment import objective
    from whisker_opt.experiment.scene import SceneRunner

    laws = tuple(laws or available_laws(cfg))
    runner = SceneRunner(memo_size=16)
    names = run_genome(cfg)
    designs = [genome_of(genes, names, f"wall-law spread: design {k}") for k, genes in enumerate(designs, start=1)]
    rows = []
    for k, genes in enumerate(designs, start=1):
        for law in laws:
            t0 = time.perf_counter()
            row: dict[str, Any] = {"design": k, "law": law, **genes, "f1": float("nan"),
                                   "recovery_rate": float("nan"), "status": "ok", "reason": ""}
            try:
                lcfg = wiring.with_wall_law(cfg, law)
                ev = wiring.evaluator(lcfg, robust=False)
                specs = wiring.design_scene_specs(lcfg, genes)
                res = {}
                for name, spec in specs.items():
                    res[name] = runner.run(spec)
                    if on_scene is not None:
                        on_scene()
                delta = ev.samples()
                curves = {n: r.curve(delta, ev.gauge_variant) for n, r in res.items()}
                row["f1"] = float(objective.f1(curves[wiring.INTACT], curves[wiring.TRIMMED]))
                if wiring.UNCOMPENSATED in curves:
                    row["recovery_rate"] = float(curve_measures(
                        curves[wiring.INTACT], curves[wiring.UNCOMPENSATED], curves[wiring.TRIMMED],
                        cfg.robustness.recovery_scalar)[0])
            except (ValueError, ArithmeticError, RuntimeError) as exc:  # table range, solve failure, mesh
                row.update(status="failed", reason=f"{type(exc).__name__}: {str(exc).splitlines()[0]}")
                logger.warning("wall-law spread: design %d under %r: %s", k, law, row["reason"])
            row["time_s"] = time.perf_counter() - t0
            if not np.isfinite(row["f1"]) and row["status"] == "ok":
                row.update(status="failed", reason="no f1")
            rows.append(row)
    return rows


def survives(rows: Sequence[Mapping[str, Any]], design: int) -> tuple[bool, str]:
    """Whether design ``design``'s compensation survives every law, and a one-line reason."""
    mine = [r for r in rows if r["design"] == design]
    bad = [r for r in mine if r["status"] != "ok" or not (r["recovery_rate"] >= SURVIVES_RECOVERY)]
    if not bad:
        lo = min(r["recovery_rate"] for r in mine)
        return True, (f"compensation survives every wall law ({', '.join(r['law'] for r in mine)}): recovery "
                      f"rate ≥ {lo:.0f} % under each (threshold {SURVIVES_RECOVERY:.0f} %)")
    why = "; ".join(f"{r['law']}: " + (r["reason"] if r["status"] != "ok" else f"recovery {r['recovery_rate']:.0f} %")
                    for r in bad)
    return False, f"compensation does not survive every wall law ({why}; threshold {SURVIVES_RECOVERY:.0f} %)"


def format_spread(rows: Sequence[Mapping[str, Any]], preset: str) -> str:
    """The printed table: per design and law, f1 and the recovery rate, then one verdict line per design."""
    lines = [f"Wall-law spread at preset {preset} (f1 in the run's calibrated strain; recovery rate of the vent):",
             f"{'design':>6} {'law':<12} {'f1':>10} {'recovery %':>11}  note"]
    for r in rows:
        note = r["reason"] if r["status"] != "ok" else ""
        lines.append(f"{r['design']:>6} {r['law']:<12} {r['f1']:>10.3g} {r['recovery_rate']:>11.1f}  {note}")
    for d in sorted({r["design"] for r in rows}):
        lines.append(f"design {d}: {survives(rows, d)[1]}")
    return "\n".join(lines)


def write_spread(rows: Sequence[Mapping[str, Any]], path, gene_names: Sequence[str] = GENE_NAMES) -> None:
    """Write the rows to ``path`` as CSV, :func:`columns` of the genome ``gene_names``, atomically
    (:func:`whisker_opt.output.storage.write_csv`)."""
    from pathlib import Path

    from whisker_opt.output.storage import write_csv

    write_csv(Path(path), columns(gene_names), rows)


def report_lines(run_dir) -> list[str]:
    """The run report's lines for a stored ``law_spread.csv`` (none when the run has none)."""
    from pathlib import Path

    from whisker_opt.output.storage import read_csv

    path = Path(run_dir) / "law_spread.csv"
    if not path.is_file():
        return []
    rows = []
    for r in read_csv(path):
        rows.append({**r, "design": int(r["design"]), "f1": float(r["f1"] or "nan"),
                     "recovery_rate": float(r["recovery_rate"] or "nan")})
    lines = ["", f"Model-form spread ({path.name}): f1 and the vent's recovery rate under each chamber-wall law"]
    lines += [f"  design {r['design']}  {r['law']:<11} f1 {r['f1']:.4g}  recovery {r['recovery_rate']:.1f} %"
              + (f"  ({r['status']}: {r['reason']})" if r["status"] != "ok" else "") for r in rows]
    lines += [f"  design {d}: {survives(rows, d)[1]}" for d in sorted({r["design"] for r in rows})]
    return lines
