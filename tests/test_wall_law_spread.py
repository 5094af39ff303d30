"""Wall laws across the product: the model-form spread, the law-robust objective, calibrating a law.

* :func:`whisker_opt.analysis.law_spread.law_spread` on a small FE case: one row per law, the own law
  first, f1 equal to the evaluator's, a verdict line per design.
* :class:`whisker_opt.wiring.LawSetEvaluator`: the mean or the worst f1 of its laws, a failure under any
  law names it, picklable (process and dask executors send it to workers).
* ``whisker-opt calibrate`` recovers the calibrated law's slope from readings made with a known slope
  (the beam model stand-in, whose chamber softening is the calibrated law's k(Q) = 1 + s·Q).
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import yaml

from whisker_opt.analysis.law_spread import available_laws, format_spread, law_spread, survives
from whisker_opt.config.model import ConfigError, WhiskerConfig, load_config
from whisker_opt.experiment.outcome import EvalOutcome
from whisker_opt.wiring import LawSetEvaluator, evaluator

GENES = {"alpha": 4.0515, "l": 11.069, "t": 2.6521, "Q_i": 0.19986}


def test_spread_rows_and_verdict():
    cfg = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"},
                                        "scene": {"deflection": 1.0, "delta_step": 0.1}})
    assert available_laws(cfg) == ("embedded", "sliding")
    rows = law_spread(cfg, [GENES])
    assert [r["law"] for r in rows] == ["embedded", "sliding"]
    assert all(r["status"] == "ok" and r["f1"] >= 0 and np.isfinite(r["recovery_rate"]) for r in rows)
    # the embedded row is the GA's own evaluation of the genome
    own = evaluator(cfg)(dict(GENES))
    assert rows[0]["f1"] == pytest.approx(own.f1, rel=1e-9)
    assert rows[0]["f1"] != pytest.approx(rows[1]["f1"], rel=1e-3)  # the laws differ
    ok, line = survives(rows, 1)
    assert line.startswith("compensation survives" if ok else "compensation does not survive")
    assert "design 1:" in format_spread(rows, "coarse")


class _Fixed:
    """A stand-in evaluator returning a fixed outcome."""

    def __init__(self, out):
        self.out = out

    def __call__(self, genes):
        return self.out


def test_law_set_objective_mean_worst_and_failure():
    a = EvalOutcome.success(1e-3, {"total": 1.0}, {"delta_l": 2.0})
    b = EvalOutcome.success(3e-3, {"total": 1.0}, {"delta_l": 2.0})
    mean = LawSetEvaluator((_Fixed(a), _Fixed(b)), ("embedded", "sliding"), "mean")(GENES)
    worst = LawSetEvaluator((_Fixed(a), _Fixed(b)), ("embedded", "sliding"), "worst")(GENES)
    assert mean.f1 == pytest.approx(2e-3) and worst.f1 == pytest.approx(3e-3)
    assert mean.extra["f1_sliding"] == 3e-3 and "sliding 0.003" in mean.reason
    bad = EvalOutcome.failure("solve_failed", "intact: no convergence", {"total": 1.0})
    out = LawSetEvaluator((_Fixed(a), _Fixed(bad)), ("embedded", "sliding"))(GENES)
    assert not out.ok and out.reason.startswith("wall law sliding:")


def test_law_set_evaluator_from_config_is_picklable_and_has_the_inner_attributes():
    cfg = WhiskerConfig.model_validate({"optimiser": {"wall_laws": {"laws": ["embedded", "sliding"],
                                                                    "objective": "worst"}}})
    ev = evaluator(cfg)
    assert isinstance(ev, LawSetEvaluator)
    assert [e.base_spec.wall_law for e in ev.inners] == ["embedded", "sliding"]
    assert ev.trim == cfg.optimiser.trim and len(ev.samples()) == 500
    back = pickle.loads(pickle.dumps(ev))
    assert back.laws == ev.laws and back.inners[1].base_spec == ev.inners[1].base_spec


@pytest.mark.parametrize("optimiser, words", [
    ({"wall_laws": {"laws": ["embedded"]}}, "1 entries given; allowed 2..3 items"),
    ({"wall_laws": {"laws": ["embedded", "embedded"]}}, "repeated"),
    ({"wall_laws": {"laws": ["embedded", "glued"]}}, "glued"),
    ({"wall_laws": {}, "robust": {}}, "choose one robust objective"),
])
def test_law_set_config_errors_are_one_line(optimiser, words):
    from whisker_opt.api import load_config as load_mapping

    with pytest.raises(ConfigError) as exc:
        load_mapping({"optimiser": optimiser})
    assert words in str(exc.value) and "\n" not in str(exc.value).strip()


def test_calibrate_recovers_the_wall_slope(tmp_path):
    from whisker_opt.calibration.forward import BeamSimulator
    from whisker_opt.calibration.job import calibrate, prepare

    s_true = -1.2
    true = WhiskerConfig.model_validate({"material": {"wall_law": "calibrated", "wall_slope": s_true}})
    sim = BeamSimulator()
    rows = ["name,Q,a,delta,eps,sigma,length"]
    for name, q, a in (("tip_0", 0.0, 1.0), ("tip_1", 0.1, 1.0), ("tip_2", 0.2, 1.0), ("mid_2", 0.2, 0.6)):
        rows.append(f"{name},{q},{a},1.0,{float(sim.reading(true, 0.0, q, a, [1.0])[0])!r},1e-4,70")
    (tmp_path / "resp.csv").write_text("\n".join(rows) + "\n")
    cal = {"source": "readings made by the beam model with wall_slope -1.2", "model": "beam",
           "parameters": [{"path": "material.wall_slope", "lower": -4.0, "upper": 2.0, "start": 0.0}],
           "measurements": [{"file": "resp.csv", "kind": "response"}], "holdout": ["mid_2"]}
    path = tmp_path / "cal.yaml"
    path.write_text(yaml.safe_dump({"material": {"wall_law": "calibrated"}, "calibration": cal}))
    run = calibrate(prepare(load_config(path), path), tmp_path)
    assert run.outcome.values[0] == pytest.approx(s_true, abs=1e-4)
    (held,) = run.outcome.held_out
    assert abs(held.miss) < 1e-4 * abs(held.measured)
    fitted = load_config(tmp_path / "calibrated.yaml")
    assert fitted.material.wall_law == "calibrated"
    assert fitted.material.wall_slope == pytest.approx(s_true, abs=1e-4)
