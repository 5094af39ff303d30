"""Model-form study: which modelling choice moves the FE model's self-compensation toward the prototype's?

The thesis' prototype (Table 3.1, [α, l, t] = [2.862°, 15, 3], L = 70 mm) read *more* per millimetre
of deflection as its chamber pressure rose, at every contact ratio (the fitted effective modulus
ratio k(Q) = −1.337 Q + 0.9958, −27 % at 0.2 MPa), and a trim of 5 mm at Q_i = 0.1 MPa was undone by
venting to 0.048 MPa. Our FE model's response changes far less with Q (docs/physics.md, "Model form").
This script changes one modelling choice at a time (each an opt-in option of
:class:`whisker_opt.experiment.spec.SceneSpec` or of the design; the defaults are today's model) and
prints, per design and variant:

``r(a=1)``, ``r(a=.55)``
    the sensitivity ratio ε(δ = 1 mm; Q = 0.2)/ε(δ = 1 mm; Q = 0) at contact ratio a;
``r01(a=1)``
    the same at Q = 0.1 MPa;
``D*(0.1)``, ``D*(0.2)``
    the trim compensable by venting from Q_i: the Δ at which the compensating vent pressure reaches 0,
    i.e. the root of ε(L − Δ, Q = 0) = ε(L, Q_i) (δ = 1 mm, a = 1), by monotone (PCHIP)
    interpolation of ε(L − Δ, 0) solved at Δ = 0, 1, 2, 5, 10 mm. ``0`` when ε(L, Q_i) ≤ ε(L, 0):
    venting then raises the reading, so no trim is compensable; ``>10`` beyond the solved trims;
``rec5``, ``rec10``
    the recovery rate after a *full* vent from Q_i = 0.2 MPa of a whisker trimmed by 5 / 10 mm
    (docs/physics.md §7, on the readings at δ = 1 mm, a = 1): (1 − |ε_c − ε_o|/|ε_b − ε_o|)·100 with
    ε_o = ε(L, 0.2), ε_b = ε(L − Δ, 0.2), ε_c = ε(L − Δ, 0); the prototypes of the thesis' GA optima
    recovered ≥ 87 % (Δ = 5) and ≥ 72 % (Δ = 10);
``dl(0.1)``, ``dl(0.2)``
    the tip's axial extension Δl(Q) [mm];
``eps0``
    ε(δ = 1 mm) at Q = 0, a = 1 (calibrated, ξ = 3.9).

A scene that does not converge is reported as ``fail@Q`` with the pressure the solver reached; the
scenes at a higher pressure of that variant are then skipped. ``no contact ring``: the pusher at
x = L (``contact_at: reference``, a = 1) lies less than 1 mm behind the extended tip, where the swept
mesher places no node ring (geometry/swept.py ``axial_knots``). Every reading is the gauge's line
reading except for the ``gauge_centroid`` variant (the thesis' element-centroid reading of the same
scenes). ``--out`` receives ``model_form.csv`` and ``model_form_tornado.png`` (the change of each
measure from the baseline, per variant, for every design; the prototype's observations as lines).

Usage::

    OMP_NUM_THREADS=1 nice -n 5 python3 -m benchmarks.studies.model_form [--preset coarse] [--designs prototype,ga-a]
        [--variants baseline,contact_reference] [--out benchmarks/out/model_form]
"""

from __future__ import annotations

import argparse
import logging
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator

from benchmarks.common import design_from_genes, markdown_table, preset_spec

from whisker_opt.analysis.beam import BeamModel
from whisker_opt.experiment.scene import SceneRunner
from whisker_opt.output.storage import atomic_write_bytes, read_csv, write_csv

#: Designs [α, l, t] (L = 70 mm, the other fields at their defaults).
DESIGNS = {
    "prototype": (2.862, 15.0, 3.0),
    "ga-a": (4.0515, 11.069, 2.6521),
    "ga-b": (3.0, 12.5, 4.0),
}

