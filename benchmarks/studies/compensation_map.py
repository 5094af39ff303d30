"""The compensation map Q(Δ, a): warm-started against independent solves of the same cells.

Solves the map of a config twice on the FE scene, each from a fresh runner:

- warm: trim by trim, one SceneRunner whose pressurise step is a WarmPressurise (pressurised
  states shared across contact ratios, Newton started from the nearest solved pressure);
- independent: contact ratio by contact ratio, cold scenes (what one `compensate` table per a costs,
  the runner's memo of identical scenes kept),

and prints both times, their ratio, the largest |ΔQ| between the two maps and the cells whose
decision (root or bound) differs. The warm map is written as `whisker-opt compensate --map` writes it.

    OMP_NUM_THREADS=1 nice -n 5 python3 -m benchmarks.studies.compensation_map configs/compensate_default.yaml \
        --step 0.5 --a 0.45 0.55 0.7 0.85 1 --out /tmp/compensation_map
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

import numpy as np

from whisker_opt.compensation import compensate_map
from whisker_opt.api import load_config


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("config", type=Path)
    p.add_argument("--step", type=float, default=0.5, help="trim step [mm]")
    p.add_argument("--a", type=float, nargs="+", default=[0.45, 0.55, 0.7, 0.85, 1.0], help="contact ratios")
    p.add_argument("--preset", default=None, help="fidelity preset over the config's")
    p.add_argument("--trim", type=float, default=None, help="largest trim [mm] over optimiser.trim")
    p.add_argument("--out", type=Path, default=None, help="write the warm map here")
    p.add_argument("--only", choices=("warm", "independent"), default=None,
                   help="solve one of the two (e.g. both in parallel on a loaded machine), saving the map as "
                        "JSON in --out; --compare then reads both")
    p.add_argument("--compare", type=Path, nargs=2, default=None, metavar=("WARM_DIR", "INDEPENDENT_DIR"),
                   help="compare two maps written with --only (with their timings.json)")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    raw = load_config(args.config).model_dump()
    if args.preset:
        raw["fidelity"] = {"preset": args.preset, "mesh_method": raw["fidelity"]["mesh_method"]}
    if args.trim is not None:
        raw["optimiser"]["trim"] = args.trim
    cfg = load_config(raw)
    runs, cpu = {}, {}
    if args.compare:
        return compare(*args.compare)
    for name, warm in (("warm", True), ("independent", False)):
        if args.only and name != args.only:
            continue
        t0, c0 = time.perf_counter(), time.process_time()
        runs[name] = compensate_map(cfg, args.out if warm else None, step=args.step, a_values=args.a, warm=warm,
                                    progress=False)
        cpu[name] = time.process_time() - c0
        print(f"{name}: {time.perf_counter() - t0:.1f} s wall, {cpu[name]:.1f} s CPU, {runs[name].scenes} scenes solved, "
              f"pressurise calls {runs[name].pressurise_counts or 'all cold'}", flush=True)
        if args.only:
            compensate_map_write(args.out, runs[name], cpu[name])
            return 0
    return report(runs["warm"].map, runs["independent"].map, {k: r.seconds for k, r in runs.items()}, cpu,
                  {k: r.scenes for k, r in runs.items()}, cfg.fidelity.preset)


def compensate_map_write(out: Path, run, cpu: float) -> None:
    """The map (JSON, CSV, PNG) and the run's timings into ``out``."""
    from whisker_opt.output.compensation import write_map
    from whisker_opt.output.storage import write_json

    write_map(out, run.map)
    write_json(out / "timings.json", {"seconds": run.seconds, "cpu_seconds": cpu, "scenes": run.scenes,
                                      "pressurise_counts": run.pressurise_counts})


def compare(warm_dir: Path, cold_dir: Path) -> int:
    """Print the table of two maps written with ``--only``."""
    import json

    from whisker_opt.compensation import CompensationMap

    t = {k: json.loads((d / "timings.json").read_text()) for k, d in (("warm", warm_dir), ("independent", cold_dir))}
    return report(CompensationMap.load(warm_dir), CompensationMap.load(cold_dir),
                  {k: v["seconds"] for k, v in t.items()}, {k: v["cpu_seconds"] for k, v in t.items()},
                  {k: v["scenes"] for k, v in t.items()}, CompensationMap.load(warm_dir).fidelity.get("preset"))


def report(w, c, seconds: dict, cpu: dict, scenes: dict, preset) -> int:
    """Print times, their ratio, the largest |ΔQ| and the warm map's tables."""
    dq = np.abs(w.Q - c.Q)
    same = w.at_bound == c.at_bound
    print(f"\nmap {w.trims.size} trims x {w.a.size} contact ratios, preset {preset}, "
          f"Q_i = {w.Q_i:g} MPa, xatol = {w.xatol:g} MPa")
    print("| | warm | independent |\n|---|---:|---:|")
    print(f"| time [s] | {seconds['warm']:.1f} | {seconds['independent']:.1f} |")
    print(f"| CPU time of the process [s] | {cpu['warm']:.1f} | {cpu['independent']:.1f} |")
    print(f"| scenes solved | {scenes['warm']} | {scenes['independent']} |")
    print(f"| responses asked (sum over cells) | {int(w.n_responses.sum())} | {int(c.n_responses.sum())} |")
    print(f"\ntime ratio independent/warm = {seconds['independent'] / seconds['warm']:.2f} (wall), "
          f"{cpu['independent'] / cpu['warm']:.2f} (CPU)")
    print(f"max |Q_warm - Q_independent| = {dq.max():.3g} MPa (cell Δ = {w.trims[np.argmax(dq) // w.a.size]:g} mm, "
          f"a = {w.a[np.argmax(dq) % w.a.size]:g}); bound decisions equal in {int(same.sum())}/{same.size} cells")
    print(f"max |recovery_warm - recovery_independent| = {np.nanmax(np.abs(w.recovery_rate - c.recovery_rate)):.3g} %")
    print("\nQ(Δ, a) [MPa] (warm; * at a bound)")
    print("trim_mm | " + " | ".join(f"a={x:g}" for x in w.a))
    for i, t in enumerate(w.trims):
        print(f"{t:g} | " + " | ".join(f"{w.Q[i, j]:.4f}{'*' if w.at_bound[i, j] and t > 0 else ''}"
                                      for j in range(w.a.size)))
    print("\nrecovery rate [%] (warm)")
    for i, t in enumerate(w.trims):
        print(f"{t:g} | " + " | ".join(f"{w.recovery_rate[i, j]:.1f}" for j in range(w.a.size)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
