"""Atomic checkpoints of the GA state, written after every generation.

A checkpoint holds the population, the hall of fame, the logbook, every evaluation record,
the evaluation cache, the Python ``random`` and NumPy RNG states, the counters and the
generation index (the DEAP checkpointing recipe, plus the cache). It is a pickle written
to a temporary file in the same directory, flushed and fsync'ed, then moved over the old
one with :func:`os.replace`, so a kill at any instant leaves either the previous or the
new checkpoint, never a torn one. Resuming restores the state exactly: the resumed run
re-breeds the interrupted generation from the same RNG state, finds the same designs, and
ends with the same population and best as an uninterrupted run.

Saving a new checkpoint keeps the one it replaces as ``checkpoint.prev.pkl`` (hard-linked,
or copied, before the atomic replacement, so ``checkpoint.pkl`` exists at every instant).
A checkpoint that cannot be read (truncated, empty, not a pickle, not a GA state) raises
:class:`RunDirectoryError` naming the file and the damage, and offering the previous one when
it is intact; :func:`restore_previous` puts the previous one back in place (``whisker-opt
resume RUN_DIR --from-previous``).

Individuals are pickled as DEAP ``creator`` instances; :mod:`whisker_opt.optimise.ga` (imported
here) creates those classes at import, which is what makes the pickle loadable.
"""

from __future__ import annotations

import logging
import os
import pickle
import shutil
from pathlib import Path
from typing import Any

from whisker_opt.optimise.evalcache import EvalCache
from whisker_opt.optimise.ga import GAState  # noqa: F401 - also registers the creator classes
from whisker_opt.output.storage import atomic_write_bytes

logger = logging.getLogger(__name__)

CHECKPOINT_NAME = "checkpoint.pkl"
PREVIOUS_NAME = "checkpoint.prev.pkl"
DAMAGED_NAME = "checkpoint.damaged.pkl"
FORMAT_VERSION = 1

#: Keys every checkpoint dictionary holds (``extra`` may be missing in old ones).
_KEYS = ("format", "config", "seed", "generation", "population", "hof", "logbook", "records", "cache", "rng_py",
         "rng_np", "n_evaluations", "n_cache_hits", "n_failures", "elapsed_s", "stop_reason")


class RunDirectoryError(ValueError):
    """A run directory whose files cannot be used: a damaged checkpoint, ``optimiser.json`` or
    ``config.yaml``, or a folder that is not a run directory (a user error: the message names
    the file and what is wrong with it)."""


def state_to_dict(state: GAState, config: dict[str, Any]) -> dict[str, Any]:
    """Plain dictionary of a state (plus the optimiser config it was produced with)."""
    return {
        "format": FORMAT_VERSION,
        "config": config,
        "seed": state.seed,
        "generation": state.generation,
        "population": state.population,
        "hof": state.hof,
        "logbook": state.logbook,
        "records": state.records,
        "cache": state.cache.to_state(),
        "rng_py": state.rng_py,
        "rng_np": state.rng_np,
        "n_evaluations": state.n_evaluations,
        "n_cache_hits": state.n_cache_hits,
        "n_failures": state.n_failures,
        "elapsed_s": state.elapsed_s,
        "stop_reason": state.stop_reason,
        "extra": state.extra,
    }


def state_from_dict(d: dict[str, Any]) -> GAState:
    """Inverse of :func:`state_to_dict` (the config is returned separately by :func:`load_checkpoint`)."""
    if d.get("format") != FORMAT_VERSION:
        raise ValueError(f"checkpoint format {d.get('format')!r} is not supported (expected {FORMAT_VERSION})")
    return GAState(
        seed=d["seed"],
        generation=d["generation"],
        population=d["population"],
        hof=d["hof"],
        logbook=d["logbook"],
        records=d["records"],
        cache=EvalCache.from_state(d["cache"]),
        rng_py=d["rng_py"],
        rng_np=d["rng_np"],
        n_evaluations=d["n_evaluations"],
        n_cache_hits=d["n_cache_hits"],
        n_failures=d["n_failures"],
        elapsed_s=d["elapsed_s"],
        stop_reason=d["stop_reason"],
        extra=d.get("extra", {}),
    )


