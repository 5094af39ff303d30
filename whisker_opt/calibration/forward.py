"""What the model predicts for an observation (the forward model of the fit).

A *simulator* gives two quantities of a run file's whisker, trimmed by Δ, at pressure Q:

- ``reading(cfg, trim, Q, a, deltas)``: the calibrated gauge reading ε(δ) at contact ratio a;
- ``extension(cfg, trim, Q)``: the tip's axial extension Δl(Q) [mm].

:class:`SceneSimulator` solves the finite-element scenes of docs/physics.md §2–3 (through
:func:`whisker_opt.wiring.scene_spec`, so every model key of the run file acts as it does in
``simulate`` and ``run``); :class:`BeamSimulator` uses the beam model of §8 (fast, for tests and
rough fits: it sees the geometry, ``scene.calibration`` and E = 6·C10 of ``material.C10``).

An observation becomes the model's value of the quantity measured (:func:`predict`):

- extension: Δl(Q);
- response: ε(δ) at (Q, a, Δ), or the ratio ε(δ; Q)/ε(δ; Q_ref) when a reference pressure is given;
- restore: the pressure Q* at which the matching whisker's reading equals the reference whisker's,
  ``ε(δ; Δ, Q*) = ε(δ; Δ_ref, Q_ref)``, the root of the signed difference (as the ``root`` method of
  :func:`whisker_opt.analysis.compensation.fe_compensation`): the difference is sampled at ``scan``
  pressures evenly on [0, Q_max]; of the brackets with a sign change, the one nearest the measured Q is
  refined by Brent's method. When no sampled bracket holds a root, the prediction is marked unmatched
  and its note gives the range the reading spans; its value is where the mismatch, extrapolated
  linearly from the closest end of the scan, would vanish (:func:`unmatched_pressure`), at most
  ``Q_max`` beyond that end, so that it moves continuously with the parameters and meets the root
  where a match enters the scanned range (a constant "no match" value gives the fit no direction).
  A pressure the model's whisker cannot be brought to (its pressurisation does not converge, e.g. a soft
  rubber; a pressure outside the beam model's range) ends the scan there, and the note says so.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from scipy import optimize

from fem.newton import SolveFailed
import whisker_opt.wiring as wiring
from whisker_opt.calibration.measurements import Extension, Observation, Response, Restore
from whisker_opt.config.model import WhiskerConfig


class Simulator(Protocol):
    """What the fit needs of a model (see the module docstring)."""

    def reading(self, cfg: WhiskerConfig, trim: float, Q: float, a: float, deltas) -> np.ndarray: ...

    def extension(self, cfg: WhiskerConfig, trim: float, Q: float) -> float: ...


class SceneSimulator:
    """The finite-element scenes of a run file, memoised (a :class:`~whisker_opt.experiment.scene.SceneRunner`).

    Parameters
    ----------
    deflection : float
        Largest deflection δ_max of the solved scenes [mm]: the largest δ of the observations, so the
        fit solves no more than it reads; the readings between solved increments come from the scene's
        spline (docs/physics.md §2).
    memo_size : int
        Scenes kept in the memo (a fit revisits the same ones for every Jacobian column).
    """

    def __init__(self, deflection: float, memo_size: int = 4096) -> None:
        from whisker_opt.experiment.scene import SceneRunner

        self.deflection = float(deflection)
        self.runner = SceneRunner(memo_size=memo_size)
        self.calls = 0

    def _result(self, cfg: WhiskerConfig, trim: float, Q: float, a: float):
        design = wiring.design_from_config(cfg, float(trim), trim_key="the trim of a measurement")
        spec = replace(wiring.scene_spec(cfg, design, float(Q)), contact_ratio=float(a), deflection=self.deflection)
        self.calls += 1
        return self.runner.run(spec)

    @property
    def solved(self) -> int:
        """Scenes solved so far (memo hits excluded)."""
        return self.calls - self.runner.memo_hits

    def reading(self, cfg: WhiskerConfig, trim: float, Q: float, a: float, deltas) -> np.ndarray:
        res = self._result(cfg, trim, Q, a)
        return res.curve(np.asarray(deltas, dtype=float), cfg.scene.gauge_variant)

    def extension(self, cfg: WhiskerConfig, trim: float, Q: float) -> float:
        return float(self._result(cfg, trim, Q, 1.0).delta_l)


@dataclass
class BeamSimulator:
    """The beam model of docs/physics.md §8 as a simulator: ε = S(a, Q)·δ (8.6), Δl from (8.7)–(8.8).

    The model's E is 6·C10 (the small-strain modulus of the neo-Hookean rubber, E = 3μ = 6 C10), its gauge
    factor ``scene.calibration``; with ``material.wall_law: calibrated`` its chamber softening is the law's
    k(Q) = 1 + s·Q (s = ``material.wall_slope``, :mod:`whisker_opt.wall.law`), otherwise the thesis' fit of
    :class:`~whisker_opt.analysis.beam.LinearSoftening`; the rest of its options are those of
    :class:`~whisker_opt.analysis.beam.BeamModel`.
    """

    calls: int = 0

    def _model(self, cfg: WhiskerConfig):
        from whisker_opt.analysis.beam import BeamModel, LinearSoftening

        law = {"softening": LinearSoftening(slope=cfg.material.wall_slope, intercept=1.0)} \
            if cfg.material.wall_law == "calibrated" else {}
        return BeamModel(E=6.0 * cfg.material.C10, calibration=cfg.scene.calibration, **law)

    @property
    def solved(self) -> int:
        return self.calls

    def reading(self, cfg: WhiskerConfig, trim: float, Q: float, a: float, deltas) -> np.ndarray:
        from whisker_opt.analysis.beam import sensitivity

        self.calls += 1
        design = wiring.design_from_config(cfg, float(trim), trim_key="the trim of a measurement")
        model = self._model(cfg)
        with _beam_range(Q):
            return sensitivity(design, float(a), float(Q), model) * np.asarray(deltas, dtype=float)

    def extension(self, cfg: WhiskerConfig, trim: float, Q: float) -> float:
        from whisker_opt.analysis.beam import chamber_extension

        self.calls += 1
        design = wiring.design_from_config(cfg, float(trim), trim_key="the trim of a measurement")
        model = self._model(cfg)
        with _beam_range(Q):
            return float(chamber_extension(design, float(Q), model))


class PressureNotHeld(SolveFailed):
    """The beam model has no state at this pressure (its softening law gives no stiffness, or the
    wall thins away): the beam's counterpart of a pressurisation that does not converge."""


