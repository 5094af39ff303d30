"""docs/config.md: generated from the configuration models, complete, and current.

Regenerate it with ``python3 -m whisker_opt.config.reference`` after changing a model.
"""

from __future__ import annotations

import re
import subprocess
import sys
import typing
from pathlib import Path

import pytest
from pydantic import BaseModel, Field

from whisker_opt.config import reference
from whisker_opt.config.base import StrictModel
from whisker_opt.config.model import WhiskerConfig
from whisker_opt.experiment.fidelity import PRESET_NAMES

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "config.md"


def _models_in(annotation) -> list[type[BaseModel]]:
    """Models named anywhere in an annotation (``X | None``, ``tuple[X, ...]``)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for a in typing.get_args(annotation) for m in _models_in(a)]


def _walk(cls: type[BaseModel], path: str = ""):
    """``(key path, model, field name, FieldInfo)`` of every field, walked independently of the renderer."""
    for name, info in cls.model_fields.items():
        key = f"{path}.{name}" if path else name
        yield key, cls, name, info
        for sub in _models_in(info.annotation):
            is_items = typing.get_origin(info.annotation) in (tuple, list)
            yield from _walk(sub, f"{key}[]" if is_items else key)


FIELDS = list(_walk(WhiskerConfig))


def _rows(text: str) -> dict[str, dict[str, str]]:
    """Table rows of the reference by key: type, unit, range, default, description."""
    rows = {}
    for line in text.splitlines():
        m = re.match(r"^\| `([^`]+)` \| (.*) \|$", line)
        if m:
            typ, unit, rng, default, desc = m.group(2).split(" | ", 4)
            rows[m.group(1)] = {"type": typ, "unit": unit, "range": rng, "default": default, "description": desc}
    return rows


@pytest.fixture(scope="module")
def text() -> str:
    return reference.render()


@pytest.fixture(scope="module")
def rows(text) -> dict[str, dict[str, str]]:
    return _rows(text)


def test_docs_config_md_matches_the_models(text):
    assert DOC.is_file(), "docs/config.md is missing: run python3 -m whisker_opt.config.reference"
    assert DOC.read_text(encoding="utf-8") == text, (
        "docs/config.md is stale: run python3 -m whisker_opt.config.reference"
    )


def test_every_field_of_every_section_has_a_row(rows):
    keys = [key for key, *_ in FIELDS]
    assert len(keys) > 80  # the walk reached the nested optimiser models
    for key in ("optimiser.ga.population", "optimiser.genes.Q_i.hi", "optimiser.penalties[].weight",
                "optimiser.stopping.stall_tol", "optimiser.executor.timeout_s", "optimiser.cache.decimals",
                "scene.contact_ratio", "fidelity.preset", "output.name", "seed"):
        assert key in keys
    missing = [k for k in keys if k not in rows]
    assert missing == []
    assert sorted(rows) == sorted(keys)  # and nothing else
    assert sorted(reference.keys()) == sorted(keys)


def test_ranges_come_from_the_field_constraints(rows):
    assert rows["optimiser.ga.population"]["range"] == "2..10000"
    assert rows["scene.contact_ratio"]["range"] == "(0, 1]"
    assert rows["design.alpha"]["range"] == "[0, 45)"
    assert rows["design.fibre_E"]["range"] == "(0, 1e6]"
    assert rows["optimiser.stopping.stall_tol"]["range"] == "[0, 1]"
    assert rows["optimiser.executor.timeout_s"]["range"] == "(0, 604800]"
    assert rows["optimiser.penalties"]["range"] == "at most 4 items"
    assert rows["output.name"]["range"] == "1..100 characters"
    assert rows["fidelity.preset"]["range"] == ", ".join(f"`{n}`" for n in PRESET_NAMES)
    assert "optimiser.genes" in rows["optimiser.penalties[].gene"]["description"]  # any gene of the genome


def test_range_derivation_ignores_the_description():
    class Probe(StrictModel):
        x: float = Field(0.5, gt=0, le=1, description="(5, 6) in words that must not be read")
        n: int = Field(3, gt=1, lt=10)
        s: str | None = Field(None, max_length=7)
        free: float = 1.0

    f = Probe.model_fields
    assert reference.field_range(f["x"].annotation, f["x"]) == "(0, 1]"
    assert reference.field_range(f["n"].annotation, f["n"]) == "2..9"
    assert reference.field_range(f["s"].annotation, f["s"]) == "at most 7 characters"
    assert reference.field_range(f["free"].annotation, f["free"]) == ""


def test_types_units_and_defaults(rows):
    assert rows["design.D"]["unit"] == "mm" and rows["design.D"]["default"] == "`18`"
    assert rows["material.D1"]["unit"] == "1/MPa"
    assert rows["optimiser.executor.timeout_s"]["type"] == "float or null"
    assert rows["optimiser.executor.timeout_s"]["unit"] == "s"
    assert rows["optimiser.stopping.target_fp"]["default"] == "`0.001`"
    assert rows["optimiser.penalties[].weight"]["default"] == "*required*"
    assert rows["optimiser"]["default"] == "`null`"
    assert rows["optimiser.ga"]["type"] == "section"


def test_every_numeric_field_has_a_unit():
    numeric = [key for key, _, _, info in FIELDS
               if reference._strip_optional(info.annotation)[0] in (int, float)]
    assert "design.L" in numeric and "optimiser.ga.population" in numeric
    assert [key for key, _, _, info in FIELDS if key in numeric and not reference.field_unit(info)] == []


def test_renamed_keys_are_listed(text):
    pairs = []
    for key, model, name, info in FIELDS:
        for sub in _models_in(info.annotation):
            for old, new in getattr(sub, "RENAMED", {}).items():
                pairs.append((f"{key}.{old}", f"{key}.{new}"))
    assert ("scene.Q", "scene.Q_i") in pairs and ("optimiser.delta_max", "optimiser.trim") in pairs
    assert ("design.alpha_deg", "design.alpha") in pairs and ("scene.delta_max", "scene.deflection") in pairs
    for old, new in pairs:
        assert f"`{old}` → `{new}`" in text


def test_check_flags_a_stale_file(tmp_path):
    out = tmp_path / "config.md"
    assert reference.main(["--check", "--output", str(out)]) == 1  # missing
    assert reference.main(["--output", str(out)]) == 0
    assert reference.main(["--check", "--output", str(out)]) == 0
    out.write_text(out.read_text() + "\nhand edit\n")
    proc = subprocess.run([sys.executable, "-m", "whisker_opt.config.reference", "--check", "--output", str(out)],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 1, proc.stderr
    assert "stale" in proc.stderr


def test_a_registry_that_grows_is_named_where_it_is_listed_not_enumerated(rows):
    """The gauge readings and the rubber laws are registries of one module each: the reference names the command
    that lists them (so adding one leaves docs/config.md current), the command lists every registered name, and
    a bad name is still refused naming them all."""
    from pydantic import ValidationError

    from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS
    from whisker_opt.experiment.rubber_laws import RUBBERS

    for key, module, names in (("scene.gauge_variant", "whisker_opt.experiment.gauge_variants", GAUGE_VARIANTS),
                               ("material.rubber", "whisker_opt.experiment.rubber_laws", RUBBERS),
                               ("material.cap_rubber", "whisker_opt.experiment.rubber_laws", RUBBERS)):
        row = rows[key]
        assert f"`python3 -m {module}`" in row["range"]
        assert not [n for n in names if f"`{n}`" in row["range"]
                    or f"'{n}'" in row["description"] and row["default"] != f"`{n}`"]  # the default may be named
        proc = subprocess.run([sys.executable, "-m", module], cwd=ROOT, capture_output=True, text=True, check=True)
        assert [line.split(":")[0] for line in proc.stdout.splitlines()] == list(names)
        section, field = key.split(".")
        with pytest.raises(ValidationError) as exc:
            WhiskerConfig.model_validate({section: {field: "no_such_name"}})
        assert all(repr(n) in str(exc.value) for n in names)
