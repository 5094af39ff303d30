"""The GA state as plain JSON data, and back: a checkpoint that loading cannot turn into code.

A checkpoint (:mod:`whisker_opt.optimise.checkpoint`) is the JSON text of :func:`encode`;
:func:`decode` rebuilds the :class:`~whisker_opt.optimise.ga.GAState` from it. Loading uses
:func:`json.loads` and builds nothing but numbers, strings, lists, dictionaries, tuples, NumPy
arrays and scalars of numeric dtypes, :class:`~whisker_opt.experiment.outcome.EvalOutcome` and
the DEAP individuals and hall of fame of this project, chosen by name from a fixed list: a
crafted file can hold wrong values, never code.

Layout (``version`` :data:`FORMAT_VERSION`)::

    {"format": "whisker-opt GA state", "version": 2, "config": {optimiser config},
     "state": {"seed", "generation", "population": [individual], "hof": {"maxsize", "items"},
               "logbook", "records", "cache": {"decimals", "enabled", "cache_failures",
               "entries": [[key, outcome]]}, "rng_py", "rng_np", "n_evaluations", "n_cache_hits",
               "n_failures", "elapsed_s", "stop_reason", "extra"}}

An individual is ``{"class", "genes", "wvalues", "info"}`` (plus ``crowding_dist`` when NSGA-II
set one). Values that JSON cannot hold as they are carry a tag, ``{"$": tag, ...}``: ``tuple``,
``dict`` (non-string keys, or a key ``$``), ``float`` (``nan``, ``inf``, ``-inf``), ``ndarray``
(dtype, shape, values) and ``scalar`` (a NumPy scalar and its dtype). Floats are written with
their shortest exact representation, so every value — the RNG states included — reads back
bit for bit and a resumed run continues exactly where the checkpoint was taken.
"""

from __future__ import annotations

import json
import math
import random
from typing import Any

import numpy as np
from deap import creator, tools

from whisker_opt.experiment.outcome import STATUSES, EvalOutcome
from whisker_opt.optimise.evalcache import EvalCache
from whisker_opt.optimise.ga import GAState

#: The ``format`` field of a checkpoint.
FORMAT_NAME = "whisker-opt GA state"
#: Version of the layout written; 1 was the pickled ``checkpoint.pkl`` of earlier versions.
FORMAT_VERSION = 2
#: DEAP individual classes a checkpoint may name (created at import of :mod:`whisker_opt.optimise.ga`).
INDIVIDUAL_CLASSES: tuple[str, ...] = ("WhiskerIndividual", *(f"WhiskerMOIndividual{m}" for m in range(2, 6)))
#: NumPy dtype kinds a checkpoint may hold: booleans, integers, floats.
_DTYPE_KINDS = "biuf"
_STATE_KEYS = ("seed", "generation", "population", "hof", "logbook", "records", "cache", "rng_py", "rng_np",
               "n_evaluations", "n_cache_hits", "n_failures", "elapsed_s", "stop_reason")


class StateFormatError(ValueError):
    """The data is not a GA state of this format (the message says what is wrong)."""


# ----------------------------------------------------------------------------- plain values
def to_data(x: Any, where: str = "state") -> Any:
    """JSON-ready data of a value (tags in the module docstring).

    Raises
    ------
    TypeError
        A value of another type (named with ``where``, its place in the state).
    """
    if x is None or isinstance(x, (bool, str)) or type(x) is int:
        return x
    if type(x) is float:
        return x if math.isfinite(x) else {"$": "float", "v": repr(x)}
    if isinstance(x, np.ndarray):
        if x.dtype.kind not in _DTYPE_KINDS:
            raise TypeError(f"{where}: a NumPy array of dtype {x.dtype} cannot be stored in a checkpoint")
        return {"$": "ndarray", "dtype": x.dtype.str, "shape": list(x.shape),
                "v": [to_data(v, where) for v in x.ravel().tolist()]}
    if isinstance(x, np.generic):
        if x.dtype.kind not in _DTYPE_KINDS:
            raise TypeError(f"{where}: a NumPy scalar of dtype {x.dtype} cannot be stored in a checkpoint")
        return {"$": "scalar", "dtype": x.dtype.str, "v": to_data(x.item(), where)}
    if isinstance(x, tuple):
        return {"$": "tuple", "v": [to_data(v, where) for v in x]}
    if isinstance(x, list):
        return [to_data(v, where) for v in x]
    if isinstance(x, dict):
        if all(isinstance(k, str) for k in x) and "$" not in x:
            return {k: to_data(v, f"{where}.{k}") for k, v in x.items()}
        return {"$": "dict", "v": [[to_data(k, where), to_data(v, where)] for k, v in x.items()]}
    raise TypeError(f"{where}: a {type(x).__name__} cannot be stored in a checkpoint")


def _dtype(name: Any) -> np.dtype:
    try:
        dt = np.dtype(str(name))
    except TypeError:
        raise StateFormatError(f"unknown dtype {name!r}") from None
    if dt.kind not in _DTYPE_KINDS:
        raise StateFormatError(f"dtype {name!r} is not allowed (booleans, integers and floats only)")
    return dt


