"""Reading a results directory: its VTU states and the metadata found beside them.

A *source* is a results directory (``simulate``, ``run`` or ``mesh`` run, or any folder
holding ``*.vtu`` files at any depth) or a single ``.vtu`` file. Each VTU is one *state*
of one *scene*: ``intact_deflected.vtu`` is scene ``intact``, state ``deflected``; a file
without a known state suffix (``mesh.vtu``) is the state ``reference``. The fibre lines
written beside a state (``intact_deflected_fibres.vtu`` next to ``intact_deflected.vtu``,
:func:`is_fibre_file`) are no state. VTU files in a
sub-folder (``best/``, ``eval_12/``) form a *group*. Optional metadata is read, when
present, from ``scenes.json`` (in the VTU's folder or a parent), ``best.json``,
``config.yaml`` and ``best_curves.csv``; every piece is optional.

:meth:`RunContents.select_delta` picks every scene at one deflection δ,
:meth:`RunContents.delta_steps` orders them for a slider.
"""

from __future__ import annotations

import csv
import functools
import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

from whisker_opt.output.scenes import FIBRE_SUFFIX
from whisker_opt.wiring import INTACT, TRIMMED, UNCOMPENSATED
from whisker_opt.viewer.genome import genome_scenes
from whisker_opt.viewer.guard import ViewerError
from whisker_opt.viewer.rubber import RunRubber, run_rubber
from whisker_opt.viewer.sceneinfo import DELTA_TOL, SceneInfo, number_in, read_json, read_scenes_json

logger = logging.getLogger(__name__)

STATE_ORDER = (
    "reference", "undeformed", "mesh", "initial", "pressurised", "pressurized", "inflated", "deflected", "final",
)
SCENE_ORDER = (
    INTACT, "uncompensated", UNCOMPENSATED, TRIMMED, "vented", "trimmed_vented", "compensated", "scene",
)


# ============================================================================ run files
def read_run_config(root: Path) -> dict[str, Any]:
    """The ``config.yaml`` of a run directory as a plain mapping ({} when absent or unreadable)."""
    p = Path(root) / "config.yaml"
    if not p.is_file():
        return {}
    try:
        import yaml

        cfg = yaml.safe_load(p.read_text()) or {}
    except Exception as exc:  # noqa: BLE001 - the config is optional metadata here
        logger.warning("%s: ignored (%s)", p, exc)
        return {}
    return cfg if isinstance(cfg, dict) else {}


def config_section(cfg: Mapping[str, Any], name: str) -> dict[str, Any]:
    """A section of a config mapping ({} when absent or not a mapping)."""
    sec = cfg.get(name)
    return sec if isinstance(sec, dict) else {}


def read_best_curves(root: Path) -> tuple[list[float], list[float], list[float]] | None:
    """``(delta, eps_i, eps_c)`` of a run's ``best_curves.csv``; None when absent or unreadable."""
    p = Path(root) / "best_curves.csv"
    if not p.is_file():
        return None
    with p.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    try:
        return ([float(r["delta_mm"]) for r in rows], [float(r["eps_i"]) for r in rows],
                [float(r["eps_c"]) for r in rows])
    except (KeyError, ValueError) as exc:
        logger.warning("%s: ignored (%s)", p, exc)
        return None


# ============================================================================ file names
@dataclass(frozen=True)
class StateFile:
    """One VTU file of a source.

    Attributes
    ----------
    group : str
        Folder relative to the source root (``"."`` for the root itself).
    scene : str
    state : str
    path : Path
    """

    group: str
    scene: str
    state: str
    path: Path


def state_sort_key(state: str) -> tuple:
    """Order of states: reference, pressurised, numbered δ states, deflected."""
    s = state.lower()
    if s in STATE_ORDER:
        idx = STATE_ORDER.index(s)
        if s in ("deflected", "final"):
            return (2, 0.0, idx, s)
        return (0, 0.0, idx, s)
    num = number_in(s)
    return (1, num if num is not None else math.inf, 0, s)


