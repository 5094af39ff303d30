"""The ``whisker-opt view`` command: show a result in a pyvista window, or screenshot it off-screen.

:data:`VIEW_COMMAND` is what :data:`whisker_opt.cli.commands.REGISTRY` registers. Importing
this module does not import pyvista (:mod:`whisker_opt.viewer.guard`), so ``--help`` works
without the ``viewer`` extra; running the command without it is a user error (status 2).

The argparse types of the options that take numbers or a path are a parameter of
:func:`add_view_args`: ``whisker-opt`` passes checking ones (a window of -1 pixels makes VTK
abort, so no bad value may reach it) and checks the output folder before running the command.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import logging
import sys
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

from whisker_opt.viewer.evaluations import evaluation_group, evaluation_row
from whisker_opt.viewer.genome import genome_scenes
from whisker_opt.viewer.guard import ViewerError, ViewerUnavailable, display_problem, is_headless, require_pyvista
from whisker_opt.viewer.plots import write_plots
from whisker_opt.viewer.colours import CLIM_MODES
from whisker_opt.viewer.render import CAVITY_MODES, interactive_plotter, render
from whisker_opt.viewer.rundir import discover
from whisker_opt.viewer.state import load_views


#: argparse ``type=`` of the options taking a number or a path, by destination, when
#: :func:`add_view_args` is given no others.
PLAIN_TYPES: dict[str, Callable[[str], Any]] = {
    "screenshot": Path, "clim_percentile": float, "delta": float, "rank": int, "eval_id": str, "scale": float,
    "window_size": int,
}


def add_view_args(p: argparse.ArgumentParser, types: Mapping[str, Callable[[str], Any]] | None = None) -> None:
    """Add the arguments of ``whisker-opt view`` to a parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
    types : mapping of str -> callable, optional
        argparse ``type=`` by destination (keys of :data:`PLAIN_TYPES`), e.g. functions that
        refuse out-of-range values; the others are :data:`PLAIN_TYPES`. ``window_size`` is
        applied to each of the two numbers.
    """
    t = {**PLAIN_TYPES, **(types or {})}
    p.add_argument("source", type=Path, help="results directory (searched recursively for *.vtu) or one .vtu file")
    p.add_argument("--screenshot", type=t["screenshot"], default=None, metavar="FILE.png",
                   help="render off-screen to this image (.png, .jpg, .jpeg, .bmp, .tif, .tiff) instead of "
                        "opening a window")
    p.add_argument("--field", default=None,
                   help="colour by: change (the axial log strain the push added, deflected minus pressurised: "
                        "zeroed at contact onset as the gauge reading; the default when a deflection is shown), "
                        "strain (the total axial log strain LE_xx, the default otherwise), displacement (|u|), mises "
                        "(von Mises, as stored; for an older file without it, of the rubber in config.yaml), any "
                        "stored array, name:x for a component, or none")
    p.add_argument("--clim", dest="clim_mode", choices=CLIM_MODES, default="panel",
                   help="colour range: panel = each panel its own range and scalar bar (default; in a window, over "
                        "all the deflections of that panel), so a vented panel is not washed out by the pressurised "
                        "ones; shared = one range for all panels, to compare magnitudes. The picture says which")
    p.add_argument("--clim-percentile", type=t["clim_percentile"], default=1.0, metavar="P",
                   help="colour range over the P-th..(100-P)-th percentiles of the field (default 1; "
                        "0 = full range, which a few cavity-corner nodes dominate); 0 <= P < 50")
    p.add_argument("--scene", action="append", default=None,
                   help="scene(s) to show (repeatable; default all, side by side)")
    p.add_argument("--state", default=None, help="state to show, e.g. pressurised or deflected (default: the last)")
    p.add_argument("--delta", type=t["delta"], default=None, metavar="MM",
                   help="show every scene at this solved deflection [mm] (0 = pressurised); in a window, the "
                        "slider and the n / b keys step through the deflections")
    p.add_argument("--rank", type=t["rank"], default=None,
                   help="show the N-th best design of a run (1 = best)")
    p.add_argument("--eval", dest="eval_id", type=t["eval_id"], default=None,
                   help="show the evaluation with this eval_id (with --rank: its scenes are solved into "
                        "RUN_DIR/eval_<id>/ when the run stored no meshes for it)")
    p.add_argument("--group", default=None,
                   help="sub-folder of the results holding the VTU files (default: best/ or the root)")
    p.add_argument("--scale", type=t["scale"], default=1.0,
                   help="displacement magnification, 0..1000 (default 1 = true scale)")
    p.add_argument("--cavity", choices=CAVITY_MODES, default="clip",
                   help="clip: cut at z=0 to show wall section and cavity; translucent: see-through outer surface")
    p.add_argument("--camera", choices=("iso", "xy"), default="iso", help="camera direction")
    p.add_argument("--layout", choices=("auto", "rows", "columns"), default="auto",
                   help="arrangement of side-by-side panels")
    p.add_argument("--window-size", type=t["window_size"], nargs=2, default=None, metavar=("W", "H"),
                   help="image size in pixels, each 50..10000")
    p.add_argument("--no-edges", action="store_true", help="do not draw element edges")
    p.add_argument("--plots", action="store_true",
                   help="also write the convergence plot and response curves into the output folder")
    p.add_argument("--list", action="store_true", help="list the groups, scenes and states found, then exit")


class _DropReaderMessages(logging.Filter):
    """Drops the VTK reader messages pyvista logs on the root logger (unless -vv): the
    viewer's own one-line error already carries the reader's reason."""

    def filter(self, record: logging.LogRecord) -> bool:  # noqa: D102 - logging.Filter.filter
        if "pyvista" not in record.pathname.replace("\\", "/").split("/"):
            return True
        return logging.getLogger().getEffectiveLevel() <= logging.DEBUG


@contextlib.contextmanager
def _quiet_vtk_readers() -> Iterator[None]:
    """Drop pyvista's VTK reader messages from the root logger meanwhile (:class:`_DropReaderMessages`)."""
    root = logging.getLogger()
    filt = _DropReaderMessages()
    root.addFilter(filt)
    try:
        yield
    finally:
        root.removeFilter(filt)