def from_data(x: Any) -> Any:
    """Inverse of :func:`to_data`.

    Raises
    ------
    StateFormatError
        An unknown tag or a malformed tagged value.
    """
    if isinstance(x, list):
        return [from_data(v) for v in x]
    if not isinstance(x, dict):
        return x
    if "$" not in x:
        return {k: from_data(v) for k, v in x.items()}
    tag, v = x.get("$"), x.get("v")
    if tag == "tuple" and isinstance(v, list):
        return tuple(from_data(e) for e in v)
    if tag == "dict" and isinstance(v, list) and all(isinstance(e, list) and len(e) == 2 for e in v):
        return {from_data(k): from_data(e) for k, e in v}
    if tag == "float" and v in ("nan", "inf", "-inf"):
        return float(v)
    if tag == "ndarray" and isinstance(v, list) and isinstance(x.get("shape"), list):
        try:
            return np.array([from_data(e) for e in v], dtype=_dtype(x.get("dtype"))).reshape(x["shape"])
        except (TypeError, ValueError, OverflowError) as exc:
            raise StateFormatError(f"malformed array: {exc}") from None
    if tag == "scalar":
        try:
            return _dtype(x.get("dtype")).type(from_data(v))
        except (TypeError, ValueError, OverflowError) as exc:
            raise StateFormatError(f"malformed NumPy scalar: {exc}") from None
    raise StateFormatError(f"unknown or malformed tagged value {str(tag)[:40]!r}")


# ----------------------------------------------------------------------------- DEAP objects
def _individual_data(ind: Any, where: str) -> dict[str, Any]:
    name = type(ind).__name__
    if name not in INDIVIDUAL_CLASSES:
        raise TypeError(f"{where}: a {name} is not an individual of this project")
    d = {"class": name, "genes": to_data(list(ind), where), "wvalues": to_data(list(ind.fitness.wvalues), where),
         "info": to_data(ind.info, f"{where}.info")}
    if "crowding_dist" in vars(ind.fitness):
        d["crowding_dist"] = to_data(ind.fitness.crowding_dist, where)
    return d


def _individual(d: Any) -> Any:
    if not isinstance(d, dict) or d.get("class") not in INDIVIDUAL_CLASSES:
        raise StateFormatError("an individual of an unknown class")
    ind = getattr(creator, d["class"])(float(g) for g in from_data(d["genes"]))
    w = tuple(float(v) for v in from_data(d["wvalues"]))
    if w and len(w) != len(ind.fitness.weights):
        raise StateFormatError(f"an individual with {len(w)} fitness values, expected {len(ind.fitness.weights)}")
    ind.fitness.wvalues = w
    if "crowding_dist" in d:
        ind.fitness.crowding_dist = float(from_data(d["crowding_dist"]))
    info = from_data(d.get("info"))
    if info is not None and not isinstance(info, dict):
        raise StateFormatError("an individual whose info is not a mapping")
    ind.info = info
    return ind


def _hall_of_fame(d: Any) -> Any:
    if not isinstance(d, dict) or not isinstance(d.get("items"), list):
        raise StateFormatError("a hall of fame without items")
    hof = tools.HallOfFame(int(d["maxsize"]))
    hof.items = [_individual(e) for e in d["items"]]
    hof.keys = [ind.fitness for ind in reversed(hof.items)]  # as HallOfFame.insert keeps them
    return hof


def _outcome_data(out: EvalOutcome, where: str) -> dict[str, Any]:
    d = {"status": out.status, "f1": to_data(out.f1, where), "reason": out.reason,
         "timings": to_data(dict(out.timings), f"{where}.timings"),
         "extra": to_data(dict(out.extra), f"{where}.extra")}
    if out.measures:  # an aggregated evaluation's named aggregates (absent otherwise, as in older files)
        d["measures"] = to_data(dict(out.measures), f"{where}.measures")
    return d


def _outcome(d: Any) -> EvalOutcome:
    if not isinstance(d, dict) or d.get("status") not in STATUSES:
        raise StateFormatError("an evaluation outcome without a known status")
    timings, extra = from_data(d.get("timings", {})), from_data(d.get("extra", {}))
    if not isinstance(timings, dict) or not isinstance(extra, dict) or not isinstance(d.get("reason", ""), str):
        raise StateFormatError("a malformed evaluation outcome")
    measures = from_data(d.get("measures", {}))
    if not isinstance(measures, dict):
        raise StateFormatError("a malformed evaluation outcome")
    return EvalOutcome(d["status"], from_data(d.get("f1")), d.get("reason", ""), timings, extra, measures)


def _cache_data(cache: EvalCache) -> dict[str, Any]:
    return {"decimals": cache.decimals, "enabled": cache.enabled, "cache_failures": cache.cache_failures,
            "entries": [[list(k), _outcome_data(v, f"cache[{list(k)}]")] for k, v in cache.entries.items()]}