def scene_sort_key(scene: str) -> tuple:
    """Order of scenes: intact, uncompensated, trimmed, vented, others by name."""
    s = scene.lower()
    return (SCENE_ORDER.index(s) if s in SCENE_ORDER else len(SCENE_ORDER), s)


def is_fibre_file(path: Path) -> bool:
    """A state's fibre lines: ``<stem>_fibres.vtu`` beside ``<stem>.vtu``
    (:data:`whisker_opt.output.scenes.FIBRE_SUFFIX`)."""
    path = Path(path)
    stem = path.stem
    return (stem.endswith(FIBRE_SUFFIX) and len(stem) > len(FIBRE_SUFFIX)
            and path.with_name(stem[: -len(FIBRE_SUFFIX)] + path.suffix).is_file())


def split_stem(stem: str, known_scenes: Sequence[str] = ()) -> tuple[str, str]:
    """(scene, state) of a VTU file stem.

    ``known_scenes`` (from ``scenes.json``) win: ``trimmed_vented_deflected`` with the
    scene ``trimmed_vented`` known gives (``trimmed_vented``, ``deflected``). Otherwise a
    trailing known state name or ``delta_<number>`` is split off, else the text after the
    first underscore is the state; a stem without underscore is the ``reference`` state.
    """
    for sc in sorted(known_scenes, key=len, reverse=True):
        if stem == sc:
            return sc, "reference"
        if stem.startswith(sc + "_"):
            return sc, stem[len(sc) + 1:]
    for st in STATE_ORDER:
        if stem.endswith("_" + st) and len(stem) > len(st) + 1:
            return stem[: -len(st) - 1], st
    m = re.match(r"^(.*?)_((?:delta|d)_?[-+]?\d.*)$", stem)
    if m and m.group(1):
        return m.group(1), m.group(2)
    if "_" in stem:
        a, b = stem.split("_", 1)
        return a, b
    return stem, "reference"


