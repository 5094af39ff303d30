"""The plots beside a view's images: a run's convergence and its gauge response curves."""

from __future__ import annotations

import csv
import logging
import math
import shutil
from pathlib import Path
from typing import Callable

from whisker_opt.viewer.rundir import RunContents
from whisker_opt.viewer.sceneinfo import finite_float

logger = logging.getLogger(__name__)


def write_plots(contents: RunContents, out_dir: Path) -> list[Path]:
    """Convergence and response-curve images of a run, into ``out_dir``.

    Copies ``convergence.png`` / ``best_curves.png`` when present, else draws them from
    ``generations.csv``, ``best_curves.csv`` or a ``simulate`` run's ``curve.csv``
    (``eps_intact``/``eps_trimmed``) with :mod:`whisker_opt.output.plots`.

    Parameters
    ----------
    contents : RunContents
        The run (its root holds the CSV / PNG files).
    out_dir : Path
        Created when missing.

    Returns
    -------
    list of Path
        The images written or copied.
    """
    from whisker_opt.output import plots

    root, out_dir = contents.root, Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    def copy_or(name: str, make: Callable[[Path], Path | None]) -> None:
        src, dst = root / name, out_dir / name
        if src.is_file():
            if src.resolve() != dst.resolve():
                shutil.copyfile(src, dst)
            written.append(dst)
            return
        res = make(dst)
        if res is not None:
            written.append(Path(res))

    def conv(dst: Path) -> Path | None:
        p = root / "generations.csv"
        if not p.is_file():
            return None
        with p.open(newline="") as fh:
            rows = list(csv.DictReader(fh))
        if not rows:
            return None
        def num(k: str) -> list[float]:
            vals = (finite_float(r.get(k)) for r in rows)
            return [math.nan if v is None else v for v in vals]

        feas = [str(r.get("best_feasible", "True")).lower() in ("true", "1") for r in rows]
        return plots.plot_convergence(dst, num("generation"), num("best_fp"), num("mean_fp"), feas)

    def curves(dst: Path) -> Path | None:
        for name, a, b in (("best_curves.csv", "eps_i", "eps_c"), ("curve.csv", "eps_intact", "eps_trimmed")):
            p = root / name
            if not p.is_file():
                continue
            with p.open(newline="") as fh:
                rows = list(csv.DictReader(fh))
            if rows and a in rows[0] and b in rows[0]:
                col = lambda k: [float(r[k]) for r in rows]  # noqa: E731
                target = dst if name == "best_curves.csv" else dst.with_name("curves.png")
                return plots.plot_curves(target, col("delta_mm"), col(a), col(b), f"{root.name}: gauge responses")
        return None

    copy_or("convergence.png", conv)
    copy_or("best_curves.png", curves)
    for w in written:
        logger.info("plot written to %s", w)
    return written
