"""The finished work of a long study, kept in its output folder so that a killed study continues.

``compensate --map`` (a cell each), ``robustness`` (a deviated design each) and ``calibrate``
(a model evaluation each) record every finished piece of work in a :class:`StudyJournal`: a
JSON file in the output folder, replaced atomically after each piece
(:func:`whisker_opt.output.storage.atomic_write_text`), holding the kind of study, a digest
of its inputs (the resolved config and the study's own options) and the work done, each under
a key of its own. Started again with the same inputs into the same folder, the study reads
the pieces back instead of computing them: floats are stored by their shortest round-trip
text (NaN and infinities as ``NaN``/``Infinity``), so what is read back is bit for bit what
was computed, and the study ends with the same result as one that was never stopped. A
journal of other inputs (a changed config or option), of another study, or one that cannot
be read is never mixed in: a warning names it and the study starts from the beginning,
replacing it. Each piece is kept with the SHA-256 of the journal's inputs, its key and its value
(:func:`piece_digest`): a piece that does not match it (a journal edited by hand, or damaged
inside a valid JSON text) is not believed, and the study is refused in one line
(:class:`JournalError`) rather than fed a value it did not compute. The journal is removed once
the study's outputs are written.

A study run without an output folder makes a new one under ``output.results_dir``; run again the same
way after a stop, it finds the folder of the stopped study by its journal (:func:`find_unfinished`: the
same kind and inputs, the resolved config among them) and continues there.
"""

from __future__ import annotations

import glob
import hashlib
import json
import logging
import time
from pathlib import Path
from typing import Any, Mapping

from whisker_opt.output import storage

logger = logging.getLogger(__name__)

#: Version of the journal's layout (2: each piece with its digest).
JOURNAL_FORMAT = 2


class JournalError(ValueError):
    """A journal whose pieces do not match their digests (a user error: the message names the file and the way out)."""


def piece_digest(inputs: str, key: str, value: Any) -> str:
    """SHA-256 (hex) of a piece of a journal: the digest of its inputs, its key and its value's canonical JSON."""
    text = json.dumps([inputs, key, value], sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def inputs_digest(inputs: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of a study's inputs (sorted keys, floats by repr).

    Parameters
    ----------
    inputs : mapping
        JSON-able values (lists, dicts, numbers, strings); anything else by its ``str``.

    Returns
    -------
    str
    """
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class StudyJournal:
    """The finished pieces of one study in ``folder / name`` (see the module docstring).

    Parameters
    ----------
    folder : Path
        The study's output folder (existing, writable).
    name : str
        File name, e.g. ``compensation_map.partial.json``.
    kind : str
        The study (``compensation_map``, ``robustness``, ``calibration``).
    inputs : mapping
        Everything the result depends on (:func:`inputs_digest`).
    min_interval : float
        Least time between two writes [s]; the pieces in between are written with the next one
        or by :meth:`flush` (0: after every piece).
    """

    def __init__(self, folder: Path, name: str, kind: str, inputs: Mapping[str, Any],
                 min_interval: float = 0.0) -> None:
        self.path = Path(folder) / name
        self.kind = kind
        self.digest = inputs_digest(inputs)
        self.min_interval = float(min_interval)
        self.done: dict[str, Any] = {}
        self._sha: dict[str, str] = {}
        self.reused = 0
        self._written = 0.0
        self._dirty = False
        self._load()

    def _load(self) -> None:
        if not self.path.exists() and not self.path.is_symlink():
            return
        why = ""
        try:
            doc = json.loads(self.path.read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError) as exc:  # RecursionError: nested too deeply
            why = f"unreadable ({getattr(exc, 'strerror', None) or type(exc).__name__})"
            doc = None
        if doc is not None:
            if not isinstance(doc, dict) or doc.get("format") != JOURNAL_FORMAT or doc.get("kind") != self.kind:
                why = f"not a {self.kind} journal of format {JOURNAL_FORMAT}"
            elif doc.get("inputs") != self.digest:
                why = "made with other inputs (config or options changed)"
            elif not isinstance(doc.get("done"), dict) or not isinstance(doc.get("sha256"), dict):
                why = "damaged (no finished work in it)"
        if why:
            logger.warning("%s: %s; not used, the %s starts from the beginning and replaces it", self.path, why,
                           self.kind.replace("_", " "))
            return
        for key, value in doc["done"].items():
            if doc["sha256"].get(key) != piece_digest(self.digest, key, value):
                raise JournalError(f"{self.path}: the finished piece {key[:80]!r} does not match its digest (the "
                                   f"journal was edited or damaged), so none of it is believed: delete {self.path} "
                                   f"to start the {self.kind.replace('_', ' ')} from the beginning")
        self.done = dict(doc["done"])
        self._sha = dict(doc["sha256"])
        if self.done:
            logger.warning("%s: continuing a %s that was stopped: %d finished piece(s) read back", self.path,
                           self.kind.replace("_", " "), len(self.done))

    def get(self, key: str) -> Any:
        """The stored piece ``key`` (None when not done); counted in :attr:`reused`."""
        value = self.done.get(key)
        if value is not None:
            self.reused += 1
        return value

    def __contains__(self, key: str) -> bool:
        return key in self.done

    def record(self, key: str, value: Any) -> None:
        """Store a finished piece (not None) and write the journal (see ``min_interval``)."""
        self.done[key] = value
        self._sha[key] = piece_digest(self.digest, key, value)
        self._dirty = True
        if time.monotonic() - self._written >= self.min_interval:
            self.flush()

    def flush(self) -> None:
        """Write the journal now when a piece was recorded since the last write."""
        if not self._dirty:
            return
        doc = {"format": JOURNAL_FORMAT, "kind": self.kind, "inputs": self.digest, "done": self.done,
               "sha256": self._sha}
        storage.atomic_write_text(self.path, json.dumps(doc, allow_nan=True, separators=(",", ":")) + "\n")
        self._written = time.monotonic()
        self._dirty = False

    def finish(self) -> None:
        """Remove the journal (the study's outputs are written)."""
        self._dirty = False
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass


def find_unfinished(results_dir: Path | str, prefix: str, name: str, kind: str,
                    inputs: Mapping[str, Any]) -> Path | None:
    """The folder of a stopped study with these inputs: the newest ``results_dir/prefix*`` holding a journal
    ``name`` of ``kind`` whose digest is that of ``inputs`` (None when there is none).

    Parameters
    ----------
    results_dir : path
        Where the study makes its folders (``output.results_dir``).
    prefix : str
        The start of their names (``<name>-<command>-``).
    name, kind : str
        The journal's file name and kind (as :class:`StudyJournal` takes them).
    inputs : mapping
        The study's inputs (:func:`inputs_digest`).
    """
    digest = inputs_digest(inputs)
    found = []
    for folder in Path(results_dir).glob(glob.escape(prefix) + "*"):
        path = folder / name
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
            mtime = path.stat().st_mtime
        except (OSError, ValueError, RecursionError):
            continue
        if (isinstance(doc, dict) and doc.get("format") == JOURNAL_FORMAT and doc.get("kind") == kind
                and doc.get("inputs") == digest):
            found.append((mtime, folder.name, folder))
    return max(found)[2] if found else None