def _looks_complete(path: Path) -> bool:
    """Cheap check that ``path`` holds a whole pickle (protocol >= 2 header, STOP opcode at the end)."""
    try:
        with path.open("rb") as fh:
            head = fh.read(1)
            fh.seek(-1, os.SEEK_END)
            tail = fh.read(1)
    except OSError:
        return False
    return head == b"\x80" and tail == b"."


def _keep_previous(run_dir: Path) -> None:
    """Make ``checkpoint.prev.pkl`` the current checkpoint's file (the current one stays in place)."""
    current = run_dir / CHECKPOINT_NAME
    if not current.is_file() or not _looks_complete(current):
        return  # nothing to keep, or a damaged file that must not replace a good previous one
    previous = run_dir / PREVIOUS_NAME
    try:
        if previous.exists() and os.path.samefile(previous, current):
            return  # already kept (a kill came between this and the replacement of current)
    except OSError:
        pass
    tmp = run_dir / f".{PREVIOUS_NAME}.{os.getpid()}.tmp"  # removed by remove_stale_temporaries if left
    try:
        try:
            os.link(current, tmp)  # the same file: no copy; the atomic replacement of current keeps it whole
        except FileExistsError:
            os.unlink(tmp)
            os.link(current, tmp)
        except OSError:  # a file system without hard links
            shutil.copyfile(current, tmp)
        os.replace(tmp, previous)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def save_checkpoint(run_dir: Path, state: GAState, config: dict[str, Any]) -> Path:
    """Write ``run_dir/checkpoint.pkl`` atomically, keeping the one it replaces as
    ``checkpoint.prev.pkl``; returns its path."""
    run_dir = Path(run_dir)
    path = run_dir / CHECKPOINT_NAME
    data = pickle.dumps(state_to_dict(state, config), protocol=pickle.HIGHEST_PROTOCOL)
    _keep_previous(run_dir)
    atomic_write_bytes(path, data)
    logger.debug("checkpoint of generation %d written to %s", state.generation, path)
    return path


def _read(path: Path) -> tuple[GAState, dict[str, Any]]:
    """State and config of one checkpoint file.

    Raises
    ------
    RunDirectoryError
        The file is not a readable whisker-opt checkpoint (the message names it and the damage).
    """
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise RunDirectoryError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if not path.is_file():
        raise RunDirectoryError(f"{path}: not a whisker-opt checkpoint (not a regular file)")
    if size == 0:
        raise RunDirectoryError(f"{path}: not a whisker-opt checkpoint (empty file)")
    try:
        with path.open("rb") as fh:
            d = pickle.load(fh)
    except OSError as exc:
        raise RunDirectoryError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    except Exception as exc:  # noqa: BLE001 - unpickling damaged bytes raises nearly anything
        msg = " ".join(str(exc).split())
        if len(msg) > 120:
            msg = msg[:117] + "..."
        raise RunDirectoryError(f"{path}: not a whisker-opt checkpoint (truncated or damaged: "
                                f"{type(exc).__name__}: {msg}; {size} bytes)") from None
    if not isinstance(d, dict):
        raise RunDirectoryError(f"{path}: not a whisker-opt checkpoint (it holds a {type(d).__name__}, "
                                "not a GA state)")
    if d.get("format") != FORMAT_VERSION:
        raise RunDirectoryError(f"{path}: checkpoint format {d.get('format')!r} is not supported "
                                f"(expected {FORMAT_VERSION})")
    missing = [k for k in _KEYS if k not in d]
    if missing:
        raise RunDirectoryError(f"{path}: not a whisker-opt checkpoint (missing {', '.join(missing)})")
    try:
        return state_from_dict(d), d["config"]
    except Exception as exc:  # noqa: BLE001 - a pickle of the right shape holding wrong values
        raise RunDirectoryError(f"{path}: not a whisker-opt checkpoint (damaged GA state: "
                                f"{type(exc).__name__}: {exc})") from None


