"""Result viewer: pyvista scenes of whisker-opt results, on screen or as PNG screenshots.

A *source* is a results directory (``simulate``, ``run`` or ``mesh`` run, or any folder
holding ``*.vtu`` files at any depth) or a single ``.vtu`` file. Each VTU is one *state*
of one *scene*: ``intact_deflected.vtu`` is scene ``intact``, state ``deflected``; a file
without a known state suffix (``mesh.vtu``) is the state ``reference``. VTU files in a
sub-folder (``best/``, ``eval_12/``) form a *group*. Optional metadata is read, when
present, from ``scenes.json`` (in the VTU's folder or a parent), ``best.json``,
``config.yaml``, ``evaluations.csv`` and ``curve.csv``; every piece is optional.

What a view shows (issue 6)

* The whisker surface warped by the displacement (factor ``scale``), drawn from its
  6-node boundary triangles subdivided ``subdivision`` times, so curved faces stay
  curved and no internal subdivision edges are drawn; the element edges are drawn
  as curved polylines (:func:`boundary_edges`).
* Coloured by a field: by default the axial logarithmic strain
  ``LE_xx = (½ ln(F Fᵀ))_xx`` (the Eulerian Hencky strain, Abaqus' LE11), computed from
  the P2 displacement by :func:`axial_log_strain`, or the displacement magnitude, or any
  array stored in the VTU; one labelled scalar bar, one colour range for all panels.
* The undeformed outline (boundary of the reference section z = 0), the chamber cavity (its own surface
  component, found by connectivity), either revealed by a cut at ``z = 0``
  (``cavity="clip"``) or seen through a translucent outer surface
  (``cavity="translucent"``); the fibre helices (:mod:`geometry.fibres`, mapped by the
  interpolated displacement); the gauge footprint ``x_ss <= x <= x_ss + e``,
  ``|angle from +y| <= gauge_half_angle_deg`` on the outer cone; the contact point.
* The design parameters, the scene (Q, trim) and the gauge reading as text.

Side-by-side views (:func:`render`) put one scene per panel with linked cameras and a
shared colour range: intact at Q_i, trimmed uncompensated (``trimmed_uncompensated``: the
trimmed whisker still at Q_i) and trimmed vented (``trimmed`` at Q = 0, the GA's compensated
state), each with its gauge reading.

Deflection states ``<scene>_delta_<δ>.vtu`` (every solved increment, δ in mm) sit between
``pressurised`` (δ = 0) and ``deflected`` (the last increment); :meth:`RunContents.select_delta`
picks every scene at one δ (``--delta``), :meth:`RunContents.delta_steps` orders them for the
interactive slider (and the ``n`` / ``b`` keys).

For a run directory ``--rank N`` / ``--eval ID`` show another evaluation: its ``eval_<id>/``
folder, or ``best/`` when it is the best design, else its scenes are solved anew with the
run's ``config.yaml`` into ``eval_<id>/`` (:func:`evaluation_group`), kept for later views.

Only :func:`require_pyvista` imports pyvista; importing this module does not, so the CLI
can register the command without the optional ``viewer`` extra installed.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import json
import logging
import math
import os
import re
import shutil
import sys
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

logger = logging.getLogger(__name__)

INSTALL_HINT = "install the viewer extra: pip install 'whisker-opt[viewer]'"
DISPLACEMENT_NAMES = ("displacement", "u", "U", "disp", "Displacement", "DISP")
STRAIN_FIELD = "axial_log_strain"
MAGNITUDE_FIELD = "displacement_magnitude"
MISES_FIELD = "von_mises"
STORED_STRAIN_NAMES = ("axial_log_strain", "le11", "le_xx", "log_strain_xx", "lexx")
FIELD_ALIASES = {
    "strain": STRAIN_FIELD,
    "axial_strain": STRAIN_FIELD,
    "log_strain": STRAIN_FIELD,
    "le11": STRAIN_FIELD,
    "le_xx": STRAIN_FIELD,
    "displacement": MAGNITUDE_FIELD,
    "magnitude": MAGNITUDE_FIELD,
    "|u|": MAGNITUDE_FIELD,
    "mises": MISES_FIELD,
    "stress": MISES_FIELD,
    "von_mises_stress": MISES_FIELD,
}
FIELD_LABELS = {STRAIN_FIELD: "LE_xx [-]", MAGNITUDE_FIELD: "displacement [mm]", MISES_FIELD: "von Mises [MPa]"}
STATE_ORDER = (
    "reference", "undeformed", "mesh", "initial", "pressurised", "pressurized", "inflated", "deflected", "final",
)
SCENE_ORDER = (
    "intact", "uncompensated", "trimmed_uncompensated", "trimmed", "vented", "trimmed_vented", "compensated", "scene",
)
UNCOMPENSATED = "trimmed_uncompensated"  # the trimmed whisker still at Q_i (whisker_opt.cli.commands.UNCOMPENSATED)
SCENE_TITLES = {
    "intact": "intact",
    "uncompensated": "trimmed, uncompensated",
    UNCOMPENSATED: "trimmed, uncompensated",
    "vented": "trimmed, vented",
    "trimmed_vented": "trimmed, vented",
    "compensated": "trimmed, compensated",
}
DELTA_TOL = 0.0051
"""Tolerance [mm] matching a requested or file-name δ to a solved one (file names carry δ to 0.01 mm)."""
CAVITY_MODES = ("clip", "translucent", "hidden")
FIBRE_COLOURS = ("darkorange", "saddlebrown")  # alternate, so the interleaved helices of a double helix stand apart
META_FILES = ("scenes.json", "best.json", "config.yaml", "evaluations.csv", "curve.csv")


class ViewerError(ValueError):
    """A request the viewer cannot serve; the message names the path, field or value."""


class ViewerUnavailable(ImportError):
    """pyvista (the optional ``viewer`` extra) is not installed."""


def require_pyvista():
    """Import pyvista or raise :class:`ViewerUnavailable` with the install command.

    Returns
    -------
    module
        The ``pyvista`` module.
    """
    try:
        import pyvista
    except ImportError as exc:  # includes sys.modules["pyvista"] = None
        raise ViewerUnavailable(
            f"the result viewer needs pyvista, which is not importable ({exc}); {INSTALL_HINT}"
        ) from exc
    return pyvista


def is_headless(environ: Mapping[str, str] | None = None, platform: str | None = None) -> bool:
    """Whether no display is available to open a window on.

    On Linux and other X11/Wayland systems a display exists when ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` is set; macOS and Windows always have one.

    Parameters
    ----------
    environ : mapping, optional
        Environment (default ``os.environ``).
    platform : str, optional
        ``sys.platform`` value (default the running one).
    """
    env = os.environ if environ is None else environ
    plat = sys.platform if platform is None else platform
    if plat.startswith(("win", "darwin", "cygwin")):
        return False
    return not (env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"))


# ============================================================================ metadata
@dataclass(frozen=True)
class GaugeSpot:
    """Where the gauge sits on the outer cone (reference coordinates).

    Attributes
    ----------
    x_ss : float
        Axial start [mm].
    e : float
        Axial length [mm].
    half_angle_deg : float
        Angular half-width about +y [deg].
    """

    x_ss: float
    e: float
    half_angle_deg: float = 20.0


@dataclass(frozen=True)
class SceneInfo:
    """Optional facts about one scene (all may be missing).

    Attributes
    ----------
    name : str
    design : dict or None
        :meth:`geometry.design.WhiskerDesign.as_dict` of the scene's design.
    Q : float or None
        Chamber pressure [MPa].
    trim : float or None
        Trimmed length [mm].
    contact_x : float or None
        Axial position of the contact in the pressurised configuration [mm].
    gauge : GaugeSpot or None
    delta : tuple of float
        Solved deflections [mm].
    eps : tuple of float
        Gauge readings at ``delta`` [-].
    delta_l : float or None
        Axial extension by the pressure [mm].
    length_q : float or None
        Length after pressurisation [mm].
    notes : dict
        Other facts shown as text (e.g. genes, f1, F_p of an evaluation).
    """

    name: str
    design: dict | None = None
    Q: float | None = None
    trim: float | None = None
    contact_x: float | None = None
    gauge: GaugeSpot | None = None
    delta: tuple[float, ...] = ()
    eps: tuple[float, ...] = ()
    delta_l: float | None = None
    length_q: float | None = None
    notes: dict = field(default_factory=dict)

    def delta_of(self, state: str) -> float | None:
        """Deflection δ [mm] of a state: 0 for the pressurised state, δ parsed from names like
        ``delta_1.50`` (snapped to a solved δ within :data:`DELTA_TOL`), the last solved δ for
        ``deflected``/``final``; None when unknown (and for the reference state)."""
        s = state.lower()
        if s in ("pressurised", "pressurized", "inflated"):
            return 0.0
        if s in ("deflected", "final"):
            return self.delta[-1] if self.delta else None
        d = _number_in(s) if ("delta" in s or s.startswith("d")) else None
        if d is None:
            return None
        if self.delta:
            k = int(np.argmin(np.abs(np.asarray(self.delta) - d)))
            if abs(self.delta[k] - d) <= DELTA_TOL:
                return self.delta[k]
        return d

    def reading(self, state: str) -> tuple[float, float] | None:
        """(δ, ε) shown for a state (δ from :meth:`delta_of`, ε interpolated in the solved
        readings); None when unknown."""
        if not self.delta or len(self.delta) != len(self.eps):
            return None
        d = self.delta_of(state)
        if d is None or not (self.delta[0] - DELTA_TOL <= d <= self.delta[-1] + DELTA_TOL):
            return None
        return d, float(np.interp(d, self.delta, self.eps))


def _float(v: Any) -> float | None:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def _number_in(s: str) -> float | None:
    m = re.search(r"[-+]?\d+(?:[.p]\d+)?(?:e[-+]?\d+)?", s)
    if not m:
        return None
    return _float(m.group(0).replace("p", "."))


def scene_info_from_dict(name: str, d: Mapping[str, Any], defaults: Mapping[str, Any] | None = None) -> SceneInfo:
    """Build a :class:`SceneInfo` from one ``scenes.json`` entry (tolerant of missing keys).

    Recognised keys: ``design`` (dict), ``Q`` or ``Q_MPa``, ``trim``, ``contact_x``,
    ``gauge`` ({x_ss, e, half_angle_deg}), ``solved_delta_mm`` or ``delta``, ``eps_line`` (or
    ``eps_centroid`` when ``gauge_variant`` is ``centroid``) or ``eps``, ``delta_l_mm``,
    ``length_q_mm``; ``defaults`` may give ``contact_ratio``.
    """
    defaults = defaults or {}
    design = d.get("design") if isinstance(d.get("design"), dict) else None
    trim = _float(d.get("trim", design.get("trim") if design else None))
    gauge = None
    g = d.get("gauge")
    if isinstance(g, Mapping) and _float(g.get("x_ss")) is not None and _float(g.get("e")) is not None:
        gauge = GaugeSpot(float(g["x_ss"]), float(g["e"]), _float(g.get("half_angle_deg")) or
                          (_float(design.get("gauge_half_angle_deg")) if design else None) or 20.0)
    elif design and _float(design.get("x_ss")) is not None and _float(design.get("e")) is not None:
        gauge = GaugeSpot(float(design["x_ss"]), float(design["e"]), _float(design.get("gauge_half_angle_deg")) or 20.0)
    delta = d.get("solved_delta_mm", d.get("delta")) or ()
    eps_key = "eps_centroid" if d.get("gauge_variant") == "centroid" and "eps_centroid" in d else "eps_line"
    eps = d.get(eps_key, d.get("eps")) or ()
    try:
        delta = tuple(float(x) for x in delta)
        eps = tuple(float(x) for x in eps)
    except (TypeError, ValueError):
        delta, eps = (), ()
    length_q = _float(d.get("length_q_mm"))
    if length_q is None and design and _float(design.get("L")) is not None:
        length_q = float(design["L"]) - (trim or 0.0) + (_float(d.get("delta_l_mm")) or 0.0)
    contact_x = _float(d.get("contact_x"))
    ratio = _float(d.get("contact_ratio", defaults.get("contact_ratio")))
    if ratio is None and design:  # the SceneConfig default: contact at the tip
        ratio = 1.0
    if contact_x is None and ratio is not None and length_q is not None:
        contact_x = ratio * length_q
    notes = {k: d[k] for k in ("genes", "f1", "F_p", "eval_id", "status") if k in d}
    return SceneInfo(
        name=name,
        design=design,
        Q=_float(d.get("Q", d.get("Q_MPa", d.get("Q_i")))),
        trim=trim,
        contact_x=contact_x,
        gauge=gauge,
        delta=delta,
        eps=eps,
        delta_l=_float(d.get("delta_l_mm", d.get("delta_l"))),
        length_q=length_q,
        notes=notes,
    )


def read_json(path: Path) -> Any:
    """Parse a JSON file; :class:`ViewerError` naming the path when it is not valid JSON."""
    try:
        return json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise ViewerError(f"{path}: not valid JSON ({exc})") from None


def read_scenes_json(path: Path, defaults: Mapping[str, Any] | None = None) -> dict[str, SceneInfo]:
    """The scenes of a ``scenes.json`` file: every top-level entry that is a mapping.

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    ViewerError
        Not JSON, or its top level is not a mapping.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such scenes file")
    data = read_json(path)
    if not isinstance(data, dict):
        raise ViewerError(f"{path}: top level must be a mapping of scene name -> facts, got {type(data).__name__}")
    return {k: scene_info_from_dict(k, v, defaults) for k, v in data.items() if isinstance(v, dict)}


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


def _section(cfg: Mapping[str, Any], name: str) -> dict[str, Any]:
    sec = cfg.get(name)
    return sec if isinstance(sec, dict) else {}


def scenes_from_genes(cfg: Mapping[str, Any], genes: Mapping[str, Any],
                      curves: tuple[Sequence[float], Sequence[float], Sequence[float]] | None = None,
                      notes: Mapping[str, Any] | None = None) -> dict[str, SceneInfo]:
    """The intact (Q = Q_i), trimmed uncompensated (trim = optimiser.delta_max, Q = Q_i; only
    when Q_i > 0) and trimmed vented (Q = 0) scenes of a genome.

    Mirrors :meth:`whisker_opt.experiment.evaluator.SceneEvaluator.specs`: the ``design`` section of
    ``cfg`` with ``alpha, l, t`` from the genes ``alpha, l, t``.

    Parameters
    ----------
    cfg : mapping
        The run's ``config.yaml``.
    genes : mapping
        ``alpha`` [deg], ``l``, ``t`` [mm], ``Q_i`` [MPa].
    curves : (delta, eps_i, eps_c), optional
        Gauge responses of the intact and the vented scene (e.g. ``best_curves.csv``).
    notes : mapping, optional
        Shown as text (f1, F_p, ...).
    """
    try:  # a partial design section takes the WhiskerDesign defaults, as the config does
        from geometry.design import WhiskerDesign

        design = WhiskerDesign().as_dict()
    except Exception:  # noqa: BLE001 - geometry unavailable: use what the config says
        design = {}
    design.update(_section(cfg, "design"))
    try:
        design.update(alpha=float(genes["alpha"]), l=float(genes["l"]), t=float(genes["t"]))
    except (KeyError, TypeError, ValueError):
        return {}
    opt = _section(cfg, "optimiser")
    trim = _float(opt.get("trim", opt.get("delta_max"))) or 5.0
    ratio = _float(_section(cfg, "scene").get("contact_ratio")) or 1.0
    out = {}
    q_i = _float(genes.get("Q_i"))
    cases = [("intact", 0.0, q_i, 1), (UNCOMPENSATED, trim, q_i, None), ("trimmed", trim, 0.0, 2)]
    for name, tr, q, k in cases:
        if name == UNCOMPENSATED and not (q_i and q_i > 0):
            continue
        d = dict(design, trim=tr)
        entry: dict[str, Any] = {"design": d, "Q": q, "trim": tr, "contact_ratio": ratio}
        if curves is not None and k is not None:
            entry.update(delta=list(curves[0]), eps=list(curves[k]))
        out[name] = dataclasses.replace(scene_info_from_dict(name, entry), notes=dict(notes or {}))
    return out


def _best_curves(root: Path) -> tuple[list[float], list[float], list[float]] | None:
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


# ============================================================================ discovery
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
    num = _number_in(s)
    return (1, num if num is not None else math.inf, 0, s)


def scene_sort_key(scene: str) -> tuple:
    s = scene.lower()
    return (SCENE_ORDER.index(s) if s in SCENE_ORDER else len(SCENE_ORDER), s)


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

    @property
    def c10(self) -> float | None:
        """Neo-Hookean C10 [MPa] of the run's ``config.yaml`` (``material.C10``), None when absent."""
        return _float(_section(self.config, "material").get("C10"))

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
        re-run, :func:`evaluation_group`).

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
        # hidden files and folders (e.g. a re-run in progress, .eval_12.partial/) are not results
        vtus = sorted(p for p in source.rglob("*.vtu")
                      if p.is_file() and not any(part.startswith(".") for part in p.relative_to(source).parts))
        single = False
        if not vtus and not allow_empty:
            present = sorted(p.name for p in source.iterdir())[:20]
            raise FileNotFoundError(
                f"{source}: no *.vtu file found (searched recursively); it holds {present}. "
                "Deformed meshes are written by `whisker-opt simulate` and, for the best design, by `whisker-opt run`"
            )
    cfg = read_run_config(root)
    defaults = {k: v for k, v in _section(cfg, "scene").items() if k == "contact_ratio"}
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
                scenes[group] = scenes_from_genes(cfg, best["genes"], _best_curves(root), notes)
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


def evaluation_row(root: Path, rank: int | None = None, eval_id: str | int | None = None) -> dict[str, str]:
    """A row of ``evaluations.csv``: by ``eval_id``, or the ``rank``-th best (1 = best) of
    the successful evaluations sorted by ``F_p``.

    Raises
    ------
    FileNotFoundError
        No ``evaluations.csv`` in ``root``.
    ViewerError
        Rank out of range or unknown evaluation id.
    """
    path = Path(root) / "evaluations.csv"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file (--rank/--eval need a run directory of `whisker-opt run`)")
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    if eval_id is not None:
        hit = [r for r in rows if str(r.get("eval_id", "")).strip() == str(eval_id)]
        if not hit:
            raise ViewerError(f"{path}: no evaluation with eval_id={eval_id!r} ({len(rows)} rows)")
        return hit[0]
    ok = [r for r in rows if r.get("status", "ok") == "ok" and _float(r.get("F_p")) is not None]
    ok.sort(key=lambda r: float(r["F_p"]))
    # the same design is evaluated once but may appear again as a cache hit
    uniq, seen = [], set()
    for r in ok:
        key = tuple(r.get(k) for k in ("alpha", "l", "t", "Q_i"))
        if key not in seen:
            seen.add(key)
            uniq.append(r)
    if rank is None or not (1 <= rank <= len(uniq)):
        raise ViewerError(f"{path}: --rank {rank} out of range: 1..{len(uniq)} successful distinct designs")
    return uniq[rank - 1]


def group_for_evaluation(contents: RunContents, eval_id: str | int) -> str:
    """The group folder holding an evaluation's meshes (``eval_12``, ``eval-0012``, ``12``...).

    Raises
    ------
    ViewerError
        No such folder; the message lists the groups that exist.
    """
    eid = str(eval_id).strip()
    pat = re.compile(rf"(?:^|[^0-9])0*{re.escape(eid.lstrip('0') or '0')}$")
    hits = [g for g in contents.groups if pat.search(g.split("/")[-1])]
    if not hits:
        raise ViewerError(
            f"{contents.root}: no meshes stored for evaluation {eid} (looked for a folder named like eval_{eid}); "
            f"folders with VTU files: {contents.groups}"
        )
    return hits[0]


GENE_NAMES = ("alpha", "l", "t", "Q_i")


def _same_design(best: Mapping[str, Any] | None, row: Mapping[str, Any]) -> bool:
    """Whether ``best.json`` describes the evaluation ``row`` (same eval_id, else same genes)."""
    if not best:
        return False
    if best.get("eval_id") is not None and str(row.get("eval_id", "")).strip():
        return str(best["eval_id"]).strip() == str(row["eval_id"]).strip()
    genes = best.get("genes")
    if not isinstance(genes, Mapping):
        return False
    pairs = [(_float(genes.get(k)), _float(row.get(k))) for k in GENE_NAMES]
    return all(a is not None and b is not None and math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12) for a, b in pairs)


def evaluation_group(contents: RunContents, row: Mapping[str, Any], rerun: bool = True) -> tuple[RunContents, str]:
    """The group holding the meshes of an evaluation, solving its scenes when none are stored.

    Looked for in order: a folder named like ``eval_<id>`` (:func:`group_for_evaluation`);
    ``best`` when ``best.json`` describes this evaluation; else, with ``rerun``, the
    evaluation's scenes (intact at Q_i, trimmed uncompensated, trimmed vented) are solved
    with the run's ``config.yaml`` by :func:`whisker_opt.cli.commands.write_design_scenes` into
    ``eval_<id>/`` of the run directory (through a hidden ``.eval_<id>.partial/`` folder
    renamed when complete), where later views find them.

    Parameters
    ----------
    contents : RunContents
        A run directory of ``whisker-opt run``.
    row : mapping
        The evaluation's row of ``evaluations.csv`` (:func:`evaluation_row`).
    rerun : bool
        Solve the scenes when no meshes are stored (else :class:`ViewerError`).

    Returns
    -------
    contents, group
        ``contents`` re-discovered after a re-run.

    Raises
    ------
    ViewerError
        No stored meshes and ``rerun`` is False, genes that are not numbers, or the
        scenes cannot be solved (invalid geometry, unconverged solve).
    FileNotFoundError
        A re-run without the run's ``config.yaml``.
    """
    eid = str(row.get("eval_id", "")).strip()
    try:
        return contents, group_for_evaluation(contents, eid)
    except ViewerError:
        if _same_design(contents.best, row) and "best" in contents.groups:
            return contents, "best"
        if not rerun:
            raise
    root = contents.root
    where = f"{root / 'evaluations.csv'}: evaluation {eid or '?'}"
    genes = {}
    for k in GENE_NAMES:
        genes[k] = _float(row.get(k))
        if genes[k] is None:
            raise ViewerError(f"{where}: gene {k}={row.get(k)!r} is not a number; cannot re-run its scenes")
    cfg_path = root / "config.yaml"
    if not cfg_path.is_file():
        raise FileNotFoundError(f"{cfg_path}: no such file; re-running the scenes of evaluation {eid} needs the "
                                "run's config")
    from whisker_opt import workflows
    from whisker_opt.config.model import ConfigError, load_config

    final = root / f"eval_{eid or '_'.join(f'{genes[k]:.6g}' for k in GENE_NAMES)}"
    tmp = root / f".{final.name}.partial"
    logger.warning("%s (status %s, F_p %s): no meshes stored; re-running its scenes (%s) into %s, "
                   "kept there for later views", where, row.get("status", "?"), row.get("F_p", "?"),
                   ", ".join(f"{k}={v:.5g}" for k, v in genes.items()), final)
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        workflows.write_design_scenes(tmp, load_config(cfg_path), genes)
    except ConfigError as exc:
        raise ViewerError(f"{cfg_path}: {exc}") from exc
    except Exception as exc:  # noqa: BLE001 - invalid geometry, unconverged solve, mesher failure
        shutil.rmtree(tmp, ignore_errors=True)
        raise ViewerError(f"{where}: its scenes cannot be re-run ({type(exc).__name__}: {exc})") from exc
    final.mkdir(exist_ok=True)  # it may exist without VTU files; nothing in it is overwritten but ours
    for f in tmp.iterdir():
        f.replace(final / f.name)
    tmp.rmdir()
    contents = discover(root)
    return contents, final.name


# ============================================================================ fields
def load_grid(path: str | Path):
    """Read a VTU file as a pyvista ``UnstructuredGrid``.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ViewerError
        It cannot be read or holds no tetrahedra (the message names the path).
    """
    pv = require_pyvista()
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such VTU file")
    with path.open("rb") as fh:
        head = fh.read(512).lstrip()
    if not (head.startswith(b"<?xml") or head.startswith(b"<VTKFile")):
        raise ViewerError(f"{path}: not a VTU file (no XML VTKFile header)")
    with warnings.catch_warnings(record=True) as caught, pv.vtk_verbosity("off"):
        warnings.simplefilter("always")
        try:
            grid = pv.read(path)
        except Exception as exc:  # noqa: BLE001 - VTK raises various types
            raise ViewerError(f"{path}: cannot read as VTU ({exc})") from None
    if not isinstance(grid, pv.UnstructuredGrid) or grid.n_cells == 0:
        why = "; ".join(str(w.message).splitlines()[0] for w in caught)
        n = f", {grid.n_cells} cells" if hasattr(grid, "n_cells") else ""
        raise ViewerError(
            f"{path}: not a readable VTU unstructured grid with cells (got {type(grid).__name__}{n})"
            + (f"; reader: {why}" if why else "")
        )
    types = set(np.unique(grid.celltypes).tolist())
    if not types & {int(pv.CellType.QUADRATIC_TETRA), int(pv.CellType.TETRA)}:
        raise ViewerError(
            f"{path}: no tetrahedra (VTK cell types {sorted(types)}; need 24 = quadratic tetra or 10 = tetra)"
        )
    return grid


def cell_volumes(grid) -> np.ndarray:
    """Signed VTK volumes of the cells (VTK's own node ordering), shape (n_cells,).

    An inverted or misordered 10-node tet (e.g. Gmsh's edge order) gives a negative or
    wrong volume; compare with :func:`fem.mesh.volumes`.
    """
    return np.asarray(grid.compute_cell_sizes(length=False, area=False, volume=True)["Volume"])


def displacement_name(grid, requested: str | None = None, where: str = "grid") -> str | None:
    """Name of the point displacement array: ``requested``, else the first of
    :data:`DISPLACEMENT_NAMES` present (3-component), else None.

    Raises
    ------
    ViewerError
        ``requested`` is not a 3-component point array (lists the arrays).
    """
    if requested:
        arr = grid.point_data.get(requested)
        if arr is None or np.ndim(arr) != 2 or np.shape(arr)[1] != 3:
            raise ViewerError(
                f"{where}: displacement array {requested!r} not found as a 3-component point array; "
                f"point arrays: {list(grid.point_data.keys())}"
            )
        return requested
    for name in DISPLACEMENT_NAMES:
        arr = grid.point_data.get(name)
        if arr is not None and np.ndim(arr) == 2 and np.shape(arr)[1] == 3:
            return name
    return None


def quadratic_cells(grid) -> np.ndarray:
    """The (n, 10) connectivity of the grid's quadratic tetrahedra (VTK = fem TET10 order)."""
    pv = require_pyvista()
    cells = grid.cells_dict.get(int(pv.CellType.QUADRATIC_TETRA), np.zeros((0, 10), np.int64))
    return np.asarray(cells, dtype=np.int64)


def nodal_deformation_gradient(points: np.ndarray, cells: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Deformation gradient at the nodes, averaged over the elements sharing each node.

    ``F = I + ∂u/∂X`` is evaluated with the TET10 shape functions (:mod:`fem.element`)
    at each element's 10 nodes (``∂u/∂X = (∂u/∂ξ)(∂X/∂ξ)⁻¹``), then averaged.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
        Reference coordinates.
    cells : ndarray, shape (n_el, 10)
    u : ndarray, shape (n_nodes, 3)

    Returns
    -------
    F : ndarray, shape (k, 3, 3)
        At the ``k`` nodes used by some cell.
    used : ndarray of bool, shape (n_nodes,)
    """
    from fem import element

    X = np.asarray(points, dtype=float)
    u = np.asarray(u, dtype=float)
    cells = np.asarray(cells, dtype=np.int64)
    dN = element.shape_gradients(element.NODES)  # (10, 10, 3) at the 10 nodes
    J = np.einsum("eai,nak->enik", X[cells], dN)  # (n_el, 10, 3, 3) dX/dxi
    H = np.einsum("eai,nak->enik", u[cells], dN)  # (n_el, 10, 3, 3) du/dxi
    F = np.eye(3) + np.einsum("enik,enkj->enij", H, np.linalg.inv(J))  # (n_el, 10, 3, 3)
    n = len(X)
    Fn = np.zeros((n, 9))
    np.add.at(Fn, cells.ravel(), F.reshape(-1, 9))
    cnt = np.bincount(cells.ravel(), minlength=n).astype(float)
    used = cnt > 0
    return (Fn[used] / cnt[used, None]).reshape(-1, 3, 3), used


def axial_log_strain(points: np.ndarray, cells: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Nodal axial Hencky strain ``LE_xx = (½ ln(F Fᵀ))_xx`` of a P2 displacement field.

    F from :func:`nodal_deformation_gradient`; ``½ ln(B)``, ``B = F Fᵀ``, by
    eigen-decomposition (``ln V = Σ_k ½ ln λ_k n_k n_kᵀ``; Abaqus' LE, Eulerian).

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
        Reference coordinates.
    cells : ndarray, shape (n_el, 10)
    u : ndarray, shape (n_nodes, 3)

    Returns
    -------
    ndarray, shape (n_nodes,)
        NaN at nodes not used by any cell.
    """
    F, used = nodal_deformation_gradient(points, cells, u)
    B = np.einsum("kij,klj->kil", F, F)  # (k, 3, 3) F Fᵀ
    lam, vec = np.linalg.eigh(B)  # (k, 3), (k, 3, 3)
    out = np.full(len(used), np.nan)
    out[used] = np.einsum("kj,kj->k", vec[:, 0, :] ** 2, 0.5 * np.log(np.maximum(lam, 1e-300)))  # (k,)
    return out


def von_mises_neo_hookean(F: np.ndarray, c10: float) -> np.ndarray:
    """Von Mises stress of the decoupled neo-Hookean law ``W = C10 (Ī₁ - 3) + U(J)``.

    The deviatoric Cauchy stress is ``s = 2 C10 J^(-5/3) dev(B)``, ``B = F Fᵀ``
    (the volumetric part, hence the element pressure, does not enter), and
    ``σ_vM = sqrt(3/2 s:s)``. For an incompressible uniaxial stretch λ this is
    ``2 C10 (λ² - 1/λ)``.

    Parameters
    ----------
    F : ndarray, shape (k, 3, 3)
    c10 : float
        [MPa].

    Returns
    -------
    ndarray, shape (k,)
        [MPa].
    """
    J = np.linalg.det(F)  # (k,)
    B = np.einsum("kij,klj->kil", F, F)  # (k, 3, 3)
    dev = B - np.einsum("kii->k", B)[:, None, None] / 3.0 * np.eye(3)  # (k, 3, 3)
    sdev = 2.0 * c10 * np.abs(J)[:, None, None] ** (-5.0 / 3.0) * dev  # (k, 3, 3)
    return np.sqrt(1.5 * np.einsum("kij,kij->k", sdev, sdev))


def add_derived_fields(grid, disp: str | None, c10: float | None = None) -> None:
    """Add ``X_ref``, ``displacement_magnitude``, ``axial_log_strain`` and (given ``c10``)
    ``von_mises`` point arrays in place.

    The strain is computed only for quadratic tets and when no stored axial strain exists;
    the von Mises stress only for quadratic tets with a known neo-Hookean C10 [MPa].
    """
    grid.point_data["X_ref"] = np.asarray(grid.points, dtype=float).copy()
    if disp is None:
        return
    u = np.asarray(grid.point_data[disp], dtype=float)
    grid.point_data[MAGNITUDE_FIELD] = np.linalg.norm(u, axis=1)
    cells = quadratic_cells(grid)
    stored = [k for k in grid.point_data.keys() if k.lower() in STORED_STRAIN_NAMES]
    if stored:
        if stored[0] != STRAIN_FIELD:
            grid.point_data[STRAIN_FIELD] = np.array(grid.point_data[stored[0]], dtype=float)
    if not len(cells) or (stored and c10 is None):
        return
    F, used = nodal_deformation_gradient(grid.points, cells, u)
    if not stored:
        B = np.einsum("kij,klj->kil", F, F)  # (k, 3, 3)
        lam, vec = np.linalg.eigh(B)  # (k, 3), (k, 3, 3)
        le = np.full(len(used), np.nan)
        le[used] = np.einsum("kj,kj->k", vec[:, 0, :] ** 2, 0.5 * np.log(np.maximum(lam, 1e-300)))  # (k,)
        grid.point_data[STRAIN_FIELD] = le
    if c10 is not None:
        vm = np.full(len(used), np.nan)
        vm[used] = von_mises_neo_hookean(F, c10)
        grid.point_data[MISES_FIELD] = vm


def field_names(grid) -> list[str]:
    """Fields a view can be coloured by: derived ones first, then stored point and cell arrays."""
    names = [n for n in (STRAIN_FIELD, MAGNITUDE_FIELD, MISES_FIELD) if n in grid.point_data]
    skip = {"X_ref", "vtkOriginalPointIds", "vtkOriginalCellIds", *names}
    names += [k for k in grid.point_data.keys() if k not in skip]
    names += [k for k in grid.cell_data.keys() if k not in skip and k not in names]
    return names


def resolve_field(grid, requested: str | None, where: str = "grid") -> tuple[str | None, str, int | None]:
    """(array name, label, component) for colouring; ``None`` array = plain colour.

    ``requested`` may be an alias (``strain``, ``LE11``, ``displacement``, ``|u|``), an
    array name (vectors are shown by magnitude) or ``name:x`` / ``name:0`` for a component.
    The default is the axial log strain, else the displacement magnitude, else the first
    stored array.

    Raises
    ------
    ViewerError
        Unknown field, naming it and listing the available ones.
    """
    available = field_names(grid)
    if requested is None:
        if not available:
            return None, "", None
        name = available[0]
        return name, FIELD_LABELS.get(name, name), None
    if requested.lower() in ("none", "solid", ""):
        return None, "", None
    comp = None
    base = requested
    m = re.match(r"^(.+?)[:\[]([xyz012])\]?$", requested)
    if m and m.group(1) in available:
        base, c = m.group(1), m.group(2)
        comp = "xyz".index(c) if c in "xyz" else int(c)
    base = FIELD_ALIASES.get(base.lower(), base) if base not in available else base
    if base not in available:
        raise ViewerError(
            f"{where}: no field {requested!r}; available fields: {available} (or aliases {sorted(FIELD_ALIASES)})"
        )
    arr = grid.point_data.get(base)
    if arr is None:
        arr = grid.cell_data.get(base)
    if comp is not None and (np.ndim(arr) != 2 or comp >= np.shape(arr)[1]):
        raise ViewerError(f"{where}: field {base!r} has no component {comp} (shape {np.shape(arr)})")
    label = FIELD_LABELS.get(base, base) + (f" [{'xyz'[comp]}]" if comp is not None and comp < 3 else "")
    if comp is None and np.ndim(arr) == 2 and np.shape(arr)[1] > 1:
        label = f"|{base}|"
    return base, label, comp


# ============================================================================ geometry of a state
@dataclass
class StateView:
    """One loaded state, ready to draw.

    Attributes
    ----------
    title : str
    grid : pyvista.UnstructuredGrid
        Reference grid with derived fields (:func:`add_derived_fields`).
    warped : pyvista.UnstructuredGrid
        ``grid`` with points moved by ``scale × displacement``.
    outer, cavity : pyvista.PolyData or None
        Smooth (subdivided P2) warped outer and cavity surfaces, carrying the point data.
    edges : pyvista.PolyData or None
        Curved element edges on the warped boundary.
    outline : pyvista.PolyData or None
        Undeformed outline: boundary of the reference section at ``z = cut_z`` (only
        when a displacement exists).
    displacement : str or None
    scale : float
    info : SceneInfo
    state : str
    path : Path or None
    cut_z : float
        The section / clipping plane ``z = cut_z`` (middle of the reference bounds; 0 for a whisker).
    """

    title: str
    grid: Any
    warped: Any
    outer: Any
    cavity: Any
    edges: Any
    outline: Any
    displacement: str | None
    scale: float
    info: SceneInfo
    state: str = ""
    path: Path | None = None
    cut_z: float = 0.0

    def field_range(self, name: str | None, comp: int | None = None,
                    percentile: float = 0.0) -> tuple[float, float] | None:
        """(min, max) of a field over the drawn surface, or its (p, 100 − p) percentiles
        when ``percentile`` = p > 0; None when absent."""
        if name is None:
            return None
        vals = []
        for s in (self.outer, self.cavity):
            if s is not None and s.n_points:
                a = s.point_data.get(name)
                if a is None:
                    a = s.cell_data.get(name)
                if a is not None:
                    vals.append(_scalar(np.asarray(a), comp))
        if not vals:
            return None
        v = np.concatenate(vals)
        v = v[np.isfinite(v)]
        if not len(v):
            return None
        if percentile > 0.0:
            lo, hi = np.percentile(v, [percentile, 100.0 - percentile])
            return float(lo), float(hi)
        return float(v.min()), float(v.max())


def _scalar(a: np.ndarray, comp: int | None) -> np.ndarray:
    if a.ndim == 2:
        return a[:, comp] if comp is not None else np.linalg.norm(a, axis=1)
    return a


def _surface_components(faces6: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Label 0 for the outer boundary component (largest bounding box), 1 for inner ones (cavities)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(points)
    a = faces6[:, [0, 1, 2]].ravel()
    b = faces6[:, [1, 2, 0]].ravel()
    g = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    face_lab = lab[faces6[:, 0]]
    comps = np.unique(face_lab)
    if len(comps) == 1:
        return np.zeros(len(faces6), dtype=int)
    diag = []
    for c in comps:
        p = points[np.unique(faces6[face_lab == c, :3])]
        diag.append(np.linalg.norm(p.max(0) - p.min(0)))
    outer = comps[int(np.argmax(diag))]
    return np.where(face_lab == outer, 0, 1)


def _tri6_surface(points: np.ndarray, faces6: np.ndarray, source, elem: np.ndarray, subdivision: int):
    """Subdivided PolyData of 6-node triangles with the source's point data and owning-cell data."""
    pv = require_pyvista()
    # copies, not views: handing one dataset's VTK-backed arrays to another corrupts the heap
    # (pyvista 0.49 / VTK 9.6, reproduced with MALLOC_CHECK_=3)
    tri = pv.UnstructuredGrid({pv.CellType.QUADRATIC_TRIANGLE: faces6}, np.array(points, dtype=float))
    for k in source.point_data.keys():
        tri.point_data[k] = np.array(source.point_data[k])
    for k in source.cell_data.keys():
        tri.cell_data[k] = np.array(source.cell_data[k])[elem]
    return tri.extract_surface(
        pass_pointid=False, pass_cellid=False, nonlinear_subdivision=subdivision, algorithm="dataset_surface"
    )


def boundary_edges(points: np.ndarray, faces6: np.ndarray, n_seg: int = 4):
    """Curved element edges of 6-node boundary triangles as polylines.

    Each edge (a, m, b) is the quadratic ``x(s) = (1-s)(1-2s) a + 4s(1-s) m + s(2s-1) b``
    sampled at ``n_seg + 1`` points; shared edges are drawn once.

    Returns
    -------
    pyvista.PolyData
    """
    pv = require_pyvista()
    e = np.concatenate([faces6[:, [0, 3, 1]], faces6[:, [1, 4, 2]], faces6[:, [2, 5, 0]]])  # (3 n_f, 3)
    key = np.sort(e[:, [0, 2]], axis=1)
    _, idx = np.unique(key, axis=0, return_index=True)
    e = e[idx]
    s = np.linspace(0.0, 1.0, n_seg + 1)
    Na, Nm, Nb = (1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)  # (n_seg+1,)
    P = np.einsum("s,ei->esi", Na, points[e[:, 0]]) + np.einsum("s,ei->esi", Nm, points[e[:, 1]]) \
        + np.einsum("s,ei->esi", Nb, points[e[:, 2]])  # (n_e, n_seg+1, 3)
    n_e = len(e)
    ids = np.arange(n_e * (n_seg + 1)).reshape(n_e, n_seg + 1)
    lines = np.hstack([np.full((n_e, 1), n_seg + 1), ids]).ravel()
    return pv.PolyData(P.reshape(-1, 3), lines=lines)


def prepare_state(
    source,
    info: SceneInfo | None = None,
    state: str = "",
    displacement: str | None = None,
    scale: float = 1.0,
    subdivision: int = 2,
    edges: bool = True,
    c10: float | None = None,
) -> StateView:
    """Load a state and build its surfaces.

    Parameters
    ----------
    source : path-like or pyvista.UnstructuredGrid
        A VTU file written by :func:`fem.io.write_vtu` (reference points + a displacement
        array) or a grid.
    info : SceneInfo, optional
    state : str
        State name (title, gauge reading).
    displacement : str, optional
        Point array to warp by (default: the first of :data:`DISPLACEMENT_NAMES`).
    scale : float
        Displacement magnification (1 = true scale).
    subdivision : int
        Subdivisions of each curved boundary triangle (0 = straight).
    edges : bool
        Build the curved element edges.
    c10 : float, optional
        Neo-Hookean C10 [MPa]; adds the ``von_mises`` field (:func:`von_mises_neo_hookean`).

    Raises
    ------
    FileNotFoundError, ViewerError
    """
    pv = require_pyvista()
    if not (math.isfinite(scale) and scale >= 0):
        raise ViewerError(f"scale={scale!r}: must be a finite number >= 0")
    path = None
    if isinstance(source, (str, Path)):
        path = Path(source)
        grid = load_grid(path)
    else:
        grid = source.copy()
    where = str(path) if path else "grid"
    info = info or SceneInfo(name=path.stem if path else "grid")
    disp = displacement_name(grid, displacement, where)
    if disp is None:
        logger.info("%s: no displacement array (looked for %s); drawn undeformed", where, DISPLACEMENT_NAMES)
    add_derived_fields(grid, disp, c10)
    vol = cell_volumes(grid)
    if np.any(vol <= 0):
        logger.warning("%s: %d of %d cells have non-positive VTK volume (inverted or misordered nodes)",
                       where, int((vol <= 0).sum()), len(vol))
    warped = grid.warp_by_vector(disp, factor=scale) if disp else grid.copy()
    cells = quadratic_cells(grid)
    if len(cells):
        from fem.mesh import boundary_faces

        elem, _, f6 = boundary_faces(cells)
        lab = _surface_components(f6, np.asarray(grid.points))
        outer = _tri6_surface(warped.points, f6[lab == 0], warped, elem[lab == 0], subdivision)
        cavity = None
        if np.any(lab == 1):
            cavity = _tri6_surface(warped.points, f6[lab == 1], warped, elem[lab == 1], subdivision)
        edge_poly = boundary_edges(np.asarray(warped.points), f6[lab == 0]) if edges else None
    else:  # linear tets: VTK's own surface
        outer = warped.extract_surface(pass_pointid=False, pass_cellid=False, algorithm="dataset_surface")
        cavity, edge_poly = None, (outer.extract_all_edges() if edges else None)
    zb = grid.bounds
    cut_z = 0.5 * (zb[4] + zb[5])
    outline = None
    if disp:
        sec = grid.slice(normal=(0.0, 0.0, 1.0), origin=(0.0, 0.0, cut_z))
        if sec.n_points:
            outline = sec.extract_feature_edges(boundary_edges=True, feature_edges=False, manifold_edges=False,
                                                non_manifold_edges=False)
    title = scene_title(info) + (f" · {state_title(info, state)}" if state else "")
    return StateView(title, grid, warped, outer, cavity, edge_poly, outline, disp, float(scale), info, state, path,
                     cut_z)


def scene_title(info: SceneInfo) -> str:
    """A scene's role as a panel title: ``intact``, ``trimmed, uncompensated`` (trimmed, still
    at Q_i), ``trimmed, vented`` (a trimmed scene at Q = 0), else the scene name."""
    if info.name in SCENE_TITLES:
        return SCENE_TITLES[info.name]
    if info.name == "trimmed" and info.Q == 0.0:
        return "trimmed, vented"
    return info.name


def state_title(info: SceneInfo, state: str) -> str:
    """A state as a panel title: ``delta_2.00`` becomes ``delta = 2 mm``, the pressurised state
    of a scene at Q = 0 ``not pressurised (Q = 0)``; other names unchanged."""
    if state.lower() in ("pressurised", "pressurized", "inflated") and info.Q == 0.0:
        return "not pressurised (Q = 0)"
    if state.lower().startswith("delta"):
        d = info.delta_of(state)
        if d is not None:
            return f"delta = {d:.3g} mm"
    return state


def displaced(sv: StateView, points_ref: np.ndarray) -> np.ndarray:
    """Current positions of reference points: ``X + scale · u(X)`` with u interpolated in the
    grid (VTK probe, quadratic shape functions); points outside take the nearest node's u."""
    pv = require_pyvista()
    X = np.asarray(points_ref, dtype=float).reshape(-1, 3)
    if sv.displacement is None or len(X) == 0:
        return X.copy()
    probe = pv.PolyData(X).sample(sv.grid, tolerance=1e-6 * sv.grid.length)
    u = np.array(probe.point_data[sv.displacement], dtype=float)
    ok = np.asarray(probe.point_data.get("vtkValidPointMask", np.ones(len(X))), dtype=bool)
    if not ok.all():
        idx = [sv.grid.find_closest_point(x) for x in X[~ok]]
        u[~ok] = np.asarray(sv.grid.point_data[sv.displacement])[idx]
    return X + sv.scale * u


def _design_obj(design: dict | None):
    if not design:
        return None
    try:
        from geometry.design import WhiskerDesign

        return WhiskerDesign.from_dict(design)
    except Exception as exc:  # noqa: BLE001 - metadata may be from another version
        logger.info("design metadata not usable (%s)", exc)
        return None


def _radius_at(sv: StateView, x: np.ndarray, design) -> np.ndarray:
    """Outer radius at reference axial positions: the design's cone, else the widest reference node near x."""
    if design is not None:
        return np.asarray(design.r_outer(x), dtype=float)
    X = np.asarray(sv.grid.points)
    r = np.hypot(X[:, 1], X[:, 2])
    out = []
    h = 0.02 * (X[:, 0].max() - X[:, 0].min()) + 1e-12
    for xi in np.atleast_1d(x):
        sel = np.abs(X[:, 0] - xi) <= h
        out.append(r[sel].max() if sel.any() else r.max())
    return np.asarray(out)


def gauge_patch(sv: StateView, n_x: int = 12, n_phi: int = 12):
    """The gauge footprint (warped) as a PolyData patch, or None without gauge metadata."""
    pv = require_pyvista()
    g = sv.info.gauge
    if g is None:
        return None
    design = _design_obj(sv.info.design)
    x = np.linspace(g.x_ss, g.x_ss + g.e, n_x)
    phi = np.radians(np.linspace(-g.half_angle_deg, g.half_angle_deg, n_phi))
    xx, pp = np.meshgrid(x, phi, indexing="ij")
    r = _radius_at(sv, xx.ravel(), design).reshape(xx.shape)
    ref = np.stack([xx, r * np.cos(pp), r * np.sin(pp)], axis=-1).reshape(-1, 3)
    # sample just inside the boundary (the P2 surface interpolates the cone)
    inward = ref * np.array([1.0, 0.995, 0.995])
    cur = displaced(sv, inward) + (ref - inward)
    grid = pv.StructuredGrid(*(cur[:, k].reshape(n_x, n_phi) for k in range(3)))
    return grid.extract_surface(algorithm="dataset_surface")


def contact_point(sv: StateView) -> np.ndarray | None:
    """Current position of the contact point on the +y generator, or None when unknown.

    ``contact_x`` is the contact's axial position in the pressurised configuration; its
    reference position is taken as ``contact_x - Δl`` clipped to the whisker length.
    """
    cx = sv.info.contact_x
    if cx is None:
        return None
    X = np.asarray(sv.grid.points)
    x_ref = float(np.clip(cx - (sv.info.delta_l or 0.0), X[:, 0].min(), X[:, 0].max()))
    design = _design_obj(sv.info.design)
    r = float(_radius_at(sv, np.array([x_ref]), design)[0])
    ref = np.array([[x_ref, r, 0.0]])
    return displaced(sv, ref * np.array([1.0, 0.995, 1.0]))[0] + np.array([0.0, 0.005 * r, 0.0])


def fibre_lines(sv: StateView, ds: float = 0.5) -> list:
    """Warped fibre helices (:func:`geometry.fibres.sample_helix`) as PolyData lines; [] without a design."""
    pv = require_pyvista()
    design = _design_obj(sv.info.design)
    if design is None or int(design.n_fibres) == 0:
        return []
    from geometry.fibres import fibre_phases, sample_helix

    out = []
    for ph in fibre_phases(design):
        pts = displaced(sv, sample_helix(design, ph, ds))
        out.append(pv.lines_from_points(pts))
    return out


# ============================================================================ drawing
def _text_lines(sv: StateView) -> tuple[str, str]:
    """(design text, gauge text) of a panel."""
    info = sv.info
    parts = []
    d = info.design
    if d:
        for key, label, unit in (("alpha", "alpha", " deg"), ("l", "l", ""), ("t", "t", ""), ("L", "L", "")):
            if _float(d.get(key)) is not None:
                parts.append(f"{label}={float(d[key]):.4g}{unit}")
        parts[-1:] = [parts[-1] + " mm"] if parts else []
    if info.trim is not None:
        parts.append(f"trim={info.trim:.3g} mm")
    if info.Q is not None:
        parts.append(f"Q={info.Q:.4g} MPa")
    for k, v in info.notes.items():
        if k == "genes" and isinstance(v, dict) and not d:
            parts.append(", ".join(f"{g}={float(x):.4g}" for g, x in v.items()))
        elif _float(v) is not None:
            parts.append(f"{k}={float(v):.4g}")
    if sv.scale != 1.0 and sv.displacement:
        parts.append(f"displacement x{sv.scale:g}")
    reading = info.reading(sv.state) if sv.state else None
    gtxt = ""
    if reading is not None:
        gtxt = f"gauge eps = {reading[1]:.5g} at delta = {reading[0]:.3g} mm"
    if info.delta_l is not None and sv.state.lower() not in ("reference", "undeformed"):
        gtxt += ("\n" if gtxt else "") + f"dl(Q) = {info.delta_l:.4g} mm"
    return ", ".join(parts), gtxt


def _clip(poly, on: bool, z: float = 0.0):
    if poly is None or not on or poly.n_points == 0:
        return poly
    return poly.clip(normal=(0.0, 0.0, 1.0), origin=(0.0, 0.0, z), invert=True)


def add_state(
    plotter,
    sv: StateView,
    field: tuple[str | None, str, int | None],
    clim: tuple[float, float] | None = None,
    cmap: str = "coolwarm",
    cavity: str = "clip",
    show_edges: bool = True,
    show_outline: bool = True,
    show_fibres: bool = True,
    show_gauge: bool = True,
    show_contact: bool = True,
    show_text: bool = True,
    prefix: str = "",
) -> None:
    """Draw one state into the plotter's current renderer (actors named ``prefix + part``).

    Parameters
    ----------
    plotter : pyvista.Plotter
    sv : StateView
    field : tuple
        ``(array, label, component)`` from :func:`resolve_field`.
    clim : (float, float), optional
        Colour range (shared between panels).
    cavity : {'clip', 'translucent', 'hidden'}
        ``clip`` removes the half z > 0 (the cut shows the wall section and the cavity),
        ``translucent`` shows the outer surface at 35 % opacity over the cavity.
    """
    if cavity not in CAVITY_MODES:
        raise ViewerError(f"cavity={cavity!r}: must be one of {CAVITY_MODES}")
    name, label, comp = field
    clip = cavity == "clip"
    mesh_kw: dict[str, Any] = dict(smooth_shading=True, show_scalar_bar=name is not None)
    if name is not None:
        mesh_kw.update(scalars=name, component=comp, cmap=cmap, clim=clim,
                       scalar_bar_args=dict(title=label, n_labels=5, fmt="%.3g", vertical=True, position_x=0.88,
                                            position_y=0.12, width=0.05, height=0.62, title_font_size=12,
                                            label_font_size=11))
    else:
        mesh_kw.update(color="lightsteelblue")
    outer = _clip(sv.outer, clip, sv.cut_z)
    opacity = 0.35 if cavity == "translucent" and sv.cavity is not None else 1.0
    if outer is not None and outer.n_points:
        plotter.add_mesh(outer, opacity=opacity, name=prefix + "outer", **mesh_kw)
    if clip:
        sec = sv.warped.slice(normal=(0.0, 0.0, 1.0), origin=(0.0, 0.0, sv.cut_z))
        if sec.n_points:
            plotter.add_mesh(sec, name=prefix + "section", **dict(mesh_kw, smooth_shading=False, show_scalar_bar=False))
    if sv.cavity is not None and cavity != "hidden":
        cav = _clip(sv.cavity, clip, sv.cut_z)
        if cav is not None and cav.n_points:
            plotter.add_mesh(cav, color="lightskyblue", opacity=0.6 if clip else 1.0, smooth_shading=True,
                             name=prefix + "cavity")
    if show_edges and sv.edges is not None:
        ed = _clip(sv.edges, clip, sv.cut_z)
        if ed is not None and ed.n_points:
            plotter.add_mesh(ed, color="black", opacity=0.2, line_width=1, name=prefix + "edges")
    if show_outline and sv.outline is not None and sv.outline.n_points:
        plotter.add_mesh(sv.outline, color="dimgrey", line_width=2, name=prefix + "outline")
    if show_fibres:
        r_tube = 0.5 * float((sv.info.design or {}).get("fibre_diameter", 0.38) or 0.38)
        for k, line in enumerate(fibre_lines(sv)):
            line = _clip(line, clip, sv.cut_z)
            if line is not None and line.n_points:
                plotter.add_mesh(line.tube(radius=r_tube, n_sides=10), color=FIBRE_COLOURS[k % len(FIBRE_COLOURS)],
                                 name=f"{prefix}fibre{k}")
    if show_gauge:
        patch = gauge_patch(sv)  # drawn whole even when the body is cut: it is a marker
        if patch is not None and patch.n_points:
            plotter.add_mesh(patch, color="gold", name=prefix + "gauge")
            plotter.add_mesh(patch.extract_feature_edges(boundary_edges=True, feature_edges=False,
                                                         manifold_edges=False, non_manifold_edges=False),
                             color="black", line_width=3, name=prefix + "gauge_outline")
    if show_contact:
        cp = contact_point(sv)
        if cp is not None:
            size = 0.04 * sv.grid.length
            pv = require_pyvista()
            plotter.add_mesh(pv.Sphere(radius=0.3 * size, center=cp), color="red", name=prefix + "contact")
            plotter.add_mesh(pv.Arrow(start=cp + np.array([0.0, 2.5 * size, 0.0]), direction=(0.0, -1.0, 0.0),
                                      scale=2.2 * size), color="red", name=prefix + "contact_arrow")
    if show_text:
        dtxt, gtxt = _text_lines(sv)
        plotter.add_text(sv.title, position="upper_left", font_size=11, name=prefix + "title")
        if dtxt:
            plotter.add_text(dtxt, position="lower_left", font_size=8, name=prefix + "design")
        if gtxt:
            plotter.add_text(gtxt, position="upper_right", font_size=9, name=prefix + "gauge_text")


def shared_clim(views: Sequence[StateView], field: tuple[str | None, str, int | None],
                percentile: float = 0.0) -> tuple[float, float] | None:
    """One colour range over all views; symmetric about 0 for a strain that changes sign.

    ``percentile`` = p > 0 spans each view's (p, 100 − p) percentiles instead of its
    extremes: the whisker's strain range is set by a few nodes at the cavity's corners
    (LE_xx ≈ ±0.7 at Q = 0.2 MPa) while the gauge region bends to ~0.05, which a full
    range paints in one colour. Values beyond the range saturate.
    """
    if not (0.0 <= percentile < 50.0):
        raise ViewerError(f"clim percentile={percentile!r} outside the allowed range [0, 50)")
    name, _, comp = field
    rngs = [r for r in (v.field_range(name, comp, percentile) for v in views) if r is not None]
    if not rngs:
        return None
    lo, hi = min(r[0] for r in rngs), max(r[1] for r in rngs)
    if name == STRAIN_FIELD and lo < 0 < hi:
        m = max(-lo, hi)
        lo, hi = -m, m
    if hi <= lo:
        hi = lo + (abs(lo) * 1e-6 or 1e-12)
    return lo, hi


def _clipped_label(field: tuple[str | None, str, int | None], percentile: float):
    """The field tuple with its scalar-bar label marked when the colour range is clipped."""
    name, label, comp = field
    if name is None or percentile <= 0.0:
        return field
    return name, f"{label} ({percentile:g}-{100 - percentile:g} %)", comp


def _layout(views: Sequence[StateView], layout: str) -> tuple[int, int]:
    n = len(views)
    if layout == "auto":
        b = np.array(views[0].warped.bounds).reshape(3, 2)
        ext = b[:, 1] - b[:, 0]
        layout = "rows" if ext[0] > 1.8 * max(ext[1], ext[2], 1e-12) else "columns"
    if layout == "rows":
        return n, 1
    if layout == "columns":
        return 1, n
    raise ViewerError(f"layout={layout!r}: must be 'auto', 'rows' or 'columns'")


def default_window_size(shape: tuple[int, int]) -> tuple[int, int]:
    """Window size for a panel grid: 1400 × 460 per row, 640 × 620 per column."""
    rows, cols = shape
    if cols == 1:
        return 1400, max(480, 440 * rows)
    return 640 * cols, 620


def _set_camera(plotter, view: str, margin: float = 0.85, reserve_right: float = 0.16) -> None:
    """Point the current renderer's camera and fit the visible props.

    ``iso`` looks from +z turned 25° about y and x, ``xy`` from +z. The props fill
    ``margin`` of the panel height and of its width less the right-hand strip
    ``reserve_right`` (a fraction of the width, kept free for the scalar bar).
    """
    if view == "xy":
        plotter.view_xy()
    elif view == "iso":
        plotter.view_xy()
        plotter.camera.azimuth = -25
        plotter.camera.elevation = 25
    else:
        raise ViewerError(f"camera view={view!r}: must be 'iso' or 'xy'")
    ren = plotter.renderer
    b = ren.ComputeVisiblePropBounds()
    ren.ResetCamera(b)
    cam = ren.GetActiveCamera()

    def view_extent() -> tuple[float, float, float, float]:
        xs, ys = [], []
        for x in b[0:2]:
            for y in b[2:4]:
                for z in b[4:6]:
                    ren.SetWorldPoint(x, y, z, 1.0)
                    ren.WorldToView()
                    vx, vy, _ = ren.GetViewPoint()
                    xs.append(vx)
                    ys.append(vy)
        return min(xs), max(xs), min(ys), max(ys)

    x0, x1, y0, y1 = view_extent()  # view coordinates, the panel is [-1, 1]²
    half_w = (1.0 - reserve_right)  # usable width [-1, 1 - 2 reserve_right] has half-width 1 - reserve_right
    zx = margin * half_w / max(0.5 * (x1 - x0), 1e-12)
    zy = margin / max(0.5 * (y1 - y0), 1e-12)
    z = min(zx, zy)
    if np.isfinite(z) and z > 0:
        cam.Zoom(z)
        cam.SetWindowCenter(reserve_right, 0.0)  # shift the image left by the reserved strip


def make_plotter(views: Sequence[StateView], off_screen: bool, window_size: tuple[int, int] | None = None,
                 layout: str = "auto"):
    """A Plotter with one renderer per view (linked cameras)."""
    pv = require_pyvista()
    if not views:
        raise ViewerError("nothing to draw: no states selected")
    shape = _layout(views, layout)
    ws = tuple(window_size) if window_size else default_window_size(shape)
    if off_screen and is_headless():
        logger.info("no display (DISPLAY/WAYLAND_DISPLAY unset): rendering off-screen")
    p = pv.Plotter(shape=shape, off_screen=off_screen, window_size=list(ws), border=False)
    p.set_background("white")
    # no depth peeling: with VTK 9.6 on EGL it drops translucent layers altogether
    return p


def draw(plotter, views: Sequence[StateView], field, clim, camera: str = "iso", prefix: str = "", **kw) -> None:
    """Draw the views into the plotter's panels (row-major), sharing ``clim`` and the camera."""
    rows, cols = plotter.shape
    if prefix:  # redraw: drop this prefix's actors (a part may be absent in the new state)
        for ren in plotter.renderers:
            for name in [n for n in ren.actors if str(n).startswith(prefix)]:
                ren.remove_actor(name, render=False)
    for i, sv in enumerate(views):
        plotter.subplot(i // cols, i % cols)
        add_state(plotter, sv, field, clim=clim, prefix=f"{prefix}{i}:", **kw)
    if not prefix:
        plotter.subplot(0, 0)
        _set_camera(plotter, camera)
        if len(views) > 1:
            plotter.link_views()


def render(
    views: Sequence[StateView],
    field: str | None = None,
    screenshot: str | Path | None = None,
    off_screen: bool | None = None,
    window_size: tuple[int, int] | None = None,
    layout: str = "auto",
    camera: str = "iso",
    cmap: str = "coolwarm",
    clim_percentile: float = 1.0,
    **kw,
):
    """Render views side by side (same camera and colour range) on screen or to a PNG.

    Parameters
    ----------
    views : sequence of StateView
    field : str, optional
        See :func:`resolve_field` (resolved on the first view).
    screenshot : path-like, optional
        Write the image there (off-screen) and return its path.
    off_screen : bool, optional
        Default: True when ``screenshot`` is given or no display exists.
    window_size : (int, int), optional
    layout : {'auto', 'rows', 'columns'}
    camera : {'iso', 'xy'}
    clim_percentile : float
        Colour range over the (p, 100 − p) percentiles of the field (0 = full range);
        see :func:`shared_clim`.
    **kw
        Passed to :func:`add_state` (``cavity``, ``show_edges``, ...).

    Returns
    -------
    Path or pyvista.Plotter
        The screenshot path, or the (already shown and closed) plotter.
    """
    if off_screen is None:
        off_screen = screenshot is not None or is_headless()
    f = resolve_field(views[0].grid, field, str(views[0].path or views[0].title)) if views else (None, "", None)
    for v in views[1:]:  # every panel must hold the field
        if f[0] is not None and f[0] not in field_names(v.grid):
            raise ViewerError(f"{v.path or v.title}: no field {f[0]!r}; available fields: {field_names(v.grid)}")
    clim = shared_clim(views, f, clim_percentile)
    f = _clipped_label(f, clim_percentile)
    p = make_plotter(views, off_screen, window_size, layout)
    draw(p, views, f, clim, camera=camera, cmap=cmap, **kw)
    if screenshot is not None:
        out = Path(screenshot)
        out.parent.mkdir(parents=True, exist_ok=True)
        p.screenshot(str(out))
        p.close()
        logger.info("screenshot written to %s", out)
        return out
    p.show()
    return p


def interactive_plotter(
    series: Sequence[Sequence[StateView]],
    field: str | None = None,
    off_screen: bool = False,
    window_size: tuple[int, int] | None = None,
    layout: str = "auto",
    camera: str = "iso",
    start: int | None = None,
    step_values: Sequence[float] | None = None,
    clim_percentile: float = 1.0,
    **kw,
) -> tuple[Any, Callable[[int], None]]:
    """A plotter that steps through states with a slider and the keys ``n`` / ``b``.

    Parameters
    ----------
    series : sequence of sequence of StateView
        ``series[k]`` are the panels shown at step k (e.g. every scene at its k-th state,
        or every scene at the k-th deflection).
    start : int, optional
        Initial step (default the last).
    step_values : sequence of float, optional
        The deflection δ [mm] of each step: the slider then runs over δ and snaps to the
        nearest step (default: over the step index).

    Returns
    -------
    plotter, set_step
        ``set_step(k)`` redraws step k (also what the slider and keys call).
    """
    if not series or not series[0]:
        raise ViewerError("nothing to draw: no states selected")
    all_views = [v for step in series for v in step]
    f = resolve_field(series[-1][0].grid, field, str(series[-1][0].path or series[-1][0].title))
    clim = shared_clim(all_views, f, clim_percentile)
    f = _clipped_label(f, clim_percentile)
    p = make_plotter(series[0], off_screen, window_size, layout)
    current = {"k": len(series) - 1 if start is None else int(start)}

    def set_step(k: float) -> None:
        k = int(round(k)) % len(series)
        current["k"] = k
        draw(p, series[k], f, clim, camera=camera, prefix="s:", **kw)
        p.render()

    draw(p, series[current["k"]], f, clim, camera=camera, prefix="s:", **kw)
    p.subplot(0, 0)
    _set_camera(p, camera)
    if len(series[0]) > 1:
        p.link_views()
    if len(series) > 1:
        if step_values is not None:
            if len(step_values) != len(series):
                raise ViewerError(f"step_values: {len(step_values)} values for {len(series)} steps")
            vals = np.asarray(step_values, dtype=float)
            p.add_slider_widget(lambda v: set_step(int(np.argmin(np.abs(vals - v)))), [vals[0], vals[-1]],
                                value=vals[current["k"]], title="delta [mm] (n / b keys)", pointa=(0.55, 0.92),
                                pointb=(0.95, 0.92), fmt="%.2f", style="modern")
        else:
            p.add_slider_widget(set_step, [0, len(series) - 1], value=current["k"], title="state (n / b keys)",
                                pointa=(0.55, 0.92), pointb=(0.95, 0.92), fmt="%.0f", style="modern")
        p.add_key_event("n", lambda: set_step(current["k"] + 1))
        p.add_key_event("b", lambda: set_step(current["k"] - 1))
    return p, set_step


# ============================================================================ plots beside the images
def write_plots(contents: RunContents, out_dir: Path) -> list[Path]:
    """Convergence and response-curve images of a run, into ``out_dir``.

    Copies ``convergence.png`` / ``best_curves.png`` when present, else draws them from
    ``generations.csv``, ``best_curves.csv`` or a ``simulate`` run's ``curve.csv``
    (``eps_intact``/``eps_trimmed``) with :mod:`whisker_opt.output.plots`.
    """
    from whisker_opt.output import plots

    root, out_dir = contents.root, Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    def copy_or(name: str, make: Callable[[Path], Path | None]) -> None:
        src, dst = root / name, out_dir / name
        if src.is_file():
            if src.resolve() != dst.resolve():
                shutil.copyfile(src, dst)
            written.append(dst)
            return
        res = make(dst)
        if res is not None:
            written.append(Path(res))

    def conv(dst: Path) -> Path | None:
        p = root / "generations.csv"
        if not p.is_file():
            return None
        with p.open(newline="") as fh:
            rows = list(csv.DictReader(fh))
        if not rows:
            return None
        num = lambda k: [_float(r.get(k)) if _float(r.get(k)) is not None else math.nan for r in rows]  # noqa: E731
        feas = [str(r.get("best_feasible", "True")).lower() in ("true", "1") for r in rows]
        return plots.plot_convergence(dst, num("generation"), num("best_fp"), num("mean_fp"), feas)

    def curves(dst: Path) -> Path | None:
        for name, a, b in (("best_curves.csv", "eps_i", "eps_c"), ("curve.csv", "eps_intact", "eps_trimmed")):
            p = root / name
            if not p.is_file():
                continue
            with p.open(newline="") as fh:
                rows = list(csv.DictReader(fh))
            if rows and a in rows[0] and b in rows[0]:
                col = lambda k: [float(r[k]) for r in rows]  # noqa: E731
                target = dst if name == "best_curves.csv" else dst.with_name("curves.png")
                return plots.plot_curves(target, col("delta_mm"), col(a), col(b), f"{root.name}: gauge responses")
        return None

    copy_or("convergence.png", conv)
    copy_or("best_curves.png", curves)
    for w in written:
        logger.info("plot written to %s", w)
    return written


# ============================================================================ command
def load_views(
    contents: RunContents,
    group: str,
    scenes: Sequence[str] | None = None,
    state: str | None = None,
    notes: Mapping[str, Any] | None = None,
    files: Sequence[StateFile] | None = None,
    **kw,
) -> list[StateView]:
    """:func:`prepare_state` for one state of each selected scene of a group.

    Parameters
    ----------
    contents : RunContents
    group : str
    scenes : sequence of str, optional
        Default: every scene of the group.
    state : str, optional
        See :meth:`RunContents.select`.
    notes : mapping, optional
        Added to each scene's text.
    files : sequence of StateFile, optional
        The states to load (overrides ``group``, ``scenes`` and ``state``), e.g. from
        :meth:`RunContents.select_delta`.
    **kw
        Passed to :func:`prepare_state` (``c10`` defaults to the run's).
    """
    out = []
    kw.setdefault("c10", contents.c10)
    for f in (contents.select(group, scenes, state) if files is None else files):
        info = contents.info(f.group, f.scene)
        if notes:
            info = dataclasses.replace(info, notes={**info.notes, **notes})
        out.append(prepare_state(f.path, info=info, state=f.state, **kw))
    return out


def _view_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("source", type=Path, help="results directory (searched recursively for *.vtu) or one .vtu file")
    p.add_argument("--screenshot", type=Path, default=None, metavar="FILE.png",
                   help="render off-screen to this PNG instead of opening a window")
    p.add_argument("--field", default=None,
                   help="colour by: strain (axial log strain LE_xx, default), displacement (|u|), mises (von Mises, "
                        "needs material.C10 in config.yaml), any stored array, name:x for a component, or none")
    p.add_argument("--clim-percentile", type=float, default=1.0, metavar="P",
                   help="colour range over the P..100-P percentiles of the field, shared by all panels (default 1; "
                        "0 = full range, which a few cavity-corner nodes dominate)")
    p.add_argument("--scene", action="append", default=None,
                   help="scene(s) to show (repeatable; default all, side by side)")
    p.add_argument("--state", default=None, help="state to show, e.g. pressurised or deflected (default: the last)")
    p.add_argument("--delta", type=float, default=None, metavar="MM",
                   help="show every scene at this solved deflection [mm] (0 = pressurised); in a window, the "
                        "slider and the n / b keys step through the deflections")
    p.add_argument("--rank", type=int, default=None, help="show the N-th best design of a run (1 = best)")
    p.add_argument("--eval", dest="eval_id", default=None,
                   help="show the evaluation with this eval_id (with --rank: its scenes are solved into "
                        "RUN_DIR/eval_<id>/ when the run stored no meshes for it)")
    p.add_argument("--group", default=None,
                   help="sub-folder of the results holding the VTU files (default: best/ or the root)")
    p.add_argument("--scale", type=float, default=1.0, help="displacement magnification (default 1 = true scale)")
    p.add_argument("--cavity", choices=CAVITY_MODES, default="clip",
                   help="clip: cut at z=0 to show wall section and cavity; translucent: see-through outer surface")
    p.add_argument("--camera", choices=("iso", "xy"), default="iso", help="camera direction")
    p.add_argument("--layout", choices=("auto", "rows", "columns"), default="auto",
                   help="arrangement of side-by-side panels")
    p.add_argument("--window-size", type=int, nargs=2, default=None, metavar=("W", "H"), help="image size in pixels")
    p.add_argument("--no-edges", action="store_true", help="do not draw element edges")
    p.add_argument("--plots", action="store_true",
                   help="also write the convergence plot and response curves into the output folder")
    p.add_argument("--list", action="store_true", help="list the groups, scenes and states found, then exit")


def _view_run(args: argparse.Namespace) -> int:
    """Runner of ``whisker-opt view``; returns the exit status (2 on a user error)."""
    try:
        return _view_main(args)
    except (ViewerError, ViewerUnavailable, FileNotFoundError) as exc:
        print(f"whisker-opt view: error: {exc}", file=sys.stderr)
        return 2


def _view_main(args: argparse.Namespace) -> int:
    other = args.rank is not None or args.eval_id is not None
    if args.rank is not None and args.eval_id is not None:
        raise ViewerError("--rank and --eval are exclusive; give one")
    # --rank/--eval: a run directory may hold no meshes yet (they are solved on demand)
    contents = discover(args.source, allow_empty=other and not args.list)
    if args.list:
        print(contents.describe())
        return 0
    notes: dict[str, Any] = {}
    group = args.group or (None if other else contents.default_group())
    if other:
        row = evaluation_row(contents.root, rank=args.rank, eval_id=args.eval_id)
        contents, group = evaluation_group(contents, row)
        notes = {"eval_id": row.get("eval_id"), "F_p": row.get("F_p"), "f1": row.get("f1")}
        if not contents.scenes.get(group):  # no scenes.json there: the design from config + genes
            contents.scenes[group] = scenes_from_genes(contents.config, row)
    elif group == "best" and contents.best:
        b = contents.best
        notes = {k: b[k] for k in ("genes", "f1", "F_p") if k in b}
    headless = is_headless()
    screenshot = args.screenshot
    if screenshot is None and headless:
        screenshot = contents.root / "view.png"
        print(f"whisker-opt view: no display found (DISPLAY/WAYLAND_DISPLAY unset); "
              f"rendering off-screen to {screenshot}", file=sys.stderr)
    kw = dict(cavity=args.cavity, show_edges=not args.no_edges, clim_percentile=args.clim_percentile)
    ws = tuple(args.window_size) if args.window_size else None
    pv = require_pyvista()
    # headless: VTK first tries X and warns before falling back to EGL; keep only its errors
    quiet = pv.vtk_verbosity("error") if headless else contextlib.nullcontext()
    if args.state is not None and args.delta is not None:
        raise ViewerError("--state and --delta are exclusive; give one")
    if screenshot is not None:
        files = None if args.delta is None else contents.select_delta(group, args.delta, args.scene)
        views = load_views(contents, group, args.scene, args.state, notes, files=files, scale=args.scale)
        with quiet:
            out = render(views, args.field, screenshot=screenshot, window_size=ws, layout=args.layout,
                         camera=args.camera, **kw)
        print(f"screenshot written to {out}")
        out_dir = Path(out).parent
    else:
        if args.state is not None:
            steps = [(None, contents.select(group, args.scene, args.state))]
        else:  # step k shows every scene at the k-th deflection (or its k-th state)
            steps = contents.delta_steps(group, args.scene)
        start = None
        if args.delta is not None:
            at = contents.select_delta(group, args.delta, args.scene)  # validates the deflection
            start = next((k for k, (_, files) in enumerate(steps) if files == at), None)
        series = [load_views(contents, group, notes=notes, files=files, scale=args.scale) for _, files in steps]
        values = [d for d, _ in steps]
        p, _ = interactive_plotter(series, args.field, off_screen=False, window_size=ws, layout=args.layout,
                                   camera=args.camera, start=start,
                                   step_values=None if None in values else values, **kw)
        p.show()
        out_dir = contents.root
    if args.plots:
        for w in write_plots(contents, out_dir):
            print(f"plot written to {w}")
    return 0


VIEW_COMMAND: tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]] = (
    "show a result (run directory or .vtu) in a pyvista window, or --screenshot it off-screen",
    _view_args,
    _view_run,
)
"""``(help, add_args, run)`` for :data:`whisker_opt.cli.commands.REGISTRY` (``whisker-opt view``)."""