# ============================================================================ contents
@dataclass(frozen=True)
class RunContents:
    """What a source holds: its VTU states and the metadata found beside them.

    Attributes
    ----------
    root : Path
        The directory (or, for a single file, its folder).
    files : tuple of StateFile
    scenes : dict
        ``{group: {scene: SceneInfo}}``.
    best : dict or None
        ``best.json`` of a run directory.
    single_file : bool
        The source was one ``.vtu`` file.
    config : dict
        The run's ``config.yaml`` ({} when absent).
    """

    root: Path
    files: tuple[StateFile, ...]
    scenes: dict[str, dict[str, SceneInfo]]
    best: dict | None = None
    single_file: bool = False
    config: dict = field(default_factory=dict)

    @functools.cached_property
    def rubber(self) -> RunRubber | None:
        """The rubber the run was solved with (its ``config.yaml``'s ``material`` section,
        :func:`whisker_opt.viewer.rubber.run_rubber`); None without a usable config."""
        return run_rubber(self.config)

    @property
    def groups(self) -> list[str]:
        """Groups holding VTU files (root first, then sorted)."""
        return sorted({f.group for f in self.files}, key=lambda g: (g != ".", g))

    def default_group(self) -> str:
        """``best`` when a run directory stored the best design's meshes, else the root or the first group."""
        gs = self.groups
        for g in ("best", "."):
            if g in gs:
                return g
        if not gs:
            raise ViewerError(f"{self.root}: no *.vtu file found (searched recursively)")
        return gs[0]

    def scene_names(self, group: str) -> list[str]:
        """Scenes of a group, in the order intact, uncompensated, trimmed, vented, others."""
        return sorted({f.scene for f in self.files if f.group == group}, key=scene_sort_key)

    def states(self, group: str, scene: str) -> list[StateFile]:
        """States of one scene, reference to deflected."""
        return sorted(
            (f for f in self.files if f.group == group and f.scene == scene), key=lambda f: state_sort_key(f.state)
        )

    def info(self, group: str, scene: str) -> SceneInfo:
        """Metadata of a scene (empty :class:`SceneInfo` when none was found)."""
        return self.scenes.get(group, {}).get(scene) or SceneInfo(name=scene)

    def select(self, group: str, scenes: Sequence[str] | None = None, state: str | None = None) -> list[StateFile]:
        """One state file per scene: ``state`` (exact, or a unique prefix) or each scene's last state.

        Raises
        ------
        ViewerError
            Unknown group, scene or state; the message lists what exists.
        """
        if group not in self.groups:
            raise ViewerError(f"{self.root}: no group {group!r}; groups with VTU files: {self.groups}")
        names = self.scene_names(group)
        wanted = list(scenes) if scenes else names
        for s in wanted:
            if s not in names:
                raise ViewerError(f"{self.root / group}: no scene {s!r}; scenes: {names}")
        out = []
        for s in wanted:
            sts = self.states(group, s)
            if state is None:
                out.append(sts[-1])
                continue
            exact = [f for f in sts if f.state == state]
            pref = [f for f in sts if f.state.startswith(state)]
            hit = exact or (pref if len(pref) == 1 else [])
            if not hit:
                raise ViewerError(
                    f"{self.root / group}: scene {s!r} has no state {state!r}; states: {[f.state for f in sts]}"
                )
            out.append(hit[0])
        return out

    def delta_of(self, f: StateFile) -> float | None:
        """Deflection δ [mm] of a state file (:meth:`SceneInfo.delta_of`); None when unknown."""
        return self.info(f.group, f.scene).delta_of(f.state)

    def select_delta(self, group: str, delta: float, scenes: Sequence[str] | None = None) -> list[StateFile]:
        """One state per scene at the deflection ``delta`` [mm] (within :data:`DELTA_TOL`).

        Raises
        ------
        ViewerError
            Unknown group or scene, or a scene without a state at ``delta`` (the message
            lists the deflections it has).
        """
        if not math.isfinite(delta) or delta < 0:
            raise ViewerError(f"delta={delta!r}: must be a finite deflection >= 0 mm")
        out = []
        for f in self.select(group, scenes):
            known = [(d, x) for x in self.states(group, f.scene) if (d := self.delta_of(x)) is not None]
            best = min(known, key=lambda dx: abs(dx[0] - delta), default=None)
            if best is None or abs(best[0] - delta) > DELTA_TOL:
                have = sorted({round(d, 4) for d, _ in known})
                raise ViewerError(
                    f"{self.root / group}: scene {f.scene!r} has no state at delta={delta:g} mm; "
                    + (f"states exist at delta = {have} mm" if have else
                       f"no state with a known deflection (states: {[x.state for x in self.states(group, f.scene)]})")
                )
            out.append(best[1])
        return out

    def delta_steps(self, group: str,
                    scenes: Sequence[str] | None = None) -> list[tuple[float | None, list[StateFile]]]:
        """The steps of the δ slider: ``(δ, one state per scene)``, increasing δ.

        Every δ at which some selected scene has a state is a step; a scene without a state
        there shows its state at the largest δ below. When a scene has a (non-reference)
        state of unknown δ (no metadata), steps go by index instead (step k: each scene's
        k-th state, its last when it has fewer) with δ None.
        """
        chosen = self.select(group, scenes)
        per = []
        for f in chosen:
            sts = self.states(group, f.scene)
            ds = [self.delta_of(x) for x in sts]
            per.append((sts, {round(d, 6): x for d, x in reversed(list(zip(ds, sts))) if d is not None},
                        any(d is None and x.state != "reference" for d, x in zip(ds, sts))))
        if any(unknown or not known for _, known, unknown in per):
            n = max(len(sts) for sts, _, _ in per)
            return [(None, [sts[min(k, len(sts) - 1)] for sts, _, _ in per]) for k in range(n)]
        steps = []
        for d in sorted(set().union(*(known for _, known, _ in per))):
            files = []
            for _, known, _ in per:
                below = [k for k in known if k <= d]
                files.append(known[max(below)] if below else known[min(known)])
            steps.append((d, files))
        return steps

    def describe(self) -> str:
        """Multi-line listing of groups, scenes and states."""
        lines = [f"{self.root}"]
        for g in self.groups:
            lines.append(f"  group {g}")
            for s in self.scene_names(g):
                info = self.info(g, s)
                facts = []
                if info.Q is not None:
                    facts.append(f"Q={info.Q:g} MPa")
                if info.trim is not None:
                    facts.append(f"trim={info.trim:g} mm")
                if info.eps:
                    facts.append(f"eps(δ={info.delta[-1]:g})={info.eps[-1]:.5g}")
                states = ", ".join(f.state for f in self.states(g, s))
                lines.append(f"    scene {s:<12} states: {states}" + (f"   ({', '.join(facts)})" if facts else ""))
        return "\n".join(lines)


