"""What the gauge's bonded backing does to the readings: the default design with and without ``scene.gauge_patch``.

The pair of ``configs/simulate_default.yaml`` (intact at Q_i = 0.2 MPa, trimmed by 5 mm and vented) at the
chosen preset, once with ``gauge_patch: none`` (the bare rubber) and once with ``bonded`` (the defaults of
:mod:`whisker_opt.experiment.patches.bonded`), and the bonded sheet's modulus divided by 10 and 100. Prints the
line reading at δ = 5 mm of both scenes, ε_i(5) and ε_c(5), their ratio, the intact Δl and the contact force at
δ = 5 mm; the results are in benchmarks/results/gauge_patch.md.

Usage::

    python3 -m benchmarks.studies.gauge_patch [--preset coarse]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

from whisker_opt import wiring
from whisker_opt.config.model import load_config
from whisker_opt.experiment.fidelity import PRESET_NAMES
from whisker_opt.experiment.patches import bonded
from whisker_opt.experiment.scene import SceneRunner


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", type=Path, default=Path("configs/simulate_default.yaml"))
    ap.add_argument("--preset", default="coarse", choices=PRESET_NAMES)
    args = ap.parse_args()
    cfg = wiring.with_preset(load_config(args.config), args.preset)
    intact_design = wiring.design_from_config(cfg)
    trimmed_design = wiring.design_from_config(cfg, trim=cfg.scene.trim)
    base = {"intact": wiring.scene_spec(cfg, intact_design, cfg.scene.Q_i),
            "vented": wiring.scene_spec(cfg, trimmed_design, 0.0)}
    delta = base["intact"].deflection
    cases = [("none", {"gauge_patch": "none"}), ("bonded", {"gauge_patch": "bonded"})]
    cases += [(f"bonded, Y/{k}", {"gauge_patch": "bonded", "patch_modulus": bonded.MODULUS_DEFAULT / k}) for k in (10, 100)]
    runner = SceneRunner()
    print(f"preset {args.preset}, Q_i = {cfg.scene.Q_i:g} MPa, trim {cfg.scene.trim:g} mm, δ = {delta:g} mm")
    print(f"{'patch':>14} {'eps_i(5)':>10} {'eps_c(5)':>10} {'eps_c/eps_i':>11} {'dl_i [mm]':>9} "
          f"{'F_i(5) [N]':>10} {'F_c(5) [N]':>10} {'time [s]':>8}")
    for name, kw in cases:
        t = time.perf_counter()
        res = {k: runner.run(replace(s, **kw)) for k, s in base.items()}
        ei, ec = (float(res[k].curve(delta)) for k in ("intact", "vented"))
        fi, fc = (float(res[k].force(delta)) for k in ("intact", "vented"))
        print(f"{name:>14} {ei:>10.5f} {ec:>10.5f} {ec / ei:>11.4f} {res['intact'].delta_l:>9.4f} {fi:>10.4f} "
              f"{fc:>10.4f} {time.perf_counter() - t:>8.1f}", flush=True)


if __name__ == "__main__":
    main()