def _damaged(path: Path, exc: BaseException) -> ViewerError:
    if isinstance(exc, UnicodeDecodeError):
        return ViewerError(f"{path}: damaged (not UTF-8 text at byte {exc.start})")
    if isinstance(exc, RecursionError):
        return ViewerError(f"{path}: damaged (JSON nested too deeply to read)")
    return ViewerError(f"{path}: damaged ({type(exc).__name__}: {' '.join(str(exc).split())})")


def _check_metadata(source: Path) -> None:
    """Refuse a results folder whose metadata files cannot be read as text of their kind.

    ``config.yaml`` (YAML mapping), ``best.json`` (JSON) and ``evaluations.csv`` (CSV) of the
    folder, and every ``scenes.json`` below it, naming the file; what they hold is checked
    where it is used.
    """
    import json

    import yaml

    root = source if source.is_dir() else source.parent
    cfg = root / "config.yaml"
    if cfg.is_file():
        try:
            data = yaml.safe_load(cfg.read_bytes().decode("utf-8"))
        except (UnicodeDecodeError, yaml.YAMLError) as exc:
            raise _damaged(cfg, exc) from None
        if data is not None and not isinstance(data, dict):
            raise ViewerError(f"{cfg}: damaged (top level is a {type(data).__name__}, not a mapping of sections)")
    jsons = [root / "best.json"] + (sorted(p for p in root.rglob("scenes.json")) if source.is_dir() else
                                    [root / "scenes.json"])
    for path in jsons:
        if path.is_file():
            try:
                json.loads(path.read_bytes().decode("utf-8"))
            except (UnicodeDecodeError, ValueError, RecursionError) as exc:
                raise _damaged(path, exc) from None
    ev = root / "evaluations.csv"
    if ev.is_file():
        try:
            with ev.open(newline="", encoding="utf-8") as fh:
                for _ in csv.reader(fh):
                    pass
        except (UnicodeDecodeError, csv.Error) as exc:
            raise _damaged(ev, exc) from None


