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
    assert all(r["status"] == "ok" and r["f1"] >= 0 and r["trim_effect"] > 0 for r in rows)
    for r in rows:  # the rate is the ratio of the two gaps, shown only when the trim's effect is resolved
        rate = (1 - r["vent_gap"] / r["trim_effect"]) * 100
        assert r["resolution"] == pytest.approx(2e-3)  # coarse, ξ = 3.9
        if r["trim_effect"] >= r["resolution"]:
            assert r["recovery_rate"] == pytest.approx(rate)
        else:
            assert np.isnan(r["recovery_rate"])
    # the embedded row is the GA's own evaluation of the genome
    own = evaluator(cfg)(dict(GENES))
    assert rows[0]["f1"] == pytest.approx(own.f1, rel=1e-9)
    assert rows[0]["f1"] != pytest.approx(rows[1]["f1"], rel=1e-3)  # the laws differ
    ok, line = survives(rows, 1)
    assert line.startswith("compensation survives" if ok else "compensation does not survive")
    assert "design 1:" in format_spread(rows, "coarse")


def _row(law, rate, effect, res=2e-3):
    return {"design": 1, "law": law, "f1": 1e-3, "recovery_rate": rate if effect >= res else float("nan"),
            "trim_effect": effect, "vent_gap": effect * (1 - rate / 100), "resolution": res, "status": "ok",
            "reason": "", "time_s": 1.0}


def test_a_trim_effect_below_the_resolution_reads_as_gaps_in_table_verdict_and_report(tmp_path):
    from whisker_opt.analysis.law_spread import report_lines, write_spread

    rows = [_row("embedded", 82.6, 6.68e-3), _row("sliding", -2981.5, 1.3e-3)]
    ok, line = survives(rows, 1)
    assert not ok and "sliding: trim effect below resolution (0.0013 < 0.002), vent gap 0.04" in line
    assert "-2981" not in line
    table = format_spread(rows, "coarse")
    assert "-2981" not in table and "trim effect below resolution" in table and "82.6" in table
    write_spread(rows, tmp_path / "law_spread.csv")
    report = "\n".join(report_lines(tmp_path))
    assert "-2981" not in report and "vent gap 0.04" in report and "calibrated strain" in report
    assert "recovery 82.6 %  (trim effect 0.0067, vent gap 0.0012)" in report
    # unresolved, but venting leaves the reading within the resolution: the compensation survives that law
    ok, line = survives([_row("embedded", 82.6, 6.68e-3), _row("sliding", 50.0 - 1e3, 1e-4)], 1)
    assert ok and line.startswith("compensation survives every wall law (embedded, sliding)")
    # an older file without the gaps reads its rate as stored
    (tmp_path / "law_spread.csv").write_text("design,law,f1,recovery_rate,status,reason\n1,embedded,1e-3,60,ok,\n")
    assert "recovery 60.0 %" in "\n".join(report_lines(tmp_path))


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
