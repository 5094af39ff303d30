"""Numerical stability stress test of the whisker scene.

Cases (one scene each: mesh, pressurise, deflect, gauge readout)
-----------------------------------------------------------------
* **box** — every corner (16) and edge midpoint (32) of the GA box [α, l, t, Q_i], each at Δ = 0 and Δ = 10 mm, under two load sets:

  - ``thesis``: Q = Q_i, δ to 5 mm, contact at the tip (a = 1), D1 = 0 (incompressible,
    the configured material) — the GA's own scene and the thesis' load range;
  - ``stress``: Q = min(1.5 Q_i, 0.3) MPa, δ to 8 mm, D1 = 2/(1000 μ) = 7.14e-3 1/MPa
    (K/μ = 1000) — beyond the GA's range —, a = 1 at even box points, 0.5 at odd ones
    (at a < 1 the scene meshes again with its node ring at the pressurised contact,
    :func:`whisker_opt.experiment.scene.run_scene`).

  48 × 2 × 2 = 192 cases.
* **random** — ``--n-random`` (default 110) designs drawn with a fixed seed: three in four
  inside the GA box, one in four in the box widened by 15 % of each range on both
  sides (so some are invalid or fragile: failures must be *classified*); Δ ∈ {0, 10},
  Q = 0 (vented) with probability 1/4 else U(0.01, 0.3) MPa, δ_max ~ U(1, 8) mm,
  a ∈ {0.5, 0.75, 1}, D1 ∈ {0, 7.14e-3} with equal probability.

A case is *in range* when its genes lie in the GA box, Q ≤ 0.2 MPa, δ_max ≤ 5 mm and
D1 = 0; *GA scene* when in range and a = 1. The target: every in-range
case converges at the default preset; no NaN anywhere (every converged case's
readings are checked finite; a non-finite one is recorded as status ``nan``); every
failure carries a classified reason (statuses as :mod:`whisker_opt.optimise.evaluator`:
``invalid_geometry``, ``mesh_failed``, ``solve_failed``, ``timeout``, ``error``).

Perturbation check
------------------
For a few in-box designs (the default design, then seeded random ones) at Q_i, a = 1,
δ = 5 mm: each gene g ∈ {α, l, t, Q_i} is changed by ±1e-6 relative and the gauge
reading ε(5 mm) recomputed (mesh and all). Reported: the relative change
(ε₊ − ε₀)/ε₀ (≈ 1e-6 × the gene's elasticity) and the non-smoothness
|ε₊ − 2ε₀ + ε₋| / |ε₀| — forward minus backward difference, zero for a smooth
response up to O(1e-12) — against the 1e-4 limit.

Outputs (``--out``, default ``results/benchmarks/stress/``): ``cases.csv`` (one row
per case, appended as each finishes, so an interrupted run loses nothing; a rerun with
the same options skips the cases already in the file unless ``--fresh``),
``perturbation.csv`` and ``summary.md``. Counts by outcome are printed.

Usage::

    python3 -m benchmarks.reliability.stress_test --quick              # ~10 cases, coarse preset, minutes
    python3 -m benchmarks.reliability.stress_test --workers 2          # full: 302 cases, default preset
    python3 -m benchmarks.reliability.stress_test --preset coarse --n-random 20 --out /tmp/stress
"""

from __future__ import annotations

import argparse
import itertools
import logging
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from benchmarks.common import (
    D1_K1000,
    GENE_BOX,
    append_csv,
    classify_exception,
    design_from_genes,
    fmt,
    markdown_table,
    preset_spec,
    read_csv,
    report_stats,
)

logger = logging.getLogger("stress_test")

PERTURBATION = 1e-6
SMOOTHNESS_LIMIT = 1e-4


