"""What agreement to expect between an exported deck run in CalculiX and the in-house solve of the same scene.

The scene of a config (default: the coarse preset's default design, intact at Q = 0.2 MPa and vented, the tip
pushed 5 mm) is meshed once; on that mesh

``in-house mixed``
    the in-house solve as the GA runs it: P2/P0 mixed u–p, incompressible rubber (D1 = 0), the reference;
``in-house mixed, K/mu``
    the in-house mixed solve with the deck's compressible D1: what the compressibility alone changes;
``in-house C3D10``
    the in-house displacement formulation with the deck's compressible D1, i.e. the deck's discretisation
    solved by this code (it isolates the two codes' difference from the element's);
``ccx C3D10``
    the deck of ``whisker-opt export --flavour calculix`` (:func:`whisker_opt.output.scene_deck.write_scene_deck`)
    run in CalculiX, read back with :func:`peers.calculix.read_scene_deck`.

For each K/μ of ``--bulk-ratios`` the table gives the tip extension Δl (end of the pressurise phase), the
contact force F and the gauge's line reading at the largest deflection, each with its difference from the
reference. Usage::

    OMP_NUM_THREADS=1 python3 -m benchmarks.accuracy.calculix_agreement [--config FILE] [--preset coarse]
        [--Q 0.2] [--bulk-ratios 1000,100,50,20,10] [--cases intact,vented] [--workdir DIR]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from benchmarks.common import markdown_table


def _cases(config: str | None, preset: str | None, Q: float, names: list[str]) -> dict:
    """``{case: SceneSpec}``: the config's design intact at ``Q`` and vented (Q = 0), those of ``names``."""
    import whisker_opt.wiring as wiring
    from whisker_opt.config.model import WhiskerConfig, load_config

    cfg = load_config(config) if config else WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"}})
    if preset:
        cfg = cfg.model_copy(update={"fidelity": cfg.fidelity.model_copy(update={"preset": preset})})
    design = wiring.design_from_config(cfg, 0.0)
    cases = {"intact": (f"intact, Q = {Q:g} MPa", Q), "vented": ("vented", 0.0)}
    return {cases[n][0]: wiring.scene_spec(cfg, design, cases[n][1]) for n in names}


def _numbers(res) -> tuple[float, float, float]:
    """(Δl, F, line reading) at the largest deflection of a ``SceneResult`` or a ``SceneDeckResult``."""
    if hasattr(res, "curve"):  # SceneResult: curves over the deflection
        return float(res.delta_l), float(res.contact_force[-1]), float(res.eps["line"][-1])
    return float(res.delta_l), float(res.contact_force), float(res.eps["line"])


def _row(case: str, solver: str, model: str, got, ref, seconds: float) -> dict:
    """One row: Δl, F and the line reading of ``got`` and their differences from ``ref`` [%]."""
    def rel(a: float, b: float) -> str:
        return "" if b == 0 else f"{100 * (a / b - 1):+.2f}"

    (dl, f, eps), (dl0, f0, eps0) = _numbers(got), _numbers(ref)
    return {"case": case, "solver": solver, "model": model, "dl_mm": f"{dl:.5g}", "dl_%": rel(dl, dl0),
            "F_N": f"{f:.5g}", "F_%": rel(f, f0), "eps_line": f"{eps:.5g}", "eps_%": rel(eps, eps0),
            "time_s": f"{seconds:.1f}"}


def _ccx(spec, wm, bulk_ratio: float, workdir: Path, name: str):
    """The calculix-flavour deck of ``spec`` on ``wm`` run in CalculiX: (SceneDeckResult, wall time)."""
    from peers.calculix import read_scene_deck, run_deck
    from whisker_opt.output.scene_deck import DeckOptions, write_scene_deck

    deck = write_scene_deck(workdir / f"{name}.inp", spec, wm, DeckOptions(bulk_ratio=bulk_ratio))
    rc, wall, log = run_deck(deck, timeout=3600)
    if rc != 0:
        raise RuntimeError(f"ccx exit {rc} on {deck} (log {log})")
    return read_scene_deck(deck, wm, spec), wall


def measure(spec, case: str, bulk_ratios: list[float], workdir: Path) -> list[dict]:
    """The rows of one scene: the reference, then per K/μ the in-house C3D10 and the CalculiX deck."""
    from geometry.mesh import build_mesh
    from whisker_opt.experiment.scene import run_scene
    from whisker_opt.output.scene_deck import deck_d1

    wm = build_mesh(spec.design, spec.sizing, method=spec.mesh_method)  # the mesh export writes
    t0 = time.perf_counter()
    ref = run_scene(spec, wm)
    rows = [_row(case, "in-house", "mixed u-p, D1 = 0 (reference)", ref, ref, time.perf_counter() - t0)]
    for k in bulk_ratios:
        d1 = deck_d1(spec.c10, spec.d1, k)
        for formulation, model in (("mixed", "mixed u-p"), ("displacement", "C3D10")):
            t0 = time.perf_counter()
            got = run_scene(replace(spec, formulation=formulation, d1=d1), wm)
            rows.append(_row(case, "in-house", f"{model}, K/mu = {k:g}", got, ref, time.perf_counter() - t0))
        got, wall = _ccx(spec, wm, k, workdir, f"{'intact' if spec.Q > 0 else 'vented'}_k{k:g}")
        rows.append(_row(case, "ccx", f"C3D10, K/mu = {k:g}", got, ref, wall))
        print(markdown_table(rows[-3:], list(rows[0])), flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", default=None, help="run file (default: the coarse preset's default design)")
    ap.add_argument("--preset", default=None, help="fidelity preset replacing the config's (e.g. default, fine)")
    ap.add_argument("--Q", type=float, default=0.2, help="pressure of the intact scene [MPa]")
    ap.add_argument("--cases", default="intact,vented", help="comma-separated scenes: intact, vented")
    ap.add_argument("--bulk-ratios", default="1000,100,50,20,10", help="comma-separated K/mu of the deck's rubber")
    ap.add_argument("--workdir", default=None, help="folder for the decks and CalculiX's files (default: temporary)")
    args = ap.parse_args()
    workdir = Path(args.workdir or tempfile.mkdtemp(prefix="calculix_agreement-"))
    workdir.mkdir(parents=True, exist_ok=True)
    ks = [float(k) for k in args.bulk_ratios.split(",")]
    cases = _cases(args.config, args.preset, args.Q, args.cases.split(","))
    rows = [r for case, spec in cases.items() for r in measure(spec, case, ks, workdir)]
    print(f"\ndecks and CalculiX files in {workdir}\n")
    print(markdown_table(rows, list(rows[0])))


if __name__ == "__main__":
    main()
