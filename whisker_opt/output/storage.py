"""Files of a run directory, every one written atomically (temp file + ``os.replace``).

A run directory written by :func:`whisker_opt.optimise.runner.run_optimisation` holds::

    optimiser.json     the resolved optimiser config and the seed (what resume needs)
    environment.json   Python, platform, library versions, git commit, seed
    checkpoint.json    GA state after the last completed generation, JSON (whisker_opt.optimise.checkpoint)
    run.lock           while a process writes into the folder: its PID and host (whisker_opt.output.lock)
    evaluations.csv    one row per evaluated individual: generation, genes, f1, κ_j, F_p,
                       status, reason, time, cache_hit
    generations.csv    one row per generation: evaluations, cache hits, failures, best /
                       min / mean F_p, best genes, time
    best.json          the best design (genes, f1, κ_j, F_p) and the run's counters
    convergence.png    best and mean F_p per generation (log scale)
    best_curves.csv/.png  ε_i(δ) and ε_c(δ) of the best design, when known

(the lead's CLI adds ``config.yaml``, the full run file, and the best design's VTU meshes).
The CSV and JSON files are rewritten whole after every generation from the checkpointed
state, so they are always consistent with the checkpoint after a resume.
"""

from __future__ import annotations

import csv
import io
import json
import logging
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path
from typing import Any, Iterable, Sequence

logger = logging.getLogger(__name__)

EVALUATIONS_CSV = "evaluations.csv"
GENERATIONS_CSV = "generations.csv"
BEST_JSON = "best.json"
ENVIRONMENT_JSON = "environment.json"
OPTIMISER_JSON = "optimiser.json"
BEST_CURVES_CSV = "best_curves.csv"

_LIBRARIES = (
    "numpy", "scipy", "deap", "pydantic", "PyYAML", "tqdm", "matplotlib", "dask", "distributed",
    "cadquery", "pytetwild", "pypardiso", "meshio", "pyvista", "whisker-opt",
)


#: Names of temporaries: atomic-write temp files and hidden folders being filled.
_TEMPORARY = re.compile(r"^(\..+\.tmp|\.tmp.*|tmp[a-z0-9_]{8}\.vtu|.+\.partial)$")


def default_file_mode() -> int:
    """Mode of a newly created ordinary file under the process umask (``0o644`` under ``022``)."""
    from fem.io import default_file_mode as mode

    return mode()


def is_temporary(name: str) -> bool:
    """True for the name of a temporary a kill may leave in a run directory.

    ``.<name>.<random>.tmp`` and ``.tmp*`` (atomic writes), ``tmpXXXXXXXX.vtu`` (VTU files of
    older versions) and ``*.partial`` (folders filled before they are renamed into place).
    """
    return bool(_TEMPORARY.match(name))


def remove_temporaries(run_dir: Path) -> list[Path]:
    """Delete the temporaries (:func:`is_temporary`) in ``run_dir`` and its direct sub-folders.

    Call it only while nothing writes into ``run_dir`` (before a resume).

    Returns
    -------
    list of Path
        What was removed.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return []
    folders = [run_dir] + sorted(p for p in run_dir.iterdir()
                                 if p.is_dir() and not p.is_symlink() and not is_temporary(p.name))
    removed = []
    for folder in folders:
        for p in sorted(folder.iterdir()):
            if not is_temporary(p.name):
                continue
            try:
                if p.is_dir() and not p.is_symlink():
                    shutil.rmtree(p)
                else:
                    p.unlink()
                removed.append(p)
            except OSError as exc:  # removed meanwhile, or not ours to remove
                logger.warning("cannot remove the temporary %s: %s", p, exc)
    return removed


class UnsafeLink(Exception):
    """A file of a run directory that the program writes into is a symbolic link (a user error, exit status 2).

    In a run directory someone else made, the link could lead to any file the user may write.
    """


class _LogFile(logging.StreamHandler):
    """A log file's handler: a record it cannot write (a full disk) is dropped without a word, and
    closing it closes its file.

    :class:`logging.Handler` would print a traceback for each such record on the console; the
    command's own one-line error (its next result file cannot be written either) says it instead.
    """

    dropped = 0

    def handleError(self, record: logging.LogRecord) -> None:  # noqa: D102, N802 - logging.Handler.handleError
        self.dropped += 1

    def close(self) -> None:  # noqa: D102 - logging.Handler.close
        try:
            super().close()
        finally:
            try:
                self.stream.close()
            except OSError:  # its last flush may meet a full disk
                pass


def log_file_handler(path: Path) -> logging.Handler:
    """A logging handler appending to ``path`` (created when missing).

    The file is opened without following a symbolic link; a record that cannot be written (a
    full disk) is dropped without a traceback on the console.

    Raises
    ------
    UnsafeLink
        ``path`` is a symbolic link (appending would write into what it leads to).
    """
    path = Path(path)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o666)
    except OSError:
        if not path.is_symlink():
            raise
        raise UnsafeLink(f"{path}: a symbolic link (to {os.readlink(path)!r}), not a log file; appending the log "
                         "would write into what it leads to: remove the link") from None
    return _LogFile(os.fdopen(fd, "a", encoding="utf-8"))


def named_os_error(exc: OSError, path: Path) -> OSError:
    """``exc`` itself when it names a file, else the same error naming ``path``.

    A write that fails for want of space (``ENOSPC``) or quota raises an :class:`OSError` naming
    no file; the one-line message of the command must say which file could not be written.
    """
    if exc.filename is not None or exc.errno is None:
        return exc
    return type(exc)(exc.errno, exc.strerror or os.strerror(exc.errno), str(path))


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (temp file in the same folder, fsync, os.replace).

    Raises
    ------
    OSError
        The file cannot be written (a full disk, no permission); it names ``path``, and ``path``
        is left as it was (no temporary file stays behind).
    """
    path = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise named_os_error(exc, path) from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, default_file_mode())  # mkstemp creates 0600; results are ordinary files
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise named_os_error(exc, path) from None
        raise


