"""Malformed run files are refused with one clear line per problem, never a traceback or a silent default.

The fuzz test writes the seeded variants of :mod:`tests.config_mutations` (every section and
nested section: wrong types, out-of-range and boundary values, NaN/inf, unknown, misspelled and
renamed keys, non-mappings, huge numbers, empty text, non-UTF-8 and empty files) and reads each
with :func:`whisker_opt.config.model.load_config`. The focused tests pin each message form.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pytest
import yaml

from geometry.design import InvalidDesignError, WhiskerDesign
from tests.config_mutations import BASE, mappings, message_path, sections, variants
from whisker_opt import wiring
from whisker_opt.config.base import StrictModel
from whisker_opt.config.model import ConfigError, WhiskerConfig, format_validation_error, load_config

ROOT = Path(__file__).resolve().parents[1]
EMPTY = "is empty: write at least one section (see docs/config.md), or pass --defaults to run with every default"


def _load(path: Path) -> str | None:
    """The message of the ConfigError reading ``path`` raises, or None when it validates."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # renamed keys read on purpose
        try:
            load_config(path)
        except ConfigError as exc:
            return str(exc)
    return None


def _write(tmp_path: Path, text: str | bytes, name: str = "run.yaml") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8") if isinstance(text, str) else text)
    return path


def _message(tmp_path: Path, text: str | bytes) -> tuple[Path, str]:
    path = _write(tmp_path, text)
    msg = _load(path)
    assert msg is not None, f"accepted: {text!r}"
    return path, msg


# ----------------------------------------------------------------------------- fuzz
def test_fuzzed_configs_validate_or_are_refused_with_one_line_per_problem(tmp_path):
    cases = variants(seed=0)
    assert len(cases) >= 300
    assert len({v.name for v in cases}) == len(cases)
    kinds = {v.kind for v in cases}
    assert kinds >= {"range", "boundary", "nan", "type", "word", "unknown", "misspelled", "renamed", "section",
                     "file", "combo", "valid"}
    words = {w for v in cases for w in v.words}
    for path in sections():  # every section and nested section is replaced by a non-mapping
        assert message_path(path) in words or any(message_path(path) in w for w in words), path
    assert sum(v.kind == "unknown" for v in cases) == len(list(mappings()))

    failures = []
    for v in cases:
        path = v.write(tmp_path)
        try:
            msg = _load(path)
        except Exception as exc:  # anything but a ConfigError is a bug
            failures.append(f"{v.name}: {type(exc).__name__}: {exc}")
            continue
        if msg is None:
            if v.expect == "error":
                failures.append(f"{v.name}: accepted")
            continue
        lines = msg.splitlines()
        if v.expect == "valid":
            failures.append(f"{v.name}: refused: {msg}")
        if not lines or any(not ln.startswith(f"{path}: ") or not ln[len(str(path)) + 2:].strip() for ln in lines):
            failures.append(f"{v.name}: a line does not start with the file: {msg!r}")
        missing = [w for w in v.words if w not in msg]
        if missing:
            failures.append(f"{v.name}: message lacks {missing}: {msg}")
        if v.lines is not None and len(lines) != v.lines:
            failures.append(f"{v.name}: {len(lines)} lines, expected {v.lines}: {msg}")
        if "Traceback" in msg or "pydantic" in msg.lower() or "errors.pydantic.dev" in msg:
            failures.append(f"{v.name}: internals in the message: {msg}")
    assert failures == [], "\n".join(failures[:40])


def test_fuzz_generator_is_seeded():
    a, b = variants(seed=3), variants(seed=3)
    assert [(v.name, v.content) for v in a] == [(v.name, v.content) for v in b]
    assert [v.content for v in variants(seed=4)] != [v.content for v in a]


def test_the_nan_and_range_cases_say_so(tmp_path):
    cases = variants(seed=1)
    nan = [v for v in cases if v.kind == "nan" and v.expect == "error" and "not a finite number" in v.words]
    ranged = [v for v in cases if v.kind == "range"]
    assert len(nan) > 30 and len(ranged) > 30
    for v in nan:
        assert "not a finite number" in _load(v.write(tmp_path)), v.name
    for v in ranged:
        msg = _load(v.write(tmp_path))
        rng = v.words[-1]
        assert f"is outside the allowed range {rng}" in msg or f"is outside {rng}" in msg, (v.name, msg)


