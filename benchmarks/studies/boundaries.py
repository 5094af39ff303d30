"""The prototype's boundaries as named mechanisms, each beside every prototype observation at once.

Each mechanism is a set of run-file settings on ``configs/calibrate_thesis.yaml`` (the Table 3.1 prototype's
design, the design defaults): the base (``scene.base_support``: clamped, axial, gripped over a depth, on
elastic supports), the gauge as built (``scene.gauge_patch``: the bare surface or the bonded backing), the cap
(``material.cap_rubber``, ``material.cap_joint``), a softened rubber (``material.C10``: stress-softening or
relaxation over the test's loading history acts on the scene as a lower modulus), and their combinations. For
each, the model values of :func:`benchmarks.prototype.claims` (δ = 1 mm) against the prototypes' (docs/physics.md
§14 and the thesis' Ch. 3 and 5):

* k(Q) as the thesis' procedure reads it from the gauge, ε(0)/ε(Q) at a = 1 (prototypes: 0.93, 0.86, 0.79,
  0.73 at 0.05 … 0.2 MPa, the law k(Q) = −1.337 Q + 0.9958 normalised by k(0));
* whether the reading rises with Q at every a = 0.45 … 1 (prototypes: yes);
* the trim effect T(Q) = ε(65, Q)/ε(70, Q) at Q = 0, 0.048 and 0.1 MPa (the softening law requires 1.081 at
  0.048 MPa for the vent and 1.166 at 0.1 MPa for the converse) and the venting that restores it (prototype:
  0.048 MPa, one specimen);
* the two-prototype converse, the pressure at which 70 mm matches 65 mm held at 0.1 MPa (0.192 MPa; a
  comparison between two specimens);
* the contact-ratio dependence of the pressure effect, ε(0.2)/ε(0) at a = 0.55 against a = 1;
* ξ's dependence on a: the thesis' factor of real reading over its FE's strain rose from 3.8 (a = 1) to 4.0
  (a = 0.5), a ratio 1.053. If the prototype behaves as the mechanism, ξ(0.5)/ξ(1) = [ε_m(0.5)/ε_c(0.5)] /
  [ε_m(1)/ε_c(1)] at Q = 0, ε_c the clamped bare scene (the thesis' FE, which had no gauge, cap joint or
  holder either);
* Δl(0.2) (not published: "nearly coinciding" with the thesis' FE).

Usage::

    OMP_NUM_THREADS=1 python3 -m benchmarks.studies.boundaries [--preset coarse] [--only NAME,...]
        [--csv benchmarks/results/boundaries.csv] [--plot docs/figures/boundaries.png]
    python3 -m benchmarks.studies.boundaries --plot docs/figures/boundaries.png \
        --from-csv benchmarks/results/boundaries.csv
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.prototype import A_VALUES, MECHANISMS, Q_VALUES, XI, claims, k_law, trim_effects_required
from fem.newton import SolveFailed
from whisker_opt.calibration.forward import RestoreSearch
from whisker_opt.config.model import load_config

ROOT = Path(__file__).resolve().parents[2]

PROTOTYPE_K = {0.05: 0.93, 0.1: 0.86, 0.15: 0.79, 0.2: 0.73}
REFERENCE = "clamped (as before)"
#: The CSV's columns: the mechanism, its settings, then the raw model values.
CSV_COLUMNS = (["mechanism", "settings", "status"] + [f"eps_a{a:g}_Q{q:g}" for a in A_VALUES for q in Q_VALUES]
               + ["eps65_Q0", "eps65_Q0.048", "eps65_Q0.1", "eps70_Q0.048", "eps_a0.5_Q0", "vent", "vent_matched",
                  "conv", "conv_matched", "dl_0.2"])


def raw(name: str, settings: tuple[str, ...], r: dict | None, status: str = "ok") -> dict:
    """The CSV row of one mechanism: its settings and raw model values (empty where it failed)."""
    out = {"mechanism": name, "settings": " ".join(settings), "status": status}
    if r is None:
        return out
    for i, a in enumerate(A_VALUES):
        for j, q in enumerate(Q_VALUES):
            out[f"eps_a{a:g}_Q{q:g}"] = repr(float(r["eps"][i, j]))
    out.update({"eps65_Q0": repr(r["eps65"][0.0]), "eps65_Q0.048": repr(r["eps65"][0.048]),
                "eps65_Q0.1": repr(r["eps65"][0.1]), "eps70_Q0.048": repr(r["eps70_vent"]),
                "eps_a0.5_Q0": repr(r["eps_a05"]),
                "vent": repr(float(r["vent"].value)), "vent_matched": str(bool(r["vent"].matched)),
                "conv": repr(float(r["conv"].value)), "conv_matched": str(bool(r["conv"].matched)),
                "dl_0.2": repr(float(r["dl"][0.2]))})
    return out


def arrays(row: dict) -> dict:
    """The model values of a CSV row as numbers: ``eps`` (n_a, n_Q) and the scalars."""
    eps = np.array([[float(row[f"eps_a{a:g}_Q{q:g}"]) for q in Q_VALUES] for a in A_VALUES])  # (n_a, n_Q)
    i1 = A_VALUES.index(1.0)
    trim = {0.0: float(row["eps65_Q0"]) / eps[i1, 0], 0.048: float(row["eps65_Q0.048"]) / float(row["eps70_Q0.048"]),
            0.1: float(row["eps65_Q0.1"]) / eps[i1, Q_VALUES.index(0.1)]}  # T(Q) = ε(65, Q)/ε(70, Q)
    return {"eps": eps, "trim": trim, "eps_a05": float(row["eps_a0.5_Q0"]),
            "vent": float(row["vent"]), "vent_matched": row["vent_matched"] == "True", "conv": float(row["conv"]),
            "conv_matched": row["conv_matched"] == "True", "dl": float(row["dl_0.2"])}


def k_values(v: dict) -> np.ndarray:
    """k(Q) the thesis' procedure infers, ε(0)/ε(Q) at a = 1, at the prototypes' pressures."""
    i1 = A_VALUES.index(1.0)
    return np.array([v["eps"][i1, 0] / v["eps"][i1, Q_VALUES.index(q)] for q in PROTOTYPE_K])


def xi_ratio(v: dict, ref: dict | None) -> float:
    """ξ(0.5)/ξ(1) if the prototype behaved as the mechanism (module docstring); nan without the reference."""
    if ref is None:
        return float("nan")
    i1 = A_VALUES.index(1.0)
    return (v["eps_a05"] / ref["eps_a05"]) / (v["eps"][i1, 0] / ref["eps"][i1, 0])


def row(name: str, v: dict, ref: dict | None) -> dict:
    """The table's row of one mechanism."""
    i1, i55 = A_VALUES.index(1.0), A_VALUES.index(0.55)
    eps = v["eps"]
    rising = all(bool(np.all(np.diff(eps[i]) > 0)) for i in range(len(A_VALUES)))
    xi = xi_ratio(v, ref)
    return {
        "mechanism": name,
        "k(0.05 / 0.1 / 0.15 / 0.2)": " / ".join(f"{k:.3f}" for k in k_values(v)),
        "rises at every a": "yes" if rising else "no",
        "trim effect T(0 / 0.048 / 0.1)": " / ".join(f"{v['trim'][q]:.3f}" for q in (0.0, 0.048, 0.1)),
        "vent Q_c [MPa]": f"{v['vent']:.4f}" if v["vent_matched"] else "no match",
        "converse Q [MPa]": f"{v['conv']:.4f}" if v["conv_matched"] else "no match",
        "ε(0.2)/ε(0) a=0.55 / a=1": f"{eps[i55, -1] / eps[i55, 0]:.3f} / {eps[i1, -1] / eps[i1, 0]:.3f}",
        "ξ(0.5)/ξ(1)": "-" if not np.isfinite(xi) else f"{xi:.3f}",
        "Δl(0.2) [mm]": f"{v['dl']:.3f}",
    }