def atomic_write_text(path: Path, text: str) -> None:
    """Write text (UTF-8) atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def _jsonable(obj: Any) -> Any:
    """Replace non-finite floats by None (strict JSON), recursively; tuples become lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalar
        return _jsonable(obj.item())
    return obj


def write_json(path: Path, obj: Any) -> None:
    """Write strict JSON (NaN/inf as null) atomically."""
    atomic_write_text(path, json.dumps(_jsonable(obj), indent=2, allow_nan=False) + "\n")


def _cell(v: Any) -> Any:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else repr(v))
    return v


def write_csv(path: Path, columns: Sequence[str], rows: Iterable[dict[str, Any]]) -> None:
    """Write dictionaries as CSV columns (missing keys empty; floats at full precision), atomically."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for row in rows:
        w.writerow([_cell(row.get(c)) for c in columns])
    atomic_write_text(path, buf.getvalue())


def read_csv(path: Path) -> list[dict[str, str]]:
    """Rows of a CSV file as dictionaries of strings."""
    with Path(path).open(newline="") as fh:
        return list(csv.DictReader(fh))


def evaluation_columns(gene_names: Sequence[str], kappa_columns: Sequence[str],
                       aggregate_columns: Sequence[str] = (), measure_columns: Sequence[str] = ()) -> list[str]:
    """Columns of ``evaluations.csv`` (``aggregate_columns`` after ``f1``: the aggregate over variants a run
    minimises and the spread of f1 beside it, e.g. ``f1_robust``, ``f1_mean``, ``f1_std``; then the measures an
    optimiser reads besides f1, e.g. NSGA-II's ``sensitivity``)."""
    return (
        ["eval_id", "generation", *gene_names, "f1", *aggregate_columns, *measure_columns, *kappa_columns, "F_p",
         "f1_uncalibrated", "F_p_uncalibrated", "status", "reason", "time_s", "cache_hit"]
    )


def generation_columns(gene_names: Sequence[str]) -> list[str]:
    """Columns of ``generations.csv``."""
    return [
        "generation", "evals", "cache_hits", "n_failures", "n_feasible", "best_fp", "best_fp_uncalibrated",
        "best_feasible", "best_f1",
        "min_fp", "mean_fp", *[f"best_{g}" for g in gene_names], "total_evals", "time_s", "elapsed_s",
    ]


def write_evaluations(run_dir: Path, records: Sequence[dict], columns: Sequence[str]) -> None:
    """``evaluations.csv``: every evaluation so far."""
    write_csv(Path(run_dir) / EVALUATIONS_CSV, columns, records)


def write_generations(run_dir: Path, logbook: Sequence[dict], columns: Sequence[str]) -> None:
    """``generations.csv``: per-generation statistics so far."""
    write_csv(Path(run_dir) / GENERATIONS_CSV, columns, logbook)


def _git_commit() -> str | None:
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True, timeout=5, check=True
        )
        return out.stdout.strip() or None
    except Exception:  # noqa: BLE001 - not a git checkout, or no git
        return None


def environment_info(seed: int) -> dict[str, Any]:
    """Python, platform, library versions (installed distributions), git commit and seed."""
    versions: dict[str, str | None] = {}
    for lib in _LIBRARIES:
        try:
            versions[lib] = metadata.version(lib)
        except metadata.PackageNotFoundError:
            versions[lib] = None
    return {
        "python": sys.version,
        "implementation": platform.python_implementation(),
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor(),
        "cpu_count": os.cpu_count(),
        "libraries": versions,
        "git_commit": _git_commit(),
        "seed": int(seed),
        "written_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def write_environment(run_dir: Path, seed: int) -> None:
    """``environment.json``."""
    write_json(Path(run_dir) / ENVIRONMENT_JSON, environment_info(seed))


def write_best(run_dir: Path, best: dict[str, Any]) -> None:
    """``best.json``."""
    write_json(Path(run_dir) / BEST_JSON, best)
