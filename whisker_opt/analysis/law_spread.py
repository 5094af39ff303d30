"""The model-form spread of a design: its f1 and recovery rate under each wall law.

The chamber wall's law under pressure (:mod:`whisker_opt.wall.law`) is the least certain part of the
model, and a design's compensation rests on it. For each design this module re-evaluates the three
scenes of a genome (intact at Q_i, trimmed at Q_i, trimmed and vented; :func:`whisker_opt.wiring.design_scene_specs`)
under each available law at the run's own preset, and reports

* f1 = mean |ε_intact − ε_trimmed| (docs/physics.md §4), and
* the recovery rate of the vent (docs/physics.md §7, ``robustness.recovery_scalar`` of the config) with the
  two absolute gaps it is the ratio of, the trim's effect and what is left after venting
  (:func:`whisker_opt.analysis.compensation.recovery`, all in the run's calibrated strain),

and whether the compensation **survives every law**: the recovery rate is at least
:data:`SURVIVES_RECOVERY` under each of them (venting undoes at least half of what the trim did). Where the
trim's effect lies below the preset's f1 resolution the rate is not a measure (it divides by mesh error): the
row says "trim effect below resolution" and shows the two gaps, and the compensation survives that law when
what is left after venting is itself within the resolution (:meth:`~whisker_opt.analysis.compensation.Recovery.restores`).
A law that cannot be evaluated for a design (a wall outside the stored table, a failed solve) is reported with
its reason and counts as not surviving.

The available laws (:func:`available_laws`) are ``embedded`` and the stored table's laws, plus the run's
own law when it is ``calibrated`` (with its fitted slope).
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any, Mapping, Sequence

from whisker_opt.genes import GENE_NAMES, genome_of, run_genome

logger = logging.getLogger(__name__)

#: Recovery rate [%] a design's vent must reach under every wall law for its compensation to "survive".
SURVIVES_RECOVERY = 50.0


def columns(gene_names: Sequence[str] = GENE_NAMES) -> tuple[str, ...]:
    """The columns of the spread's rows and CSV: the design, the law, the genome ``gene_names`` (each gene by
    its key, :func:`whisker_opt.genes.run_genome` of the run), then f1, the recovery rate (empty when the trim's
    effect is below the resolution), the trim's effect, what is left after venting and the resolution
    [calibrated strain], and the status."""
    return ("design", "law", *gene_names, "f1", "recovery_rate", "trim_effect", "vent_gap", "resolution",
            "status", "reason", "time_s")


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
    from whisker_opt.analysis.compensation import recovery
    from whisker_opt.experiment import objective
    from whisker_opt.experiment.fidelity import describe
    from whisker_opt.experiment.scene import SceneRunner

    laws = tuple(laws or available_laws(cfg))
    runner = SceneRunner(memo_size=16)
    names = run_genome(cfg)
    designs = [genome_of(genes, names, f"wall-law spread: design {k}") for k, genes in enumerate(designs, start=1)]
    resolution = describe(cfg.fidelity, cfg.scene.calibration)["f1_resolution"]
    rows = []
    for k, genes in enumerate(designs, start=1):
        for law in laws:
            t0 = time.perf_counter()
            row: dict[str, Any] = {"design": k, "law": law, **genes, "f1": float("nan"),
                                   "recovery_rate": float("nan"), "trim_effect": float("nan"),
                                   "vent_gap": float("nan"), "resolution": resolution, "status": "ok", "reason": ""}
            try:
                lcfg = wiring.with_wall_law(cfg, law)
                ev = wiring.nominal_evaluator(lcfg)
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
                    rec = recovery(curves[wiring.INTACT], curves[wiring.UNCOMPENSATED], curves[wiring.TRIMMED],
                                   cfg.robustness.recovery_scalar, resolution)
                    row.update(recovery_rate=rec.shown_rate, trim_effect=rec.trim_effect, vent_gap=rec.vent_gap)
            except (ValueError, ArithmeticError, RuntimeError) as exc:  # table range, solve failure, mesh
                row.update(status="failed", reason=f"{type(exc).__name__}: {str(exc).splitlines()[0]}")
                logger.warning("wall-law spread: design %d under %r: %s", k, law, row["reason"])
            row["time_s"] = time.perf_counter() - t0
            if not np.isfinite(row["f1"]) and row["status"] == "ok":
                row.update(status="failed", reason="no f1")
            rows.append(row)
    return rows


def row_recovery(row: Mapping[str, Any]):
    """The :class:`~whisker_opt.analysis.compensation.Recovery` of a row (also of a row read back from the CSV,
    whose rate is empty when not resolved: it is the ratio of the two gaps)."""
    from whisker_opt.analysis.compensation import Recovery

    effect, left, res = (float(row[k] if row[k] != "" else "nan") for k in ("trim_effect", "vent_gap", "resolution"))
    rate = (1.0 - left / effect) * 100.0 if effect > 0.0 else float("nan")
    return Recovery(rate, effect, left, res)


def survives(rows: Sequence[Mapping[str, Any]], design: int) -> tuple[bool, str]:
    """Whether design ``design``'s compensation survives every law, and a one-line reason."""
    mine = [r for r in rows if r["design"] == design]
    bad = [r for r in mine if r["status"] != "ok" or not row_recovery(r).restores(SURVIVES_RECOVERY)]
    if not bad:
        rates = [r["recovery_rate"] for r in mine if row_recovery(r).resolved]
        least = f"recovery rate ≥ {min(rates):.0f} % under each" if len(rates) == len(mine) else \
            "recovery rate ≥ threshold or the vent leaves the reading within the resolution under each"
        return True, (f"compensation survives every wall law ({', '.join(r['law'] for r in mine)}): {least} "
                      f"(threshold {SURVIVES_RECOVERY:.0f} %)")
    why = "; ".join(f"{r['law']}: " + (r["reason"] if r["status"] != "ok" else row_recovery(r).text())
                    for r in bad)
    return False, f"compensation does not survive every wall law ({why}; threshold {SURVIVES_RECOVERY:.0f} %)"


