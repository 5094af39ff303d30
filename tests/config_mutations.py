"""Seeded malformed variants of a valid run file, for the config fuzz test and its command-line benchmark.

:func:`variants` starts from :data:`BASE`, a valid run file that sets every key of every section
and nested section (genes written both as mappings and as ``[lo, hi]`` lists, three penalty
entries), and writes variants of it as file contents (bytes):

- every leaf: values below, above and at the ends of its range, far outside it, integers too
  large for a float, NaN and ±infinity, wrong types (text, lists, mappings, null, empty text,
  true), words that are not allowed, fractional integers;
- every mapping: an unknown key, a misspelled key; every section replaced by a list, text,
  a number, null, an empty mapping;
- the renamed keys, alone and given with their new names;
- whole files: empty, only comments, ``{}``, not a mapping, YAML syntax errors, YAML tags,
  several documents, deep nesting, non-UTF-8 bytes, NUL bytes, random binary, a UTF-8 BOM;
- random combinations of several leaf mutations.

Each :class:`Variant` says what :func:`whisker_opt.config.model.load_config` must do with it
(``"error"``, ``"valid"`` or ``"any"``) and which words its message must hold (the key path,
the range of an out-of-range value, "not a finite number" for NaN/infinity, ...). The ranges
and allowed words are read from the config models, so the variants follow the models.
"""

from __future__ import annotations

import copy
import random
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import yaml

from whisker_opt.config.fields import choices, constraints, field_range, item_model, strip_optional
from whisker_opt.config.messages import resolve
from whisker_opt.config.model import WhiskerConfig

#: A valid run file setting every key of every section (validated by :func:`variants`).
BASE: dict[str, Any] = {
    "design": {"D": 18.0, "L": 70.0, "alpha": 2.862, "c": 2.0, "l": 15.0, "t": 3.0, "x_ss": 6.0, "e": 2.0,
               "fibre_radius_frac": 0.5, "fibre_pitch": 3.0, "fibre_diameter": 0.38, "n_fibres": 2,
               "fibre_E": 31067.0, "fibre_nu": 0.36},
    "material": {"C10": 0.14, "D1": 0.0},
    "scene": {"Q_i": 0.1, "trim": 5.0, "contact_ratio": 1.0, "contact_at": "pressurised", "deflection": 5.0,
              "delta_step": 0.01, "calibration": 3.9, "band_width": 1.0, "gauge_variant": "line", "pair": True},
    "fidelity": {"preset": "coarse", "h_wall": 1.0, "h_body": 4.0, "n_deflection_steps": 5,
                 "n_pressure_steps": 3, "mesh_method": "auto"},
    "optimiser": {
        "genes": {"alpha": {"lo": 2.5, "hi": 6.0}, "l": [10.0, 15.0], "t": {"lo": 2.0, "hi": 6.0},
                  "Q_i": [0.01, 0.2]},
        "trim": 5.0,
        "penalties": [{"gene": "Q_i", "prefer": "low", "weight": 0.5},
                      {"gene": "t", "prefer": "high", "weight": 0.2},
                      {"gene": "alpha", "prefer": "low", "weight": 0.2}],
        "failure_penalty": 1000.0,
        "ga": {"population": 20, "tournament": 2, "cx_prob": 0.9, "mut_prob": 0.4, "indpb": 0.25, "eta_cx": 15.0,
               "eta_mut": 20.0, "n_elite": 2, "hall_of_fame": 10, "init": "lhs"},
        "stopping": {"max_generations": 10, "target_fp": 0.001, "stall_generations": 20, "stall_tol": 1e-9},
        "executor": {"kind": "dask", "n_workers": 2, "scheduler_address": "tcp://127.0.0.1:8786",
                     "dask_processes": True, "threads_per_worker": 1, "timeout_s": 900.0, "start_method": "spawn"},
        "cache": {"enabled": True, "decimals": 6, "cache_failures": True},
        "seed": 7,
    },
    "output": {"results_dir": "results", "name": "fuzz"},
    "seed": 3,
}

#: Old key -> new key of the renamed keys, by section.
RENAMED = {"design": {"alpha_deg": "alpha"}, "scene": {"Q": "Q_i", "delta_max": "deflection"},
           "optimiser": {"delta_max": "trim"}}


