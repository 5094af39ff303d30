"""Other evaluations of a run than its best: rows of ``evaluations.csv`` and their meshes.

``--rank N`` / ``--eval ID`` show another evaluation of a run directory: its ``eval_<id>/``
folder, or ``best/`` when it is the best design, else its scenes are solved anew with the
run's ``config.yaml`` into ``eval_<id>/`` (:func:`evaluation_group`), kept for later views.
"""

from __future__ import annotations

import csv
import logging
import math
import re
import shutil
from pathlib import Path
from typing import Any, Mapping

from whisker_opt.genes import GENE_NAMES
from whisker_opt.viewer.guard import ViewerError
from whisker_opt.viewer.rundir import RunContents, discover
from whisker_opt.viewer.sceneinfo import finite_float

logger = logging.getLogger(__name__)


def _run_optimiser(root: Path):
    """The optimiser section of a run's ``config.yaml`` (defaults without one or when unusable, said so)."""
    from whisker_opt.config.optimiser import OptimiserConfig
    from whisker_opt.viewer.rundir import config_section, read_run_config

    try:
        opt = OptimiserConfig.model_validate(config_section(read_run_config(root), "optimiser"))
    except ValueError as exc:  # an unusable section: the defaults, said so
        logger.warning("%s: optimiser section not usable (%s); ranking with the default gene bounds and distance",
                       Path(root) / "config.yaml", " ".join(str(exc).split())[:200])
        opt = OptimiserConfig()
    return opt


def run_gene_names(root: Path) -> tuple[str, ...]:
    """The genome of a run (``optimiser.genes.names()`` of its ``config.yaml``)."""
    return _run_optimiser(Path(root)).genes.names()


def evaluation_row(root: Path, rank: int | None = None, eval_id: str | int | None = None) -> dict[str, str]:
    """A row of ``evaluations.csv``: by ``eval_id``, or the ``rank``-th (1 = best) of the run's best
    designs, pairwise distinct by its ``optimiser.distinct_distance``
    (:func:`whisker_opt.optimise.best.best_designs`: the designs and order of its report and ``best.json``).

    Parameters
    ----------
    root : Path
        A run directory of ``whisker-opt run``.
    rank : int, optional
        Among the run's distinct best designs (a cache hit repeats a design, a near-copy is no
        second design).
    eval_id : str or int, optional
        Wins over ``rank``.

    Returns
    -------
    dict of str -> str

    Raises
    ------
    FileNotFoundError
        No ``evaluations.csv`` in ``root``.
    ViewerError
        Rank out of range or unknown evaluation id.
    """
    path = Path(root) / "evaluations.csv"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file (--rank/--eval need a run directory of `whisker-opt run`)")
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    if eval_id is not None:
        hit = [r for r in rows if str(r.get("eval_id", "")).strip() == str(eval_id)]
        if not hit:
            raise ViewerError(f"{path}: no evaluation with eval_id={eval_id!r} ({len(rows)} rows)")
        return hit[0]
    from whisker_opt.optimise.best import best_designs, describe_distance

    opt = _run_optimiser(Path(root))
    distance = opt.distinct_distance
    listed = best_designs(rows, opt.genes.bounds(), 1000, distance, names=opt.genes.names())
    if rank is None or not (1 <= rank <= len(listed)):
        raise ViewerError(f"{path}: --rank {rank} out of range: 1..{len(listed)} successful designs "
                          f"{describe_distance(distance)}")
    wanted = listed[rank - 1]
    ok = [r for r in rows if r.get("status", "ok") == "ok" and finite_float(r.get("F_p")) is not None]
    if wanted["eval_id"] is not None:
        return next(r for r in ok if finite_float(r.get("eval_id")) == wanted["eval_id"])
    return next(r for r in ok if all(finite_float(r.get(k)) == v for k, v in wanted["genes"].items()))


def group_for_evaluation(contents: RunContents, eval_id: str | int) -> str:
    """The group folder holding an evaluation's meshes (``eval_12``, ``eval-0012``, ``12``...).

    Raises
    ------
    ViewerError
        No such folder; the message lists the groups that exist.
    """
    eid = str(eval_id).strip()
    pat = re.compile(rf"(?:^|[^0-9])0*{re.escape(eid.lstrip('0') or '0')}$")
    hits = [g for g in contents.groups if pat.search(g.split("/")[-1])]
    if not hits:
        raise ViewerError(
            f"{contents.root}: no meshes stored for evaluation {eid} (looked for a folder named like eval_{eid}); "
            f"folders with VTU files: {contents.groups}"
        )
    return hits[0]