# ----------------------------------------------------------------------------- message forms
def test_out_of_range_states_value_range_and_unit(tmp_path):
    path, msg = _message(tmp_path, "scene:\n  contact_ratio: 1.5\n")
    assert msg == f"{path}: scene.contact_ratio: 1.5 is outside the allowed range (0, 1] (-)"
    path, msg = _message(tmp_path, "optimiser:\n  ga: {population: 1}\n")
    assert msg == f"{path}: optimiser.ga.population: 1 is outside 2..10000 (-)"
    path, msg = _message(tmp_path, "design: {D: 0}\n")
    assert msg == f"{path}: design.D: 0 is outside the allowed range (0, 100] (mm)"
    path, msg = _message(tmp_path, "optimiser:\n  genes: {Q_i: [0.01, 2.0]}\n")
    assert msg == f"{path}: optimiser.genes.Q_i.hi: 2.0 is outside the allowed range (0, 1] (MPa)"
    path, msg = _message(tmp_path, "design: {D: 1" + "0" * 400 + "}\n")  # too large even for a float
    assert msg.startswith(f"{path}: design.D: 1000") and msg.endswith("is outside the allowed range (0, 100] (mm)")


def test_nan_and_infinity_are_not_finite_numbers(tmp_path):
    assert StrictModel.model_config["allow_inf_nan"] is False
    path, msg = _message(tmp_path, "design: {L: .nan}\n")
    assert msg == f"{path}: design.L: not a finite number (got nan)"
    path, msg = _message(tmp_path, "optimiser:\n  executor: {timeout_s: .inf}\n")
    assert msg == f"{path}: optimiser.executor.timeout_s: not a finite number (got inf)"
    path, msg = _message(tmp_path, "design: {n_fibres: -.inf}\n")
    assert msg == f"{path}: design.n_fibres: not a finite number (got -inf)"
    path, msg = _message(tmp_path, "optimiser:\n  penalties: [{gene: t, prefer: high, weight: .nan}]\n")
    assert msg == f"{path}: optimiser.penalties.0.weight: not a finite number (got nan)"


def test_words_of_a_choice_are_listed(tmp_path):
    path, msg = _message(tmp_path, "optimiser:\n  executor: {kind: mpi}\n")
    words = "'serial', 'processes', 'dask'"
    assert msg == f"{path}: optimiser.executor.kind: 'mpi' is not one of the allowed words: {words}"
    path, msg = _message(tmp_path, "fidelity: {preset: ultra}\n")
    assert msg == (f"{path}: fidelity.preset: 'ultra' is not one of the allowed words: 'coarse', 'default', "
                   "'level2', 'fine', 'level3', 'level4', 'reference'")


def test_unknown_keys_suggest_the_closest_key(tmp_path):
    path, msg = _message(tmp_path, "design: {alpha_degg: 3.0}\n")
    assert msg == f"{path}: design.alpha_degg: unknown key 'alpha_degg'; did you mean 'alpha'?"
    path, msg = _message(tmp_path, "scene: {delta_maks: 3.0}\n")  # close to the old name: the new one is named
    assert msg == f"{path}: scene.delta_maks: unknown key 'delta_maks'; did you mean 'deflection'?"
    path, msg = _message(tmp_path, "optimiser:\n  ga: {populaton: 10}\n")
    assert msg == f"{path}: optimiser.ga.populaton: unknown key 'populaton'; did you mean 'population'?"
    path, msg = _message(tmp_path, "desing: {D: 5}\n")
    assert msg == f"{path}: desing: unknown key 'desing'; did you mean 'design'?"
    path, msg = _message(tmp_path, "material: {c10: 0.2}\n")
    assert msg == f"{path}: material.c10: unknown key 'c10'; did you mean 'C10'?"
    path, msg = _message(tmp_path, "output: {colour: red}\n")
    assert msg == f"{path}: output.colour: unknown key 'colour'; the keys of output are: results_dir, name"


def test_renamed_keys_with_their_new_names_are_refused(tmp_path):
    path, msg = _message(tmp_path, "design: {alpha_deg: 3.0, alpha: 3.0}\n")
    assert msg == f"{path}: design: 'alpha_deg' is the old name of 'alpha'; give only 'alpha'"
    path = _write(tmp_path, "design: {alpha_deg: 3.5}\nscene: {Q: 0.1}\n")
    with pytest.warns(DeprecationWarning) as record:
        cfg = load_config(path)
    assert sorted(str(w.message) for w in record) == [
        "config key 'design.alpha_deg' is deprecated: write 'design.alpha'",
        "config key 'scene.Q' is deprecated: write 'scene.Q_i'",
    ]
    assert (cfg.design.alpha, cfg.scene.Q_i) == (3.5, 0.1)
    path, msg = _message(tmp_path, "scene: {Q: abc}\n")  # a bad value under an old name is named as written
    assert msg == f"{path}: scene.Q: expected a number in [0, 1] (MPa), got 'abc' (Q is the old name of Q_i)"


