"""Mesh acceptance: fresh fTetWild meshes of the box corners, and the fast path.

Part 1 — fresh meshes (``build_mesh(method="fresh")``, the default preset's sizing, which
the fTetWild path raises to at least 3 wall layers, :func:`geometry.mesh.fresh_sizing`) of
the default design and the eight corners of the (α, l, t) box of the GA, each at the full
length L = 70 mm and trimmed to L = 60 mm (18 meshes). Per mesh: elements, time, volume
error against the closed form (target |e| ≤ 0.5 %), cavity area error (≤ 1 %), smallest
radius ratio and TET10 Jacobian ratio (no inverted element: > 0; no degenerate one:
radius ratio > 0.01), and elements crossed by radial lines through the chamber wall
(minimum over 40 lines; target ≥ 3).

Part 2 — the fast path (``method="template"``, default preset) on ``--n-random`` designs
drawn uniformly in the GA box with Δ ∈ {0} ∪ U(5, 10) (seed 2024): largest volume and
cavity-area errors, smallest qualities, and the median time per design against the
median fresh time of part 1 (target ≥ 100× faster).

Usage::

    python3 -m benchmarks.performance.bench_mesh            # 18 fresh meshes + 100 mapped, ~15 min
    python3 -m benchmarks.performance.bench_mesh --quick    # default design and 2 corners at L = 70, 20 mapped

Outputs (``--out``, default ``results/benchmarks/mesh/``): ``fresh.csv``, ``fast_path.csv``
and ``mesh.md`` (the printed tables). fTetWild runs on one thread (``--threads``) so the
times compare with a GA worker's.
"""

from __future__ import annotations

import argparse
import itertools
import logging
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.common import GENE_BOX, append_csv, design_from_genes, markdown_table

from fem.mesh import jacobian_determinants
from fem.quadrature import tet_rule
from geometry.design import WhiskerDesign
from geometry.mesh import MeshSizing, build_mesh
from whisker_opt.experiment.fidelity import PRESETS

#: Acceptance limits of the meshes.
MAX_VOLUME_ERROR = 5e-3
MAX_AREA_ERROR = 1e-2
MIN_RADIUS_RATIO = 0.01
MIN_WALL_CROSSINGS = 3
MIN_SPEEDUP = 100.0

FIELDS = ["design", "alpha", "l", "t", "L", "method", "n_elements", "time_s", "volume_error", "cavity_area_error",
          "quality_min", "jacobian_ratio_min", "min_detJ", "through_wall_min", "through_wall_median", "ok"]


def designs(quick: bool) -> list[tuple[str, WhiskerDesign]]:
    """(name, design): the default design, then the (α, l, t) box corners, at Δ = 0 and 10 mm."""
    out = []
    box = [GENE_BOX[g] for g in ("alpha", "l", "t")]
    corners = list(itertools.product(*box))
    if quick:
        corners = [corners[0], corners[-1]]
    trims = (0.0,) if quick else (0.0, 10.0)
    for trim in trims:
        out.append((f"default/L{70 - trim:g}", WhiskerDesign(trim=trim)))
        for a, l_, t in corners:
            out.append((f"a{a:g}-l{l_:g}-t{t:g}/L{70 - trim:g}", design_from_genes(a, l_, t, trim)))
    return out


def measure(name: str, d: WhiskerDesign, method: str, sizing: MeshSizing, threads: int) -> dict:
    t = time.perf_counter()
    wm = build_mesh(d, sizing, method=method, num_threads=threads)
    dt = time.perf_counter() - t
    r = wm.report
    detj = float(jacobian_determinants(wm.mesh.points, wm.mesh.cells, tet_rule(3).points).min())
    ok = (abs(r.volume_error) <= MAX_VOLUME_ERROR and abs(r.cavity_area_error) <= MAX_AREA_ERROR
          and r.quality_min > MIN_RADIUS_RATIO and r.jacobian_ratio_min > 0 and detj > 0)
    if method == "fresh":
        ok = ok and r.elements_through_wall >= MIN_WALL_CROSSINGS
    return {"design": name, "alpha": d.alpha, "l": d.l, "t": d.t, "L": d.length, "method": method,
            "n_elements": r.n_elements, "time_s": dt, "volume_error": r.volume_error,
            "cavity_area_error": r.cavity_area_error, "quality_min": r.quality_min,
            "jacobian_ratio_min": r.jacobian_ratio_min, "min_detJ": detj,
            "through_wall_min": r.elements_through_wall, "through_wall_median": r.elements_through_wall_median,
            "ok": ok}


