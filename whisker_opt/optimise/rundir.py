"""A run directory's config as part of its state, and the folder a new run may be written into.

Config
    A run records its resolved run file (``config.yaml`` read back with every default filled in)
    and the SHA-256 of its canonical JSON (:func:`config_digest`) in ``optimiser.json`` and in
    every checkpoint (``state.extra["run_config"]``, ``state.extra["run_config_sha256"]``).
    ``resume`` compares ``config.yaml`` with it (:func:`check_config`; keys a later version added
    count as unchanged at their defaults): an edited file is
    refused with :class:`ConfigChanged`, naming the keys that differ, unless the user allows
    the change; an allowed change is applied from the next generation on and recorded in
    ``state.extra["config_changes"]`` (shown by ``whisker-opt report`` and in ``best.json``).

Target folder of ``run``
    :func:`check_run_target` accepts a missing or empty folder, or one holding only a run of the
    same config killed before its first checkpoint (which starts again). A folder holding a run
    is refused unless ``overwrite`` is given, which empties it first (:func:`clear_run_dir`); a
    non-empty folder holding no run is refused, and is never emptied. A folder whose ``config.yaml``
    names another command (:func:`whisker_opt.config.model.recorded_command`) holds no run.

Target folder of the other commands
    :func:`check_output_folder` refuses, for a command that writes into an output folder (``export``,
    ``compensate``, ``calibrate``, ...), a folder holding a GA run or the results of another command, as
    the first line of its ``config.yaml`` names it; a new or empty folder, one of the same command's, or
    one of an earlier version (its ``config.yaml`` names no command) is accepted.
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

from whisker_opt.config.model import recorded_command
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GENE_NAMES
from whisker_opt.optimise.checkpoint import CHECKPOINT_NAME, OLDER_NAME, RunDirectoryError, has_checkpoint
from whisker_opt.output import storage
from whisker_opt.output.lock import LOCK_NAME

logger = logging.getLogger(__name__)

CONFIG_YAML = "config.yaml"
#: Sections of the run file a running GA cannot take over (its individuals and streams depend on them).
FIXED_KEYS = ("optimiser.algorithm", "optimiser.objectives", "seed")
#: The flag of ``whisker-opt resume`` that continues with an edited ``config.yaml``.
ALLOW_FLAG = "--allow-config-change"


class ConfigChanged(RunDirectoryError):
    """``config.yaml`` of a run directory differs from the config the run was started with."""


def config_digest(resolved: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of a resolved config's canonical JSON (sorted keys, no spaces)."""
    text = json.dumps(resolved, sort_keys=True, separators=(",", ":"), allow_nan=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _flat(d: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(d, Mapping) and d:
        out: dict[str, Any] = {}
        for k, v in d.items():
            out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    return {prefix: d}


def config_differences(old: Mapping[str, Any] | None, new: Mapping[str, Any]) -> list[str]:
    """``key: old -> new`` for every leaf that differs (``key: changed`` when the old config is unknown)."""
    if old is None:
        return ["(the config the run started with is not recorded)"]
    a, b = _flat(old), _flat(new)
    missing = object()
    return [f"{k}: {a.get(k, 'absent')!r} -> {b.get(k, 'absent')!r}" for k in sorted(set(a) | set(b))
            if a.get(k, missing) != b.get(k, missing)]


@dataclass(frozen=True)
class ConfigChange:
    """An allowed change of a run's ``config.yaml``, applied from the next generation on.

    Attributes
    ----------
    after_generation : int
        The last generation run with the old config (−1: none).
    sha256_before, sha256_after : str
        Digests of the old and the new resolved config.
    differences : tuple of str
        ``key: old -> new`` per changed key.
    optimiser : OptimiserConfig
        The new config's optimiser section, which the run continues with.
    """

    after_generation: int
    sha256_before: str
    sha256_after: str
    differences: tuple[str, ...]
    optimiser: OptimiserConfig

    def record(self) -> dict[str, Any]:
        """What ``state.extra["config_changes"]`` keeps of it."""
        return {"after_generation": self.after_generation, "sha256_before": self.sha256_before,
                "sha256_after": self.sha256_after, "differences": list(self.differences)}


def stored_config(run_dir: Path, extra: Mapping[str, Any] | None) -> tuple[str | None, dict | None]:
    """(digest, resolved config) a run recorded: from its state's ``extra``, else ``optimiser.json``."""
    if extra and extra.get("run_config_sha256"):
        return extra["run_config_sha256"], extra.get("run_config")
    try:
        meta = json.loads((Path(run_dir) / storage.OPTIMISER_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # RecursionError: nested too deeply
        return None, None
    if not isinstance(meta, dict) or not isinstance(meta.get("run_config_sha256"), str):
        return None, None
    return meta["run_config_sha256"], meta.get("run_config")


def check_config(run_dir: Path, extra: Mapping[str, Any] | None, generation: int, resolved: Mapping[str, Any],
                 optimiser: OptimiserConfig, allow: bool) -> ConfigChange | None:
    """Compare ``config.yaml`` (``resolved``) with the config the run recorded.

    Parameters
    ----------
    run_dir : Path
    extra : mapping or None
        ``state.extra`` of the run's checkpoint (None before its first one).
    generation : int
        The run's last completed generation (−1 before its first checkpoint).
    resolved : mapping
        ``config.yaml`` as it is now, resolved (``model_dump(mode="json")``).
    optimiser : OptimiserConfig
        Its optimiser section.
    allow : bool
        Continue with a changed config (``--allow-config-change``).

    Returns
    -------
    ConfigChange or None
        None when nothing changed (or the run recorded no config).

    Raises
    ------
    ConfigChanged
        The config changed and ``allow`` is False, or a key of :data:`FIXED_KEYS` or the genome (the names of
        ``optimiser.genes``, which the checkpoint's individuals follow) changed.
    """
    digest, old = stored_config(run_dir, extra)
    new_digest = config_digest(resolved)
    if digest is None or digest == new_digest or _same_with_new_defaults(old, resolved):
        return None
    diffs = config_differences(old, resolved)
    path = Path(run_dir) / CONFIG_YAML
    shown = "; ".join(diffs[:6]) + (f"; and {len(diffs) - 6} more" if len(diffs) > 6 else "")
    fixed = [d for d in diffs if any(d.startswith(k + ":") or d.startswith(k + ".") for k in FIXED_KEYS)]
    if fixed:
        raise ConfigChanged(f"{path}: edited since the run started ({'; '.join(fixed[:3])}); a run cannot continue "
                            f"under another {', '.join(FIXED_KEYS)}: restore the file, or start a new run")
    genome, bred = tuple(optimiser.genes.names()), tuple((extra or {}).get("gene_names") or GENE_NAMES)
    if generation >= 0 and genome != bred:
        raise ConfigChanged(f"{path}: optimiser.genes names the genome ({', '.join(genome)}), the run's checkpoint "
                            f"holds individuals of ({', '.join(bred)}); a run cannot continue under another genome: "
                            "restore the genes (their bounds may change), or start a new run")
    if not allow:
        raise ConfigChanged(f"{path}: edited since the run started ({shown}); restore it, or continue with the new "
                            f"config with `whisker-opt resume {run_dir} {ALLOW_FLAG}` (the change is recorded)")
    return ConfigChange(generation, digest, new_digest, tuple(diffs), optimiser)


def check_state_config(run_dir: Path, extra: Mapping[str, Any] | None) -> None:
    """Refuse a checkpoint written under another config than the run's ``config.yaml`` (what ``report`` reads).

    Nothing is checked when the checkpoint records no config (an earlier version) or ``config.yaml`` is
    missing or does not load (``report`` does not need it).

    Raises
    ------
    ConfigChanged
        One line naming both files and the keys that differ: the checkpoint is another run's, or
        ``config.yaml`` was edited since it was written.
    """
    from whisker_opt.config.model import ConfigError, load_config

    digest = (extra or {}).get("run_config_sha256")
    path = Path(run_dir) / CONFIG_YAML
    if not isinstance(digest, str) or not path.is_file():
        return
    try:
        resolved = load_config(path).model_dump(mode="json")
    except ConfigError:
        return
    old = (extra or {}).get("run_config")
    if digest == config_digest(resolved) or _same_with_new_defaults(old, resolved):
        return
    diffs = config_differences(old if isinstance(old, Mapping) else None, resolved)
    shown = "; ".join(diffs[:4]) + (f"; and {len(diffs) - 4} more" if len(diffs) > 4 else "")
    raise ConfigChanged(f"{Path(run_dir) / CHECKPOINT_NAME}: written under another config than {path} ({shown}); "
                        f"it is another run's checkpoint, or {CONFIG_YAML} was edited since: restore the run's files "
                        f"(an edit is continued with `whisker-opt resume {run_dir} {ALLOW_FLAG}`)")


def _same_with_new_defaults(old: Mapping[str, Any] | None, resolved: Mapping[str, Any]) -> bool:
    """True when the recorded config, read by this version, is ``resolved``: the run directory of an
    earlier version whose ``config.yaml`` was not edited, the keys added since at their defaults."""
    if not isinstance(old, Mapping):
        return False
    from whisker_opt.config.model import WhiskerConfig

    try:
        return WhiskerConfig.model_validate(dict(old)).model_dump(mode="json") == dict(resolved)
    except ValueError:
        return False


def record_config(state: Any, resolved: Mapping[str, Any] | None, change: ConfigChange | None) -> None:
    """Keep the resolved config and its digest in ``state.extra``; append an allowed change."""
    if resolved is None:
        return
    if change is not None:
        state.extra.setdefault("config_changes", []).append(change.record())
        logger.warning("config.yaml changed after generation %d and the run continues with it (%s): %s",
                       change.after_generation, ALLOW_FLAG, "; ".join(change.differences))
    state.extra["run_config"] = dict(resolved)
    state.extra["run_config_sha256"] = config_digest(resolved)


def write_run_metadata(run_dir: Path, cfg_opt: OptimiserConfig, seed: int,
                       run_config: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Write ``optimiser.json`` (what a resume needs), then ``environment.json``.

    Parameters
    ----------
    run_dir : Path
        An existing run directory.
    cfg_opt : OptimiserConfig
    seed : int
        Master seed of the run.
    run_config : mapping, optional
        The resolved run file, stored with its digest (``run_config``, ``run_config_sha256``).

    Returns
    -------
    dict
        The optimiser config as stored (``cfg_opt.model_dump(mode="json")``).
    """
    config = cfg_opt.model_dump(mode="json")
    meta: dict[str, Any] = {"seed": int(seed), "optimiser": config}
    if run_config is not None:
        meta.update(run_config=dict(run_config), run_config_sha256=config_digest(run_config))
    storage.write_json(Path(run_dir) / storage.OPTIMISER_JSON, meta)
    storage.write_environment(run_dir, seed)
    return config


def complete_metadata(run_dir: Path, config: dict[str, Any], seed: int) -> None:
    """Write ``optimiser.json`` and ``environment.json`` when a kill came before them."""
    run_dir = Path(run_dir)
    if not (run_dir / storage.OPTIMISER_JSON).is_file():
        storage.write_json(run_dir / storage.OPTIMISER_JSON, {"seed": int(seed), "optimiser": config})
        logger.info("wrote the missing %s", storage.OPTIMISER_JSON)
    if not (run_dir / storage.ENVIRONMENT_JSON).is_file():
        storage.write_environment(run_dir, seed)
        logger.info("wrote the missing %s", storage.ENVIRONMENT_JSON)


def rewrite_optimiser_json(run_dir: Path, seed: int, config: dict[str, Any],
                           run_config: Mapping[str, Any] | None = None) -> None:
    """Store a changed optimiser config in ``optimiser.json``, keeping the recorded run file (replaced
    by ``run_config`` when given)."""
    path = Path(run_dir) / storage.OPTIMISER_JSON
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        meta = {}
    keep = {k: meta[k] for k in ("run_config", "run_config_sha256") if isinstance(meta, dict) and k in meta}
    if run_config is not None:
        keep = {"run_config": dict(run_config), "run_config_sha256": config_digest(run_config)}
    storage.write_json(path, {"seed": int(seed), "optimiser": config, **keep})


def change_lines(extra: Mapping[str, Any] | None) -> list[str]:
    """Report lines of the recorded config changes (none when the config never changed)."""
    lines = []
    for c in (extra or {}).get("config_changes", []):
        lines.append(f"config changed after generation {c.get('after_generation')} ({ALLOW_FLAG}): "
                     + "; ".join(c.get("differences", [])))
    return lines


# ----------------------------------------------------------------------------- the target of `run`
def _ignored(name: str) -> bool:
    return name == LOCK_NAME or storage.is_temporary(name)


def check_run_target(run_dir: Path, same_config: Callable[[Path], bool], overwrite: bool = False) -> bool:
    """Refuse a folder a new run must not be written into (module docstring).

    Parameters
    ----------
    run_dir : Path
    same_config : callable
        ``same_config(config_yaml_path)``: the file holds the config of the new run.
    overwrite : bool
        Accept a folder holding a run (it is to be emptied with :func:`clear_run_dir`).

    Returns
    -------
    bool
        True when the folder holds a run that ``overwrite`` is to replace.

    Raises
    ------
    FileExistsError
        One line naming the folder, what it holds and the way out.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return False
    names = sorted(p.name for p in run_dir.iterdir() if not _ignored(p.name))
    if not names:
        return False
    cfg_path = run_dir / CONFIG_YAML
    other = recorded_command(cfg_path)
    is_run = ((cfg_path.is_file() and other in (None, "run")) or (run_dir / storage.OPTIMISER_JSON).is_file()
              or has_checkpoint(run_dir))
    if not is_run and other is not None:
        raise FileExistsError(f"--out {run_dir}: holds the results of `whisker-opt {other}` (named in {cfg_path}); "
                              f"a run needs a new or empty folder: choose another --out")
    if not is_run:
        shown = ", ".join(names[:5]) + (", ..." if len(names) > 5 else "")
        raise FileExistsError(f"{run_dir}: not empty ({len(names)} entries: {shown}) and not a run directory; "
                              f"choose a new or empty folder for --out")
    if overwrite:
        return True
    if has_checkpoint(run_dir):
        name = CHECKPOINT_NAME if (run_dir / CHECKPOINT_NAME).exists() else OLDER_NAME
        raise FileExistsError(f"{run_dir} already holds a run ({name}): continue it with `whisker-opt resume "
                              f"{run_dir}`, choose another --out, or pass --overwrite to delete it and start again")
    if cfg_path.exists() and not same_config(cfg_path):
        raise FileExistsError(f"{run_dir} already holds a run of another config ({cfg_path} differs): continue it "
                              f"with `whisker-opt resume {run_dir}`, choose another --out, or pass --overwrite to "
                              f"delete it and start again")
    return False  # a run of this config killed before its first checkpoint: it starts again


def clear_run_dir(run_dir: Path) -> int:
    """Delete everything in a run directory but its lock file; returns how many entries.

    Call it only while holding the folder's lock, after :func:`check_run_target` said it holds a run.
    """
    n = 0
    for p in sorted(Path(run_dir).iterdir()):
        if p.name == LOCK_NAME:
            continue
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p)
        else:
            p.unlink()
        n += 1
    logger.warning("%s: deleted the %d entries of the run it held (--overwrite)", run_dir, n)
    return n


def _ga_run_file(folder: Path) -> str | None:
    """The file that makes ``folder`` a GA run directory (None: it is none)."""
    for name in (storage.OPTIMISER_JSON, CHECKPOINT_NAME, OLDER_NAME):
        if (folder / name).exists() or (folder / name).is_symlink():
            return name
    return CONFIG_YAML if recorded_command(folder / CONFIG_YAML) == "run" else None


def check_output_folder(folder: Path, command: str, what: str = "--out") -> None:
    """Refuse an output folder that holds a GA run or another command's results (module docstring).

    Parameters
    ----------
    folder : Path
    command : str
        The command about to write there, as :func:`whisker_opt.config.model.dump_config` names it
        (``export``, ``compensate``, ...; ``run`` is checked by :func:`check_run_target`).
    what : str
        How the message names the folder (``--out``).

    Raises
    ------
    FileExistsError
        One line naming the folder, what it holds and what is accepted.
    """
    folder = Path(folder)
    if command == "run" or not folder.is_dir() or not any(not _ignored(p.name) for p in folder.iterdir()):
        return
    accepted = f"`whisker-opt {command}` writes into a new or empty folder or one it wrote before: choose another {what}"
    ga = _ga_run_file(folder)
    if ga is not None:
        raise FileExistsError(f"{what} {folder}: holds a GA run ({ga}), not the results of `whisker-opt {command}`; "
                              + accepted)
    other = recorded_command(folder / CONFIG_YAML)
    if other is not None and other != command:
        raise FileExistsError(f"{what} {folder}: holds the results of `whisker-opt {other}` (named in {CONFIG_YAML}); "
                              + accepted)
