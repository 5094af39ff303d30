"""Atomic checkpoints of the GA state, written after every generation.

A checkpoint holds the population, the hall of fame, the logbook, every evaluation record,
the evaluation cache, the Python ``random`` and NumPy RNG states, the counters and the
generation index (the DEAP checkpointing recipe, plus the cache), with the optimiser config,
as JSON data of a versioned format (:mod:`whisker_opt.optimise.statefile`): reading one never
runs code, so a run directory is safe to share. It is written to a temporary file in the same
directory, flushed and fsync'ed, then moved over the old one with :func:`os.replace`, so a kill
at any instant leaves either the previous or the new checkpoint, never a torn one. Resuming
restores the state exactly: the resumed run re-breeds the interrupted generation from the
same RNG state, finds the same designs, and ends with the same population and best as an
uninterrupted run.

Saving a new checkpoint keeps the one it replaces as ``checkpoint.prev.json`` (hard-linked,
or copied, before the atomic replacement, so ``checkpoint.json`` exists at every instant).
A checkpoint that cannot be read (truncated, empty, not JSON, not a GA state) raises
:class:`RunDirectoryError` naming the file and the damage, and offering the previous one when
it is intact. So does one whose individuals (population and hall of fame) do not fit the
genome of its config: a gene vector of another length, a gene that is not finite, or one outside
its bounds (the GA clamps every gene into them; after an allowed config change, outside the
range of its key). :func:`restore_previous` puts the previous one back in place (``whisker-opt
resume RUN_DIR --from-previous``).

Earlier versions pickled the state into ``checkpoint.pkl`` (format 1). Such a run directory
is refused with :class:`OlderFormatError`, which names the format and what to do; the pickle
is never loaded implicitly. :func:`convert_older_checkpoint` converts it when the user states
that they trust the folder (``whisker-opt resume RUN_DIR --trust-pickle``), and even then
unpickles only the classes a checkpoint of format 1 holds.
"""

from __future__ import annotations

import io
import json
import logging
import math
import os
import pickle
import shutil
from pathlib import Path
from typing import Any

from whisker_opt.optimise.ga import GAState
from whisker_opt.optimise.statefile import (
    FORMAT_VERSION,
    INDIVIDUAL_CLASSES,
    StateFormatError,
    decode,
    encode,
    read_header,
)
from whisker_opt.output.storage import atomic_write_bytes

logger = logging.getLogger(__name__)

CHECKPOINT_NAME = "checkpoint.json"
PREVIOUS_NAME = "checkpoint.prev.json"
DAMAGED_NAME = "checkpoint.damaged.json"
#: The pickled checkpoint of earlier versions (format 1), and the name it is kept under once converted.
OLDER_NAME = "checkpoint.pkl"
CONVERTED_NAME = "checkpoint.format1.pkl"
#: The flag of ``whisker-opt resume`` that converts an older checkpoint.
TRUST_FLAG = "--trust-pickle"


class RunDirectoryError(ValueError):
    """A run directory whose files cannot be used: a damaged checkpoint, ``optimiser.json`` or
    ``config.yaml``, or a folder that is not a run directory (a user error: the message names
    the file and what is wrong with it)."""


class OlderFormatError(RunDirectoryError):
    """A run directory written by an earlier version, whose checkpoint this version does not load."""


def older_format_message(run_dir: Path) -> str:
    """The one-line refusal of a run directory holding a format-1 ``checkpoint.pkl``."""
    run_dir = Path(run_dir)
    return (f"{run_dir / OLDER_NAME}: a checkpoint of an earlier whisker-opt (format 1, a Python pickle); this "
            f"version reads format {FORMAT_VERSION} ({CHECKPOINT_NAME}) and does not load pickles, which can run "
            f"code: start the run again with `whisker-opt run`, or, only if you trust whoever wrote this folder, "
            f"convert it with `whisker-opt resume {run_dir} {TRUST_FLAG}`")