@dataclass(frozen=True)
class Case:
    """One stress-test scene.

    Attributes
    ----------
    case_id : str
        Stable identifier (resume key).
    group : str
        'box/thesis', 'box/stress' or 'random'.
    alpha, l, t, Q_i : float
        Genes [deg, mm, mm, MPa].
    trim : float
        Δ [mm].
    Q : float
        Pressure of the scene [MPa].
    delta_max : float
        Final deflection [mm].
    contact_ratio : float
        a [-].
    d1 : float
        Neo-Hookean D1 [1/MPa].
    """

    case_id: str
    group: str
    alpha: float
    l: float  # noqa: E741
    t: float
    Q_i: float
    trim: float
    Q: float
    delta_max: float
    contact_ratio: float
    d1: float

    @property
    def in_box(self) -> bool:
        genes = {"alpha": self.alpha, "l": self.l, "t": self.t, "Q_i": self.Q_i}
        return all(lo - 1e-12 <= genes[g] <= hi + 1e-12 for g, (lo, hi) in GENE_BOX.items())

    @property
    def in_range(self) -> bool:
        """Inside the GA box and the thesis' load ranges (Q ≤ 0.2, δ ≤ 5 mm, D1 = 0)."""
        return self.in_box and self.Q <= 0.2 + 1e-12 and self.delta_max <= 5.0 + 1e-12 and self.d1 == 0.0

    @property
    def ga_scene(self) -> bool:
        """In range with the contact at the tip, as the GA's evaluations are."""
        return self.in_range and self.contact_ratio == 1.0


def box_points() -> list[dict]:
    """Corners (16) and edge midpoints (32) of the 4-D gene box."""
    names = list(GENE_BOX)
    pts = []
    for levels in itertools.product((0.0, 0.5, 1.0), repeat=len(names)):
        if sum(v == 0.5 for v in levels) <= 1:  # corner (0 mids) or edge midpoint (1 mid)
            pts.append({g: GENE_BOX[g][0] + v * (GENE_BOX[g][1] - GENE_BOX[g][0]) for g, v in zip(names, levels)})
    return pts


def make_cases(n_random: int, seed: int = 7) -> list[Case]:
    """The full case list (deterministic for a given ``n_random`` and ``seed``)."""
    cases = []
    for i, p in enumerate(box_points()):
        for trim in (0.0, 10.0):
            cases.append(Case(f"box{i:02d}-T{trim:g}-thesis", "box/thesis", p["alpha"], p["l"], p["t"], p["Q_i"],
                              trim, p["Q_i"], 5.0, 1.0, 0.0))
            cases.append(Case(f"box{i:02d}-T{trim:g}-stress", "box/stress", p["alpha"], p["l"], p["t"], p["Q_i"],
                              trim, min(1.5 * p["Q_i"], 0.3), 8.0, (1.0, 0.5)[i % 2], D1_K1000))
    rng = np.random.default_rng(seed)
    for i in range(n_random):
        widen = 0.15 if rng.random() < 0.25 else 0.0
        g = {}
        for name, (lo, hi) in GENE_BOX.items():
            w = widen * (hi - lo)
            g[name] = float(rng.uniform(lo - w, hi + w))
        g["Q_i"] = max(g["Q_i"], 0.0)
        trim = float(rng.choice([0.0, 10.0]))
        Q = 0.0 if rng.random() < 0.25 else float(rng.uniform(0.01, 0.3))
        cases.append(Case(f"rnd{i:03d}", "random", round(g["alpha"], 6), round(g["l"], 6), round(g["t"], 6),
                          round(g["Q_i"], 6), trim, round(Q, 6), round(float(rng.uniform(1.0, 8.0)), 4),
                          float(rng.choice([0.5, 0.75, 1.0])), float(rng.choice([0.0, D1_K1000]))))
    return cases


def quick_cases() -> list[Case]:
    """A handful: two box corners under both load sets and trims, and two random cases."""
    full = make_cases(n_random=4)
    box = [c for c in full if c.case_id.startswith(("box00-", "box47-"))]
    return box[:2] + box[-4:] + [c for c in full if c.group == "random"][:2]