#: Variant: (SceneSpec overrides, design overrides, gauge reading).
VARIANTS = {
    "baseline": ({}, {}, "line"),
    "gauge_centroid": ({}, {}, "centroid"),
    "yeoh_ds30": ({"rubber": "yeoh_dragon_skin_30"}, {}, "line"),
    "body_ds10_cap_ds30": ({"rubber": "yeoh_dragon_skin_10", "cap_rubber": "yeoh_dragon_skin_30"}, {}, "line"),
    "body_ef0030_cap_ds30": ({"rubber": "yeoh_ecoflex_00_30", "cap_rubber": "yeoh_dragon_skin_30"}, {}, "line"),
    "fibre_r0": ({}, {"fibre_radius_frac": 0.0}, "line"),
    "fibre_r0.25": ({}, {"fibre_radius_frac": 0.25}, "line"),
    "base_sliding": ({"base_support": "sliding"}, {}, "line"),
    "contact_reference": ({"contact_at": "reference"}, {}, "line"),
    "reference+body_ds10": ({"contact_at": "reference", "rubber": "yeoh_dragon_skin_10",
                             "cap_rubber": "yeoh_dragon_skin_30"}, {}, "line"),
}

TRIMS = (0.0, 1.0, 2.0, 5.0, 10.0)
Q_LEVELS = (0.1, 0.2)
DELTA = 1.0  # mm, the deflection the prototype's observations were stated at
A_OFF = 0.55

COLUMNS = ["design", "variant", "eps0", "r01(a=1)", "r(a=1)", "r(a=.55)", "D*(0.1)", "D*(0.2)", "rec5", "rec10",
           "dl(0.1)", "dl(0.2)", "scenes", "time_s"]
REC_TRIMS = (5.0, 10.0)


class Failed(Exception):
    """A scene did not converge; ``q`` is the pressure reached."""

    def __init__(self, q: float, what: str):
        super().__init__(what)
        self.q = q


def _reached(exc: BaseException, Q: float) -> float:
    """Pressure reached before a failure: the load fraction s of a SolveFailed message times Q."""
    m = re.search(r"failed at s=([0-9.eE+-]+)", str(exc))
    return float(m.group(1)) * Q if m else float("nan")


class Study:
    """Solves the scenes of one (design, variant) through one memoising runner."""

    def __init__(self, preset: str):
        self.preset = preset
        self.runner = SceneRunner(memo_size=4096)
        self.n_scenes = 0

    def eps(self, genes, variant: str, Q: float, a: float = 1.0, trim: float = 0.0) -> tuple[float, float]:
        """(ε(δ = 1 mm), Δl) of one scene; raises :class:`Failed`."""
        over, dover, reading = VARIANTS[variant]
        over = dict(over)
        if Q == 0:  # the contact placement only differs under pressure: share the vented scene
            over.pop("contact_at", None)
        design = design_from_genes(*genes, trim=trim, **dover)
        spec = preset_spec(design, self.preset, Q=Q, contact_ratio=a, deflection=DELTA, **over)
        try:
            res = self.runner.run(spec)
        except Exception as exc:  # noqa: BLE001 - a failed scene is a result here
            raise Failed(_reached(exc, Q), f"{type(exc).__name__}: {str(exc)[:120]}") from exc
        self.n_scenes += 1
        y = res.eps[reading]
        return float(y[-1]), float(res.delta_l)


def compensable_trim(trims, eps_vented, target: float) -> float:
    """Root Δ* of ε(L − Δ, 0) = target by PCHIP through the solved trims (0 when target ≤ ε(L, 0),
    +inf beyond the largest trim)."""
    trims, eps_vented = np.asarray(trims, float), np.asarray(eps_vented, float)
    if target <= eps_vented[0]:
        return 0.0
    if target > eps_vented.max():
        return math.inf
    f = PchipInterpolator(trims, eps_vented - target)
    grid = np.linspace(trims[0], trims[-1], 2001)
    vals = f(grid)
    k = int(np.nonzero(vals >= 0)[0][0])
    lo, hi = grid[max(k - 1, 0)], grid[k]
    for _ in range(60):  # bisection on the monotone interpolant
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
    return float(0.5 * (lo + hi))