@contextmanager
def _beam_range(Q: float):
    """Turns the beam model's refusal of a pressure outside its range (ValueError) into
    :class:`PressureNotHeld`, as a scene that cannot be pressurised raises ``SolveFailed``."""
    try:
        yield
    except ValueError as exc:
        raise PressureNotHeld(f"the beam model holds no state at Q = {float(Q):g} MPa: {exc}", []) from exc


@dataclass(frozen=True)
class Prediction:
    """The model's value of an observed quantity.

    Attributes
    ----------
    value : float
        In the observation's unit (mm, strain, a ratio, MPa).
    matched : bool
        False for a restore observation whose match the search did not find (``value`` is then the
        sampled pressure of the smallest mismatch).
    note : str
        How the value was found, or why no match was.
    """

    value: float
    matched: bool = True
    note: str = ""


@dataclass(frozen=True)
class RestoreSearch:
    """Settings of the search of a restore observation's pressure (``calibration.restore_*`` keys)."""

    Q_max: float = 0.3
    scan: int = 7
    xtol: float = 1e-5


def _restore(ob: Restore, cfg: WhiskerConfig, sim: Simulator, search: RestoreSearch) -> Prediction:
    """Q* with ε(δ; Δ, Q*) = ε(δ; Δ_ref, Q_ref): bracketed on a scan of [0, Q_max], refined by Brent."""
    d = np.array([ob.delta])
    target = float(sim.reading(cfg, ob.trim_ref, ob.Q_ref, ob.a, d)[0])

    def diff(q: float) -> float:
        return float(sim.reading(cfg, ob.trim, q, ob.a, d)[0]) - target

    qs, fs, held = [], [], ""
    for q in np.linspace(0.0, search.Q_max, search.scan):
        try:
            fs.append(diff(float(q)))
        except SolveFailed as exc:  # the model's whisker holds no more pressure: scan what it holds
            held = f"; the model does not hold Q = {q:g} MPa ({exc}), scanned up to {qs[-1]:g} MPa" if qs else ""
            if not qs:
                raise
            break
        qs.append(float(q))
    qs, fs = np.asarray(qs), np.asarray(fs)  # (n_scanned,)
    zeros = [float(q) for q, f in zip(qs, fs) if f == 0.0]
    brackets = [(float(qs[k]), float(qs[k + 1])) for k in range(len(qs) - 1) if fs[k] * fs[k + 1] < 0.0]
    if zeros or brackets:
        def distance(b: tuple[float, float]) -> float:
            return 0.0 if b[0] <= ob.Q <= b[1] else min(abs(ob.Q - b[0]), abs(ob.Q - b[1]))

        candidates = [(abs(z - ob.Q), z, None) for z in zeros] + [(distance(b), None, b) for b in brackets]
        _, z, b = min(candidates, key=lambda c: c[0])
        if b is None:
            return Prediction(z, True, f"exact match at the sampled Q = {z:g} MPa")
        q = float(optimize.brentq(diff, b[0], b[1], xtol=search.xtol))
        others = len(brackets) + len(zeros) - 1
        more = f"; {others} other match(es) on the scan" if others else ""
        return Prediction(q, True, f"root in [{b[0]:g}, {b[1]:g}] MPa{more}{held}")
    k = int(np.argmin(np.abs(fs)))
    lo, hi = float(np.min(fs + target)), float(np.max(fs + target))
    q_star = unmatched_pressure(qs, fs, search.Q_max)
    beyond = f"; extrapolated, the mismatch vanishes at Q = {q_star:.4g} MPa" if q_star != qs[k] else ""
    note = (f"no Q in [0, {search.Q_max:g}] MPa matches: the reading ε({ob.delta:g} mm) spans [{lo:.5g}, {hi:.5g}] "
            f"over it, the reference reads {target:.5g} ({100 * fs[k] / target:+.1f} % at the closest, "
            f"Q = {qs[k]:g} MPa{beyond}){held}")
    return Prediction(q_star, False, note)


