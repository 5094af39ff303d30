"""The reference table of f1: each design refined over the mesh ladder, and whether it stops moving.

Reads the rows of :mod:`benchmarks.accuracy.f1_convergence` (``ladder --method template``: one
evaluation per design and ladder level k, the GA's increments, only the mesh differs) and states,
per design and per quantity — f1, ε_i(5), ε_c(5) of the line and the section readings, and Δl —

* the values over the levels, the last move (finest − next finest) and whether the sequence is
  monotone;
* the observed order p and the Richardson value q∞ from the three finest levels, where they are
  monotone (sizes h = 1/k: the wall layers, the chamber layers and the body elements all scale
  with 1/k; the sectors 8, 10, 12, 16, 20 do not exactly; level 5 is the ``reference`` preset);
* the remaining uncertainty of the finest value: the larger of |q∞ − q_finest| and the last move where p
  exists, else the largest of the last two moves (no asymptotic range, so nothing better can be claimed);
* whether it has stopped moving: the last move and the uncertainty within max(``--tol-f1-rel`` · f1,
  ``--tol-f1``) (5 % or 1e-4 calibrated strain) for f1, ``--tol-reading`` (0.3 %) for the readings
  and Δl — the limits a reading at the GA's preset would have to meet against it, so a reference
  that moves by more than them cannot judge it.

Then each ladder preset's f1 distance from the finest level per design (and that of the presets
``coarse`` and ``fine`` as a run uses them: ``f1_convergence presets``), the largest over the designs (what :attr:`whisker_opt.experiment.fidelity.Preset.f1_resolution` states), and the cost.

Usage::

    python3 -m benchmarks.accuracy.f1_reference [--csv benchmarks/results/f1_section_ladder.csv]
        [--out benchmarks/results/f1_reference.csv]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from benchmarks.common import markdown_table, read_csv
from benchmarks.numerics import richardson

#: (column in the ladder CSV, name in the table, relative tolerance?) of every quantity judged
QUANTITIES = (
    ("f1", "f1 line", False),
    ("f1_section", "f1 section", False),
    ("eps_i5", "eps_i5 line", True),
    ("eps_c5", "eps_c5 line", True),
    ("eps_i5_section", "eps_i5 section", True),
    ("eps_c5_section", "eps_c5 section", True),
    ("delta_l", "delta_l", True),
)
LEVEL_PRESET = {1: "default", 2: "level2", 3: "level3", 4: "level4", 5: "reference"}
FIELDS = ["design", "quantity", "levels", "values", "finest_level", "finest", "last_move", "monotone", "p",
          "richardson", "uncertainty", "stopped", "finest_time_s", "finest_elements"]


def ladders(rows: list[dict], prefix: str = "tpl-ladder") -> dict[str, dict[int, dict]]:
    """design -> level -> row, for the rows of the ladder whose mesh label starts with ``prefix``."""
    by: dict = {}
    for r in rows:
        if r["mesh"].startswith(prefix):
            by.setdefault(r["design"], {})[int(r["level"])] = r
    return by


def judge(levels: list[int], values: list[float], tol: float, relative: bool, floor: float = 0.0) -> dict:
    """The convergence verdict of one quantity over the ladder levels (see the module docstring): stopped when
    the last move and the uncertainty are within max(``tol`` · |finest| if ``relative`` else ``tol``, ``floor``)."""
    q = np.asarray(values, float)
    out = {"levels": ",".join(map(str, levels)), "values": " / ".join(f"{v:.6g}" for v in q),
           "finest_level": levels[-1], "finest": float(q[-1])}
    moves = np.diff(q)
    out["last_move"] = float(moves[-1]) if len(moves) else math.nan
    out["monotone"] = bool(len(moves) and (np.all(moves > 0) or np.all(moves < 0)))
    p = rich = math.nan
    if len(q) >= 3:
        p, rich = richardson([1.0 / k for k in levels[-3:]], q[-3:])
    out["p"], out["richardson"] = p, rich
    if math.isfinite(rich):
        out["uncertainty"] = max(abs(rich - q[-1]), abs(out["last_move"]))
    elif len(moves) >= 2:
        out["uncertainty"] = float(np.max(np.abs(moves[-2:])))
    else:
        out["uncertainty"] = abs(out["last_move"])
    limit = max(tol * abs(q[-1]) if relative else tol, floor)
    out["stopped"] = bool(len(moves) and abs(out["last_move"]) <= limit and out["uncertainty"] <= limit)
    return out


def reference_rows(by: dict, tol_f1: float, tol_reading: float, tol_f1_rel: float = 0.0) -> list[dict]:
    """One row per (design, quantity); f1 judged against max(``tol_f1_rel`` · f1, ``tol_f1``)."""
    rows = []
    for design, lv in by.items():
        ks = sorted(lv)
        fin = lv[ks[-1]]
        for col, name, rel in QUANTITIES:
            have = [k for k in ks if lv[k].get(col)]
            if not have:
                continue
            row = {"design": design, "quantity": name, "finest_time_s": fin["time_s"],
                   "finest_elements": fin["elements"]}
            vals = [float(lv[k][col]) for k in have]
            if rel:
                row.update(judge(have, vals, tol_reading, True))
            else:
                row.update(judge(have, vals, tol_f1_rel, True, floor=tol_f1))
            rows.append(row)
    return rows


def resolution_rows(by: dict, col: str = "f1", presets: dict | None = None,
                    uncertainty: dict | None = None) -> list[dict]:
    """Per ladder level below the finest, and per preset evaluated as a run uses it (``presets``: name ->
    design -> row): |f1 − f1(finest level)| per design and the largest and median over the designs; with
    ``uncertainty`` (design -> the finest level's own uncertainty), also the largest gap plus that uncertainty
    (the bound a preset's ``f1_resolution`` states)."""
    out = []
    cands = [(LEVEL_PRESET.get(k, f"level{k}"), str(k), {d: lv[k] for d, lv in by.items() if k in lv})
             for k in sorted({k for lv in by.values() for k in lv})]
    cands += [(name, "-", rows) for name, rows in (presets or {}).items()]
    for name, level, rows in cands:
        gaps = {}
        for design, r in rows.items():
            lv = by.get(design, {})
            if not lv:
                continue
            fin = max(lv)
            if (level == "-" or int(level) < fin) and r.get(col) and lv[fin].get(col):
                gaps[design] = (abs(float(r[col]) - float(lv[fin][col])), fin)
        if gaps:
            worst = max(gaps, key=lambda d: gaps[d][0])
            row = {"preset": name, "level": level, "designs": len(gaps),
                   "largest gap to the finest": f"{gaps[worst][0]:.2e} ({worst}, vs level {gaps[worst][1]})",
                   "median gap": f"{float(np.median([g for g, _ in gaps.values()])):.2e}"}
            if uncertainty:
                bound = {d: g + uncertainty.get(d, 0.0) for d, (g, _) in gaps.items()}
                top = max(bound, key=bound.get)
                row["gap + the finest's uncertainty"] = f"{bound[top]:.2e} ({top})"
            out.append(row)
    return out


def preset_rows(rows: list[dict]) -> dict[str, dict[str, dict]]:
    """preset name -> design -> row, for the rows of ``f1_convergence presets`` (mesh label ``preset-NAME``)."""
    out: dict = {}
    for r in rows:
        if r["mesh"].startswith("preset-"):
            out.setdefault(r["mesh"][len("preset-"):], {})[r["design"]] = r
    return out


def compact_rows(rows: list[dict]) -> list[dict]:
    """One row per design: f1 of both readings over the levels with their last move, uncertainty and verdict,
    and the last relative move of ε_i(5), ε_c(5) (line, section) and Δl."""
    by: dict = {}
    for r in rows:
        by.setdefault(r["design"], {})[r["quantity"]] = r
    out = []
    for design, q in by.items():
        row = {"design": design, "levels": q["f1 line"]["levels"], "cost of finest [s]": q["f1 line"]["finest_time_s"]}
        for name in ("f1 line", "f1 section"):
            r = q.get(name)
            if r:
                vals = " / ".join(f"{float(v):.3g}" for v in r["values"].split(" / "))
                row[name] = f"{vals} (±{r['uncertainty']:.1e}, {'stopped' if r['stopped'] else 'moving'})"
        moves = []
        for name, short in (("eps_i5 line", "ε_i"), ("eps_c5 line", "ε_c"), ("eps_i5 section", "ε_i s"),
                            ("eps_c5 section", "ε_c s"), ("delta_l", "Δl")):
            r = q.get(name)
            if r and math.isfinite(r["last_move"]):
                moves.append(f"{short} {r['last_move'] / r['finest']:+.2%}")
        row["last move of the readings"] = ", ".join(moves)
        out.append(row)
    return out


def fmt_row(r: dict) -> dict:
    """Rounded strings for the markdown table."""
    out = dict(r)
    for c in ("finest", "last_move", "richardson", "uncertainty"):
        v = r[c]
        out[c] = "-" if not math.isfinite(v) else (f"{v:+.2e}" if c == "last_move" else f"{v:.4e}")
    out["p"] = "-" if not math.isfinite(r["p"]) else f"{r['p']:.2f}"
    out["monotone"] = "yes" if r["monotone"] else "no"
    out["stopped"] = "yes" if r["stopped"] else "no"
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csv", default="benchmarks/results/f1_section_ladder.csv")
    ap.add_argument("--out", default=None, help="write the reference rows to this CSV")
    ap.add_argument("--compact", action="store_true", help="one row per design instead of one per quantity")
    ap.add_argument("--tol-f1", type=float, default=1e-4, help="absolute f1 tolerance [calibrated strain]")
    ap.add_argument("--tol-f1-rel", type=float, default=0.05, help="relative f1 tolerance (the larger one applies)")
    ap.add_argument("--tol-reading", type=float, default=0.003, help="relative tolerance of ε_i(5), ε_c(5), Δl")
    args = ap.parse_args(argv)
    raw = read_csv(Path(args.csv))
    by, named = ladders(raw), preset_rows(raw)
    if not by:
        print(f"--csv: no ladder rows in {args.csv}", file=sys.stderr)
        return 2
    rows = reference_rows(by, args.tol_f1, args.tol_reading, args.tol_f1_rel)
    if args.out:
        import csv

        with open(args.out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=FIELDS)
            w.writeheader()
            for r in rows:
                w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    if args.compact:
        print(markdown_table(compact_rows(rows), ["design", "levels", "f1 line", "f1 section",
                                                  "last move of the readings", "cost of finest [s]"]))
    else:
        print(markdown_table([fmt_row(r) for r in rows], ["design", "quantity", "levels", "values", "last_move",
                                                          "monotone", "p", "richardson", "uncertainty", "stopped",
                                                          "finest_time_s"]))
    stopped = [r for r in rows if r["stopped"]]
    print(f"\n{len(stopped)} of {len(rows)} (design, quantity) pairs stopped moving "
          f"(f1 within max({args.tol_f1_rel:.0%}, {args.tol_f1:g}), readings and Δl within {args.tol_reading:.1%}).")
    for q in ("f1 line", "f1 section"):
        n = [r for r in rows if r["quantity"] == q]
        print(f"{q}: stopped at {sum(r['stopped'] for r in n)} of {len(n)} designs")
    print("\nThe odd levels alone (1, 3, 5: one, three and five wall layers, the mid-wall fibres inside elements on"
          " each), where a design has all three: observed order and Richardson value of f1")
    for design, lv in by.items():
        if all(k in lv for k in (1, 3, 5)):
            for col, name in (("f1", "line"), ("f1_section", "section")):
                q = [float(lv[k][col]) for k in (1, 3, 5)]
                p, rich = richardson([1.0, 1 / 3, 1 / 5], q)
                verdict = (f"p = {p:.2f}, q∞ = {rich:.3e} ({(q[-1] - rich) / rich:+.0%} at level 5)"
                           if math.isfinite(p) else "no order (the moves change sign or no p in [0.1, 8] fits)")
                print(f"  {design}, {name}: {' / '.join(f'{v:.3e}' for v in q)}: {verdict}")
    for col, name in (("f1", "line"), ("f1_section", "section")):
        unc = {r["design"]: r["uncertainty"] for r in rows if r["quantity"] == f"f1 {name}"}
        print(f"\nf1 ({name} reading): each ladder level's distance from the finest level of each design")
        print(markdown_table(resolution_rows(by, col, named, unc), ["preset", "level", "designs",
                                                                     "largest gap to the finest", "median gap",
                                                                     "gap + the finest's uncertainty"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