def dangling_link(path: Path) -> str | None:
    """The refusal of a state file that is a symbolic link leading nowhere, or None when it is not one.

    Such a link in place of ``checkpoint.json`` (or ``checkpoint.pkl``) means the run's state is
    missing, not that the run never started: a run directory holding one is refused, never run
    again from generation 0.

    Parameters
    ----------
    path : Path

    Returns
    -------
    str or None
        One line naming the path and what it leads to.
    """
    path = Path(path)
    if not path.is_symlink() or path.exists():
        return None
    try:
        target = os.readlink(path)
    except OSError:
        target = "?"
    return (f"{path}: a symbolic link to {target!r}, which does not exist (or is a loop): the run's state is "
            "missing, so the run is not started again from generation 0; restore what the link leads to, or delete "
            "the run directory (`whisker-opt run CONFIG --out DIR --overwrite`) to start afresh")


def _looks_complete(path: Path) -> bool:
    """Cheap check that ``path`` holds a whole JSON object (``{`` first, ``}`` last but for a newline)."""
    try:
        with path.open("rb") as fh:
            head = fh.read(1)
            fh.seek(max(path.stat().st_size - 2, 0))
            tail = fh.read(2).rstrip(b"\n")
    except OSError:
        return False
    return head == b"{" and tail.endswith(b"}")


def _keep_previous(run_dir: Path) -> None:
    """Make ``checkpoint.prev.json`` the current checkpoint's file (the current one stays in place)."""
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
    """Write ``run_dir/checkpoint.json`` atomically, keeping the one it replaces as
    ``checkpoint.prev.json``; returns its path."""
    run_dir = Path(run_dir)
    path = run_dir / CHECKPOINT_NAME
    data = encode(state, config)
    _keep_previous(run_dir)
    atomic_write_bytes(path, data)
    logger.debug("checkpoint of generation %d written to %s", state.generation, path)
    return path


def _damaged(path: Path, what: str) -> RunDirectoryError:
    return RunDirectoryError(f"{path}: not a whisker-opt checkpoint ({what})")


def _parse(path: Path, data: bytes) -> Any:
    """The JSON document of a checkpoint file's bytes."""
    if data[:1] == b"\x80":
        raise _damaged(path, f"it holds a Python pickle, not the JSON state of format {FORMAT_VERSION}; it was not "
                             "loaded, as loading a pickle can run code")
    try:
        return json.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise _damaged(path, f"truncated or damaged: not UTF-8 text at byte {exc.start}; {len(data)} bytes") from None
    except json.JSONDecodeError as exc:
        raise _damaged(path, f"truncated or damaged: not valid JSON, {exc.msg} at line {exc.lineno} column "
                             f"{exc.colno}; {len(data)} bytes") from None
    except RecursionError:
        raise _damaged(path, "truncated or damaged: nested too deeply") from None
    except ValueError as exc:  # Python's limit on the digits of an integer read from text
        raise _damaged(path, f"damaged: a number too long to read ({' '.join(str(exc).split(';')[0].split())})") from None


def _gene_refusal(x: float, name: str, lo: float, hi: float, changed: bool) -> str | None:
    """Why gene ``name`` = ``x`` of a checkpoint's individual cannot be bred on, or None.

    The GA clamps every gene into its bounds before and after each bounded operator (SBX,
    polynomial mutation) and draws the initial population inside them, so an individual it made
    lies in ``[lo, hi]``. After an allowed config change (``changed``) the bounds may have moved
    since older individuals were bred: the range of the gene's key then holds every legal bound.
    """
    if not math.isfinite(x):
        return f"{x!r}, not a finite number"
    if not changed:
        return None if lo <= x <= hi else f"{x:g}, outside its bounds [{lo:g}, {hi:g}] (optimiser.genes.{name})"
    from whisker_opt.genes import gene_key

    key = gene_key(name)
    return None if key.admits(x) else f"{x:g}, outside the allowed range {key.range_text()} of {name}"


