"""Typed, validated configuration of whisker-opt runs (YAML -> pydantic models).

Every numeric field carries its range (the ``Field`` constraints) and its unit
(``json_schema_extra={"unit": ...}``, ``-`` for a pure number); unknown keys are errors
that name the key (``extra="forbid"`` on :class:`whisker_opt.config.base.StrictModel`).
Units: mm, N, MPa, degrees for angles. The defaults describe the thesis' prototype
(docs/physics.md). ``docs/config.md`` is generated from these models
(``python3 -m whisker_opt.config.reference``).

A YAML file has these top-level sections, each optional (an empty file is refused unless
:func:`load_config` is told ``allow_empty``: the command line's ``--defaults``)::

    design:     the whisker geometry and fibres
    material:   rubber law
    scene:      the simulated experiment (pressurise, deflect, read the gauge)
    fidelity:   preset name, optional overrides of mesh size / increments, linear solver
    optimiser:  genes, penalties, GA, stopping, executor, see whisker_opt.config.optimiser
    robustness: fabrication tolerances, see whisker_opt.config.robustness
    output:     where results go
    calibration: model parameters fitted to measurements, see whisker_opt.config.calibration
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any, Literal, Sequence

import yaml
from pydantic import BaseModel, Field, ValidationError, create_model, field_validator, model_validator

from geometry.design import WhiskerDesign, user_parameters
from geometry.sizing import H_BODY_RANGE, H_WALL_RANGE
from fem.linsolve import SOLVER_NAMES
from whisker_opt.config.base import KEY_PATHS, ConfigError, StrictModel
from whisker_opt.config.calibration import CalibrationConfig
from whisker_opt.config.fields import is_model, item_model, strip_optional
from whisker_opt.config.messages import describe_errors, show
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.config.robustness import RobustnessConfig
from whisker_opt.config.wall_ranges import check_wall_laws
from whisker_opt.experiment.fidelity import PRESET_NAMES
from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS
from whisker_opt.experiment.spec import Q_RANGE, SceneSpec


class _DesignSection(StrictModel):
    SECTION = "design"
    RENAMED = {"alpha_deg": "alpha"}


def declared_fields(cls, names: tuple[str, ...] | None = None) -> dict[str, Any]:
    """``{key: (type, Field)}`` of the user parameters a dataclass declares with
    :func:`geometry.design.parameter` (all of them, or ``names`` in that order), for
    :func:`pydantic.create_model`."""
    scalar = {"float": float, "int": int, "str": str, "bool": bool}
    params = {f.name: f for f in user_parameters(cls)}
    out = {}
    for name in (tuple(params) if names is None else names):
        f = params[name]
        m = f.metadata
        kind = Literal[m["choices"]] if m["choices"] else scalar.get(f.type, f.type)
        schema = {k: v for k, v in (("unit", m["unit"]), ("listed", m.get("listed"))) if v}
        extra = {"json_schema_extra": schema} if schema else {}
        out[m["key"] or f.name] = (kind, Field(f.default, description=m["doc"], **extra, **m["bounds"]))
    return out


#: The ``design`` section: generated from the parameters that :class:`geometry.design.WhiskerDesign`
#: declares (defaults, units, ranges and meanings live there alone).
DesignConfig = create_model(
    "DesignConfig", __base__=_DesignSection, __module__=__name__,
    __doc__="Whisker geometry (a truncated cone along +x with a chamber from x = c to x = l) and fibre winding.",
    **declared_fields(WhiskerDesign),
)


#: The ``material`` section: the rubber constants :class:`whisker_opt.experiment.spec.SceneSpec` declares.
MaterialConfig = create_model(
    "MaterialConfig", __base__=StrictModel, __module__=__name__,
    __doc__="Rubber: neo-Hookean W = C10 (Ī1 − 3) + (1/D1)(J − 1)² by default (D1 = 0 is fully incompressible), "
    "or another registered law, e.g. a named Yeoh fit of a published silicone (docs/physics.md, model form); the cap "
    "may be of another rubber; "
    "the fibre winding embedded as lines or smeared over the wall.",
    **declared_fields(SceneSpec, ("c10", "d1", "rubber", "cap_rubber", "cap_joint", "cap_joint_k", "fibre_model",
                                "wall_law", "wall_slope")),
)


#: What the reference says of the allowed gauge readings instead of listing them (they are a registry that grows).
LISTED_READINGS = "a registered gauge reading, listed by `python3 -m whisker_opt.experiment.gauge_variants`"


class _SceneSection(StrictModel):
    SECTION = "scene"
    RENAMED = {"Q": "Q_i", "delta_max": "deflection"}


_SCENE_OWN: dict[str, Any] = {
    "Q_i": (float, Field(
        0.0, ge=Q_RANGE[0], le=Q_RANGE[1],
        description="initial (intact) chamber pressure Q_i of `simulate`, `export`, `compensate` and `robustness` "
        "of the config's design; the pressure of the single scene when `pair` is false (the GA takes Q_i from its "
        "genes; see Keys read by each command)",
        json_schema_extra={"unit": "MPa"},
    )),
    "trim": (float, Field(0.0, ge=0, le=100, description="length cut off the tip Δ for `simulate`, `export` and "
                          "`mesh` (the GA and `compensate` use optimiser.trim)", json_schema_extra={"unit": "mm"})),
    "delta_step": (float, Field(0.01, gt=0, le=1, description="deflection sampling Δδ of the curves and of f1",
                                json_schema_extra={"unit": "mm"})),
    "gauge_variant": (Literal[tuple(GAUGE_VARIANTS)], Field(
        "line", description=f"the gauge reading of the curves and of f1, by name: 'line' (the default), the "
        f"{GAUGE_VARIANTS['line']}, or another registered reading (docs/physics.md §3)",
        json_schema_extra={"listed": LISTED_READINGS})),
    "pair": (bool, Field(
        True, description="`simulate` runs the intact (at Q_i) / trimmed (vented) pair instead of one scene")),
}
_SCENE_SHARED = declared_fields(SceneSpec, ("contact_ratio", "contact_at", "deflection", "calibration", "band_width",
                                            "base_support", "base_grip_depth", "base_k_n", "base_k_t",
                                            "gauge_patch", "patch_length", "patch_width", "patch_thickness",
                                            "patch_modulus", "patch_poisson"))
_SCENE_ORDER = ("Q_i", "trim", "contact_ratio", "contact_at", "deflection", "delta_step", "calibration", "band_width",
                "base_support", "base_grip_depth", "base_k_n", "base_k_t", "gauge_patch", "patch_length", "patch_width",
                "patch_thickness", "patch_modulus", "patch_poisson", "gauge_variant", "pair")

#: The ``scene`` section: its own keys plus the experiment settings :class:`whisker_opt.experiment.spec.SceneSpec`
#: declares (contact, deflection, gauge factor, contact band).
SceneConfig = create_model(
    "SceneConfig", __base__=_SceneSection, __module__=__name__,
    __doc__="The simulated experiment: pressurise, then deflect, read the gauge (docs/physics.md).",
    **{k: {**_SCENE_OWN, **_SCENE_SHARED}[k] for k in _SCENE_ORDER},
)


class FidelityConfig(StrictModel):
    """Accuracy/speed preset, optionally overridden field by field."""

    preset: Literal[PRESET_NAMES] = Field("default", description="named preset (whisker_opt.experiment.fidelity)")
    h_wall: float | None = Field(None, ge=H_WALL_RANGE[0], le=H_WALL_RANGE[1], description="override: element size in the chamber wall "
                                 "(meshes afresh: no template applies)", json_schema_extra={"unit": "mm"})
    h_body: float | None = Field(None, ge=H_BODY_RANGE[0], le=H_BODY_RANGE[1], description="override: largest element size in the solid body",
                                 json_schema_extra={"unit": "mm"})
    n_deflection_steps: int | None = Field(
        None, ge=1, le=1000, description="override: solved deflection increments", json_schema_extra={"unit": "-"}
    )
    n_pressure_steps: int | None = Field(
        None, ge=1, le=1000, description="override: solved pressure increments", json_schema_extra={"unit": "-"}
    )
    mesh_method: Literal["auto", "fresh", "template", "swept"] = Field(
        "auto",
        description="'template' maps a stored template mesh; 'swept' builds a structured swept mesh; "
        "'fresh' re-tetrahedralises with fTetWild; 'auto' tries them in that order",
    )
    linear_solver: Literal[SOLVER_NAMES] = Field(
        "auto",
        description="sparse direct solver of the Newton systems (fem.linsolve): 'pardiso' (MKL PARDISO), 'superlu' "
        "(scipy, 10-40 times slower on the 3-D scenes), 'auto' = PARDISO when it loads, else SuperLU with a "
        "warning; the same answer to the solver's tolerance",
    )


class OutputConfig(StrictModel):
    """Where results are written."""

    results_dir: Path = Field(Path("results"), description="parent folder of run directories")
    name: str | None = Field(None, min_length=1, max_length=100,
                             description="run name, a plain name (no folder: no '/', '\\', '.' or '..'); null = the "
                             "config file's stem (the command and the UTC time are appended)")

    @field_validator("name")
    @classmethod
    def _plain_name(cls, v: str | None) -> str | None:
        if v is not None and (v.strip() in ("", ".", "..") or any(c in v for c in "/\\\0")):
            raise ValueError(f"{v!r} is not a plain name: the run directories are made in output.results_dir, so a "
                             "name holds no '/', '\\' or NUL and is not '.' or '..'")
        if v is not None and any(ord(c) < 32 or ord(c) == 127 for c in v):
            raise ValueError(f"{v!r} holds a line break or another control character; a run name is one line of "
                             "printable characters")
        return v

    @field_validator("results_dir")
    @classmethod
    def _home(cls, v: Path) -> Path:
        """``~`` and ``~user`` at the start are the home folder, as a shell reads them."""
        if not str(v).startswith("~"):
            return v
        expanded = Path(os.path.expanduser(v))  # Path.expanduser raises on an unknown ~user
        if str(expanded).startswith("~"):
            raise ValueError(f"{str(v)!r}: {str(v).split('/')[0]!r} names no home folder here; give the folder "
                             "without '~'")
        return expanded


class WhiskerConfig(StrictModel):
    """A whole run file: the sections below and the master ``seed``.

    ``optimiser`` is validated by :mod:`whisker_opt.config.optimiser` when present; commands
    that need it use its defaults when it is absent.
    """

    design: DesignConfig = DesignConfig()
    material: MaterialConfig = MaterialConfig()
    scene: SceneConfig = SceneConfig()
    fidelity: FidelityConfig = FidelityConfig()
    optimiser: OptimiserConfig | None = Field(None, description="GA section (whisker_opt.config.optimiser); null = "
                                                "its defaults")
    robustness: RobustnessConfig = RobustnessConfig()
    output: OutputConfig = OutputConfig()
    calibration: CalibrationConfig | None = Field(None, description="what `whisker-opt calibrate` fits "
                                                  "(whisker_opt.config.calibration); other commands ignore it")
    seed: int = Field(0, ge=0, le=2**32 - 1, description="master random seed", json_schema_extra={"unit": "-"})

    @model_validator(mode="after")
    def _wall_laws_can_be_evaluated(self) -> "WhiskerConfig":
        check_wall_laws(self)  # the slope, the design, scene.Q_i and the gene box against the laws
        return self

    @model_validator(mode="after")
    def _grip_within_the_whisker(self) -> "WhiskerConfig":
        d, L = self.scene.base_grip_depth, self.design.L - self.scene.trim
        if self.scene.base_support == "grip" and not d < L:
            raise ValueError(f"scene.base_grip_depth={d:g}: must be < the whisker's length {L:g} mm "
                             "(design.L - scene.trim)")
        return self


def _key_paths(model: type[BaseModel], prefix: tuple[str, ...] = ()) -> None:
    """Fill :data:`whisker_opt.config.base.KEY_PATHS`: each section's model and its key path in a run file."""
    KEY_PATHS.setdefault(model, (WhiskerConfig, prefix))
    for name, info in model.model_fields.items():
        tp, _ = strip_optional(info.annotation)
        if is_model(tp) and tp not in KEY_PATHS:
            _key_paths(tp, (*prefix, name))


