"""The subcommands of ``whisker-opt``: each is (help text, argument adder, runner).

Runners import their heavy dependencies lazily so ``whisker-opt --help`` stays fast.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path
from typing import Callable

from whisker_opt.config import ConfigError, WhiskerConfig, dump_config, load_config

logger = logging.getLogger(__name__)


def _user_errors() -> tuple[type[BaseException], ...]:
    errs: list[type[BaseException]] = [ConfigError, FileNotFoundError]
    try:
        from geometry.design import InvalidDesignError

        errs.append(InvalidDesignError)
    except ImportError:  # pragma: no cover - geometry is a core package
        pass
    return tuple(errs)


USER_ERRORS = _user_errors()


def design_from_config(cfg: WhiskerConfig, trim: float = 0.0):
    """The validated :class:`geometry.design.WhiskerDesign` described by ``cfg.design``."""
    from geometry.design import WhiskerDesign

    d = WhiskerDesign(**cfg.design.model_dump(), trim=trim)
    d.validate()
    return d


def new_run_dir(cfg: WhiskerConfig, config_path: Path, kind: str) -> Path:
    """Create ``<results_dir>/<name or stem>-<kind>-<UTC time>`` (only after validation)."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    name = cfg.output.name or config_path.stem
    run_dir = Path(cfg.output.results_dir) / f"{name}-{kind}-{stamp}"
    k = 1
    while run_dir.exists():
        k += 1
        run_dir = Path(cfg.output.results_dir) / f"{name}-{kind}-{stamp}-{k}"
    run_dir.mkdir(parents=True)
    (run_dir / "config.yaml").write_text(dump_config(cfg))
    return run_dir


# ----------------------------------------------------------------------------- mesh
def _mesh_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", type=Path, help="YAML run file (design + fidelity sections are used)")
    p.add_argument("--trim", type=float, default=None, help="mesh the design trimmed by this length [mm]")
    p.add_argument("--method", choices=["auto", "fresh", "template"], default=None, help="override fidelity.mesh_method")
    p.add_argument("--step", action="store_true", help="also export the CAD solid as STEP and STL")
    p.add_argument("--out", type=Path, default=None, help="output directory (default: a new run directory)")


def _mesh_run(args: argparse.Namespace) -> int:
    from geometry.mesh import build_mesh
    from whisker_opt.fidelity import mesh_sizing

    cfg = load_config(args.config)
    trim = cfg.scene.trim if args.trim is None else args.trim
    design = design_from_config(cfg, trim=trim)
    method = args.method or cfg.fidelity.mesh_method
    out = args.out or new_run_dir(cfg, args.config, "mesh")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    wm = build_mesh(design, mesh_sizing(cfg.fidelity, design), method=method)
    elapsed = time.perf_counter() - t0
    wm.save(out / "mesh.npz")
    from fem.io import write_vtu

    write_vtu(out / "mesh.vtu", wm.mesh)
    if args.step:
        from geometry.cad import build_solid, export_step, export_stl

        solid = build_solid(design)
        export_step(solid, out / "whisker.step")
        export_stl(solid, out / "whisker.stl")
    report = dict(wm.report.as_dict(), mesh_seconds=round(elapsed, 3), method=method)
    (out / "mesh_report.json").write_text(json.dumps(report, indent=2))
    width = max(len(k) for k in report)
    print(f"mesh of {design.describe()}")
    for k, v in report.items():
        print(f"  {k:<{width}}  {v}")
    print(f"written to {out}")
    return 0


REGISTRY: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {
    "mesh": ("build and mesh a design; write the mesh and a quality report", _mesh_args, _mesh_run),
}
