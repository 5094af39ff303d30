"""Checks of a run directory given to ``resume``, ``report`` and ``verify``, made before they compute.

A run directory is what ``whisker-opt run`` writes (:mod:`whisker_opt.output.storage`):
``config.yaml``, ``optimiser.json`` and, after the first generation, ``checkpoint.json``.
Each damaged or missing file is reported in one line naming it and what is wrong
(:class:`whisker_opt.optimise.checkpoint.RunDirectoryError`, or :class:`FileNotFoundError`
for a missing folder or file), so that no command reads a damaged file half-way. A run
directory of an earlier version (a pickled ``checkpoint.pkl``) is refused with
:class:`whisker_opt.optimise.checkpoint.OlderFormatError`, its pickle never loaded.
"""

from __future__ import annotations

import json
from pathlib import Path

from whisker_opt.config.model import load_config
from whisker_opt.optimise.checkpoint import (
    CHECKPOINT_NAME,
    OLDER_NAME,
    OlderFormatError,
    RunDirectoryError,
    dangling_link,
    has_older_checkpoint,
    older_format_message,
)
from whisker_opt.output.storage import OPTIMISER_JSON


def _optimiser_json(run_dir: Path) -> None:
    """Check ``optimiser.json`` as :func:`whisker_opt.optimise.runner.load_run` reads it."""
    from pydantic import ValidationError

    from whisker_opt.config.model import format_validation_error
    from whisker_opt.config.optimiser import OptimiserConfig

    path = run_dir / OPTIMISER_JSON
    if not path.exists():
        raise FileNotFoundError(f"{run_dir}: not a run directory (no {CHECKPOINT_NAME} nor {OPTIMISER_JSON})")
    if not path.is_file():
        raise RunDirectoryError(f"{path}: not a file")
    try:
        meta = json.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise RunDirectoryError(f"{path}: damaged (not UTF-8 text at position {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise RunDirectoryError(f"{path}: damaged (not valid JSON: {exc.msg} at line {exc.lineno} "
                                f"column {exc.colno})") from None
    except RecursionError:
        raise RunDirectoryError(f"{path}: damaged (JSON nested too deeply to read)") from None
    except OSError as exc:
        raise RunDirectoryError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if not isinstance(meta, dict):
        raise RunDirectoryError(f"{path}: damaged (top level is a {type(meta).__name__}, expected an object with "
                                "'seed' and 'optimiser')")
    seed = meta.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= 2**32 - 1:
        raise RunDirectoryError(f"{path}: damaged ('seed' is {seed!r}, expected an integer in 0..4294967295)")
    if not isinstance(meta.get("optimiser"), dict):
        raise RunDirectoryError(f"{path}: damaged ('optimiser' is a {type(meta.get('optimiser')).__name__}, "
                                "expected an object)")
    try:
        OptimiserConfig.model_validate(meta["optimiser"])
    except ValidationError as exc:
        raise RunDirectoryError(format_validation_error(exc, f"{path}: optimiser")) from None


def check_run_dir(run_dir: Path, need_config: bool = False, load_state: bool = False,
                  allow_unstarted: bool = False, allow_older: bool = False) -> Path:
    """Refuse a folder that is not a usable run directory, naming the file at fault.

    Parameters
    ----------
    run_dir : Path
    need_config : bool
        ``config.yaml`` must be a valid run file (``resume``, ``verify``).
    load_state : bool
        Read the whole checkpoint now (``resume``, which deletes stale temporary files
        before reading it); otherwise only its presence is checked here and its contents
        when the command reads it.
    allow_unstarted : bool
        Accept a run directory holding only ``config.yaml`` (a run killed before it wrote
        anything else, which ``resume`` starts again).
    allow_older : bool
        Accept a checkpoint of an earlier version (``resume --trust-pickle`` converts it).

    Returns
    -------
    Path
        ``run_dir``.

    Raises
    ------
    FileNotFoundError
        No such folder, or it holds neither a checkpoint nor ``optimiser.json``, or no
        ``config.yaml`` when one is needed.
    OlderFormatError
        A checkpoint of an earlier version, unless ``allow_older``.
    RunDirectoryError
        Not a folder, a damaged checkpoint or ``optimiser.json``, or a ``checkpoint.json`` or
        ``checkpoint.pkl`` that is a symbolic link leading nowhere (the run's state is missing: it
        is not started again from generation 0).
    ConfigError
        A damaged ``config.yaml``.
    """
    from whisker_opt.optimise.checkpoint import load_checkpoint

    run_dir = Path(run_dir)
    if not run_dir.exists():
        raise FileNotFoundError(f"{run_dir}: no such run directory")
    if not run_dir.is_dir():
        raise RunDirectoryError(f"{run_dir}: not a folder; give a run directory written by `whisker-opt run`")
    for name in (CHECKPOINT_NAME, OLDER_NAME):
        dangling = dangling_link(run_dir / name)
        if dangling:
            raise RunDirectoryError(dangling)
    older = has_older_checkpoint(run_dir)
    if older and not allow_older:
        raise OlderFormatError(older_format_message(run_dir))
    if need_config:
        cfg = run_dir / "config.yaml"
        if not cfg.exists():
            raise FileNotFoundError(f"{cfg}: not found; is {run_dir} a run directory?")
        load_config(cfg)
    ck = run_dir / CHECKPOINT_NAME
    if older:
        pass  # converted by `resume --trust-pickle` before it is read
    elif ck.exists() or ck.is_symlink():
        if not ck.is_file():
            raise RunDirectoryError(f"{ck}: not a whisker-opt checkpoint (not a regular file)")
        if load_state:
            load_checkpoint(run_dir)
    elif not (allow_unstarted and not (run_dir / OPTIMISER_JSON).exists()):
        _optimiser_json(run_dir)
    return run_dir