_key_paths(WhiskerConfig)


def _models(root: type[BaseModel] | None = None) -> dict[str, type[BaseModel]]:
    """Every model of a run file by class name (the ``title`` of its validation errors)."""
    root = root or WhiskerConfig
    out = {root.__name__: root}
    for info in root.model_fields.values():
        tp, _ = strip_optional(info.annotation)
        sub = tp if is_model(tp) else item_model(tp)
        if sub is not None and sub.__name__ not in out:
            out.update(_models(sub))
    return out


def format_validation_error(err: ValidationError, source: str = "config", data: Any = None) -> str:
    """One line per problem: ``SOURCE: section.key: <what>``.

    ``<what>`` states the value given and what the key allows, read from the model field:
    the range and unit of a number (``1.5 is outside the allowed range (0, 1] (-)``), ``not a
    finite number (got nan)``, the allowed words of a choice, the closest key to an unknown
    one (``unknown key 'alpha_degg'; did you mean 'alpha'?``) or the expected type
    (:mod:`whisker_opt.config.messages`).

    Parameters
    ----------
    err : ValidationError
        From validating :class:`WhiskerConfig` or one of its sections (found by the error's title).
    source : str
        What was read, e.g. the file's path; starts every line.
    data : Any, optional
        What was validated: an old name of a renamed key is then named as written
        (``scene.Q: ... (Q is the old name of Q_i)``).

    Returns
    -------
    str
    """
    root = _models().get(err.title, WhiskerConfig)
    return "\n".join(describe_errors(err, source, root, data))