def prototype_row() -> dict:
    k = " / ".join(f"{v:.2f}" for v in PROTOTYPE_K.values())
    return {"mechanism": "prototypes", "k(0.05 / 0.1 / 0.15 / 0.2)": k,
            "rises at every a": "yes",
            "trim effect T(0 / 0.048 / 0.1)": "- / {:.3f} (vent) / {:.3f} (converse), by the k law".format(
                *trim_effects_required().values()), "vent Q_c [MPa]": "0.048 ± 0.021",
            "converse Q [MPa]": "0.192 ± 0.032 (2 specimens)",
            "ε(0.2)/ε(0) a=0.55 / a=1": f"{k_law(0) / k_law(0.2):.3f} (k law, both)",
            "ξ(0.5)/ξ(1)": f"{XI[0.5] / XI[1.0]:.3f}", "Δl(0.2) [mm]": "not published"}


def table(rows: list[dict]) -> str:
    """The markdown table of the prototype's row and every mechanism's (failed ones with their reason)."""
    values = {r["mechanism"]: arrays(r) for r in rows if r["status"] == "ok"}
    ref = values.get(REFERENCE)
    out = [prototype_row()]
    for r in rows:
        if r["status"] == "ok":
            out.append(row(r["mechanism"], values[r["mechanism"]], ref))
        else:
            out.append({"mechanism": r["mechanism"], **{c: "-" for c in list(out[0])[1:]},
                        "k(0.05 / 0.1 / 0.15 / 0.2)": r["status"]})
    cols = list(out[0])
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(str(r[c]) for c in cols) + " |" for r in out]
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    """Two panels: the k(Q) each mechanism implies against the prototypes', and the pressure effect
    ε(0.2)/ε(0) against a beside the prototypes' law (the same at every a)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "ok"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 7.2))
    qs = [0.0] + list(PROTOTYPE_K)
    cmap = plt.get_cmap("tab20")
    for n, r in enumerate(ok):
        v = arrays(r)
        style = dict(color=cmap(n % 20), lw=2.2 if r["mechanism"] == REFERENCE else 1.3,
                     ls="-" if "+" not in r["mechanism"] else "--", marker="o", ms=3)
        ax1.plot(qs, [1.0] + list(k_values(v)), label=r["mechanism"], **style)
        ax2.plot(A_VALUES, v["eps"][:, -1] / v["eps"][:, 0], **style)
    ax1.plot(qs, [1.0] + list(PROTOTYPE_K.values()), "ks", ms=8, mfc="none", mew=2, label="prototypes")
    ax2.axhline(k_law(0) / k_law(0.2), color="k", lw=2, ls=":", label="prototypes (k law at every a)")
    ax1.set(xlabel="Q [MPa]", ylabel="k(Q) = ε(0)/ε(Q) at a = 1", title="softening the gauge implies")
    ax2.set(xlabel="contact ratio a", ylabel="ε(0.2 MPa)/ε(0) at δ = 1 mm",
            title="pressure effect along the whisker")
    ax2.axhline(1.0, color="grey", lw=0.8)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    handles, labels = ax1.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    fig.legend(handles + h2, labels + l2, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle("Base, gauge, cap and rubber mechanisms beside the Table 3.1 prototype (coarse preset)")
    fig.tight_layout(rect=(0, 0.2, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", type=Path, default=ROOT / "configs" / "calibrate_thesis.yaml")
    ap.add_argument("--preset", default=None, help="fidelity preset (default: the config's)")
    ap.add_argument("--only", default=None, help="comma-separated mechanism names (default: all)")
    ap.add_argument("--set", dest="extra", action="append", default=[],
                    help="NAME=KEY=VALUE;KEY=VALUE: one more mechanism of these settings (e.g. a calibrated one)")
    ap.add_argument("--q-max", type=float, default=0.25)
    ap.add_argument("--scan", type=int, default=6)
    ap.add_argument("--csv", type=Path, default=None, help="write the raw model values here")
    ap.add_argument("--from-csv", type=Path, default=None, help="read the raw values instead of solving")
    ap.add_argument("--plot", type=Path, default=None, help="write the figure here")
    args = ap.parse_args(argv)
    mechanisms = dict(MECHANISMS)
    for spec in args.extra:
        name, _, settings = spec.partition("=")
        if not name or not settings:
            print(f"--set: {spec!r} is not NAME=KEY=VALUE;KEY=VALUE", file=sys.stderr)
            return 2
        mechanisms[name] = tuple(s for s in settings.split(";") if s)
    if args.from_csv is not None:
        with open(args.from_csv, newline="") as fh:
            rows = list(csv.DictReader(fh))
    else:
        names = list(mechanisms) if args.only is None else [n.strip() for n in args.only.split(",")]
        unknown = [n for n in names if n not in mechanisms]
        if unknown:
            print(f"--only: {unknown[0]!r} is not one of {', '.join(mechanisms)}", file=sys.stderr)
            return 2
        base = (f"fidelity.preset={args.preset}",) if args.preset else ()
        search = RestoreSearch(Q_max=args.q_max, scan=args.scan, xtol=1e-5)
        rows = []
        for name in names:
            cfg = load_config(args.config, settings=base + mechanisms[name])
            t0 = time.perf_counter()
            try:
                r = claims(cfg, search)
            except SolveFailed as exc:  # a scene of the mechanism that does not solve: its reason in the table
                rows.append(raw(name, mechanisms[name], None, f"a scene failed: {' '.join(str(exc).split())[:90]}"))
                print(f"# {name}: failed ({exc})", flush=True)
                continue
            rows.append(raw(name, mechanisms[name], r))
            print(f"# {name}: {r['scenes']} scenes, {time.perf_counter() - t0:.0f} s, preset {cfg.fidelity.preset}",
                  flush=True)
        if args.csv is not None:
            args.csv.parent.mkdir(parents=True, exist_ok=True)
            with open(args.csv, "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
                w.writeheader()
                w.writerows(rows)
    print(table(rows))
    print("\n# the trim effect the softening law needs for each restore observation: "
          + ", ".join(f"{k} = {v:.4f}" for k, v in trim_effects_required().items()))
    if args.plot is not None:
        plot(rows, args.plot)
        print(f"# figure: {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
