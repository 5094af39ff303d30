"""The GA's fitness: one design evaluation = intact scene at Q_i + trimmed, vented scene.

f1 is the mean over the deflection samples δ_k = k·Δδ (k = 1 … δ_max/Δδ,
Δδ = 0.01 mm by default) of |ε_i(δ_k) − ε_c(δ_k)|, both curves interpolated from the
solved increments (:meth:`whisker_opt.experiment.scene.SceneResult.curve`). Failures are
classified (invalid geometry, mesh failure, unconverged solve, other error) and
returned as :class:`whisker_opt.experiment.outcome.EvalOutcome`; nothing raises into the GA.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, replace

import numpy as np

from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.experiment import objective
from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS
from whisker_opt.genes import design_from_genes, spec_from_genes

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SceneEvaluator:
    """Picklable evaluator ``genes -> EvalOutcome`` for the GA.

    Parameters
    ----------
    base_spec : whisker_opt.experiment.spec.SceneSpec
        Scene settings (material, contact, fidelity); its design supplies every
        non-gene geometric parameter.
    trim : float
        Trim Δmax of the compensated whisker [mm].
    delta_step : float
        Deflection sampling of f1 [mm].
    gauge_variant : str
        'line' or 'centroid'.
    keep_curves : bool
        Attach the sampled curves to the outcome's ``extra`` (for the best design only:
        they are large).
    """

    base_spec: object
    trim: float
    delta_step: float = 0.01
    gauge_variant: str = "line"
    keep_curves: bool = False

    def specs(self, genes: dict, validate: bool = True) -> tuple:
        """(intact, trimmed) SceneSpecs of a genome; both designs validated unless ``validate`` is False
        (for describing stored results whose design may not pass today's checks)."""
        intact = spec_from_genes(self.base_spec, genes, 0.0, float(genes["Q_i"]))
        trimmed = replace(intact, design=replace(intact.design, trim=float(self.trim)), Q=0.0)
        if validate:
            intact.design.validate()
            trimmed.design.validate()
        return intact, trimmed

    def samples(self) -> np.ndarray:
        """Deflections at which f1 samples the curves: Δδ, 2Δδ, …, δ_max."""
        dm = self.base_spec.deflection
        n = int(round(dm / self.delta_step))
        return np.arange(1, n + 1) * (dm / n)

    #: The scenes of one evaluation, in the order they are solved.
    SCENES = ("intact", "trimmed")

    def __call__(self, genes: dict, on_scene=None) -> EvalOutcome:
        """Evaluate a genome; ``on_scene(name, seconds)``, if given, after each scene of :data:`SCENES` solved."""
        from fem.newton import SolveFailed
        from geometry.design import InvalidDesignError
        from whisker_opt.experiment.scene import run_scene

        t0 = time.perf_counter()
        timings: dict[str, float] = {}
        try:
            intact, trimmed = self.specs(genes)
        except InvalidDesignError as exc:
            return EvalOutcome.failure("invalid_geometry", str(exc), {"total": time.perf_counter() - t0},
                                       {"violation": _violation(genes, self.base_spec.design)})
        results = {}
        for name, spec in zip(self.SCENES, (intact, trimmed)):
            t = time.perf_counter()
            try:
                results[name] = run_scene(spec)
            except SolveFailed as exc:
                return EvalOutcome.failure("solve_failed", f"{name}: {exc}", {"total": time.perf_counter() - t0})
            except InvalidDesignError as exc:
                return EvalOutcome.failure("invalid_geometry", f"{name}: {exc}", {"total": time.perf_counter() - t0},
                                           {"violation": _violation(genes, self.base_spec.design)})
            except Exception as exc:  # meshing (TemplateError, fTetWild), location, linear solver
                kind = "mesh_failed" if _is_mesh_error(exc) else "error"
                logger.warning("design %s: %s scene failed: %s", genes, name, exc)
                return EvalOutcome.failure(kind, f"{name}: {type(exc).__name__}: {exc}",
                                           {"total": time.perf_counter() - t0})
            timings[name] = time.perf_counter() - t
            if on_scene is not None:
                on_scene(name, timings[name])
            for k, v in results[name].timings.items():
                timings[f"{name}_{k}"] = v
        delta = self.samples()
        eps_i = results["intact"].curve(delta, self.gauge_variant)
        eps_c = results["trimmed"].curve(delta, self.gauge_variant)
        f1 = objective.f1(eps_i, eps_c)
        if not math.isfinite(f1):  # a reading undefined for this design (the section reading off its wall table)
            return EvalOutcome.failure("error", f"gauge reading {self.gauge_variant!r} is not defined for this "
                                       "design (its wall lies outside the wall table)", {"total": time.perf_counter() - t0})
        timings["total"] = time.perf_counter() - t0
        extra = {
            "genes": {k: float(v) for k, v in genes.items()},  # the inputs a measure may read (measures/)
            "delta_l": results["intact"].delta_l,
            "eps_i_max": float(eps_i[-1]),
            "eps_c_max": float(eps_c[-1]),
            "deflection": float(delta[-1]),
            "readings": {v: {n: float(results[n].eps[v][-1]) for n in self.SCENES} for v in GAUGE_VARIANTS},
            "von_mises_max": {n: results[n].von_mises_max for n in self.SCENES},
            "iterations": int(sum(r.iterations for res in results.values() for r in res.reports)),
        }
        if self.keep_curves:
            extra.update(delta=delta.tolist(), eps_i=eps_i.tolist(), eps_c=eps_c.tolist())
        return EvalOutcome.success(f1, timings, extra)


def _is_mesh_error(exc: BaseException) -> bool:
    """A design the geometry layer could not build or mesh (:class:`geometry.errors.GeometryError`), or a
    mesh the solver refused (:class:`fem.mesh.MeshError`), as opposed to a fault of the solve."""
    from fem.mesh import MeshError
    from geometry.errors import GeometryError

    return isinstance(exc, (GeometryError, MeshError))


def _violation(genes: dict, design) -> float:
    """A distance (mm) into the infeasible region: how much wall/tip material is missing.

    Uses the worst of: r_i(l) ≤ 0 (cavity radius at the chamber end), the tip radius
    r_o(L − Δ) ≤ 0; 1.0 if neither explains the refusal.
    """
    try:
        d = design_from_genes(design, genes, trim=design.trim)
        worst = max(-(d.r_outer(d.l) - d.t), -d.r_outer(d.L))
        return float(max(worst, 0.0) + 1.0)
    except Exception:  # pragma: no cover - defensive
        return 1.0