def run_view(args: argparse.Namespace) -> int:
    """Runner of ``whisker-opt view``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed by a parser set up with :func:`add_view_args`.

    Returns
    -------
    int
        Exit status: 0, or 2 on a user error (printed to stderr), including a missing pyvista.
    """
    try:
        with _quiet_vtk_readers():
            return _view_main(args)
    except (ViewerError, ViewerUnavailable, FileNotFoundError) as exc:
        msg = "; ".join(ln.strip() for ln in str(exc).splitlines() if ln.strip())
        print(f"whisker-opt view: error: {msg}", file=sys.stderr)
        return 2


def _view_main(args: argparse.Namespace) -> int:
    """:func:`run_view` without the translation of user errors into an exit status."""
    other = args.rank is not None or args.eval_id is not None
    if args.rank is not None and args.eval_id is not None:
        raise ViewerError("--rank and --eval are exclusive; give one")
    if args.state is not None and args.delta is not None:
        raise ViewerError("--state and --delta are exclusive; give one")
    if Path(args.source).exists():
        _check_metadata(Path(args.source))
    # --rank/--eval: a run directory may hold no meshes yet (they are solved on demand)
    contents = discover(args.source, allow_empty=other and not args.list)
    if args.list:
        print(contents.describe())
        return 0
    notes: dict[str, Any] = {}
    group = args.group or (None if other else contents.default_group())
    if other:
        row = evaluation_row(contents.root, rank=args.rank, eval_id=args.eval_id)
        contents, group = evaluation_group(contents, row)
        notes = {"eval_id": row.get("eval_id"), "F_p": row.get("F_p"), "f1": row.get("f1")}
        if not contents.scenes.get(group):  # no scenes.json there: the design from config + genes
            contents.scenes[group] = genome_scenes(contents.config, row)
    elif group == "best" and contents.best:
        b = contents.best
        notes = {k: b[k] for k in ("genes", "f1", "F_p") if k in b}
    headless = is_headless()
    screenshot = args.screenshot
    if screenshot is None and headless:
        screenshot = contents.root / "view.png"
        print(f"whisker-opt view: {display_problem() or 'no display found'}; "
              f"rendering off-screen to {screenshot}", file=sys.stderr)
    kw = dict(cavity=args.cavity, show_edges=not args.no_edges, clim_percentile=args.clim_percentile,
              clim_mode=getattr(args, "clim_mode", "panel"))
    ws = tuple(args.window_size) if args.window_size else None
    pv = require_pyvista()
    # headless: VTK first tries X and warns before falling back to EGL; keep only its errors
    quiet = pv.vtk_verbosity("error") if headless else contextlib.nullcontext()
    if screenshot is not None:
        files = None if args.delta is None else contents.select_delta(group, args.delta, args.scene)
        views = load_views(contents, group, args.scene, args.state, notes, files=files, scale=args.scale)
        with quiet:
            out = render(views, args.field, screenshot=screenshot, window_size=ws, layout=args.layout,
                         camera=args.camera, **kw)
        print(f"screenshot written to {out}")
        out_dir = Path(out).parent
    else:
        if args.state is not None:
            steps = [(None, contents.select(group, args.scene, args.state))]
        else:  # step k shows every scene at the k-th deflection (or its k-th state)
            steps = contents.delta_steps(group, args.scene)
        start = None
        if args.delta is not None:
            at = contents.select_delta(group, args.delta, args.scene)  # validates the deflection
            start = next((k for k, (_, files) in enumerate(steps) if files == at), None)
        series = [load_views(contents, group, notes=notes, files=files, scale=args.scale) for _, files in steps]
        values = [d for d, _ in steps]
        p, _ = interactive_plotter(series, args.field, off_screen=False, window_size=ws, layout=args.layout,
                                   camera=args.camera, start=start,
                                   step_values=None if None in values else values, **kw)
        p.show()
        out_dir = contents.root
    if args.plots:
        for w in write_plots(contents, out_dir):
            print(f"plot written to {w}")
    return 0


VIEW_COMMAND: tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]] = (
    "show a result (run directory or .vtu) in a pyvista window, or --screenshot it off-screen",
    add_view_args,
    run_view,
)
"""``(help, add_args, run)`` for :data:`whisker_opt.cli.commands.REGISTRY` (``whisker-opt view``)."""
