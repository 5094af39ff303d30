"""A commented run file to start from (``whisker-opt init``): every key with its meaning, unit and range.

The file holds every section and key of :class:`whisker_opt.config.model.WhiskerConfig` at
its default, with one comment line per key read from the models (:mod:`whisker_opt.config.fields`),
and a case's own settings (:data:`CASES`) in place of the defaults. It validates as it is.
"""

from __future__ import annotations

import json
from typing import Any, Mapping

import yaml
from pydantic import BaseModel

from whisker_opt.config.fields import field_range, field_unit, is_model, item_model, strip_optional

#: Starting points: a short demo GA, the thesis' reference case 1, one simulated pair. Each writes the
#: values of its shipped run file (:data:`SHIPPED`; ``tests/test_cli_conveniences.py`` compares them).
CASES: dict[str, dict[str, Any]] = {
    "demo": {
        "fidelity": {"preset": "coarse"},
        "optimiser": {"trim": 5.0, "ga": {"population": 6, "n_elite": 1},
                      "stopping": {"max_generations": 2, "target_fp": 1.0e-4},
                      "executor": {"kind": "processes", "n_workers": 2, "timeout_s": 600}},
        "seed": 1,
        "output": {"name": "demo"},
    },
    "case1": {
        "fidelity": {"preset": "default"},
        "optimiser": {"trim": 5.0, "executor": {"kind": "processes", "n_workers": 2, "timeout_s": 900}},
        "seed": 2026,
        "output": {"name": "case1_trim5"},
    },
    "simulate": {
        "fidelity": {"preset": "coarse"},
        "scene": {"Q_i": 0.2, "trim": 5.0, "pair": True},
    },
}

#: The shipped run file (in the repository's ``configs/``) whose values each case of :data:`CASES` writes.
SHIPPED: dict[str, str] = {"demo": "demo.yaml", "case1": "case1_trim5.yaml", "simulate": "simulate_default.yaml"}

_INTRO = {
    "demo": "A short GA over [alpha, l, t, Q_i] on the coarse preset (1-2 min on 2 cores): whisker-opt run FILE",
    "case1": "Reference case 1 (docs/physics.md): the thesis' GA settings, trim 5 mm, preset default at ~1.1-1.2 s "
             "per evaluation on one core (50 generations: about 20 min on 2 cores): whisker-opt run FILE",
    "simulate": "One intact/trimmed pair of the design below: whisker-opt simulate FILE",
}


def _scalar(value: Any) -> str:
    text = yaml.safe_dump(value, default_flow_style=True, width=10_000).strip()
    return text[:-4].strip() if text.endswith("...") else text


def _comment(info) -> str:
    parts = [info.description or ""]
    unit = field_unit(info)
    if unit and unit != "-":
        parts.append(f"[{unit}]")
    return " ".join(p for p in parts if p)


def _lines(model: type[BaseModel], values: Mapping[str, Any], indent: int) -> list[str]:
    pad = "  " * indent
    out: list[str] = []
    for name, info in model.model_fields.items():
        if name not in values:
            continue
        value = values[name]
        ann, _ = strip_optional(info.annotation)
        comment, rng = _comment(info), field_range(info.annotation, info)
        if comment or rng:
            out.append(f"{pad}# {comment}" + (f"; allowed: {rng}" if rng else ""))
        if is_model(ann) and isinstance(value, dict):
            out.append(f"{pad}{name}:")
            out += _lines(ann, value, indent + 1)
        elif item_model(ann) is not None and isinstance(value, list):
            out.append(f"{pad}{name}:")
            out += [f"{pad}  - {_scalar(v)}" for v in value]
        else:
            out.append(f"{pad}{name}: {_scalar(value)}")
    return out


def render_template(case: str = "demo") -> str:
    """The commented YAML run file of ``case`` (a key of :data:`CASES`).

    Raises
    ------
    ValueError
        Unknown case.
    """
    from whisker_opt.config.model import WhiskerConfig

    if case not in CASES:
        raise ValueError(f"init: case {case!r} is not one of {', '.join(CASES)}")
    cfg = WhiskerConfig.model_validate(CASES[case])
    values = json.loads(cfg.model_dump_json())
    head = [f"# {_INTRO[case]}", "# Every key is shown at its value; delete what you do not change. Reference: docs/config.md.",
            ""]
    body: list[str] = []
    for name, info in WhiskerConfig.model_fields.items():
        ann, optional = strip_optional(info.annotation)
        if is_model(ann):
            section = values[name] if values[name] is not None else json.loads(ann().model_dump_json())
            body += [f"# {ann.__doc__.strip().splitlines()[0]}" if ann.__doc__ else f"# {name}", f"{name}:"]
            body += _lines(ann, section, 1)
        else:
            body += _lines(WhiskerConfig, {name: values[name]}, 0)
        body.append("")
    return "\n".join(head + body)
