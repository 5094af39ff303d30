"""What a configuration field allows, read from its type and its ``Field`` constraints.

Shared by the generated reference (:mod:`whisker_opt.config.reference`) and the error
messages of :func:`whisker_opt.config.model.format_validation_error`, so that a message
states the same range and unit as ``docs/config.md``. Nothing here reads a description:
the range comes from ``gt``/``ge``/``lt``/``le`` and ``min_length``/``max_length``, the
choices from ``Literal`` types, the unit from ``json_schema_extra={"unit": ...}``.
"""

from __future__ import annotations

import math
import types
from typing import Any, Literal, Union, get_args, get_origin

import annotated_types as at
from pydantic import BaseModel
from pydantic.fields import FieldInfo


def strip_optional(annotation: Any) -> tuple[Any, bool]:
    """Split off ``None`` from an optional annotation.

    Parameters
    ----------
    annotation : Any
        A field's annotation.

    Returns
    -------
    tuple
        ``(inner type, True)`` for ``X | None``, else ``(annotation, False)``.
    """
    if get_origin(annotation) in (Union, types.UnionType):
        args = [a for a in get_args(annotation) if a is not type(None)]
        if len(args) < len(get_args(annotation)) and len(args) == 1:
            return args[0], True
    return annotation, False


def is_model(tp: Any) -> bool:
    """True when ``tp`` is a pydantic model class."""
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def item_model(tp: Any) -> type[BaseModel] | None:
    """The model of ``tuple[Model, ...]`` (or ``list[Model]``), else None."""
    if get_origin(tp) in (tuple, list):
        args = [a for a in get_args(tp) if a is not Ellipsis]
        if len(args) == 1 and is_model(args[0]):
            return args[0]
    return None


def choices(annotation: Any) -> tuple[Any, ...]:
    """The allowed values of a ``Literal`` field (optional or not), else ``()``."""
    tp, _ = strip_optional(annotation)
    return get_args(tp) if get_origin(tp) is Literal else ()


def num(v: float | int) -> str:
    """A number as written in a run file: ``5``, ``0.01``, ``1e-9``, ``1e6``.

    Parameters
    ----------
    v : float or int

    Returns
    -------
    str
    """
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    v = float(v)
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "∞" if v > 0 else "−∞"
    if v != 0.0 and not 1e-4 <= abs(v) < 1e6:  # 1e6, 1e-9: mantissa and exponent
        mantissa, exponent = f"{v:.12e}".split("e")
        return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"
    return str(int(v)) if v.is_integer() else f"{v:.12g}"


def constraints(info: FieldInfo) -> dict[str, Any]:
    """The field's numeric and length constraints by name.

    Parameters
    ----------
    info : FieldInfo

    Returns
    -------
    dict
        Any of ``gt``, ``ge``, ``lt``, ``le``, ``min_length``, ``max_length``.
    """
    out: dict[str, Any] = {}
    for m in info.metadata:
        for name, kind in (("gt", at.Gt), ("ge", at.Ge), ("lt", at.Lt), ("le", at.Le),
                           ("min_length", at.MinLen), ("max_length", at.MaxLen)):
            if isinstance(m, kind):
                out[name] = getattr(m, name)
    return out


def field_range(annotation: Any, info: FieldInfo) -> str:
    """The allowed values of a field, from its type and its ``Field`` constraints.

    Real numbers as an interval, ``(0, 1]``; integers as ``lo..hi``; choices as a list, or the words of
    ``json_schema_extra["listed"]`` that say where the choices of a growing registry are listed (the error
    messages list them); strings and tuples by their length limits.

    Parameters
    ----------
    annotation : Any
        The field's annotation (``X | None`` is read as ``X``).
    info : FieldInfo

    Returns
    -------
    str
        ``""`` when the field has no limits.
    """
    tp, _ = strip_optional(annotation)
    c = constraints(info)
    extra = info.json_schema_extra
    if isinstance(extra, dict) and extra.get("listed"):  # choices of a registry that grows: where they are listed
        return str(extra["listed"])
    if get_origin(tp) is Literal:
        return ", ".join(f"`{a}`" for a in get_args(tp))
    if tp is bool:
        return "`true`, `false`"
    if tp is int:
        lo = c["ge"] if "ge" in c else (c["gt"] + 1 if "gt" in c else None)
        hi = c["le"] if "le" in c else (c["lt"] - 1 if "lt" in c else None)
        if lo is not None and hi is not None:
            return f"{num(lo)}..{num(hi)}"
        if lo is not None:
            return f"≥ {num(lo)}"
        return f"≤ {num(hi)}" if hi is not None else ""
    if tp is float:
        if not any(k in c for k in ("gt", "ge", "lt", "le")):
            return ""
        left = f"({num(c['gt'])}" if "gt" in c else (f"[{num(c['ge'])}" if "ge" in c else "(−∞")
        right = f"{num(c['lt'])})" if "lt" in c else (f"{num(c['le'])}]" if "le" in c else "∞)")
        return f"{left}, {right}"
    lo, hi = c.get("min_length"), c.get("max_length")
    what = "items" if get_origin(tp) in (tuple, list) else "characters"
    if lo is not None and hi is not None:
        return f"{lo}..{hi} {what}"
    if hi is not None:
        return f"at most {hi} {what}"
    return f"at least {lo} {what}" if lo is not None else ""


def field_unit(info: FieldInfo) -> str:
    """The unit of a field (``json_schema_extra["unit"]``), or ``""``."""
    extra = info.json_schema_extra
    return str(extra.get("unit", "")) if isinstance(extra, dict) else ""
