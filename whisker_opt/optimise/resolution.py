"""How far a run's numbers are resolved: its fidelity, and the warnings about f1 below the resolution.

A run records its fidelity, ``{"preset", "f1_resolution", "calibration"}``
(:func:`whisker_opt.experiment.fidelity.describe`), in ``state.extra["fidelity"]``: the f1
resolution in the run's calibrated strain and the gauge factor ξ. The checks here compare f1
(and F_p) with that resolution and state every figure in the strain ``stopping.target_fp`` is
given in first (``stopping.target_strain``, docs/physics.md §4), the other in brackets, so that
a threshold and the resolution can be read side by side:

- :func:`resolution_warning`: the best design's f1 lies below the resolution (after a run);
- :func:`target_warning`: ``stopping.target_fp`` itself lies below it (before a run): a design
  can only reach that target through mesh error.

The stopping rule that ends a run whose best f1 stays below the resolution is the GA's
(:meth:`whisker_opt.optimise.ga.GeneticAlgorithm.stop_reason`, rule ``resolution``).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any, Mapping

from whisker_opt.optimise.ga import GAState, best_design, in_strain
from whisker_opt.numfmt import short_float

logger = logging.getLogger(__name__)


def run_fidelity(state: GAState, run_dir: Path | None = None) -> dict[str, Any] | None:
    """The fidelity a run was made at: ``state.extra["fidelity"]``, else (older runs) the preset of
    ``run_dir/config.yaml``; None when neither is known (e.g. an analytic evaluator)."""
    fid = (state.extra or {}).get("fidelity")
    if fid or run_dir is None or not (Path(run_dir) / "config.yaml").is_file():
        return dict(fid) if fid else None
    try:
        from whisker_opt.config.model import load_config
        from whisker_opt.experiment.fidelity import describe

        cfg = load_config(Path(run_dir) / "config.yaml")
        return describe(cfg.fidelity, cfg.scene.calibration)
    except Exception as exc:  # noqa: BLE001 - a report goes on without it
        logger.info("fidelity of %s unknown: %s", run_dir, exc)
        return None


def _resolution(fidelity: Mapping[str, Any] | None) -> float | None:
    res = (fidelity or {}).get("f1_resolution")
    try:
        res = float(res)
    except (TypeError, ValueError):
        return None
    return res if math.isfinite(res) and res > 0 else None


def _finer(preset: str, run_dir: Path | None) -> str:
    """The hint to verify at the finest preset after ``preset`` whose f1 resolution is measured."""
    from whisker_opt.experiment.fidelity import PRESET_NAMES, PRESETS

    after = PRESET_NAMES[PRESET_NAMES.index(preset) + 1:] if preset in PRESET_NAMES else ()
    finer = [p for p in after if math.isfinite(PRESETS[p].f1_resolution)]
    if not finer:
        return ": no shipped preset resolves it; treat it as f1 ≈ 0 within mesh error"
    where = f" (whisker-opt verify {run_dir} --preset {finer[-1]})" if run_dir is not None else ""
    return f": verify at a finer preset{where}"


def resolution_warning(state: GAState, fidelity: Mapping[str, Any] | None, run_dir: Path | None = None,
                       target_strain: str = "uncalibrated") -> str | None:
    """The warning when a run's best feasible design has an f1 below its preset's f1 resolution, else None.

    The mesh's error in such an f1 is as large as f1 itself (F_p ≥ f1 is named beside it). Figures
    are written in ``target_strain`` first (:func:`whisker_opt.optimise.ga.in_strain`).

    Parameters
    ----------
    state : GAState
    fidelity : mapping or None
        ``{"preset", "f1_resolution", "calibration"}`` of the run (:func:`run_fidelity`).
    run_dir : Path, optional
        Named in the ``whisker-opt verify`` hint.
    target_strain : {'uncalibrated', 'calibrated'}
        ``stopping.target_strain`` of the run.

    Returns
    -------
    str or None
    """
    res = _resolution(fidelity)
    if not state.hof or res is None:
        return None
    b = best_design(state)
    objective = b.get("objective") or "f1"  # what the run minimises: f1 or its aggregate (f1_robust, ...)
    if not b["feasible"] or b[objective] is None or not float(b[objective]) < res:
        return None
    xi = (fidelity or {}).get("calibration")
    preset = fidelity["preset"]  # type: ignore[index]
    fp = b["F_p"] / xi if target_strain == "uncalibrated" and xi else b["F_p"]
    unit = f" {target_strain}" if xi else ""
    msg = (f"best {objective} {in_strain(b[objective], target_strain, xi)} is below the f1 resolution "
           f"~{in_strain(res, target_strain, xi)} of preset {preset} (its F_p {short_float(fp, 2)}{unit})")
    msg += _finer(preset, run_dir)
    if state.stop_reason == "target_fp":
        msg += "; the run stopped on target_fp, which lies below what this preset resolves"
    return msg


def target_warning(stopping, fidelity: Mapping[str, Any] | None) -> str | None:
    """The warning when ``stopping.target_fp`` (in its ``target_strain``) lies below the run's f1 resolution.

    F_p ≥ f1, so a design reaches such a target only with an f1 below the resolution, i.e. within
    the mesh's error. A ``target_fp`` of 0 (no target) is not warned about.

    Parameters
    ----------
    stopping : whisker_opt.config.optimiser.StoppingConfig
    fidelity : mapping or None
        As in :func:`resolution_warning`.

    Returns
    -------
    str or None
    """
    res = _resolution(fidelity)
    if res is None or not stopping.target_fp > 0:
        return None
    xi = (fidelity or {}).get("calibration")
    target = stopping.target_fp * xi if stopping.target_strain == "uncalibrated" and xi else stopping.target_fp
    if not target < res:
        return None
    n = stopping.resolution_generations
    rule = (f"the resolution rule ends the run after {n} generations of such an f1 "
            f"(stopping.resolution_generations = {n})" if n else
            "the resolution rule is off (stopping.resolution_generations = 0)")
    return (f"stopping.target_fp = {stopping.target_fp:g} ({stopping.target_strain} strain) lies below the f1 "
            f"resolution ~{in_strain(res, stopping.target_strain, xi)} of preset {fidelity['preset']}: a design "
            f"reaches it only within mesh error; {rule}")