def same_design(best: Mapping[str, Any] | None, row: Mapping[str, Any]) -> bool:
    """Whether ``best.json`` describes the evaluation ``row`` (same eval_id, else same genes)."""
    if not best:
        return False
    if best.get("eval_id") is not None and str(row.get("eval_id", "")).strip():
        return str(best["eval_id"]).strip() == str(row["eval_id"]).strip()
    genes = best.get("genes")
    if not isinstance(genes, Mapping):
        return False
    pairs = [(finite_float(genes.get(k)), finite_float(row.get(k))) for k in (*GENE_NAMES, *genes)]
    return all(a is not None and b is not None and math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12) for a, b in pairs)


def evaluation_group(contents: RunContents, row: Mapping[str, Any], rerun: bool = True) -> tuple[RunContents, str]:
    """The group holding the meshes of an evaluation, solving its scenes when none are stored.

    Looked for in order: a folder named like ``eval_<id>`` (:func:`group_for_evaluation`);
    ``best`` when ``best.json`` describes this evaluation; else, with ``rerun``, the
    evaluation's scenes (intact at Q_i, trimmed uncompensated, trimmed vented) are solved
    with the run's ``config.yaml`` by :func:`whisker_opt.workflows.write_design_scenes` into
    ``eval_<id>/`` of the run directory (through a hidden ``.eval_<id>.partial/`` folder
    renamed when complete), where later views find them.

    Parameters
    ----------
    contents : RunContents
        A run directory of ``whisker-opt run``.
    row : mapping
        The evaluation's row of ``evaluations.csv`` (:func:`evaluation_row`).
    rerun : bool
        Solve the scenes when no meshes are stored (else :class:`ViewerError`).

    Returns
    -------
    contents, group
        ``contents`` re-discovered after a re-run.

    Raises
    ------
    ViewerError
        No stored meshes and ``rerun`` is False, genes that are not numbers, or the
        scenes cannot be solved (invalid geometry, unconverged solve).
    FileNotFoundError
        A re-run without the run's ``config.yaml``.
    """
    eid = str(row.get("eval_id", "")).strip()
    try:
        return contents, group_for_evaluation(contents, eid)
    except ViewerError:
        if same_design(contents.best, row) and "best" in contents.groups:
            return contents, "best"
        if not rerun:
            raise
    root = contents.root
    where = f"{root / 'evaluations.csv'}: evaluation {eid or '?'}"
    genes = {}
    names = run_gene_names(root)
    for k in names:
        genes[k] = finite_float(row.get(k))
        if genes[k] is None:
            raise ViewerError(f"{where}: gene {k}={row.get(k)!r} is not a number; cannot re-run its scenes")
    cfg_path = root / "config.yaml"
    if not cfg_path.is_file():
        raise FileNotFoundError(f"{cfg_path}: no such file; re-running the scenes of evaluation {eid} needs the "
                                "run's config")
    import whisker_opt.workflows as workflows
    from whisker_opt.config.model import ConfigError, load_config

    final = root / f"eval_{eid or '_'.join(f'{genes[k]:.6g}' for k in names)}"
    tmp = root / f".{final.name}.partial"
    logger.warning("%s (status %s, F_p %s): no meshes stored; re-running its scenes (%s) into %s, "
                   "kept there for later views", where, row.get("status", "?"), row.get("F_p", "?"),
                   ", ".join(f"{k}={v:.5g}" for k, v in genes.items()), final)
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        workflows.write_design_scenes(tmp, load_config(cfg_path), genes)
    except ConfigError as exc:
        raise ViewerError(f"{cfg_path}: {exc}") from exc
    except Exception as exc:  # noqa: BLE001 - invalid geometry, unconverged solve, mesher failure
        shutil.rmtree(tmp, ignore_errors=True)
        raise ViewerError(f"{where}: its scenes cannot be re-run ({type(exc).__name__}: {exc})") from exc
    final.mkdir(exist_ok=True)  # it may exist without VTU files; nothing in it is overwritten but ours
    for f in tmp.iterdir():
        f.replace(final / f.name)
    tmp.rmdir()
    contents = discover(root)
    return contents, final.name