def test_wrong_types_name_the_expected_type(tmp_path):
    cases = {
        "design: {D: abc}\n": "design.D: expected a number in (0, 100] (mm), got 'abc'",
        "design: {n_fibres: 2.5}\n": "design.n_fibres: expected an integer in 0..8 (-), got 2.5",
        "scene: {pair: maybe}\n": "scene.pair: expected true or false, got 'maybe'",
        "scene: [1, 2]\n": "scene: expected a mapping of keys (a section), got a list [1, 2]",
        "optimiser:\n  genes: {alpha: wide}\n":
            "optimiser.genes.alpha: expected [lo, hi] or {lo: .., hi: ..} (a section), got 'wide'",
        "optimiser: {penalties: {gene: t}}\n":
            "optimiser.penalties: expected a list of entries, each a mapping of keys, got a mapping {'gene': 't'}",
        "output: {name: ''}\n": "output.name: an empty string is not allowed (allowed: 1..100 characters)",
        "output: {results_dir: [a]}\n": "output.results_dir: expected a path (text), got a list ['a']",
        "fidelity: {h_wall: [1]}\n": "fidelity.h_wall: expected a number in [0.05, 10] (mm) or null, got a list [1]",
    }
    for text, line in cases.items():
        path, msg = _message(tmp_path, text)
        assert msg == f"{path}: {line}", text


def test_an_empty_section_says_so(tmp_path):
    path, msg = _message(tmp_path, "design:\n")
    assert msg == (f"{path}: design: expected a mapping of keys (a section), got null (an empty section: write its "
                   "keys, or leave the section out)")


def test_every_problem_has_its_own_line(tmp_path):
    path, msg = _message(tmp_path, "design: {D: -1, alpah: 3}\nscene: {contact_ratio: .nan}\nseed: -2\n")
    assert msg.splitlines() == [
        f"{path}: design.D: -1 is outside the allowed range (0, 100] (mm)",
        f"{path}: design.alpah: unknown key 'alpah'; did you mean 'alpha'?",
        f"{path}: scene.contact_ratio: not a finite number (got nan)",
        f"{path}: seed: -2 is outside 0..4294967295 (-)",
    ]


def test_format_validation_error_finds_the_section_model():
    from pydantic import ValidationError

    from whisker_opt.config.optimiser import OptimiserConfig

    with pytest.raises(ValidationError) as info:
        OptimiserConfig.model_validate({"ga": {"tournament": 0}, "trim": "x"})
    assert format_validation_error(info.value, "run.yaml: optimiser").splitlines() == [
        "run.yaml: optimiser: trim: expected a number in (0, 100] (mm), got 'x'",
        "run.yaml: optimiser: ga.tournament: 0 is outside 1..100 (-)",
    ]


# ----------------------------------------------------------------------------- whole files
@pytest.mark.parametrize("text", ["", "# only a comment\n\n# and another\n", "{}\n", "~\n", "\n \n"])
def test_an_empty_config_is_refused_unless_allowed(tmp_path, text):
    path, msg = _message(tmp_path, text)
    assert msg == f"{path}: the run file {EMPTY}"
    assert load_config(path, allow_empty=True) == WhiskerConfig()


@pytest.mark.parametrize(("content", "words"), [
    (b"design:\n  D: \xff\xfe\n", "not UTF-8 text (byte 0xff at line 2, column 6)"),
    ("design: {D: 5}\n".encode("utf-16"), "not UTF-8 text"),
    (b"design: {D: 5}\x00\n", "not a text file (it holds NUL bytes"),
    (b"- design\n- scene\n", "the top level must be a mapping of sections (design, material, scene, fidelity, "
                             "optimiser, robustness, output, calibration, seed), got a list ['design', 'scene']"),
    (b"42\n", "the top level must be a mapping of sections"),
    (b"scene: [1, 2\n", "YAML syntax error at line 2, column 1: while parsing a flow sequence"),
    (b"design:\n\tD: 5\n", "YAML syntax error at line 2"),
    (b"seed: !!python/object/apply:os.system ['true']\n", "YAML syntax error"),
    (b"fidelity: fine\n", "fidelity: expected a mapping of keys (a section), got 'fine'"),
    (b"optimiser: [ga]\n", "optimiser: expected a mapping of keys (a section) or null, got a list ['ga']"),
])
def test_unusable_files_are_one_line_naming_the_file(tmp_path, content, words):
    path, msg = _message(tmp_path, content)
    assert len(msg.splitlines()) == 1 and msg.startswith(f"{path}: ")
    assert words in msg, msg