@dataclass(frozen=True)
class Variant:
    """One malformed (or valid) run file.

    Attributes
    ----------
    name : str
        ``<number>-<kind>-<key path>``, unique.
    kind : str
        What was done: ``range``, ``boundary``, ``nan``, ``type``, ``word``, ``unknown``,
        ``misspelled``, ``renamed``, ``section``, ``file``, ``combo``, ``valid``.
    content : bytes
        The file.
    expect : str
        ``"error"`` (a ConfigError), ``"valid"`` or ``"any"``.
    words : tuple of str
        Texts the error message must hold when it is an error.
    lines : int or None
        The number of message lines, when it is known.
    """

    name: str
    kind: str
    content: bytes
    expect: str
    words: tuple[str, ...] = ()
    lines: int | None = None

    def write(self, folder: Path) -> Path:
        """Write the file as ``folder/<name>.yaml`` and return its path."""
        path = Path(folder) / f"{self.name}.yaml"
        path.write_bytes(self.content)
        return path


def dump(data: Any) -> bytes:
    """YAML of a (mutated) run file; NaN and infinities as ``.nan`` and ``.inf``."""
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml when present: same text, 5x faster
    return yaml.dump(data, Dumper=dumper, sort_keys=False, allow_unicode=True, width=10_000).encode("utf-8")


# ----------------------------------------------------------------------------- the tree of BASE
def _is_bounds_list(path: tuple) -> bool:
    return len(path) == 3 and path[:2] == ("optimiser", "genes")


def message_path(path: tuple) -> str:
    """The key path an error message names for a place in :data:`BASE` (``[lo, hi]`` items are lo and hi)."""
    if path and isinstance(path[-1], int) and _is_bounds_list(path[:-1]):
        path = path[:-1] + (("lo", "hi")[path[-1]],)
    return ".".join(str(p) for p in path)


def _field(path: tuple):
    """The model field at a place in BASE (``[lo, hi]`` items resolve to lo and hi)."""
    if path and isinstance(path[-1], int) and _is_bounds_list(path[:-1]):
        path = path[:-1] + (("lo", "hi")[path[-1]],)
    return resolve(WhiskerConfig, path)