def discover(source: str | Path, allow_empty: bool = False) -> RunContents:
    """Find the VTU states and metadata of a results directory or a single VTU file.

    Parameters
    ----------
    source : path-like
        A directory searched recursively for ``*.vtu``, or one ``.vtu`` file.
    allow_empty : bool
        Accept a directory without VTU files (a run directory whose evaluations are to be
        re-run, :func:`whisker_opt.viewer.evaluations.evaluation_group`).

    Returns
    -------
    RunContents

    Raises
    ------
    FileNotFoundError
        ``source`` does not exist, or holds no ``*.vtu`` file (the message names it).
    ViewerError
        A file that is not a VTU, or unreadable metadata (naming the file).
    """
    source = Path(source)
    if not source.exists():
        raise FileNotFoundError(f"{source}: no such results directory or VTU file")
    if source.is_file():
        if source.suffix.lower() != ".vtu":
            raise ViewerError(f"{source}: not a .vtu file (give a results directory or a .vtu file)")
        root, vtus, single = source.parent, [source], True
    else:
        root = source
        # hidden files and folders (e.g. a re-run in progress, .eval_12.partial/) are not results,
        # nor are the fibre lines beside a state
        vtus = sorted(p for p in source.rglob("*.vtu")
                      if p.is_file() and not any(part.startswith(".") for part in p.relative_to(source).parts)
                      and not is_fibre_file(p))
        single = False
        if not vtus and not allow_empty:
            present = sorted(p.name for p in source.iterdir())[:20]
            raise FileNotFoundError(
                f"{source}: no *.vtu file found (searched recursively); it holds {present}. "
                "Deformed meshes are written by `whisker-opt simulate` and, for the best design, by `whisker-opt run`"
            )
    cfg = read_run_config(root)
    defaults = {k: v for k, v in config_section(cfg, "scene").items() if k == "contact_ratio"}
    best = None
    if (root / "best.json").is_file():
        b = read_json(root / "best.json")
        best = b if isinstance(b, dict) else None
    scenes: dict[str, dict[str, SceneInfo]] = {}
    files = []
    for p in vtus:
        group = "." if p.parent == root else p.parent.relative_to(root).as_posix()
        if group not in scenes:
            scenes[group] = _group_scenes(root, p.parent, defaults)
            if not scenes[group] and group == "best" and best and isinstance(best.get("genes"), dict):
                notes = {k: best[k] for k in ("f1", "F_p", "eval_id") if k in best}
                scenes[group] = genome_scenes(cfg, best["genes"], read_best_curves(root), notes)
        scene, state = split_stem(p.stem, list(scenes[group]))
        files.append(StateFile(group, scene, state, p))
    logger.info("%s: %d VTU file(s) in %d group(s)", source, len(files), len({f.group for f in files}))
    return RunContents(root=root, files=tuple(files), scenes=scenes, best=best, single_file=single, config=cfg)


def _group_scenes(root: Path, folder: Path, defaults: Mapping[str, Any]) -> dict[str, SceneInfo]:
    """scenes.json of ``folder`` or of its nearest parent up to ``root``."""
    d = folder
    while True:
        p = d / "scenes.json"
        if p.is_file():
            return read_scenes_json(p, defaults)
        if d == root or root not in d.parents:
            return {}
        d = d.parent