def _check_genomes(path: Path, state: GAState, config: dict[str, Any]) -> None:
    """Refuse a state whose individuals (population and hall of fame) do not fit the genome of its config.

    Raises
    ------
    RunDirectoryError
        One line naming the file, the individual, the gene, its value and the allowed range.
    """
    from whisker_opt.config.optimiser import OptimiserConfig

    try:
        genes = OptimiserConfig.model_validate(config).genes
    except ValueError:
        return  # a damaged config is refused where the run reads it (runner.load_run)
    names, bounds = genes.names(), genes.bounds()
    changed = bool(state.extra.get("config_changes"))
    for group, individuals in (("population", state.population), ("hof", state.hof.items)):
        for i, ind in enumerate(individuals):
            if len(ind) != len(names):
                raise RunDirectoryError(f"{path}: {group}[{i}] has {len(ind)} genes, the run's genome has "
                                        f"{len(names)} ({', '.join(names)})")
            for j, (name, x, (lo, hi)) in enumerate(zip(names, ind, bounds)):
                why = _gene_refusal(float(x), name, lo, hi, changed)
                if why:
                    raise RunDirectoryError(f"{path}: {group}[{i}] gene {j} ({name}) is {why}")


def _differing_keys(a: Any, b: Any, prefix: str = "") -> list[str]:
    """Dotted keys at which two JSON documents differ (a key missing on one side counts)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[str] = []
        for k in sorted(set(a) | set(b), key=str):
            out += _differing_keys(a.get(k), b.get(k), f"{prefix}{k}.")
        return out
    return [] if a == b else [prefix.rstrip(".") or "(the whole section)"]


#: Optimiser keys a resume changes in the checkpoint without editing ``config.yaml``: ``--max-generations``.
RESUME_MAY_CHANGE = ("stopping.max_generations",)


def _check_own_config(path: Path, state: GAState, config: dict[str, Any]) -> None:
    """Refuse a checkpoint whose optimiser section is not the one of the run config its state records.

    A checkpoint keeps the optimiser section twice: as its ``config`` (what a resume breeds with) and inside
    ``state.extra["run_config"]`` (the resolved run file, with its SHA-256, that resume and report compare with
    ``config.yaml``). A resume with an allowed config change rewrites both, and ``resume --max-generations``
    raises the first one's ``stopping.max_generations`` alone (:data:`RESUME_MAY_CHANGE`); two that differ
    otherwise are a checkpoint pieced together from two runs, and neither can be trusted.

    Raises
    ------
    RunDirectoryError
        One line naming the file and the keys that differ.
    """
    recorded = state.extra.get("run_config") if isinstance(state.extra, dict) else None
    if not isinstance(recorded, dict) or not isinstance(recorded.get("optimiser"), dict):
        return  # an earlier run that recorded no run config: nothing to compare
    keys = [k for k in _differing_keys(config, recorded["optimiser"]) if k not in RESUME_MAY_CHANGE]
    if keys:
        shown = ", ".join(keys[:4]) + (f" and {len(keys) - 4} more" if len(keys) > 4 else "")
        raise RunDirectoryError(f"{path}: its optimiser section differs from the run config it records at {shown}: "
                                "not one run's checkpoint (copied from another run, or edited)")


def _read(path: Path) -> tuple[GAState, dict[str, Any]]:
    """State and config of one checkpoint file.

    Raises
    ------
    RunDirectoryError
        The file is not a readable whisker-opt checkpoint (the message names it and the damage).
    """
    try:
        dangling = dangling_link(path)
        if dangling and path.name == PREVIOUS_NAME:
            raise _damaged(path, f"a symbolic link to {os.readlink(path)!r}, which does not exist")
        if dangling:
            raise RunDirectoryError(dangling)
        if not path.is_file():
            raise _damaged(path, "not a regular file")
        data = path.read_bytes()
    except OSError as exc:
        raise RunDirectoryError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if not data:
        raise _damaged(path, "empty file")
    doc = _parse(path, data)
    try:
        version = read_header(doc)
    except StateFormatError as exc:
        raise _damaged(path, str(exc)) from None
    if version > FORMAT_VERSION:
        raise RunDirectoryError(f"{path}: checkpoint format {version} was written by a later whisker-opt; this "
                                f"version reads format {FORMAT_VERSION}: resume it with that version")
    if version != FORMAT_VERSION:
        raise RunDirectoryError(f"{path}: checkpoint format {version} is not supported (this version reads format "
                                f"{FORMAT_VERSION}): start the run again with `whisker-opt run`")
    try:
        state, config = decode(doc)
    except (StateFormatError, RecursionError) as exc:
        msg = " ".join(str(exc).split())
        raise _damaged(path, f"damaged GA state: {msg[:160]}") from None
    _check_own_config(path, state, config)
    _check_genomes(path, state, config)
    return state, config


def previous_generation(run_dir: Path) -> int | None:
    """Generation of ``run_dir/checkpoint.prev.json``, or None when it is missing or unreadable."""
    path = Path(run_dir) / PREVIOUS_NAME
    if not path.is_file():
        return None
    try:
        return _read(path)[0].generation
    except RunDirectoryError:
        return None


def load_checkpoint(run_dir: Path, previous: bool = False) -> tuple[GAState, dict[str, Any]]:
    """Read ``run_dir/checkpoint.json`` (or ``checkpoint.prev.json``).

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
    OlderFormatError
        Only a ``checkpoint.pkl`` of an earlier version (:func:`older_format_message`).
    RunDirectoryError
        The checkpoint is damaged: truncated, empty, not JSON, not a GA state or of another
        format. When the previous checkpoint is intact, the message says how to resume from it.
    """
    run_dir = Path(run_dir)
    path = run_dir / (PREVIOUS_NAME if previous else CHECKPOINT_NAME)
    if not path.exists() and not path.is_symlink():
        if has_older_checkpoint(run_dir):
            raise OlderFormatError(older_format_message(run_dir))
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
    """Put ``checkpoint.prev.json`` back as the current checkpoint; returns its generation.

    The current checkpoint, if any, is kept as ``checkpoint.damaged.json``. Nothing is changed
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
        No ``checkpoint.prev.json``.
    RunDirectoryError
        It is damaged too, or the current checkpoint is not damaged (it reads back).
    """
    run_dir = Path(run_dir)
    state, _ = load_checkpoint(run_dir, previous=True)
    current = run_dir / CHECKPOINT_NAME
    if current.exists() and not current.is_file():
        raise RunDirectoryError(f"{current}: not a file; move it away, then resume with --from-previous again")
    if current.is_file():
        try:
            good = load_checkpoint(run_dir)[0].generation
        except Exception:  # noqa: BLE001 - whatever stops it reading back is the damage --from-previous is for
            good = None
        if good is not None:  # it is not damaged: rolling it back would lose its generations
            raise RunDirectoryError(f"--from-previous: {current} is not damaged (it reads back, generation {good}); "
                                    f"resume without --from-previous: `whisker-opt resume {run_dir}`")
    if current.is_file():
        shutil.copyfile(current, run_dir / DAMAGED_NAME)
    atomic_write_bytes(current, (run_dir / PREVIOUS_NAME).read_bytes())
    logger.info("%s: continuing from the previous checkpoint (generation %d); the replaced one is kept as %s",
                run_dir, state.generation, DAMAGED_NAME)
    return state.generation


def has_checkpoint(run_dir: Path) -> bool:
    """True when ``run_dir`` holds a checkpoint, of this format or an earlier one (a dangling link counts)."""
    path = Path(run_dir) / CHECKPOINT_NAME
    return path.exists() or path.is_symlink() or has_older_checkpoint(run_dir)


def has_older_checkpoint(run_dir: Path) -> bool:
    """True when ``run_dir`` holds a format-1 ``checkpoint.pkl`` and no checkpoint of this format."""
    run_dir = Path(run_dir)
    older = run_dir / OLDER_NAME
    return (older.exists() or older.is_symlink()) and not (run_dir / CHECKPOINT_NAME).exists()


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


# ----------------------------------------------------------------------------- format 1
class _Format1Unpickler(pickle.Unpickler):
    """Unpickles the classes a format-1 checkpoint holds, and nothing else."""

    ALLOWED = frozenset({
        ("builtins", "list"), ("deap.base", "Fitness"), ("deap.tools.support", "HallOfFame"), ("_operator", "eq"),
        ("numpy", "dtype"), ("numpy", "ndarray"), ("whisker_opt.experiment.outcome", "EvalOutcome"),
        *((f"numpy.{core}.{mod}", name) for core in ("core", "_core")
          for mod, name in (("numeric", "_frombuffer"), ("multiarray", "scalar"), ("multiarray", "_reconstruct"))),
    })

    def find_class(self, module: str, name: str) -> Any:  # noqa: D102 - pickle.Unpickler
        from deap import creator

        if (module, name) == ("deap.creator", "meta_create"):
            def existing(cname, base, dct):  # the classes exist (created by whisker_opt.optimise.ga)
                fitness = {"WhiskerFitness"} | {f"WhiskerMOFitness{m}" for m in range(2, 6)}
                if cname not in INDIVIDUAL_CLASSES and cname not in fitness:
                    raise pickle.UnpicklingError(f"class deap.creator.{cname} is not one of a checkpoint")
                return getattr(creator, cname)
            return existing
        if (module, name) in self.ALLOWED:
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"{module}.{name} is not part of a format-1 checkpoint")


def convert_older_checkpoint(run_dir: Path) -> int:
    """Convert the format-1 ``checkpoint.pkl`` of ``run_dir`` to ``checkpoint.json``; returns its generation.

    Only for a run directory the user trusts: the pickle is loaded, though only the classes a
    format-1 checkpoint holds are accepted. The pickle is kept as ``checkpoint.format1.pkl``.

    Raises
    ------
    FileNotFoundError
        No ``checkpoint.pkl`` in ``run_dir``.
    RunDirectoryError
        It is not a readable format-1 checkpoint.
    """
    from whisker_opt.optimise.evalcache import EvalCache

    run_dir = Path(run_dir)
    path = run_dir / OLDER_NAME
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no checkpoint of an earlier version to convert")
    try:
        d = _Format1Unpickler(io.BytesIO(path.read_bytes())).load()
        if not isinstance(d, dict) or d.get("format") != 1:
            raise ValueError(f"format {d.get('format') if isinstance(d, dict) else type(d).__name__!r}, expected 1")
        state = GAState(seed=d["seed"], generation=d["generation"], population=d["population"], hof=d["hof"],
                        logbook=d["logbook"], records=d["records"], cache=EvalCache.from_state(d["cache"]),
                        rng_py=d["rng_py"], rng_np=d["rng_np"], n_evaluations=d["n_evaluations"],
                        n_cache_hits=d["n_cache_hits"], n_failures=d["n_failures"], elapsed_s=d["elapsed_s"],
                        stop_reason=d["stop_reason"], extra=d.get("extra", {}))
        data = encode(state, d["config"])
        decode(json.loads(data))  # what is written reads back
    except Exception as exc:  # noqa: BLE001 - a refused or damaged pickle raises nearly anything
        msg = " ".join(str(exc).split())[:160]
        raise RunDirectoryError(f"{path}: cannot be converted ({type(exc).__name__}: {msg})") from None
    atomic_write_bytes(run_dir / CHECKPOINT_NAME, data)
    os.replace(path, run_dir / CONVERTED_NAME)
    older_prev = run_dir / "checkpoint.prev.pkl"
    if older_prev.is_file():
        os.replace(older_prev, run_dir / "checkpoint.prev.format1.pkl")
    logger.warning("%s: converted the format-1 checkpoint (generation %d) to %s; the pickle is kept as %s",
                   run_dir, state.generation, CHECKPOINT_NAME, CONVERTED_NAME)
    return state.generation