ROW_FIELDS = ["case_id", "group", "alpha", "l", "t", "Q_i", "trim", "Q", "delta_max", "contact_ratio", "d1",
              "in_box", "in_range", "ga_scene", "preset", "status", "converged", "n_elements", "increments",
              "cutbacks", "iterations", "min_j", "time_s", "delta_l", "eps_max", "reason"]


def _scene(case: Case, preset: str, solve_options=None):
    """(spec, mesh) of a case; raises what meshing raises."""
    from geometry.mesh import build_mesh

    design = design_from_genes(case.alpha, case.l, case.t, case.trim)
    kw = {"solve_options": solve_options} if solve_options is not None else {}
    spec = preset_spec(design, preset, Q=case.Q, deflection=case.delta_max, contact_ratio=case.contact_ratio,
                       d1=case.d1, **kw)
    design.validate()
    return spec, build_mesh(design, spec.sizing, method=spec.mesh_method, num_threads=1)


def run_case(case: Case, preset: str = "default", timeout_s: float | None = 600.0, solve_options=None) -> dict:
    """Run one case and return its CSV row; never raises for a failure of the scene.

    Parameters
    ----------
    case : Case
    preset : str
        Fidelity preset ('coarse' | 'default' | 'fine').
    timeout_s : float or None
        Wall-clock limit (SIGALRM; main thread of the process only).
    solve_options : fem.newton.SolveOptions, optional
        Replaces the preset's (e.g. to provoke a failure in a test).

    Returns
    -------
    dict
        The fields of :data:`ROW_FIELDS`.
    """
    from fem.newton import SolveFailed
    from whisker_opt.optimise.executors import _call_with_alarm, _EvalTimeout
    from whisker_opt.experiment.scene import run_scene

    row = {**asdict(case), "in_box": case.in_box, "in_range": case.in_range, "ga_scene": case.ga_scene,
           "preset": preset, "converged": False, "n_elements": 0, "increments": 0, "cutbacks": 0,
           "iterations": 0, "min_j": float("nan"), "delta_l": float("nan"), "eps_max": float("nan"), "reason": ""}
    t0 = time.perf_counter()
    n_el = [0]

    def _go():
        spec, wm = _scene(case, preset, solve_options)
        n_el[0] = wm.mesh.n_elements
        return run_scene(spec, wm)

    try:
        res = _call_with_alarm(_go, timeout_s) if timeout_s else _go()
    except _EvalTimeout:
        row.update(status="timeout", reason=f"scene exceeded {timeout_s:g} s")
    except Exception as exc:  # noqa: BLE001 - every failure is recorded with its class
        row.update(status=classify_exception(exc), reason=f"{type(exc).__name__}: {exc}".replace("\n", " ")[:300])
        if isinstance(exc, SolveFailed):
            row.update(report_stats(exc.reports))
    else:
        row.update(report_stats(res.reports), delta_l=res.delta_l, eps_max=float(res.eps["line"][-1]))
        readings = np.concatenate([*res.eps.values(), [res.delta_l, res.length_q, res.radial_growth]])
        if np.all(np.isfinite(readings)):
            row.update(status="ok", converged=True)
        else:
            row.update(status="nan", reason="converged solve returned non-finite readings")
    row["n_elements"] = n_el[0]
    row["time_s"] = time.perf_counter() - t0
    return row


def _run_case_star(args):
    return run_case(*args)


def run_all(cases: list[Case], preset: str, out: Path, workers: int, timeout_s: float, fresh: bool) -> list[dict]:
    """Run the cases not yet in ``out/cases.csv`` (appending each row), return all rows."""
    path = out / "cases.csv"
    if fresh and path.exists():
        path.unlink()
    done = {r["case_id"]: r for r in read_csv(path) if r.get("preset") == preset}
    todo = [c for c in cases if c.case_id not in done]
    if done:
        print(f"resuming: {len(cases) - len(todo)} of {len(cases)} cases already in {path}")
    t0 = time.perf_counter()

    def _log(i, row):
        append_csv(path, row, ROW_FIELDS)
        print(f"[{i:>3}/{len(todo)}] {row['case_id']:<22} {row['status']:<16} {row['time_s']:7.1f} s  "
              f"inc {row['increments']:>3} cut {row['cutbacks']:>2} it {row['iterations']:>4}  "
              f"eps {fmt(row['eps_max']):>10}  ({time.perf_counter() - t0:6.0f} s)", flush=True)

    if workers <= 1:
        for i, c in enumerate(todo, 1):
            _log(i, run_case(c, preset, timeout_s))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futs = [pool.submit(_run_case_star, (c, preset, timeout_s)) for c in todo]
            for i, f in enumerate(as_completed(futs), 1):
                _log(i, f.result())
    rows = {r["case_id"]: r for r in read_csv(path) if r.get("preset") == preset}
    return [rows[c.case_id] for c in cases if c.case_id in rows]