def unmatched_pressure(qs: np.ndarray, fs: np.ndarray, reach: float) -> float:
    """The model's value of a restore observation that no scanned pressure matches.

    With f(Q) = ε(δ; Δ, Q) − ε_ref sampled at ``qs`` (no sign change) and Q_c the sample of the smallest
    |f|: at an end of the scan, Q_c − f(Q_c)/f′ with f′ the slope of the end interval (where the
    mismatch, continued linearly, vanishes: outside the scan, on the side of Q_c), moved at most
    ``reach`` from Q_c; inside the scan, Q_c. It is continuous in the model's parameters while Q_c stays
    at the same end, and equals the root where a match leaves the scan through that end (f(Q_c) = 0).

    Parameters
    ----------
    qs, fs : ndarray, shape (n,)
        Scanned pressures (increasing) and the mismatch there.
    reach : float
        Largest distance of the value from Q_c [MPa].

    Returns
    -------
    float
    """
    k = int(np.argmin(np.abs(fs)))
    if qs.size < 2 or 0 < k < qs.size - 1:
        return float(qs[k])
    j = (0, 1) if k == 0 else (k - 1, k)
    slope = (fs[j[1]] - fs[j[0]]) / (qs[j[1]] - qs[j[0]])
    side = -1.0 if k == 0 else 1.0  # the match lies below the scan from its lower end, above it from its upper
    step = abs(fs[k] / slope) if slope != 0.0 else np.inf
    return float(qs[k] + side * min(step, reach))


def predict(ob: Observation, cfg: WhiskerConfig, sim: Simulator, search: RestoreSearch = RestoreSearch()) -> Prediction:
    """The model's value of the quantity an observation measured (see the module docstring).

    Parameters
    ----------
    ob : Extension, Response or Restore
    cfg : WhiskerConfig
        The model: a run file with the parameter values under test.
    sim : Simulator
    search : RestoreSearch
        How a restore observation's pressure is searched.

    Returns
    -------
    Prediction
    """
    if isinstance(ob, Extension):
        return Prediction(sim.extension(cfg, ob.trim, ob.Q))
    if isinstance(ob, Response):
        eps = float(sim.reading(cfg, ob.trim, ob.Q, ob.a, [ob.delta])[0])
        if ob.ref_Q is None:
            return Prediction(eps)
        ref = float(sim.reading(cfg, ob.trim, ob.ref_Q, ob.a, [ob.delta])[0])
        if ref == 0.0:
            return Prediction(float("nan"), False, f"the reading at the reference pressure {ob.ref_Q:g} MPa is 0")
        return Prediction(eps / ref, True, f"ε = {eps:.6g}, at Q_ref: {ref:.6g}")
    if isinstance(ob, Restore):
        return _restore(ob, cfg, sim, search)
    raise TypeError(f"not an observation: {ob!r}")