def previous_generation(run_dir: Path) -> int | None:
    """Generation of ``run_dir/checkpoint.prev.pkl``, or None when it is missing or unreadable."""
    path = Path(run_dir) / PREVIOUS_NAME
    if not path.is_file():
        return None
    try:
        return _read(path)[0].generation
    except RunDirectoryError:
        return None


def load_checkpoint(run_dir: Path, previous: bool = False) -> tuple[GAState, dict[str, Any]]:
    """Read ``run_dir/checkpoint.pkl`` (or ``checkpoint.prev.pkl``).

    Parameters
    ----------
    run_dir : Path
    previous : bool
        Read the previous checkpoint instead of the current one.

    Returns
    -------
    state : GAState
    config : dict
        The optimiser config (``OptimiserConfig.model_dump(mode="json")``) of the run.

    Raises
    ------
    FileNotFoundError
        No checkpoint in ``run_dir``.
    RunDirectoryError
        The checkpoint is damaged: truncated, empty, not a pickle, not a GA state or of another
        format. When the previous checkpoint is intact, the message says how to resume from it.
    """
    run_dir = Path(run_dir)
    path = run_dir / (PREVIOUS_NAME if previous else CHECKPOINT_NAME)
    if not path.exists():
        if previous:
            raise FileNotFoundError(f"{path}: no previous checkpoint (one is kept from the second generation on)")
        raise FileNotFoundError(f"{path}: no checkpoint (was the run started?)")
    try:
        return _read(path)
    except RunDirectoryError as exc:
        if previous:
            raise
        gen = previous_generation(run_dir)
        if gen is None:
            raise RunDirectoryError(f"{exc}; no intact previous checkpoint ({PREVIOUS_NAME}) to fall back on") from None
        raise RunDirectoryError(f"{exc}; the previous checkpoint {PREVIOUS_NAME} (generation {gen}) is intact: "
                                f"continue from it with `whisker-opt resume {run_dir} --from-previous`") from None


def restore_previous(run_dir: Path) -> int:
    """Put ``checkpoint.prev.pkl`` back as the current checkpoint; returns its generation.

    The current checkpoint, if any, is kept as ``checkpoint.damaged.pkl``. Nothing is changed
    unless the previous checkpoint reads back.

    Parameters
    ----------
    run_dir : Path

    Returns
    -------
    int
        Generation of the restored checkpoint.

    Raises
    ------
    FileNotFoundError
        No ``checkpoint.prev.pkl``.
    RunDirectoryError
        It is damaged too.
    """
    run_dir = Path(run_dir)
    state, _ = load_checkpoint(run_dir, previous=True)
    current = run_dir / CHECKPOINT_NAME
    if current.exists() and not current.is_file():
        raise RunDirectoryError(f"{current}: not a file; move it away, then resume with --from-previous again")
    if current.is_file():
        shutil.copyfile(current, run_dir / DAMAGED_NAME)
    atomic_write_bytes(current, (run_dir / PREVIOUS_NAME).read_bytes())
    logger.info("%s: continuing from the previous checkpoint (generation %d); the replaced one is kept as %s",
                run_dir, state.generation, DAMAGED_NAME)
    return state.generation


def has_checkpoint(run_dir: Path) -> bool:
    """True when ``run_dir`` holds a checkpoint."""
    return (Path(run_dir) / CHECKPOINT_NAME).is_file()


def remove_stale_temporaries(run_dir: Path) -> int:
    """Delete temporary files left by a kill during an atomic write; returns how many."""
    n = 0
    for p in Path(run_dir).glob(".*.tmp"):
        try:
            p.unlink()
            n += 1
        except OSError:
            pass
    return n