# ----------------------------------------------------------------------------- perturbation
def perturbation_check(designs: list[dict], preset: str, h: float = PERTURBATION) -> list[dict]:
    """Gauge reading ε(5 mm) of each design with each gene at (1 − h), 1, (1 + h) times its value.

    Returns one row per (design, gene) with eps0, rel_change = (ε₊ − ε₀)/ε₀ and
    nonsmooth = |ε₊ − 2ε₀ + ε₋|/|ε₀|.
    """
    from whisker_opt.experiment.scene import run_scene

    def eps(g: dict) -> float:
        case = Case("perturb", "perturb", g["alpha"], g["l"], g["t"], g["Q_i"], 0.0, g["Q_i"], 5.0, 1.0, 0.0)
        spec, wm = _scene(case, preset)
        return float(run_scene(spec, wm).eps["line"][-1])

    rows = []
    for k, g0 in enumerate(designs):
        e0 = eps(g0)
        for gene in ("alpha", "l", "t", "Q_i"):
            ep = eps({**g0, gene: g0[gene] * (1 + h)})
            em = eps({**g0, gene: g0[gene] * (1 - h)})
            rows.append({"design": k, **{n: g0[n] for n in ("alpha", "l", "t", "Q_i")}, "gene": gene,
                         "eps0": e0, "rel_change": (ep - e0) / e0, "rel_change_bwd": (e0 - em) / e0,
                         "nonsmooth": abs(ep - 2 * e0 + em) / abs(e0)})
            logger.info("perturbation %d %s: %s", k, gene, rows[-1])
    return rows


def perturbation_designs(n: int, seed: int = 11) -> list[dict]:
    """The default design at Q_i = 0.2 MPa, then ``n − 1`` seeded random in-box designs."""
    out = [{"alpha": 2.862, "l": 15.0, "t": 3.0, "Q_i": 0.2}]
    rng = np.random.default_rng(seed)
    for _ in range(n - 1):
        out.append({g: float(rng.uniform(lo, hi)) for g, (lo, hi) in GENE_BOX.items()})
    return out


