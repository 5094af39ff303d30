"""The output folder of a command while it writes: locked, and refused when it holds a GA run or another
command's results (:func:`whisker_opt.optimise.rundir.check_output_folder`, on the command each folder's
``config.yaml`` names)."""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path
from typing import Iterator

from whisker_opt.output.lock import RunDirLock

logger = logging.getLogger(__name__)


@contextlib.contextmanager
def writing(out: Path, command: str, holder: str | None = None) -> Iterator[Path]:
    """Hold the lock of the output folder ``out`` (:class:`~whisker_opt.output.lock.RunDirLock`, naming ``holder``)
    while ``command`` writes there, after refusing, under the lock, a folder that holds a GA run or another
    command's results: a run, resume or study writing there, or one that finished there, is refused in one line
    and nothing is written. A folder made here and left empty by a command that failed is removed."""
    from whisker_opt.optimise.rundir import check_output_folder

    out = Path(out)
    check_output_folder(out, command)
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    try:
        with RunDirLock(out, holder or command):
            check_output_folder(out, command)
            yield out
    except BaseException:
        if made:
            with contextlib.suppress(OSError):
                out.rmdir()  # only when empty
        raise


def study_folder(args, cfg, config_path: Path | str, command: str, journal: str, study: str, inputs) -> Path:
    """Where a study with a journal writes: ``--out``; else the folder under ``output.results_dir`` of the same
    study stopped before its end (:func:`whisker_opt.output.journal.find_unfinished`: its journal holds these
    ``inputs``), which it continues; else a new folder (:func:`whisker_opt.workflows.new_run_dir`, whose names
    start ``<output.name or the run file's stem>-<command>-``). The folder is kept in ``args.study_out`` for the
    line an interrupt prints (what to type to continue)."""
    from whisker_opt.output.journal import find_unfinished
    from whisker_opt.workflows import new_run_dir

    if args.out is not None:
        out = Path(args.out)
    else:
        prefix = f"{cfg.output.name or Path(config_path).stem}-{command}-"
        out = find_unfinished(cfg.output.results_dir, prefix, journal, study, inputs)
        if out is not None:
            logger.info("%s: the %s stopped there continues", out, command)
        else:
            out = new_run_dir(cfg, config_path, command)
    args.study_out = out
    return out
