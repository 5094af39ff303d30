"""Evaluation cache keyed by the rounded genome.

Elites, unchanged clones and designs that crossover/mutation happen to reproduce are
not solved again: an evaluation costs two FE scenes. The key is the tuple of genes rounded to ``decimals`` decimals, so
two genomes closer than half a unit in the last kept decimal share one outcome. The
cache is part of the GA state and is saved with every checkpoint, so a resumed run does
not re-solve anything and reproduces the uninterrupted run exactly.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Iterable

from whisker_opt.experiment.outcome import EvalOutcome

Key = tuple[float, ...]


def genome_key(genes: Iterable[float], decimals: int) -> Key:
    """Rounded genome used as the cache key (``-0.0`` normalised to ``0.0``)."""
    return tuple(round(float(g), decimals) + 0.0 for g in genes)


def evaluation_seed(run_seed: int, key: Key) -> int:
    """Seed handed to the worker for one design: a hash of (run seed, rounded genome).

    The evaluator's own randomness, if any, then depends only on the design and the run
    seed, never on the executor, the worker or the order of evaluation.
    """
    h = hashlib.blake2b(repr((int(run_seed), key)).encode(), digest_size=4)
    return int.from_bytes(h.digest(), "little")


@dataclass
class EvalCache:
    """Mapping rounded genome -> :class:`EvalOutcome` (hits are counted by the GA).

    Parameters
    ----------
    decimals : int
        Rounding of the key.
    enabled : bool
        When False, :meth:`get` always misses and :meth:`put` stores nothing.
    cache_failures : bool
        Store failed outcomes too.
    """

    decimals: int = 6
    enabled: bool = True
    cache_failures: bool = True
    entries: dict[Key, EvalOutcome] = field(default_factory=dict)

    def key(self, genes: Iterable[float]) -> Key:
        """Cache key of a genome."""
        return genome_key(genes, self.decimals)

    def get(self, key: Key) -> EvalOutcome | None:
        """Stored outcome, or None (always None when disabled)."""
        return self.entries.get(key) if self.enabled else None

    def __contains__(self, key: Key) -> bool:
        return self.enabled and key in self.entries

    def put(self, key: Key, outcome: EvalOutcome) -> None:
        """Store an outcome (failures only when ``cache_failures``)."""
        if not self.enabled:
            return
        if outcome.status != "ok" and not self.cache_failures:
            return
        self.entries[key] = outcome

    def __len__(self) -> int:
        return len(self.entries)

    def to_state(self) -> dict:
        """Plain picklable state for a checkpoint."""
        return {
            "decimals": self.decimals,
            "enabled": self.enabled,
            "cache_failures": self.cache_failures,
            "entries": dict(self.entries),
        }

    @classmethod
    def from_state(cls, state: dict) -> "EvalCache":
        """Inverse of :meth:`to_state`."""
        return cls(
            decimals=int(state["decimals"]),
            enabled=bool(state["enabled"]),
            cache_failures=bool(state["cache_failures"]),
            entries=dict(state["entries"]),
        )