def random_designs(n: int, seed: int = 2024) -> list[WhiskerDesign]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        a, l_, t = (rng.uniform(*GENE_BOX[g]) for g in ("alpha", "l", "t"))
        trim = float(rng.choice([0.0, rng.uniform(5.0, 10.0)]))
        out.append(design_from_genes(a, l_, t, trim))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="default design and two corners at L = 70; 20 mapped designs")
    ap.add_argument("--n-random", type=int, default=None, help="fast-path designs (default 100, quick 20)")
    ap.add_argument("--threads", type=int, default=1, help="fTetWild threads")
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/mesh"))
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    args.out.mkdir(parents=True, exist_ok=True)
    sizing = PRESETS["default"].sizing
    n_random = args.n_random if args.n_random is not None else (20 if args.quick else 100)

    for f in ("fresh.csv", "fast_path.csv"):
        (args.out / f).unlink(missing_ok=True)
    fresh = []
    for name, d in designs(args.quick):
        row = measure(name, d, "fresh", sizing, args.threads)
        fresh.append(row)
        append_csv(args.out / "fresh.csv", row, FIELDS)
        print(f"fresh {name:<22} {row['n_elements']:>6} el {row['time_s']:7.1f} s  vol {row['volume_error']:+.2e}  "
              f"area {row['cavity_area_error']:+.2e}  q_min {row['quality_min']:.3f}  "
              f"wall {row['through_wall_min']}  {'ok' if row['ok'] else 'FAIL'}", flush=True)

    fast = []
    for i, d in enumerate(random_designs(n_random)):
        fast.append(measure(f"rnd{i:03d}", d, "template", sizing, args.threads))
        append_csv(args.out / "fast_path.csv", fast[-1], FIELDS)

    t_fresh = statistics.median(r["time_s"] for r in fresh)
    t_fast = statistics.median(r["time_s"] for r in fast)
    speedup = t_fresh / t_fast
    cols = ["design", "L", "n_elements", "time_s", "volume_error", "cavity_area_error", "quality_min",
            "jacobian_ratio_min", "through_wall_min", "through_wall_median", "ok"]
    lines = ["## Fresh fTetWild meshes (default preset sizing, ≥ 3 wall layers)", "",
             markdown_table(fresh, cols), "",
             f"## Fast path (mapped template, default preset): {len(fast)} random designs in the GA box", "",
             f"- largest |volume error| {max(abs(r['volume_error']) for r in fast):.2e}, "
             f"|cavity area error| {max(abs(r['cavity_area_error']) for r in fast):.2e}",
             f"- smallest radius ratio {min(r['quality_min'] for r in fast):.3f}, "
             f"Jacobian ratio {min(r['jacobian_ratio_min'] for r in fast):.3f}, "
             f"det J {min(r['min_detJ'] for r in fast):.3g}; all valid: {all(r['ok'] for r in fast)}",
             f"- median time per design {t_fast:.3f} s against {t_fresh:.1f} s fresh: {speedup:.0f}x faster", ""]
    met = all(r["ok"] for r in fresh) and all(r["ok"] for r in fast) and speedup >= MIN_SPEEDUP
    lines.append(f"Targets (volume ≤ 0.5 %, cavity area ≤ 1 %, no inverted or degenerate element, ≥ 3 elements "
                 f"through the wall on fresh meshes, fast path ≥ 100x): {'MET' if met else 'NOT MET'}")
    text = "\n".join(lines)
    (args.out / "mesh.md").write_text(text + "\n")
    print()
    print(text)
    return 0 if met else 1


if __name__ == "__main__":
    raise SystemExit(main())
