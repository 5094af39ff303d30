"""The output folder of a command while it writes: locked, and refused when it holds a GA run or another
command's results (:func:`whisker_opt.optimise.rundir.check_output_folder`, on the command each folder's
``config.yaml`` names)."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Iterator

from whisker_opt.output.lock import RunDirLock


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
