"""The prototype's boundaries as named mechanisms, each beside every prototype observation at once.

Each mechanism is a set of run-file settings on ``configs/calibrate_thesis.yaml`` (the Table 3.1 prototype's
design, the design defaults): the base (``scene.base_support``: clamped, axial, gripped over a depth, on
elastic supports) and the gauge as built (``scene.gauge_patch``: the bare surface or the bonded backing).
For each, the model values of :func:`benchmarks.prototype.claims` (a = 1 and the contact ratios
0.45 … 1, δ = 1 mm) against the prototypes' (docs/physics.md §14 and the thesis' Ch. 3 and 5):

* k(Q) as the thesis' procedure reads it from the gauge, ε(0)/ε(Q) at a = 1 (prototypes: 0.93, 0.86, 0.79,
  0.73 at 0.05 … 0.2 MPa, the law k(Q) = −1.337 Q + 0.9958 normalised by k(0));
* whether the reading rises with Q at every a (prototypes: yes);
* the trim effect ε(65, 0.1)/ε(70, 0.1) and the venting that restores it (prototype: 0.048 MPa);
* the two-prototype converse, the pressure at which 70 mm matches 65 mm held at 0.1 MPa (0.192 MPa; a
  comparison between two specimens);
* Δl(0.2) (not published: "nearly coinciding" with the thesis' FE);
* the contact-ratio dependence of the pressure effect, ε(0.2)/ε(0) at a = 0.55 against a = 1.

Usage::

    OMP_NUM_THREADS=1 python3 -m benchmarks.studies.boundaries [--preset coarse] [--only clamped,axial,...]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.prototype import A_VALUES, Q_VALUES, claims, k_law
from fem.newton import SolveFailed
from whisker_opt.calibration.forward import RestoreSearch
from whisker_opt.config.model import load_config

ROOT = Path(__file__).resolve().parents[2]

#: name -> run-file settings of the mechanism (the defaults of each key are in docs/config.md)
MECHANISMS: dict[str, tuple[str, ...]] = {
    "clamped (as before)": (),
    "axial base": ("scene.base_support=axial",),
    "grip 2 mm": ("scene.base_support=grip", "scene.base_grip_depth=2"),
    "compliant base (h = 2 mm)": ("scene.base_support=compliant",),
    "compliant base (h = 10 mm)": ("scene.base_support=compliant", "scene.base_k_n=0.118", "scene.base_k_t=0.028"),
    "bonded gauge": ("scene.gauge_patch=bonded",),
    "bonded gauge, modulus / 10": ("scene.gauge_patch=bonded", "scene.patch_modulus=210"),
    "grip 2 mm + bonded gauge": ("scene.base_support=grip", "scene.base_grip_depth=2", "scene.gauge_patch=bonded"),
}
PROTOTYPE_K = {0.05: 0.93, 0.1: 0.86, 0.15: 0.79, 0.2: 0.73}


def row(name: str, r: dict) -> dict:
    """The table's row of one mechanism from its :func:`claims`."""
    i1, i55 = A_VALUES.index(1.0), A_VALUES.index(0.55)
    eps = r["eps"]  # (n_a, n_Q)
    k = {q: eps[i1, 0] / eps[i1, Q_VALUES.index(q)] for q in PROTOTYPE_K}
    rising = all(bool(np.all(np.diff(eps[i]) > 0)) for i in range(len(A_VALUES)))
    vent, conv = r["vent"], r["conv"]
    return {
        "mechanism": name,
        "k(0.05 / 0.1 / 0.15 / 0.2)": " / ".join(f"{k[q]:.3f}" for q in PROTOTYPE_K),
        "rises at every a": "yes" if rising else "no",
        "trim effect": f"{r['eps65'][0.1] / eps[i1, Q_VALUES.index(0.1)]:.4f}",
        "vent Q_c [MPa]": f"{vent.value:.4f}" if vent.matched else "no match",
        "converse Q [MPa]": f"{conv.value:.4f}" if conv.matched else "no match",
        "ε(0.2)/ε(0) a=0.55 / a=1": f"{eps[i55, -1] / eps[i55, 0]:.3f} / {eps[i1, -1] / eps[i1, 0]:.3f}",
        "Δl(0.2) [mm]": f"{r['dl'][0.2]:.3f}",
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", type=Path, default=ROOT / "configs" / "calibrate_thesis.yaml")
    ap.add_argument("--preset", default=None, help="fidelity preset (default: the config's)")
    ap.add_argument("--only", default=None, help="comma-separated mechanism names (default: all)")
    ap.add_argument("--q-max", type=float, default=0.25)
    ap.add_argument("--scan", type=int, default=6)
    args = ap.parse_args(argv)
    names = list(MECHANISMS) if args.only is None else [n.strip() for n in args.only.split(",")]
    unknown = [n for n in names if n not in MECHANISMS]
    if unknown:
        print(f"--only: {unknown[0]!r} is not one of {', '.join(MECHANISMS)}", file=sys.stderr)
        return 2
    base = (f"fidelity.preset={args.preset}",) if args.preset else ()
    search = RestoreSearch(Q_max=args.q_max, scan=args.scan, xtol=1e-5)
    rows = [{"mechanism": "prototypes", "k(0.05 / 0.1 / 0.15 / 0.2)": " / ".join(f"{v:.2f}" for v in PROTOTYPE_K.values()),
             "rises at every a": "yes", "trim effect": "-", "vent Q_c [MPa]": "0.048", "converse Q [MPa]": "0.192",
             "ε(0.2)/ε(0) a=0.55 / a=1": f"{k_law(0) / k_law(0.2):.3f} (k law, both)", "Δl(0.2) [mm]": "not published"}]
    for name in names:
        cfg = load_config(args.config, settings=base + MECHANISMS[name])
        t0 = time.perf_counter()
        try:
            r = claims(cfg, search)
        except SolveFailed as exc:  # a scene of the mechanism that does not solve: its reason in the table
            rows.append({"mechanism": name, **{c: "-" for c in list(rows[0])[1:]},
                         "k(0.05 / 0.1 / 0.15 / 0.2)": f"a scene failed: {' '.join(str(exc).split())[:90]}"})
            print(f"# {name}: failed ({exc})", flush=True)
            continue
        rows.append(row(name, r))
        print(f"# {name}: {r['scenes']} scenes, {time.perf_counter() - t0:.0f} s, preset {cfg.fidelity.preset}",
              flush=True)
    cols = list(rows[0])
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for r in rows:
        print("| " + " | ".join(str(r[c]) for c in cols) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