def leaves(node: Any = None, path: tuple = ()) -> Iterator[tuple[tuple, Any]]:
    """``(path, value)`` of every leaf value of BASE, depth first."""
    node = BASE if node is None else node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from leaves(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from leaves(v, path + (i,))
    else:
        yield path, node


def mappings(node: Any = None, path: tuple = ()) -> Iterator[tuple]:
    """The path of every mapping of BASE (the file itself is ``()``)."""
    node = BASE if node is None else node
    if isinstance(node, dict):
        yield path
        for k, v in node.items():
            yield from mappings(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from mappings(v, path + (i,))


def sections() -> list[tuple]:
    """The path of every section and nested section of BASE (mappings, ``[lo, hi]`` lists, the penalties)."""
    out = []
    for path, _ in leaves():
        for n in range(1, len(path)):
            parent = path[:n]
            cls, info = _field(parent)
            is_section = cls is not None or (info is not None and item_model(strip_optional(info.annotation)[0]))
            if is_section and parent not in out:
                out.append(parent)
    return out


def _get(data: Any, path: tuple) -> Any:
    for p in path:
        data = data[p]
    return data


def _set(data: Any, path: tuple, value: Any) -> None:
    _get(data, path[:-1])[path[-1]] = value


def _keys_of(path: tuple) -> set[str]:
    """The keys a mapping of BASE may hold (fields and old names of renamed keys)."""
    cls = WhiskerConfig if path == () else _field(path)[0]
    return set(cls.model_fields) | set(getattr(cls, "RENAMED", {}) or {}) if cls is not None else set()


# ----------------------------------------------------------------------------- leaf mutations
@dataclass(frozen=True)
class Mutation:
    """One change of one leaf: ``(path, value)``, what it must give and the words of the message."""

    kind: str
    path: tuple
    value: Any
    expect: str
    words: tuple[str, ...] = ()


def _numeric_mutations(path: tuple, info, is_int: bool, optional: bool) -> Iterator[Mutation]:
    key = message_path(path)
    c = constraints(info)
    rng = field_range(info.annotation, info)
    out_of_range = (key, "is outside", rng)
    step = 1 if is_int else 1.0
    if "ge" in c:
        yield Mutation("range", path, c["ge"] - step, "error", out_of_range)
        yield Mutation("boundary", path, c["ge"], "any")
    if "gt" in c:
        yield Mutation("range", path, c["gt"], "error", out_of_range)
        yield Mutation("boundary", path, c["gt"] + (1 if is_int else 1e-9), "any")
    if "le" in c:
        yield Mutation("range", path, c["le"] + step, "error", out_of_range)
        yield Mutation("boundary", path, c["le"], "any")
    if "lt" in c:
        yield Mutation("range", path, c["lt"], "error", out_of_range)
    if any(k in c for k in ("le", "lt")):
        yield Mutation("range", path, 10**30 if is_int else 1e30, "error", out_of_range)
        yield Mutation("range", path, 10**400, "error", out_of_range)  # too large for a float
    if any(k in c for k in ("ge", "gt")):
        yield Mutation("range", path, -(10**30) if is_int else -1e30, "error", out_of_range)
    for bad in (float("nan"), float("inf"), float("-inf")):
        yield Mutation("nan", path, bad, "error", (key, "not a finite number"))
    if not is_int:
        yield Mutation("nan", path, "1e400", "error", (key, "not a finite number"))  # text that reads as inf
    expected = "expected an integer" if is_int else "expected a number"
    for bad in ("abc", "", [1, 2], {"a": 1}):
        yield Mutation("type", path, bad, "error", (key, expected))
    yield Mutation("type", path, None, "any" if optional else "error", () if optional else (key, expected))
    yield Mutation("type", path, True, "any")
    if is_int:
        yield Mutation("type", path, 1.5, "error", (key, "expected an integer"))


def leaf_mutations(path: tuple) -> list[Mutation]:
    """Every mutation of the leaf at ``path`` of BASE."""
    _, info = _field(path)
    assert info is not None, path
    key = message_path(path)
    tp, optional = strip_optional(info.annotation)
    out: list[Mutation] = []
    if choices(info.annotation):
        words = choices(info.annotation)
        quoted = ", ".join(repr(w) for w in words)
        out.append(Mutation("word", path, "not_a_word", "error", (key, "allowed words", quoted)))
        out.append(Mutation("word", path, str(words[0]).upper() + "x", "error", (key, "allowed words")))
        out.append(Mutation("word", path, 3, "error", (key, "allowed words")))
        out.append(Mutation("word", path, "", "error", (key,)))
        out.append(Mutation("type", path, [words[0]], "error", (key,)))
        out.append(Mutation("type", path, None, "any" if optional else "error", () if optional else (key,)))
    elif tp is bool:
        out.append(Mutation("type", path, "maybe", "error", (key, "expected true or false")))
        out.append(Mutation("type", path, [True], "error", (key, "expected true or false")))
        out.append(Mutation("type", path, None, "error", (key, "expected true or false")))
        out.append(Mutation("type", path, 2, "any"))
        out.append(Mutation("nan", path, float("nan"), "error", (key,)))
    elif tp in (int, float):
        out += list(_numeric_mutations(path, info, tp is int, optional))
    else:  # text and paths
        rng = field_range(info.annotation, info)
        out.append(Mutation("type", path, [1, 2], "error", (key, "expected")))
        out.append(Mutation("type", path, {"a": 1}, "error", (key, "expected")))
        out.append(Mutation("type", path, 5, "any"))
        out.append(Mutation("type", path, None, "any" if optional else "error", () if optional else (key,)))
        out.append(Mutation("type", path, "", "error" if "1.." in rng else "any", (key, rng) if "1.." in rng else ()))
        out.append(Mutation("type", path, "x" * 600, "error" if rng else "any", (key, rng) if rng else ()))
    return out


def _apply(data: dict, m: Mutation) -> None:
    _set(data, m.path, m.value)


# ----------------------------------------------------------------------------- key and section mutations
def _misspell(key: str, rng: random.Random) -> str:
    how = rng.choice(("drop", "double", "swap", "append", "prefix"))
    i = rng.randrange(len(key))
    if how == "drop" and len(key) > 1:
        return key[:i] + key[i + 1:]
    if how == "double":
        return key[:i] + key[i] + key[i:]
    if how == "swap" and len(key) > 1:
        i = min(i, len(key) - 2)
        return key[:i] + key[i + 1] + key[i] + key[i + 2:]
    if how == "prefix":
        return "_" + key
    return key + "s"


def _key_variants(rng: random.Random) -> Iterator[tuple[str, dict, str, tuple, int | None]]:
    """``(kind, data, expect, words, lines)`` of unknown and misspelled keys in every mapping."""
    for path in mappings():
        allowed = _keys_of(path)
        where = message_path(path)
        prefix = f"{where}." if where else ""
        data = copy.deepcopy(BASE)
        unknown = f"zz_{rng.randrange(10**6)}"
        _get(data, path)[unknown] = rng.choice((1, "x", None, [1], {"a": 1}))
        yield "unknown", data, "error", (f"{prefix}{unknown}", f"unknown key '{unknown}'"), 1
        keys = list(_get(BASE, path))
        for key in rng.sample(keys, min(2, len(keys))):
            wrong = _misspell(key, rng)
            if wrong in allowed or wrong == "":
                continue
            data = copy.deepcopy(BASE)
            node = _get(data, path)
            node[wrong] = node.pop(key)
            words = (f"{prefix}{wrong}", f"unknown key '{wrong}'") + (("did you mean",) if len(key) >= 4 else ())
            required = path[:2] == ("optimiser", "penalties")  # a penalty entry's keys are required
            yield "misspelled", data, "error", words, None if required else 1


def _renamed_variants() -> Iterator[tuple[str, dict, str, tuple, int | None]]:
    for section, pairs in RENAMED.items():
        for old, new in pairs.items():
            both = copy.deepcopy(BASE)
            both[section][old] = both[section][new]
            yield "renamed", both, "error", (section, f"'{old}' is the old name of '{new}'"), 1
            alone = copy.deepcopy(BASE)
            alone[section][old] = alone[section].pop(new)
            yield "renamed", alone, "valid", (), None
            wrong = copy.deepcopy(BASE)
            wrong[section].pop(new)
            wrong[section][old] = "abc"
            yield "renamed", wrong, "error", (f"{section}.{old}", f"({old} is the old name of {new})"), 1


def _section_variants(rng: random.Random, thorough: bool) -> Iterator[tuple[str, dict, str, tuple, int | None]]:
    values = ([1, 2], "x", 42, None, {}, [], True)
    for path in sections():
        key = message_path(path)
        cls, info = _field(path)
        optional = info is not None and strip_optional(info.annotation)[1]
        is_bounds = _is_bounds_list(path)
        is_list = info is not None and item_model(strip_optional(info.annotation)[0]) is not None
        for value in (values if thorough else rng.sample(values, 3)):
            data = copy.deepcopy(BASE)
            _set(data, path, value)
            if value is None and optional:
                expect = "valid"
            elif value == {} and not is_list:
                expect = "valid" if not path[:2] == ("optimiser", "penalties") else "error"
            elif value == [] and is_list:
                expect = "valid"
            elif is_bounds and value == [1, 2]:
                expect = "any"
            else:
                expect = "error"
            words = (key,) if expect == "error" else ()
            yield "section", data, expect, words, None


def _file_variants(rng: random.Random) -> Iterator[tuple]:
    """Whole files: ``(label, content, expect, words)``, and the number of message lines when it is not 1."""
    empty = ("is empty", "write at least one section (see docs/config.md)", "--defaults")
    yield "empty", b"", "error", empty
    yield "comments", b"# a run file\n   # with only comments\n", "error", empty
    yield "empty-mapping", b"{}\n", "error", empty
    yield "null-document", b"~\n", "error", empty
    yield "blank-lines", b"\n\n   \n", "error", empty
    top = ("top level must be a mapping",)
    yield "top-list", b"- design\n- scene\n", "error", top
    yield "top-number", b"42\n", "error", top
    yield "top-text", b"just some words\n", "error", top
    yield "top-empty-list", b"[]\n", "error", top
    syntax = ("YAML syntax error",)
    yield "unclosed-flow", b"scene: [1, 2\n", "error", syntax
    yield "mapping-in-scalar", b"design: D: 5\n", "error", syntax
    yield "tab-indent", b"design:\n\tD: 5\n", "error", syntax
    yield "two-documents", b"design: {D: 5}\n---\nseed: 1\n", "error", syntax
    yield "python-tag", b"seed: !!python/object/apply:os.system ['true']\n", "error", syntax
    yield "bad-alias", b"design: *nothing\n", "error", syntax
    yield "unterminated-quote", b"output: {name: 'abc}\n", "error", syntax
    yield "deep-nesting", b"design: " + b"[" * 300 + b"]" * 300 + b"\n", "error", ("design",)
    yield "deeper-nesting", b"design: " + b"{a: " * 600 + b"1" + b"}" * 600 + b"\n", "error", ("nested too deeply",)
    unreadable = ("a YAML value cannot be read",)
    yield "bad-date", b"seed: 2024-13-45\n", "error", unreadable
    yield "bad-float-tag", b"scene: {deflection: !!float abc}\n", "error", unreadable
    yield "bad-int-tag", b"seed: !!int abc\n", "error", unreadable
    yield "binary-tag", b"output: {name: !!binary /w==}\n", "error", ("output.name", "got binary data")
    yield "empty-binary-tag", b"output: {name: !!binary ''}\n", "error", ("output.name", "allowed: 1..100")
    yield "huge-integer-text", b"seed: " + b"9" * 5000 + b"\n", "error", ("too many digits",)
    laughs = "zz:\n  a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(  # 9**9 items, if anything expanded them
        f"  {chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 9)}]\n" for i in range(8))
    yield "alias-bomb", (laughs + "optimiser: {genes: {alpha: *i}}\n").encode(), "error", (
        "optimiser.genes.alpha: bounds must be [lo, hi] or {lo: .., hi: ..}, got a list of 9 items",
        "unknown key 'zz'"), 2
    yield "alias-to-section", b"design: &d {D: 5}\nscene: *d\n", "error", ("scene.D", "unknown key")
    not_utf8 = ("not UTF-8 text",)
    yield "latin-1", "output: {name: café}\n".encode("latin-1"), "error", not_utf8
    yield "utf-16", "design: {D: 5}\n".encode("utf-16"), "error", not_utf8
    yield "ff-bytes", b"design:\n  D: \xff\xfe\n", "error", not_utf8
    for i in range(4):
        blob = bytes(rng.randrange(256) for _ in range(rng.randrange(16, 400)))
        yield f"binary-{i}", b"\xff" + blob, "error", not_utf8
    yield "nul-bytes", b"design: {D: 5}\x00\x00\n", "error", ("NUL",)
    yield "bom", b"\xef\xbb\xbf" + dump(BASE), "valid", ()
    yield "crlf", dump(BASE).replace(b"\n", b"\r\n"), "valid", ()
    yield "capital-section", b"Design: {D: 5}\n", "error", ("unknown key 'Design'", "did you mean 'design'?")
    yield "int-key", b"1: 2\n", "error", ("keys must be text",)
    yield "null-key", b"~: 2\ndesign: {D: 5}\n", "error", ("keys must be text",)


# ----------------------------------------------------------------------------- all variants
def variants(seed: int = 0, n_combos: int = 60, thorough: bool = False) -> list[Variant]:
    """The systematic variants of BASE, then ``n_combos`` random combinations, seeded.

    Parameters
    ----------
    seed : int
        Seeds the random choices (which mutations, misspellings, unknown keys, binary files,
        combinations).
    n_combos : int
        Variants that change 2 to 4 leaves at once.
    thorough : bool
        Every mutation of every leaf and section (about 1400 variants); otherwise one
        mutation of each kind per leaf and three per section, chosen by the seed (about 500).

    Returns
    -------
    list of Variant
        Names are unique; the same seed gives the same list.
    """
    WhiskerConfig.model_validate(BASE)  # the base itself must be valid
    rng = random.Random(seed)
    out: list[Variant] = []

    def add(kind: str, content: bytes, expect: str, words: tuple = (), lines: int | None = None,
            label: str = "") -> None:
        safe = "".join(ch if ch.isalnum() or ch in "._-" else "_" for ch in label)[:60]
        out.append(Variant(f"{len(out):04d}-{kind}-{safe}", kind, content, expect, tuple(words), lines))

    add("valid", dump(BASE), "valid", label="base")
    single: list[Mutation] = []
    for path, _ in leaves():
        mutations = leaf_mutations(path)
        if not thorough:  # one of each kind, e.g. one range, one boundary, one NaN, one wrong type
            kinds = sorted({m.kind for m in mutations})
            mutations = [rng.choice([m for m in mutations if m.kind == k]) for k in kinds]
        for m in mutations:
            data = copy.deepcopy(BASE)
            _apply(data, m)
            add(m.kind, dump(data), m.expect, m.words, 1 if m.expect == "error" else None, message_path(path))
            if m.expect == "error":
                single.append(m)
    for kind, data, expect, words, lines in _key_variants(rng):
        add(kind, dump(data), expect, words, lines, words[0] if words else "")
    for kind, data, expect, words, lines in _renamed_variants():
        add(kind, dump(data), expect, words, lines, words[0] if words else "renamed-alone")
    for kind, data, expect, words, lines in _section_variants(rng, thorough):
        add(kind, dump(data), expect, words, lines, words[0] if words else "section")
    for label, content, expect, words, *lines in _file_variants(rng):
        add("file", content, expect, words, lines[0] if lines else 1 if expect == "error" else None, label)
    for _ in range(n_combos):
        chosen: list[Mutation] = []
        for m in rng.sample(single, rng.randint(2, 4)):
            if all(m.path[:len(o.path)] != o.path and o.path[:len(m.path)] != m.path for o in chosen):
                chosen.append(m)
        data = copy.deepcopy(BASE)
        for m in chosen:
            _apply(data, m)
        words = tuple(w for m in chosen for w in m.words)
        add("combo", dump(data), "error", words, len(chosen), "+".join(message_path(m.path) for m in chosen))
    return out