# ----------------------------------------------------------------------------- summary
def summarise(rows: list[dict], pert: list[dict], preset: str, n_cases: int) -> tuple[str, bool]:
    """Markdown summary and whether the targets hold."""
    def truthy(v):
        return str(v) == "True"

    statuses = sorted({r["status"] for r in rows})
    groups = ["box/thesis", "box/stress", "random"]
    counts = [{"group": g, **{s: sum(1 for r in rows if r["group"] == g and r["status"] == s) for s in statuses}}
              for g in groups]
    counts.append({"group": "all", **{s: sum(1 for r in rows if r["status"] == s) for s in statuses}})
    in_range = [r for r in rows if truthy(r["in_range"])]
    ga = [r for r in rows if truthy(r["ga_scene"])]
    ok_range = all(r["status"] == "ok" for r in in_range)
    ok_ga = all(r["status"] == "ok" for r in ga)
    nan_rows = [r for r in rows if r["status"] == "nan"
                or (r["status"] == "ok" and not all(math.isfinite(float(r[k])) for k in ("eps_max", "delta_l", "min_j")))]
    unclassified = [r for r in rows if r["status"] != "ok" and not r["reason"]]
    times = np.array([float(r["time_s"]) for r in rows])
    lines = [f"# Stress test ({preset} preset, {len(rows)} of {n_cases} cases)", "",
             "## Counts by outcome", "", markdown_table(counts, ["group"] + statuses), "",
             f"- cases in the GA box within the thesis' load ranges (Q ≤ 0.2, δ ≤ 5 mm, D1 = 0, a ∈ [0.5, 1]): "
             f"{sum(r['status'] == 'ok' for r in in_range)}/{len(in_range)} converged "
             f"({'all' if ok_range else 'NOT all'})",
             f"- of which the GA's scene (a = 1): {sum(r['status'] == 'ok' for r in ga)}/{len(ga)} converged",
             f"- non-finite readings: {len(nan_rows)}; failures without a reason: {len(unclassified)}",
             f"- time per case: median {np.median(times):.1f} s, max {times.max():.1f} s, total {times.sum():.0f} s",
             f"- max cut-backs {max(int(r['cutbacks']) for r in rows)}, "
             f"min J over converged cases {min((float(r['min_j']) for r in rows if r['status'] == 'ok'), default=float('nan')):.3g}",
             ""]
    fails = [r for r in rows if r["status"] != "ok"]
    if fails:
        lines += ["## Failures", "", markdown_table(fails, ["case_id", "alpha", "l", "t", "trim", "Q", "delta_max",
                                                             "contact_ratio", "d1", "in_range", "status", "reason"]), ""]
    ok_pert = True
    if pert:
        worst = max(r["nonsmooth"] for r in pert)
        ok_pert = worst <= SMOOTHNESS_LIMIT
        lines += [f"## Perturbation check (relative change {PERTURBATION:g} of each gene)", "",
                  markdown_table(pert, ["design", "alpha", "l", "t", "Q_i", "gene", "eps0", "rel_change",
                                        "rel_change_bwd", "nonsmooth"]), "",
                  f"max |ε₊ − 2ε₀ + ε₋|/|ε₀| = {worst:.2e} against the limit {SMOOTHNESS_LIMIT:g}: "
                  f"{'smooth' if ok_pert else 'NOT smooth'}", ""]
    return "\n".join(lines), ok_range and not nan_rows and not unclassified and ok_pert


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="8 cases and 1 perturbed design at the coarse preset")
    ap.add_argument("--preset", default=None, choices=["coarse", "default", "fine"],
                    help="fidelity preset (default: 'default', or 'coarse' with --quick)")
    ap.add_argument("--n-random", type=int, default=110, help="random designs (default 110: 302 cases in all)")
    ap.add_argument("--n-perturb", type=int, default=None, help="designs of the perturbation check (default 3; 1 quick)")
    ap.add_argument("--seed", type=int, default=7, help="seed of the random designs")
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/stress"))
    ap.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per case before status 'timeout'")
    ap.add_argument("--fresh", action="store_true", help="discard the rows of an earlier run in --out")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    preset = args.preset or ("coarse" if args.quick else "default")
    cases = quick_cases() if args.quick else make_cases(args.n_random, args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"{len(cases)} cases at the {preset} preset -> {args.out}/cases.csv ({args.workers} worker(s))")
    rows = run_all(cases, preset, args.out, args.workers, args.timeout, args.fresh)

    n_pert = args.n_perturb if args.n_perturb is not None else (1 if args.quick else 3)
    pert = []
    if n_pert > 0:
        t = time.perf_counter()
        pert = perturbation_check(perturbation_designs(n_pert), preset)
        ppath = args.out / "perturbation.csv"
        ppath.unlink(missing_ok=True)
        for r in pert:
            append_csv(ppath, r, list(pert[0]))
        print(f"perturbation check: {len(pert)} gene perturbations in {time.perf_counter() - t:.0f} s")
    text, ok = summarise(rows, pert, preset, len(cases))
    (args.out / "summary.md").write_text(text + "\n")
    print(text)
    print(f"targets {'MET' if ok else 'NOT met'}; written {args.out}/summary.md")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
