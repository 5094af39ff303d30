"""One line per problem of a run file: the key path, the value given and what is allowed.

:func:`describe_errors` turns a pydantic :class:`~pydantic.ValidationError` into lines
``SOURCE: section.key: <what>``. The range, unit and allowed words of a key are read from
the model field the error's location points to (:mod:`whisker_opt.config.fields`, the same
functions that write ``docs/config.md``), never from pydantic's English text or a description:

- out of range: ``scene.contact_ratio: 1.5 is outside the allowed range (0, 1] (-)``,
  ``optimiser.ga.population: 1 is outside 2..10000 (-)``;
- NaN or infinity: ``design.L: not a finite number (got nan)``;
- a word that is not allowed: ``'mpi' is not one of the allowed words: 'serial', ...``;
- an unknown key: ``unknown key 'alpha_degg'; did you mean 'alpha'?`` (old names of renamed
  keys are matched too, and suggest the new name);
- a wrong type: ``expected a number in (0, 100] (mm), got 'abc'``.
"""

from __future__ import annotations

import difflib
import math
import re
import reprlib
from pathlib import Path
from typing import Any, Sequence, get_origin

from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

from whisker_opt.config.fields import choices, field_range, field_unit, is_model, item_model, num, strip_optional

#: Longest rendering of a value given, in characters (longer values are cut with "…").
MAX_SHOWN = 60
#: Longest description of one problem, in characters.
MAX_LINE = 400

_RANGE_TYPES = frozenset({"greater_than", "greater_than_equal", "less_than", "less_than_equal"})
_WRONG_TYPES = frozenset({
    "int_parsing", "int_type", "int_from_float", "float_parsing", "float_type", "bool_parsing", "bool_type",
    "string_type", "string_unicode", "path_type", "model_type", "model_attributes_type", "dict_type",
    "tuple_type", "list_type", "literal_error", "iterable_type", "is_instance_of",
})
_PLAIN_KEY = re.compile(r"[A-Za-z0-9_\-]+")


#: Bounded ``repr`` of nested values (a YAML file can share one huge list many times through aliases).
_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxdict, _REPR.maxlist, _REPR.maxtuple, _REPR.maxset = 3, 4, 6, 6, 6
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 2 * MAX_SHOWN, MAX_SHOWN, MAX_SHOWN


def _cut(text: str, limit: int = MAX_SHOWN) -> str:
    return text if len(text) <= limit else text[: limit - 1] + "…"


def show(value: Any) -> str:
    """A value as a user wrote it, short and on one line: ``1.5``, ``nan``, ``'abc'``, ``null``,
    ``a list [1, 2]``, ``a mapping {...}``.

    Parameters
    ----------
    value : Any
        What the YAML file gave.

    Returns
    -------
    str
    """
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return num(value).replace("∞", "inf").replace("−", "-") if not math.isfinite(value) else repr(value)
    if isinstance(value, int):
        if value.bit_length() > 4000:  # str() of an integer this long is refused by Python
            return f"an integer of about {int(value.bit_length() * 0.30103)} digits"
        digits = str(value)
        return digits if len(digits) <= 24 else f"{digits[:12]}… ({len(digits.lstrip('-'))} digits)"
    if isinstance(value, str):
        return "an empty string ''" if value == "" else _cut(repr(value[: 2 * MAX_SHOWN]))
    if isinstance(value, dict):
        return "a mapping " + _cut(_REPR.repr(value), MAX_SHOWN - 10)
    if isinstance(value, (list, tuple)):
        return "a list " + _cut(_REPR.repr(list(value)), MAX_SHOWN - 7)
    if isinstance(value, (bytes, bytearray)):
        return "binary data"
    if isinstance(value, BaseModel):  # a section built in Python: shown by its keys, not by its class
        return "a section " + _cut(_REPR.repr(value.model_dump(mode="json")), MAX_SHOWN - 10)
    return f"a {type(value).__name__} {_cut(_REPR.repr(value), MAX_SHOWN - 10)}"


def key_path(loc: Sequence[Any]) -> str:
    """``section.key`` of an error location; list positions are numbers, odd keys are quoted."""
    if not loc:
        return "(top level)"
    parts = []
    for p in loc:
        if isinstance(p, int) and not isinstance(p, bool):
            parts.append(str(p))
        elif isinstance(p, str) and _PLAIN_KEY.fullmatch(p):
            parts.append(p)
        else:
            parts.append(_cut(_REPR.repr(p), 40))
    return ".".join(parts)


