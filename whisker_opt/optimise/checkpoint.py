"""Atomic checkpoints of the GA state, written after every generation.

A checkpoint holds the population, the hall of fame, the logbook, every evaluation record,
the evaluation cache, the Python ``random`` and NumPy RNG states, the counters and the
generation index (the DEAP checkpointing recipe, plus the cache). It is a pickle written
to a temporary file in the same directory, flushed and fsync'ed, then moved over the old
one with :func:`os.replace`, so a kill at any instant leaves either the previous or the
new checkpoint, never a torn one. Resuming restores the state exactly: the resumed run
re-breeds the interrupted generation from the same RNG state, finds the same designs, and
ends with the same population and best as an uninterrupted run.

Individuals are pickled as DEAP ``creator`` instances; :mod:`whisker_opt.optimise.ga` (imported
here) creates those classes at import, which is what makes the pickle loadable.
"""

from __future__ import annotations

import logging
import pickle
from pathlib import Path
from typing import Any

from whisker_opt.optimise.evalcache import EvalCache
from whisker_opt.optimise.ga import GAState  # noqa: F401 - also registers the creator classes
from whisker_opt.output.storage import atomic_write_bytes

logger = logging.getLogger(__name__)

CHECKPOINT_NAME = "checkpoint.pkl"
FORMAT_VERSION = 1


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


def save_checkpoint(run_dir: Path, state: GAState, config: dict[str, Any]) -> Path:
    """Write ``run_dir/checkpoint.pkl`` atomically; returns its path."""
    path = Path(run_dir) / CHECKPOINT_NAME
    atomic_write_bytes(path, pickle.dumps(state_to_dict(state, config), protocol=pickle.HIGHEST_PROTOCOL))
    logger.debug("checkpoint of generation %d written to %s", state.generation, path)
    return path


def load_checkpoint(run_dir: Path) -> tuple[GAState, dict[str, Any]]:
    """Read ``run_dir/checkpoint.pkl``.

    Returns
    -------
    state : GAState
    config : dict
        The optimiser config (``OptimiserConfig.model_dump(mode="json")``) of the run.

    Raises
    ------
    FileNotFoundError
        No checkpoint in ``run_dir``.
    """
    path = Path(run_dir) / CHECKPOINT_NAME
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no checkpoint (was the run started?)")
    with path.open("rb") as fh:
        d = pickle.load(fh)
    return state_from_dict(d), d["config"]


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