def test_a_directory_or_missing_file_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="is a directory, not a config file"):
        load_config(tmp_path)
    with pytest.raises(ConfigError, match="no such config file"):
        load_config(tmp_path / "nope.yaml")


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads any file")
def test_an_unreadable_file_is_refused(tmp_path):
    path = _write(tmp_path, "seed: 1\n")
    path.chmod(0)
    try:
        with pytest.raises(ConfigError, match="cannot be read"):
            load_config(path)
    finally:
        path.chmod(0o644)


def test_a_read_error_is_one_line(tmp_path, monkeypatch):
    path = _write(tmp_path, "seed: 1\n")

    def refuse(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "read_bytes", refuse)
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value) == f"{path}: cannot be read (Permission denied)"


def test_valid_configs_are_read_as_before(tmp_path):
    files = sorted((ROOT / "configs").glob("*.yaml"))
    assert files
    for p in files:
        assert load_config(p) == WhiskerConfig.model_validate(yaml.safe_load(p.read_text()))
    path = _write(tmp_path, yaml.safe_dump(BASE))
    assert load_config(path) == WhiskerConfig.model_validate(BASE)
    assert load_config(_write(tmp_path, "optimiser: ~\n", "null.yaml")).optimiser is None


# ----------------------------------------------------------------------------- design errors
def _cfg(**sections) -> WhiskerConfig:
    return WhiskerConfig.model_validate(sections)


def test_an_impossible_design_names_its_keys():
    with pytest.raises(InvalidDesignError) as info:
        wiring.design_from_config(_cfg(design={"alpha": 9.0}))
    msg = str(info.value)
    assert msg == ("invalid whisker design: design.D=18, design.alpha=9, design.L=70, scene.trim=0: violates tip "
                   "radius D/2 - (L - trim) tan(alpha) = -2.087 > 0")
    assert set(info.value.parameters) == {"D", "alpha", "L", "trim"}
    with pytest.raises(InvalidDesignError) as info:
        wiring.design_from_config(_cfg(design={"c": 20.0}))
    assert str(info.value).startswith("invalid whisker design: design.c=20, design.l=15: violates c < l")
    assert len(info.value.violations) == 2


def test_the_trim_of_an_impossible_design_is_named_by_its_key():
    cfg = _cfg(design={"l": 60.0}, scene={"trim": 6.0}, optimiser={"trim": 8.0})
    for trim, key in ((6.0, "scene.trim=6"), (8.0, "optimiser.trim=8"), (7.0, "trim=7")):
        with pytest.raises(InvalidDesignError, match=r"design\.L=70, " + key.replace(".", r"\.") +
                           r", design\.l=60, tip_clearance=5 \(fixed\): violates L - trim - l >= tip_clearance"):
            wiring.design_from_config(cfg, trim)
    with pytest.raises(InvalidDesignError, match=r"--trim=7"):
        wiring.design_from_config(cfg, 7.0, trim_key="--trim")


def test_an_impossible_genome_names_its_genes():
    cfg = _cfg(design={})
    with pytest.raises(InvalidDesignError, match=r"design\.D=18, gene alpha=9, design\.L=70, trim=0: violates tip"):
        wiring.design_scene_specs(cfg, {"alpha": 9.0, "l": 12.0, "t": 3.0, "Q_i": 0.1})
    with pytest.raises(InvalidDesignError, match=r"optimiser\.trim=5, gene l=62"):
        wiring.design_scene_specs(cfg, {"alpha": 3.0, "l": 62.0, "t": 3.0, "Q_i": 0.1})
    specs = wiring.design_scene_specs(cfg, {"alpha": 3.0, "l": 12.0, "t": 3.0, "Q_i": 0.1})
    assert list(specs) == [wiring.INTACT, wiring.UNCOMPENSATED, wiring.TRIMMED]


def test_a_valid_design_is_built_as_before():
    cfg = _cfg(design={"alpha": 4.0, "l": 12.0}, scene={"trim": 5.0})
    assert wiring.design_from_config(cfg, 5.0) == WhiskerDesign(**cfg.design.model_dump(), trim=5.0)