def resolve(root: type[BaseModel], loc: Sequence[Any]) -> tuple[type[BaseModel] | None, FieldInfo | None]:
    """What an error location points to in the model tree.

    Parameters
    ----------
    root : type[BaseModel]
        The model that was validated.
    loc : sequence
        The error's location (keys and list positions).

    Returns
    -------
    tuple
        ``(model, field)``: the model class when the location is a section or a list entry
        (else None), and the ``FieldInfo`` of the last key (None at the top level, at a list
        entry, or when the location is not a declared key).
    """
    cls: type[BaseModel] | None = root
    info: FieldInfo | None = None
    i = 0
    while i < len(loc):
        p = loc[i]
        if cls is None or not isinstance(p, str) or p not in cls.model_fields:
            return None, None
        info = cls.model_fields[p]
        tp, _ = strip_optional(info.annotation)
        item = item_model(tp)
        cls = tp if is_model(tp) else None
        i += 1
        if item is not None and i < len(loc) and isinstance(loc[i], int):
            cls, info = item, None
            i += 1
    return cls, info


def _unknown_key(root: type[BaseModel], loc: Sequence[Any]) -> str:
    key = loc[-1]
    parent, _ = resolve(root, loc[:-1])
    if parent is None:
        return f"unknown key {key!r}"
    renamed = dict(getattr(parent, "RENAMED", {}) or {})
    names = list(parent.model_fields)
    by_lower: dict[str, str] = {}
    for cand in names + list(renamed):
        by_lower.setdefault(cand.lower(), renamed.get(cand, cand))
    close = difflib.get_close_matches(str(key).lower(), list(by_lower), n=1, cutoff=0.6)
    if close:
        return f"unknown key {key!r}; did you mean {by_lower[close[0]]!r}?"
    where = f"of {key_path(loc[:-1])}" if len(loc) > 1 else "at the top level"
    return f"unknown key {key!r}; the keys {where} are: {', '.join(names)}"


def _out_of_range(value: Any, annotation: Any, rng: str, unit: str) -> str:
    u = f" ({unit})" if unit else ""
    if strip_optional(annotation)[0] is int:
        return f"{show(value)} is outside {rng}{u}"
    return f"{show(value)} is outside the allowed range {rng}{u}"


def _expected(cls: type[BaseModel] | None, info: FieldInfo | None) -> str:
    """What the key takes, in words: ``a number in (0, 1] (-)``, ``true or false``, ..."""
    if cls is not None and info is None:  # a list entry or the whole file
        return f"{getattr(cls, 'SHAPE', 'a mapping of keys')}"
    if info is None:
        return "a value of another type"
    tp, optional = strip_optional(info.annotation)
    rng, unit = field_range(info.annotation, info), field_unit(info)
    u = f" ({unit})" if unit else ""
    if is_model(tp):
        text = f"{getattr(tp, 'SHAPE', 'a mapping of keys')} (a section)"
    elif item_model(tp) is not None:
        text = f"a list of entries, each {getattr(item_model(tp), 'SHAPE', 'a mapping of keys')}"
    elif choices(info.annotation):
        text = "one of " + ", ".join(repr(c) for c in choices(info.annotation))
    elif tp is bool:
        text = "true or false"
    elif tp is int:
        text = f"an integer in {rng}{u}" if rng else "an integer"
    elif tp is float:
        text = f"a number in {rng}{u}" if rng else "a number"
    elif tp is str:
        text = f"text of {rng}" if rng else "text"
    elif isinstance(tp, type) and issubclass(tp, Path):
        text = "a path (text)"
    elif get_origin(tp) in (tuple, list):
        text = "a list"
    else:
        text = f"a {getattr(tp, '__name__', str(tp))}"
    return f"{text} or null" if optional else text