def row_for(study: Study, dname: str, variant: str) -> dict:
    genes = DESIGNS[dname]
    t0, n0 = time.perf_counter(), study.n_scenes
    row: dict = {"design": dname, "variant": variant}
    fail: dict[str, str] = {}
    solver_failed: set[str] = set()

    def get(key, Q, a=1.0, trim=0.0):
        if key in fail:
            return None
        try:
            return study.eps(genes, variant, Q, a, trim)
        except Failed as exc:
            logging.info("%s %s Q=%g a=%g trim=%g: %s", dname, variant, Q, a, trim, exc)
            fail[key] = f"fail@{exc.q:.3f}" if math.isfinite(exc.q) else "no contact ring"
            if math.isfinite(exc.q):
                solver_failed.add(key)
            return None

    e0 = get("e0", 0.0)
    vented = [e0] + [get(f"t{d}", 0.0, trim=d) for d in TRIMS[1:]]
    e = {Q: get(f"q{Q}", Q) for Q in Q_LEVELS[:1]}
    # a solve that failed below 0.1 MPa fails above it too (and each failure costs ~20 cut-backs)
    e[0.2] = get("q0.2", 0.2) if "q0.1" not in solver_failed else None
    if "q0.1" in solver_failed:
        fail["q0.2"] = "skipped"
    f0 = get("f0", 0.0, A_OFF)
    f2 = get("f2", 0.2, A_OFF) if not solver_failed & {"q0.1", "q0.2"} else None
    row["eps0"] = e0[0] if e0 else float("nan")
    row["r01(a=1)"] = e[0.1][0] / e0[0] if e0 and e[0.1] else fail.get("q0.1", "")
    row["r(a=1)"] = e[0.2][0] / e0[0] if e0 and e[0.2] else fail.get("q0.2", fail.get("q0.1", ""))
    row["r(a=.55)"] = f2[0] / f0[0] if f0 and f2 else fail.get("f2", fail.get("q0.2", "skipped"))
    ok = [v is not None for v in vented]
    for Q in Q_LEVELS:
        key = f"D*({Q:g})"
        if e[Q] is None or not ok[0]:
            row[key] = fail.get(f"q{Q}", "")
            continue
        tr = [t for t, good in zip(TRIMS, ok) if good]
        ev = [v[0] for v in vented if v is not None]
        row[key] = compensable_trim(tr, ev, e[Q][0])
        row[f"dl({Q:g})"] = e[Q][1]
    for Q in Q_LEVELS:
        row.setdefault(f"dl({Q:g})", fail.get(f"q{Q}", ""))
    for d in REC_TRIMS:
        eb = get(f"b{d}", 0.2, trim=d) if e[0.2] is not None else None
        ec = vented[TRIMS.index(d)]
        if eb is None or ec is None:
            row[f"rec{d:g}"] = fail.get(f"b{d}", fail.get("q0.2", "skipped"))
            continue
        row[f"rec{d:g}"] = (1.0 - abs((ec[0] - e[0.2][0]) / (eb[0] - e[0.2][0]))) * 100.0
    row["scenes"] = study.n_scenes - n0
    row["time_s"] = time.perf_counter() - t0
    return row


def beam_reference(dname: str) -> dict:
    """The thesis' beam model with its fitted softening law k(Q) (docs/physics.md §8): r(a) at 0.2 MPa."""
    d = design_from_genes(*DESIGNS[dname])
    b = BeamModel()
    return {"design": dname, "variant": "beam, thesis k(Q)",
            "r01(a=1)": b.sensitivity(d, 1.0, 0.1) / b.sensitivity(d, 1.0, 0.0),
            "r(a=1)": b.sensitivity(d, 1.0, 0.2) / b.sensitivity(d, 1.0, 0.0),
            "r(a=.55)": b.sensitivity(d, A_OFF, 0.2) / b.sensitivity(d, A_OFF, 0.0)}


def _cell_value(v: str):
    """A CSV cell back as a float where it is a number, else the text (e.g. ``fail@0.139``)."""
    try:
        return float(v)
    except ValueError:
        return v


def _num(v) -> float:
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return float(v)
    return float("nan")


PLOT_METRICS = (("r(a=1)", "ε(Q=0.2)/ε(0), a = 1"), ("r(a=.55)", "ε(Q=0.2)/ε(0), a = 0.55"),
                ("D*(0.1)", "trim compensable\nfrom 0.1 MPa [mm]"), ("D*(0.2)", "trim compensable\nfrom 0.2 MPa [mm]"),
                ("rec5", "recovery, trim 5, full vent\nfrom 0.2 MPa [%] (GA protos ≥ 87)"),
                ("rec10", "recovery, trim 10, full vent\nfrom 0.2 MPa [%] (GA protos ≥ 72)"))