def _recovery_cells(r: Mapping[str, Any]) -> tuple[str, str]:
    """The recovery rate's cell (``-`` when not a measure) and the row's note."""
    if r["status"] != "ok":
        return "-", r["reason"]
    rec = row_recovery(r)
    return (f"{rec.rate:.1f}" if rec.resolved else "-"), ("" if rec.resolved else rec.text())


def format_spread(rows: Sequence[Mapping[str, Any]], preset: str) -> str:
    """The printed table: per design and law, f1, the trim's effect, what venting leaves and the recovery rate
    (all gaps in the run's calibrated strain), then one verdict line per design."""
    lines = [f"Wall-law spread at preset {preset} (f1 and the gaps of the recovery rate in the run's calibrated "
             "strain; recovery = 1 − vent gap / trim effect):",
             f"{'design':>6} {'law':<12} {'f1':>10} {'trim effect':>12} {'vent gap':>10} {'recovery %':>11}  note"]
    for r in rows:
        rate, note = _recovery_cells(r)
        lines.append(f"{r['design']:>6} {r['law']:<12} {r['f1']:>10.3g} {r['trim_effect']:>12.3g} "
                     f"{r['vent_gap']:>10.3g} {rate:>11}  {note}")
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
    for r in rows:
        if "trim_effect" not in r:  # an older file without the gaps: its rate as stored
            r.update(trim_effect=1.0, vent_gap=1.0 - float(r["recovery_rate"] or "nan") / 100.0,
                     resolution=float("nan"))
    lines = ["", f"Model-form spread ({path.name}): f1 and the vent's recovery under each chamber-wall law "
             "(f1 and gaps in calibrated strain)"]
    for r in rows:
        if r["status"] != "ok":
            lines.append(f"  design {r['design']}  {r['law']:<11} ({r['status']}: {r['reason']})")
            continue
        rec = row_recovery(r)
        gaps = f"  (trim effect {rec.trim_effect:.2g}, vent gap {rec.vent_gap:.2g})" if rec.resolved and \
            not math.isnan(rec.resolution) else ""
        lines.append(f"  design {r['design']}  {r['law']:<11} f1 {r['f1']:.4g}  {rec.text()}{gaps}")
    lines += [f"  design {d}: {survives(rows, d)[1]}" for d in sorted({r["design"] for r in rows})]
    return lines