#: The end of the message of an empty run file.
EMPTY_HINT = "write at least one section (see docs/config.md), or pass --defaults to run with every default"


def _read_text(path: Path) -> str:
    """The text of a run file, or a one-line :class:`ConfigError` naming the file."""
    try:
        if not path.exists():
            raise ConfigError(f"{path}: no such config file")
        if path.is_dir():
            raise ConfigError(f"{path}: is a directory, not a config file")
        if not path.is_file():
            raise ConfigError(f"{path}: not a regular file (a run file is a YAML text file)")
        raw = path.read_bytes()
    except OSError as exc:  # unreadable, a name too long, a parent that cannot be searched
        raise ConfigError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise ConfigError(f"{path}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line}, column {column}); "
                          "a run file is YAML text") from None
    if "\x00" in text:
        raise ConfigError(f"{path}: not a text file (it holds NUL bytes at position {text.index(chr(0))}); "
                          "a run file is YAML text")
    return text


class DuplicateKeyError(yaml.YAMLError):
    """A key given twice in one mapping of a run file."""


class UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader that refuses a mapping giving a key twice (YAML would keep the last silently)."""

    def construct_mapping(self, node, deep=False):  # noqa: D102 - yaml.SafeLoader.construct_mapping
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.get(key)
                if first is None:
                    seen[key] = key_node.start_mark.line + 1
                    continue
            except TypeError:  # an unhashable key: YAML's own error follows
                continue
            raise DuplicateKeyError(f"the key {key!r} is given twice in one section (lines {first} and "
                                    f"{key_node.start_mark.line + 1}); give it once")
        return super().construct_mapping(node, deep=deep)


def _parse(path: Path, text: str) -> Any:
    """The YAML document of a run file, or a one-line :class:`ConfigError` naming the file."""
    try:
        return yaml.load(text, Loader=UniqueKeyLoader)  # noqa: S506 - a SafeLoader that refuses repeated keys
    except DuplicateKeyError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        what = ": ".join(str(p) for p in (exc.context, exc.problem) if p) or str(exc)
        raise ConfigError(f"{path}: YAML syntax error{where}: {what}".replace("\n", " ")) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: YAML syntax error: {exc}".replace("\n", " ")) from None
    except RecursionError:
        raise ConfigError(f"{path}: YAML nested too deeply to read") from None
    except (ValueError, OverflowError) as exc:  # e.g. an integer of more digits than Python converts
        what = "an integer of too many digits" if "integer string conversion" in str(exc) else str(exc)
        raise ConfigError(f"{path}: a YAML value cannot be read: {what}".replace("\n", " ")) from None


def _refuse_binary(path: Path, data: Any, where: str = "") -> None:
    """Refuse a YAML ``!!binary`` value anywhere in a run file: no key takes binary data, and a text key
    would otherwise take its decoded bytes silently."""
    if isinstance(data, (bytes, bytearray)):
        raise ConfigError(f"{path}: {where or 'the top level'}: a YAML !!binary value ({len(data)} bytes); no key of a "
                          "run file takes binary data: write the value as text or a number")
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for k, v in items:
        _refuse_binary(path, v, f"{where}.{k}" if where else str(k))


def apply_settings(data: dict, settings: Sequence[str]) -> dict:
    """``data`` (a run file's content) with ``KEY=VALUE`` settings applied, as ``--set`` does.

    ``KEY`` is a dotted path of sections and keys (``optimiser.ga.population``); ``VALUE`` is
    read as YAML (``3``, ``0.2``, ``true``, ``[2, 6]``, ``coarse``). Sections are created as
    needed; the result is validated with the file, so a wrong key or value is reported as
    in a file.

    Raises
    ------
    ConfigError
        A setting without ``=``, an empty key, or a key below a value that is not a section.
    """
    out = dict(data)
    for item in settings:
        key, sep, text = str(item).partition("=")
        parts = [k.strip() for k in key.split(".")]
        if not sep or not all(parts):
            raise ConfigError(f"--set {item!r}: expected KEY=VALUE with a dotted key, e.g. optimiser.ga.population=20")
        shown = item if len(item) <= 80 else f"{item[:60]}…({len(item)} characters)"
        try:
            value = yaml.safe_load(text) if text.strip() else ""
        except yaml.YAMLError as exc:
            raise ConfigError(f"--set {shown!r}: VALUE is not readable: {str(exc).splitlines()[0]}") from None
        except RecursionError:
            raise ConfigError(f"--set {shown!r}: VALUE is nested too deeply to read") from None
        except (ValueError, OverflowError) as exc:  # an integer of more digits than Python converts
            what = "an integer of too many digits" if "integer string conversion" in str(exc) else str(exc)
            raise ConfigError(f"--set {shown!r}: VALUE cannot be read: {what}".replace("\n", " ")) from None
        out = with_key(out, parts, value, f"--set {item!r}")
    return out


def with_key(data: dict, parts: Sequence[str], value: Any, where: str) -> dict:
    """A copy of ``data`` with the key at the path ``parts`` (sections, then the key) set to ``value``;
    missing sections are created, the sections on the path copied.

    Raises
    ------
    ConfigError
        A section on the path is a value (``where`` starts the message).
    """
    out = dict(data)
    node = out
    for depth, k in enumerate(parts[:-1]):
        child = node.get(k)
        if child is None:
            child = {}
        elif not isinstance(child, dict):
            raise ConfigError(f"{where}: {'.'.join(parts[:depth + 1])} is a value, not a section")
        node[k] = child = dict(child)
        node = child
    node[parts[-1]] = value
    return out


def load_config(path: str | Path, allow_empty: bool = False, settings: Sequence[str] = ()) -> WhiskerConfig:
    """Read and validate a YAML run file.

    Parameters
    ----------
    path : str or Path
        The run file.
    allow_empty : bool
        Accept an empty file (nothing, only comments, or ``{}``) as "every default"
        (the command line's ``--defaults``); otherwise it is an error.
    settings : sequence of str
        ``KEY=VALUE`` settings applied over the file (:func:`apply_settings`; ``--set``).

    Returns
    -------
    WhiskerConfig

    Raises
    ------
    ConfigError
        Missing file, a directory, unreadable, not UTF-8 text, empty (unless ``allow_empty``),
        YAML syntax error, a top level or section that is not a mapping, or a validation
        problem. The message names the file and, one line per problem, the key.
    """
    if not str(path).strip():
        raise ConfigError(f"config path: {str(path)!r} is empty; give the path of a YAML run file")
    path = Path(path)
    data = _parse(path, _read_text(path))
    if data is None or data == {}:
        if not allow_empty:
            raise ConfigError(f"{path}: the run file is empty: {EMPTY_HINT}")
        data = {}
    if not isinstance(data, dict):
        sections = ", ".join(WhiskerConfig.model_fields)
        raise ConfigError(f"{path}: the top level must be a mapping of sections ({sections}), got {show(data)}")
    if settings:
        data = apply_settings(data, settings)
    try:
        cfg = WhiskerConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, str(path), data)) from None
    except RecursionError:
        raise ConfigError(f"{path}: nested too deeply to read") from None
    _refuse_binary(path, data)  # a text key takes !!binary bytes as their text: refused, not decoded
    return cfg


#: First line of the ``config.yaml`` a command writes into its output folder: the folder's command
#: (:func:`dump_config`, :func:`recorded_command`).
RECORD_HEADER = "# written by `whisker-opt {command}`: the resolved run file of the results in this folder\n"
_RECORD = re.compile(r"# written by `whisker-opt ([a-z][a-z-]*)`")


def dump_config(cfg: WhiskerConfig, command: str | None = None) -> str:
    """The fully resolved config as YAML (defaults filled in), for storing beside results; headed by
    :data:`RECORD_HEADER` (a YAML comment) naming ``command`` when given."""
    text = yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)
    return RECORD_HEADER.format(command=command) + text if command else text


def recorded_command(path: Path | str) -> str | None:
    """The command named by the first line of a ``config.yaml`` (:data:`RECORD_HEADER`); None when the file
    is missing or unreadable or names none (written by hand, or by an earlier version)."""
    try:
        with open(path, "rb") as f:
            first = f.readline(200).decode("utf-8", "replace")
    except OSError:
        return None
    m = _RECORD.match(first)
    return m.group(1) if m else None