def tornado(rows: list[dict], refs: list[dict], path: Path, preset: str) -> None:
    """Change of each measure from the baseline per variant (bars: prototype; markers: other designs)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    designs = list(dict.fromkeys(r["design"] for r in rows))
    variants = [v for v in dict.fromkeys(r["variant"] for r in rows) if v != "baseline"]
    by = {(r["design"], r["variant"]): r for r in rows}
    fig, axes = plt.subplots(1, len(PLOT_METRICS), figsize=(3.3 * len(PLOT_METRICS), 0.42 * len(variants) + 2.6),
                             sharey=True)
    main = designs[0]
    markers = ("o", "s", "^", "D")
    for ax, (key, label) in zip(axes, PLOT_METRICS):
        base = _num(by.get((main, "baseline"), {}).get(key))
        vals = [_num(by.get((main, v), {}).get(key)) - base for v in variants]
        y = np.arange(len(variants))
        fin = np.where(np.isfinite(vals), vals, 0.0)
        ax.barh(y, fin, color=["tab:red" if v > 0 else "tab:blue" for v in fin], alpha=0.7, label=f"{main} (bars)")
        for yi, v, name in zip(y, vals, variants):
            if not np.isfinite(v):
                cell = by.get((main, name), {}).get(key, "")
                ax.text(0, yi, f" {cell or 'n/a'}", va="center", fontsize=7, color="0.3")
        for k, dn in enumerate(designs[1:]):
            b2 = _num(by.get((dn, "baseline"), {}).get(key))
            v2 = [_num(by.get((dn, v), {}).get(key)) - b2 for v in variants]
            ax.plot(v2, y, markers[k % len(markers)], ms=4, color="k", alpha=0.6, label=dn)
        if key == "D*(0.1)" and np.isfinite(base):
            ax.axvline(5.0 - base, color="g", ls="--", lw=1)
            ax.text(5.0 - base, -0.6, "prototype ≥ 5", color="g", fontsize=7, ha="right")
        ref = next((r for r in refs if r["design"] == main), None)
        if ref is not None and key in ref and np.isfinite(base):
            ax.axvline(ref[key] - base, color="m", ls=":", lw=1)
            ax.text(ref[key] - base, -0.6, "thesis k(Q) beam", color="m", fontsize=7, ha="right")
        ax.axvline(0.0, color="0.5", lw=0.8)
        ax.set_title(f"{label}\n{main} baseline {base:.3g}", fontsize=8)
        ax.set_xlabel("change from baseline", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].set_yticks(np.arange(len(variants)))
    axes[0].set_yticklabels(variants, fontsize=8)
    axes[0].set_ylim(len(variants) - 0.5, -1.0)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8)
    fig.suptitle(f"Model-form study ({preset} preset, δ = 1 mm): change of each measure from the baseline model "
                 f"(each design against its own baseline)", fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="coarse")
    ap.add_argument("--designs", default=",".join(DESIGNS))
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--out", type=Path, default=Path("benchmarks/out/model_form"))
    ap.add_argument("--replot", action="store_true", help="only redraw the plot from OUT/model_form.csv")
    ap.add_argument("-v", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.v else logging.WARNING)
    designs = [d for d in args.designs.split(",") if d]
    variants = [v for v in args.variants.split(",") if v]
    for name, known in (("design", DESIGNS), ("variant", VARIANTS)):
        bad = [x for x in (designs if name == "design" else variants) if x not in known]
        if bad:
            print(f"unknown {name}(s) {bad}; allowed {list(known)}", file=sys.stderr)
            return 2
    if args.replot:
        rows = [{k: _cell_value(v) for k, v in r.items()} for r in read_csv(args.out / "model_form.csv")]
        tornado(rows, [beam_reference(dn) for dn in dict.fromkeys(r["design"] for r in rows)],
                args.out / "model_form_tornado.png", args.preset)
        return 0
    study = Study(args.preset)
    rows = []
    t0 = time.perf_counter()
    for dn in designs:
        for v in variants:
            rows.append(row_for(study, dn, v))
            print(f"[{time.perf_counter() - t0:6.0f} s] {dn:<10} {v:<22} done", file=sys.stderr, flush=True)
    refs = [beam_reference(dn) for dn in designs]
    print(f"Model-form study, preset {args.preset}, δ = {DELTA} mm, trims {TRIMS} mm "
          f"({time.perf_counter() - t0:.0f} s, {study.n_scenes} scenes solved)\n")
    print(markdown_table(rows, COLUMNS))
    print("\nReference: the thesis' beam model with its fitted softening law (docs/physics.md §8)\n")
    print(markdown_table(refs, ["design", "variant", "r01(a=1)", "r(a=1)", "r(a=.55)"]))
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(args.out / "model_form.csv", COLUMNS, rows)
    tornado(rows, refs, args.out / "model_form_tornado.png", args.preset)
    print(f"\nwrote {args.out / 'model_form.csv'} and {args.out / 'model_form_tornado.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