def _cache(d: Any) -> EvalCache:
    if not isinstance(d, dict) or not isinstance(d.get("entries"), list):
        raise StateFormatError("an evaluation cache without entries")
    entries = {}
    for e in d["entries"]:
        if not isinstance(e, list) or len(e) != 2 or not isinstance(e[0], list):
            raise StateFormatError("a malformed cache entry")
        entries[tuple(float(k) for k in e[0])] = _outcome(e[1])
    return EvalCache(int(d["decimals"]), bool(d["enabled"]), bool(d["cache_failures"]), entries)


def _rng_states(rng_py: Any, rng_np: Any) -> tuple[tuple, tuple]:
    """The two RNG states, checked by installing them in fresh generators."""
    try:
        random.Random().setstate(rng_py)
        np.random.RandomState().set_state(rng_np)
    except (TypeError, ValueError, OverflowError, IndexError) as exc:
        raise StateFormatError(f"a malformed random state: {exc}") from None
    return rng_py, rng_np


# ----------------------------------------------------------------------------- the state
def encode(state: GAState, config: dict[str, Any]) -> bytes:
    """The checkpoint text (UTF-8 JSON) of a state and the optimiser config it runs with.

    Raises
    ------
    TypeError
        The state holds a value a checkpoint cannot store (a bug of the evaluator's ``extra``).
    """
    s = {
        "seed": state.seed,
        "generation": state.generation,
        "population": [_individual_data(ind, f"population[{i}]") for i, ind in enumerate(state.population)],
        "hof": {"maxsize": state.hof.maxsize,
                "items": [_individual_data(ind, f"hof[{i}]") for i, ind in enumerate(state.hof.items)]},
        "logbook": to_data(state.logbook, "logbook"),
        "records": to_data(state.records, "records"),
        "cache": _cache_data(state.cache),
        "rng_py": to_data(state.rng_py, "rng_py"),
        "rng_np": to_data(state.rng_np, "rng_np"),
        "n_evaluations": state.n_evaluations,
        "n_cache_hits": state.n_cache_hits,
        "n_failures": state.n_failures,
        "elapsed_s": to_data(float(state.elapsed_s)),
        "stop_reason": state.stop_reason,
        "extra": to_data(state.extra, "extra"),
    }
    doc = {"format": FORMAT_NAME, "version": FORMAT_VERSION, "config": to_data(config, "config"), "state": s}
    return (json.dumps(doc, separators=(",", ":"), allow_nan=False) + "\n").encode("utf-8")


def read_header(doc: Any) -> int:
    """The version of a decoded checkpoint document.

    Raises
    ------
    StateFormatError
        Not a whisker-opt GA state.
    """
    if not isinstance(doc, dict) or doc.get("format") != FORMAT_NAME:
        raise StateFormatError("no 'format' field naming a whisker-opt GA state")
    version = doc.get("version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise StateFormatError(f"'version' is {version!r}, expected an integer")
    return version


def decode(doc: dict[str, Any]) -> tuple[GAState, dict[str, Any]]:
    """The state and optimiser config of a decoded checkpoint document of version :data:`FORMAT_VERSION`.

    Raises
    ------
    StateFormatError
        A missing or malformed part (the message names it).
    """
    s = doc.get("state")
    if not isinstance(s, dict):
        raise StateFormatError("no 'state' object")
    missing = [k for k in _STATE_KEYS if k not in s]
    if missing:
        raise StateFormatError(f"missing {', '.join(missing)}")
    config = from_data(doc.get("config"))
    if not isinstance(config, dict):
        raise StateFormatError("no 'config' object")
    try:
        logbook, records, extra = from_data(s["logbook"]), from_data(s["records"]), from_data(s.get("extra", {}))
        if not (isinstance(logbook, list) and isinstance(records, list) and isinstance(extra, dict)
                and all(isinstance(r, dict) for r in logbook + records)):
            raise StateFormatError("logbook and records must be lists of objects, extra an object")
        if not isinstance(s["population"], list):
            raise StateFormatError("population must be a list")
        rng_py, rng_np = _rng_states(from_data(s["rng_py"]), from_data(s["rng_np"]))
        stop = s["stop_reason"]
        if stop is not None and not isinstance(stop, str):
            raise StateFormatError("stop_reason must be a string or null")
        state = GAState(
            seed=int(s["seed"]), generation=int(s["generation"]),
            population=[_individual(e) for e in s["population"]], hof=_hall_of_fame(s["hof"]),
            logbook=logbook, records=records, cache=_cache(s["cache"]), rng_py=rng_py, rng_np=rng_np,
            n_evaluations=int(s["n_evaluations"]), n_cache_hits=int(s["n_cache_hits"]),
            n_failures=int(s["n_failures"]), elapsed_s=float(from_data(s["elapsed_s"])), stop_reason=stop,
            extra=extra,
        )
    except StateFormatError:
        raise
    except (TypeError, ValueError, KeyError, OverflowError, AttributeError) as exc:
        raise StateFormatError(f"{type(exc).__name__}: {exc}") from None
    return state, config
