"""Wall laws across the product: the model-form spread, the law-robust objective, calibrating a law.

* :func:`whisker_opt.analysis.law_spread.law_spread` on a small FE case: one row per law, the own law
  first, f1 equal to the evaluator's, a verdict line per design.
* ``optimiser.wall_laws``: an evaluation whose every measure is the mean over the laws at coarse, its f1 the
  run's own law's; picklable (process and dask executors send it to workers).
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
from whisker_opt.wiring import evaluator

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


def test_a_law_set_evaluation_reduces_every_measure_over_the_laws():
    """At coarse: f1 is the run's own law's (embedded), every aggregate the mean over the laws' own evaluations."""
    from fem.linsolve import mkl_threads
    from whisker_opt.experiment.measures import MEASURE_NAMES, measure_values
    from whisker_opt.optimise.aggregate import AggregateEvaluator, LawVariants
    from whisker_opt.wiring import with_wall_law

    cfg = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"}, "scene": {"deflection": 1.0, "delta_step": 0.1},
                                        "optimiser": {"wall_laws": {"laws": ["sliding", "embedded"]}}})
    ev = evaluator(cfg)
    assert isinstance(ev, AggregateEvaluator) and isinstance(ev.variants, LawVariants)
    assert [e.base_spec.wall_law for e in ev.variants.evaluators] == ["sliding", "embedded"]
    with mkl_threads(1):  # the solves of a scene bit-identical, whichever evaluator makes them
        out = ev(dict(GENES))
        per_law = {law: evaluator(with_wall_law(cfg, law), robust=False)(dict(GENES))
                   for law in ("sliding", "embedded")}
    assert out.ok and all(o.ok for o in per_law.values())
    assert out.f1 == per_law["embedded"].f1  # f1 is the nominal design's, under material.wall_law
    values = {law: measure_values(o, MEASURE_NAMES) for law, o in per_law.items()}
    for n in MEASURE_NAMES:  # every measure is the mean over the laws, none the first law's
        assert out.measures[f"{n}_mean_over_laws"] == pytest.approx(
            (values["sliding"][n] + values["embedded"][n]) / 2, rel=1e-12), n
    assert out.measures["f1_mean_over_laws"] != pytest.approx(values["sliding"]["f1"], rel=1e-3)
    assert out.measures["sensitivity_mean_over_laws"] != pytest.approx(values["sliding"]["sensitivity"], rel=1e-3)
    assert out.extra["variant_evaluations"] == 2  # the embedded law's evaluation is the nominal one


def test_law_set_evaluator_from_config_is_picklable_and_has_the_inner_attributes():
    from whisker_opt.optimise.aggregate import AggregateEvaluator

    cfg = WhiskerConfig.model_validate({"optimiser": {"wall_laws": {"laws": ["embedded", "sliding"],
                                                                    "objective": "worst"}}})
    ev = evaluator(cfg)
    assert isinstance(ev, AggregateEvaluator) and (ev.reduction, ev.label) == ("worst", "worst_over_laws")
    assert [e.base_spec.wall_law for e in ev.variants.evaluators] == ["embedded", "sliding"]
    assert ev.trim == cfg.optimiser.trim and len(ev.samples()) == 500
    back = pickle.loads(pickle.dumps(ev))
    assert back == ev and back.variants.evaluators[1].base_spec == ev.variants.evaluators[1].base_spec


def test_a_law_set_that_cannot_differ_is_warned(caplog):
    """``embedded`` and ``calibrated`` at slope 0 are one law: warned once, naming both; a slope or a slope gene
    makes them differ and nothing is said."""
    from whisker_opt.wiring import warn_laws_that_cannot_differ

    laws = {"optimiser": {"wall_laws": {"laws": ["embedded", "calibrated", "sliding"]}}}
    same = WhiskerConfig.model_validate(laws)
    with caplog.at_level("WARNING", logger="whisker_opt.wiring"):
        assert warn_laws_that_cannot_differ(same) == ("embedded", "calibrated")
        evaluator(same)
    warned = [r.getMessage() for r in caplog.records if "cannot differ" in r.getMessage()]
    assert len(warned) == 2 and "'embedded' and 'calibrated'" in warned[0] and "wall_slope = 0" in warned[0]
    sloped = WhiskerConfig.model_validate({**laws, "material": {"wall_law": "calibrated", "wall_slope": -1.0}})
    assert warn_laws_that_cannot_differ(sloped) == ()
    assert warn_laws_that_cannot_differ(WhiskerConfig.model_validate(
        {"optimiser": {"wall_laws": {"laws": ["embedded", "sliding"]}}})) == ()


@pytest.mark.parametrize("optimiser, words", [
    ({"wall_laws": {"laws": ["embedded"]}}, "1 entries given; allowed 2..3 items"),
    ({"wall_laws": {"laws": ["embedded", "embedded"]}}, "repeated"),
    ({"wall_laws": {"laws": ["embedded", "glued"]}}, "glued"),
    ({"wall_laws": {}, "robust": {}}, "choose one robust objective"),
    ({"wall_laws": {}, "algorithm": "nsga2", "objectives": [{"name": "f1"}, {"name": "Q_i"}]},
     "algorithm 'nsga2' with wall_laws set"),
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