def as_written(loc: Sequence[Any], root: type[BaseModel], data: Any) -> tuple[tuple, str]:
    """The location as the file wrote it: an old name of a renamed key instead of the new one.

    Parameters
    ----------
    loc : sequence
        The error's location (new key names: renamed keys are renamed before validation).
    root : type[BaseModel]
    data : Any
        What was validated, or None.

    Returns
    -------
    tuple
        ``(location, note)``; ``note`` is ``" (Q is the old name of Q_i)"`` when a key was
        renamed, else ``""``.
    """
    out, note, node, cls = [], "", data, root
    for p in loc:
        shown = p
        if isinstance(node, dict) and isinstance(p, str) and p not in node and cls is not None:
            for old, new in (getattr(cls, "RENAMED", {}) or {}).items():
                if new == p and old in node:
                    shown, note = old, f" ({old} is the old name of {new})"
        out.append(shown)
        if isinstance(node, dict):
            node = node.get(shown)
        elif isinstance(node, (list, tuple)) and isinstance(p, int) and 0 <= p < len(node):
            node = node[p]
        else:
            node = None
        cls, _ = resolve(root, tuple(loc[: len(out)]))
    return tuple(out), note


def describe(error: dict[str, Any], root: type[BaseModel], data: Any = None) -> str:
    """``key.path: <what>`` for one pydantic error (one entry of ``ValidationError.errors()``).

    Parameters
    ----------
    error : dict
        With ``type``, ``loc``, ``msg`` and ``input``.
    root : type[BaseModel]
        The model that was validated.
    data : Any, optional
        What was validated: a renamed key is then named as the file wrote it.

    Returns
    -------
    str
        One line.
    """
    loc, kind, value = tuple(error["loc"]), error["type"], error.get("input")
    ctx = error.get("ctx") or {}
    cls, info = resolve(root, loc)
    rng = field_range(info.annotation, info) if info is not None else ""
    unit = field_unit(info) if info is not None else ""
    if kind == "extra_forbidden":
        what = _unknown_key(root, loc)
    elif kind == "invalid_key":
        what = f"keys must be text, got {show(value)}"
        loc = loc[:-1] + (value,) if loc else loc
    elif kind == "finite_number":
        what = f"not a finite number (got {show(value)})"
    elif kind in _RANGE_TYPES and rng:
        what = _out_of_range(value, info.annotation, rng, unit)
    elif kind == "float_type" and isinstance(value, int) and not isinstance(value, bool) and rng:
        what = _out_of_range(value, info.annotation, rng, unit)  # an integer too large for a float
    elif kind == "literal_error" and info is not None and choices(info.annotation):
        words = ", ".join(repr(c) for c in choices(info.annotation))
        what = f"{show(value)} is not one of the allowed words: {words}"
    elif kind in _WRONG_TYPES:
        got = show(value)
        if value is None and cls is not None:
            got += " (an empty section: write its keys, or leave the section out)"
        what = f"expected {_expected(cls, info)}, got {got}"
    elif kind in ("string_too_short", "string_too_long") and isinstance(value, (str, bytes)):
        what = ("an empty string is not allowed" if not value else f"{show(value)} has {len(value)} characters")
        what += f" (allowed: {rng})" if rng else ""
    elif kind in ("too_short", "too_long") and "actual_length" in ctx:
        what = f"{ctx['actual_length']} entries given; allowed {rng or 'fewer'}"
    elif kind == "missing":
        allowed = rng.replace("`", "") + (f" ({unit})" if unit else "")
        what = "required key is missing" + (f" (allowed: {allowed})" if rng else "")
    elif kind in ("value_error", "assertion_error"):
        what = re.sub(r"^(Value error|Assertion failed), ", "", error["msg"])
    else:
        what = f"{error['msg']} (got {show(value)})"
    loc, note = as_written(loc, root, data) if data is not None else (loc, "")
    where = f"{key_path(loc)}: " if loc or kind not in ("value_error", "assertion_error") else ""  # a check of
    return f"{where}{_cut(what, MAX_LINE)}{note}".replace("\r", " ").replace("\n", " ")  # the whole file names keys


def describe_errors(err: ValidationError, source: str, root: type[BaseModel], data: Any = None) -> list[str]:
    """One line ``SOURCE: key.path: <what>`` per problem of ``err`` (repeated lines dropped).

    Parameters
    ----------
    err : ValidationError
    source : str
        What was read (the file, or ``<mapping>``).
    root : type[BaseModel]
        The model that was validated (the error's locations start there).
    data : Any, optional
        What was validated (see :func:`describe`).

    Returns
    -------
    list of str
    """
    lines: list[str] = []
    for e in err.errors():
        line = f"{source}: {describe(e, root, data)}"
        if line not in lines:
            lines.append(line)
    return lines
