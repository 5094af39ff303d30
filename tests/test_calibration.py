"""Calibration (``whisker-opt calibrate``): the fit recovers known parameters, bad files are one line.

The fits here use the beam model stand-in (``calibration.model: beam``) through the same code path as
the command (:func:`whisker_opt.calibration.job.prepare` and :func:`~whisker_opt.calibration.job.calibrate`),
on observations the model itself makes with known parameters.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from whisker_opt.calibration.fit import bounds_reached, chi2_limit, covariance
from whisker_opt.calibration.forward import BeamSimulator, RestoreSearch, predict
from whisker_opt.calibration.job import calibrate, prepare
from whisker_opt.calibration.measurements import MeasurementError, Restore, read_measurements
from whisker_opt.config.model import ConfigError, WhiskerConfig, load_config

#: The parameters the synthetic observations are made with.
TRUE = {"material.C10": 0.2, "scene.calibration": 4.2}


def _true_cfg() -> WhiskerConfig:
    return WhiskerConfig.model_validate({"material": {"C10": TRUE["material.C10"]},
                                         "scene": {"calibration": TRUE["scene.calibration"]}})


def _write_data(folder: Path) -> dict[str, float]:
    """Observations of every kind made by the beam model at :data:`TRUE`; returns the restore's Q."""
    cfg, sim = _true_cfg(), BeamSimulator()
    ext = ["# made by the beam model", "Q,dl,sigma"]
    ext += [f"{q},{sim.extension(cfg, 0.0, q)!r},0.01" for q in (0.05, 0.1)]
    resp = ["name,Q,a,delta,eps,sigma,length"]
    for name, q, a, length in (("tip_vented", 0.0, 1.0, 70), ("mid_pressurised", 0.1, 0.6, 70),
                               ("trimmed_tip", 0.05, 1.0, 66)):
        eps = float(sim.reading(cfg, 70 - length, q, a, [1.5])[0])
        resp.append(f"{name},{q},{a},1.5,{eps!r},1e-4,{length}")
    restore = Restore("r", "-", trim_ref=4.0, Q_ref=0.05, trim=0.0, Q=0.1, a=1.0, delta=1.0, sigma=0.005)
    q_star = predict(restore, cfg, sim, RestoreSearch(Q_max=0.3)).value
    rest = ["name,trim_ref,Q_ref,trim,Q,a,delta,sigma", f"pressurise,4,0.05,0,{q_star!r},1,1,0.005"]
    for name, lines in (("ext.csv", ext), ("resp.csv", resp), ("restore.csv", rest)):
        (folder / "data").mkdir(exist_ok=True)
        (folder / "data" / name).write_text("\n".join(lines) + "\n")
    return {"Q_star": q_star}


def _config(folder: Path, holdout=("trimmed_tip",), **extra) -> Path:
    cal = {
        "source": "synthetic observations made by the beam model", "model": "beam",
        "parameters": [{"path": "material.C10", "lower": 0.05, "upper": 0.5, "start": 0.14},
                       {"path": "scene.calibration", "lower": 1.0, "upper": 10.0}],
        "measurements": [{"file": "data/ext.csv", "kind": "extension"},
                         {"file": "data/resp.csv", "kind": "response", "weight": 2.0},
                         {"file": "data/restore.csv", "kind": "restore"}],
        "holdout": list(holdout), "restore_Q_max": 0.3, **extra,
    }
    path = folder / "cal.yaml"
    path.write_text(yaml.safe_dump({"fidelity": {"preset": "coarse"}, "calibration": cal}))
    return path


def test_the_fit_recovers_the_parameters_that_made_the_data(tmp_path):
    made = _write_data(tmp_path)
    path = _config(tmp_path)
    prepared = prepare(load_config(path), path)
    assert [p.start for p in prepared.parameters] == [0.14, 3.9]  # 3.9: the run file's own value
    run = calibrate(prepared, tmp_path)
    out = run.outcome
    np.testing.assert_allclose(out.values, [TRUE["material.C10"], TRUE["scene.calibration"]], rtol=1e-4)
    assert out.cost < 1e-6 < out.cost_start
    assert np.all(np.isfinite(out.std)) and np.all(out.std > 0)
    # the held-out reading is predicted, by the fitted model, as the true model made it
    (held,) = out.held_out
    assert held.name == "trimmed_tip" and abs(held.miss) < 1e-4 * held.measured
    assert abs(held.start_miss) > 10 * abs(held.miss)
    restore = next(o for o in out.observations if o.kind == "restore")
    assert restore.unit == "MPa" and restore.fitted.matched
    assert restore.fitted.value == pytest.approx(made["Q_star"], abs=1e-4)

    report = json.loads((tmp_path / "calibration.json").read_text())
    assert [p["path"] for p in report["parameters"]] == list(TRUE)
    assert report["held_out"]["trimmed_tip"]["miss"] == pytest.approx(held.miss)
    assert np.isfinite(held.predicted_std) and held.predicted_std > 0
    assert report["held_out"]["trimmed_tip"]["predicted_std"] == pytest.approx(held.predicted_std)
    assert abs(report["held_out"]["trimmed_tip"]["z"]) < 1.0  # the true model, predicted within its uncertainty
    assert report["evaluations"] == out.evaluations > 3
    # the calibrated run file is a run file with the fitted values, and says what it is
    text = (tmp_path / "calibrated.yaml").read_text()
    assert text.startswith("# CALIBRATED MODEL") and "synthetic observations made by the beam model" in text
    cfg = load_config(tmp_path / "calibrated.yaml")
    assert cfg.calibration is None
    assert cfg.material.C10 == pytest.approx(TRUE["material.C10"], rel=1e-4)
    assert cfg.scene.calibration == pytest.approx(TRUE["scene.calibration"], rel=1e-4)
    assert (tmp_path / "calibration.png").stat().st_size > 1000


def test_the_uncertainties_follow_the_stated_sigmas(tmp_path):
    """Doubling every σ doubles the std (Cov = (JᵀJ)⁻¹ with J ∝ 1/σ) and leaves the fitted values."""
    _write_data(tmp_path)
    first = calibrate(prepare(load_config(_config(tmp_path)), _config(tmp_path)), tmp_path).outcome
    for name in ("ext.csv", "resp.csv", "restore.csv"):
        f = tmp_path / "data" / name
        rows = [ln.split(",") for ln in f.read_text().splitlines()]
        col = next(r for r in rows if not r[0].startswith("#")).index("sigma")
        f.write_text("\n".join(",".join(r) if r[0].startswith("#") or r[col] == "sigma" else
                               ",".join(r[:col] + [repr(2 * float(r[col]))] + r[col + 1:]) for r in rows) + "\n")
    second = calibrate(prepare(load_config(_config(tmp_path)), _config(tmp_path)), tmp_path).outcome
    np.testing.assert_allclose(second.values, first.values, rtol=1e-4)
    np.testing.assert_allclose(second.std, 2 * first.std, rtol=0.05)


def test_covariance_is_the_inverse_normal_matrix_and_flags_undetermined_parameters():
    rng = np.random.default_rng(3)
    jac = rng.normal(size=(7, 3))
    cov, s = covariance(jac)
    np.testing.assert_allclose(cov, np.linalg.inv(jac.T @ jac), rtol=1e-10)
    assert s.shape == (3,)
    # a parameter the residuals do not depend on is undetermined; the others keep their covariance
    flat = np.column_stack([jac[:, :2], np.zeros(7)])
    cov2, _ = covariance(flat)
    assert np.all(np.isinf(cov2[2])) and np.all(np.isinf(cov2[:, 2]))
    np.testing.assert_allclose(cov2[:2, :2], np.linalg.inv(jac[:, :2].T @ jac[:, :2]), rtol=1e-10)


def test_a_restore_prediction_is_the_pressure_where_the_readings_match():
    """The root found against a brute-force scan of the beam model's readings."""
    cfg, sim = WhiskerConfig(), BeamSimulator()
    ob = Restore("r", "-", trim_ref=5.0, Q_ref=0.02, trim=0.0, Q=0.1, a=1.0, delta=1.0, sigma=0.005)
    p = predict(ob, cfg, sim, RestoreSearch(Q_max=0.3, scan=4, xtol=1e-7))
    target = sim.reading(cfg, 5.0, 0.02, 1.0, [1.0])[0]
    qs = np.linspace(0, 0.3, 61)
    diff = np.array([sim.reading(cfg, 0.0, q, 1.0, [1.0])[0] for q in qs]) - target
    k = np.flatnonzero(np.diff(np.sign(diff)))
    assert p.matched and k.size == 1 and qs[k[0]] <= p.value <= qs[k[0] + 1]
    # a match beyond the searched range is reported as such, its value where the mismatch, continued
    # linearly from the scan's last interval, vanishes: near the true root (the readings are nearly linear in Q)
    q_max = 0.8 * p.value
    q = predict(ob, cfg, sim, RestoreSearch(Q_max=q_max, scan=5))
    ends = np.array([sim.reading(cfg, 0.0, x, 1.0, [1.0])[0] for x in (0.75 * q_max, q_max)]) - target
    linear = q_max - ends[1] * 0.25 * q_max / (ends[1] - ends[0])
    assert not q.matched and "no Q in" in q.note and f"vanishes at Q = {linear:.4g} MPa" in q.note
    assert q.value == pytest.approx(linear, rel=1e-12) and q_max < q.value and abs(q.value - p.value) < 0.02 * p.value
    # at most Q_max beyond the scan, and continuous where the match leaves the scan through its end
    far = predict(ob, cfg, sim, RestoreSearch(Q_max=0.2 * p.value, scan=5))
    assert not far.matched and far.value == pytest.approx(0.4 * p.value, rel=1e-12)
    edge = predict(ob, cfg, sim, RestoreSearch(Q_max=p.value * (1 - 1e-6), scan=5))
    assert not edge.matched and edge.value == pytest.approx(p.value, rel=1e-7)


GOOD = "Q,a,delta,eps,sigma\n0.1,1,1,0.013,1e-4\n"


@pytest.mark.parametrize("text, words", [
    ("", ("empty file", "Q, a, delta, eps, sigma")),
    ("# only a comment\n\n", ("empty file",)),
    ("Q,a,delta,eps,sigma\n", ("no data rows",)),
    ("Q,a,delta,eps\n0.1,1,1,0.013\n", ("header (line 1)", "missing column 'sigma'")),
    ("Q,a,delta,eps,sigma,alpha\n0.1,1,1,0.013,1e-4,3\n", ("header (line 1), column 6", "unknown column 'alpha'")),
    (GOOD + "0.1,abc,1,0.013,1e-4\n", ("row 2 (line 3), column a", "'abc' is not a number")),
    (GOOD + "0.1,1.5,1,0.013,1e-4\n", ("row 2 (line 3), column a", "1.5 is outside the allowed range (0, 1]")),
    ("# a comment\n" + GOOD + "0.1,1,1,nan,1e-4\n", ("row 2 (line 4), column eps", "not a finite number")),
    (GOOD + "0.1,1,1,0.013\n", ("row 2 (line 3)", "4 cells for the 5 columns")),
    (GOOD + "0.1,1,,0.013,1e-4\n", ("row 2 (line 3), column delta", "empty")),
    (GOOD + "0.1,1,40,0.013,1e-4\n", ("row 2 (line 3), column delta", "outside the allowed range (0, 30]")),
    (GOOD + "-0.1,1,1,0.013,1e-4\n", ("row 2 (line 3), column Q", "outside the allowed range [0, 1] MPa")),
    (GOOD + "0.1,1,1,0.013,0\n", ("row 2 (line 3), column sigma", "outside the allowed range [1e-12, 1000]")),
    ("Q,a,delta,eps,sigma,specimens\n0.1,1,1,0.013,1e-4,3\n", ("row 1 (line 2), column specimens",
                                                               "outside the allowed range [1, 2]")),
    ("Q,a,delta,eps,sigma,specimens\n0.1,1,1,0.013,1e-4,1.5\n", ("row 1 (line 2), column specimens",
                                                                 "1.5 is not 1 or 2")),
])
def test_a_malformed_file_is_one_line_naming_file_row_and_column(tmp_path, text, words):
    path = tmp_path / "resp.csv"
    path.write_text(text)
    with pytest.raises(MeasurementError) as info:
        read_measurements(path, "response", length_L=70.0, max_delta=30.0)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ")
    for w in words:
        assert w in msg, msg


def test_lengths_and_trims_of_a_row(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("Q,a,delta,eps,sigma,length\n0,1,1,0.01,1e-4,65\n0,1,1,0.01,1e-4,75\n")
    with pytest.raises(MeasurementError, match=r"row 2 \(line 3\), column length: 75 is outside the allowed range "
                       r"\(0, 70\] mm \(design.L = 70\)"):
        read_measurements(path, "response", length_L=70.0)
    path.write_text("Q,a,delta,eps,sigma,length\n0,1,1,0.01,1e-4,65\n")
    (ob,) = read_measurements(path, "response", length_L=70.0)
    assert ob.trim == 5.0 and ob.name == "r:1" and ob.ref_Q is None and ob.specimens == 1


def test_a_row_says_how_many_specimens_it_compares(tmp_path):
    """The shipped restore file: the vent compares one specimen with itself, the converse two prototypes, whose σ
    carries the casting-to-casting spread and is the larger."""
    obs = {o.name: o for o in read_measurements(Path(__file__).parents[1] / "configs" / "data" / "thesis_restore.csv",
                                                 "restore", length_L=70.0)}
    assert obs["vent_65_matches_70"].specimens == 1 and obs["pressurise_70_matches_65"].specimens == 2
    assert obs["pressurise_70_matches_65"].sigma > obs["vent_65_matches_70"].sigma


def test_a_held_out_prediction_carries_the_parameters_uncertainty():
    """σ_pred = √(gᵀ Cov g) for a model linear in θ: m(θ) = G θ, g the row of G; exact for forward differences.
    An observation that moves along an undetermined direction is inf; one the shifts cannot match is nan."""
    from whisker_opt.calibration.propagation import prediction_std
    from whisker_opt.calibration.forward import Prediction

    G = np.array([[2.0, -1.0], [0.5, 3.0]])  # (k, n)
    lower, width = np.array([0.0, 1.0]), np.array([2.0, 4.0])

    class Linear:
        def __init__(self):
            self.lower, self.width = lower, width

        def u(self, theta):
            return (np.asarray(theta) - lower) / width

        def theta(self, u):
            return lower + np.asarray(u) * width

        def predictions(self, theta, observations):
            return [Prediction(float(v)) for v in G @ np.asarray(theta)]

    cov = np.array([[0.04, 0.01], [0.01, 0.09]])
    theta = np.array([1.0, 2.0])
    at = Linear().predictions(theta, None)
    got = prediction_std(Linear(), theta, [None, None], at, cov, 0.05)
    np.testing.assert_allclose(got, [np.sqrt(g @ cov @ g) for g in G], rtol=1e-10)
    undetermined = cov.copy()
    undetermined[1, :] = undetermined[:, 1] = np.inf
    assert prediction_std(Linear(), theta, [None, None], at, undetermined, 0.05) == [np.inf, np.inf]
    unmatched = [Prediction(at[0].value, matched=False), at[1]]
    assert np.isnan(prediction_std(Linear(), theta, [None, None], unmatched, cov, 0.05)[0])


def test_the_command_refuses_bad_input_in_one_line_and_runs_on_a_calibrated_file(tmp_path, capsys):
    from whisker_opt.cli.main import main

    _write_data(tmp_path)
    path = _config(tmp_path)
    (tmp_path / "data" / "resp.csv").write_text("name,Q,a,delta,eps,sigma\nx,0.1,1,1,oops,1e-4\n")

    def cli(*args):
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return SimpleNamespace(returncode=code, stdout=out, stderr=err)

    bad = cli("calibrate", path, "--out", tmp_path / "out")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().count("\n") == 0
    assert "resp.csv: row 1 (line 2), column eps: 'oops' is not a number" in bad.stderr
    assert not (tmp_path / "out").exists()  # refused before the folder is made
    _write_data(tmp_path)
    for setting, words in (("calibration.holdout=[nope]", "calibration.holdout[0]: no observation is named 'nope'"),
                           ("calibration.parameters=[{path: design.n_fibres, lower: 1, upper: 3}]",
                            "calibration.parameters[0].path: 'design.n_fibres' is not a real-valued key"),
                           ("calibration.parameters=[{path: material.C10, lower: 0, upper: 1}]",
                            "calibration.parameters[0].lower: 0.0 is outside the allowed range (0, 100] (MPa)")):
        r = cli("calibrate", path, "--set", setting)
        assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, r.stderr
    ok = cli("calibrate", path, "--out", tmp_path / "out")
    assert ok.returncode == 0, ok.stderr
    assert "trimmed_tip" in ok.stdout and "[held out]" in ok.stdout
    run = cli("run", tmp_path / "out" / "calibrated.yaml", "--out", tmp_path / "ga", "--no-progress",
              "--set", "optimiser.ga.population=2", "--set", "optimiser.ga.n_elite=0",
              "--set", "optimiser.stopping.max_generations=0", "--set", "scene.deflection=1")
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "ga" / "evaluations.csv").read_text().count("\n") == 3  # header + 2 designs


def test_parameters_name_real_valued_keys_within_their_range(tmp_path):
    _write_data(tmp_path)
    for params, words in (([{"path": "fidelity.h_wall", "lower": 0.5, "upper": 2}], None),
                          ([{"path": "design", "lower": 0, "upper": 1}], "'design' is not the dotted path of a key in a section"),
                          ([{"path": "design.fibre", "lower": 0, "upper": 1}], "is no key of a run file"),
                          ([{"path": "optimiser.ga", "lower": 0, "upper": 1}], "is a section, not a key"),
                          ([{"path": "design.t", "lower": 1, "upper": 12}],
                           "calibration.parameters[0].upper: design.t = 12 leaves no whisker"),
                          ([{"path": "material.wall_slope", "lower": -4, "upper": 2, "start": 0}],
                           "calibration.parameters[0].lower: material.wall_slope = -4.0 makes the run file impossible: "
                           "material.wall_slope=-4.0 is read only by material.wall_law 'calibrated'")):
        path = _config(tmp_path, parameters=params)
        if words is None:
            with pytest.raises(ConfigError, match="start: the run file gives fidelity.h_wall = None"):
                prepare(load_config(path), path)
            continue
        with pytest.raises(ConfigError) as info:
            prepare(load_config(path), path)
        assert words in str(info.value)


def test_a_pressure_the_model_cannot_hold_ends_the_restore_scan():
    """A reading linear in Q (ε = 1 + Q on the trimmed whisker, 1.12 at the reference) whose pressurisation
    fails above 0.2 MPa: the scan stops there and the root 0.12 is still found, the note says why."""
    from fem.newton import SolveFailed

    class Sim:
        def reading(self, cfg, trim, Q, a, deltas):
            if trim == 0.0 and Q > 0.2:
                raise SolveFailed("no convergence", [])
            return np.array([1.12]) if trim > 0 else np.array([1.0 + Q])

    ob = Restore("r", "-", trim_ref=5.0, Q_ref=0.1, trim=0.0, Q=0.1, a=1.0, delta=1.0, sigma=0.005)
    pred = predict(ob, WhiskerConfig(), Sim(), RestoreSearch(Q_max=0.3, scan=7))
    assert pred.matched and pred.value == pytest.approx(0.12, abs=1e-5)
    assert "does not hold Q = 0.25 MPa" in pred.note and "scanned up to 0.2 MPa" in pred.note


def _cli(capsys, *args):
    from whisker_opt.cli.main import main

    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return SimpleNamespace(returncode=code, stdout=out, stderr=err)


@pytest.mark.parametrize("budget, state", [(6, "budget exhausted"), (3, "not moved")])
def test_a_fit_stopped_by_its_budget_is_not_labelled_calibrated(tmp_path, capsys, budget, state):
    """Header, JSON, summary and exit status say that the fit did not converge."""
    _write_data(tmp_path)
    path = _config(tmp_path)
    r = _cli(capsys, "calibrate", path, "--out", tmp_path / "out", "--set", f"calibration.max_evaluations={budget}")
    assert r.returncode == 4, r.stderr
    assert "Traceback" not in r.stderr and r.stderr.strip().count("\n") == 0
    assert "not calibrated" in r.stderr and "NOT CALIBRATED" in r.stderr and "exit status 4" in r.stderr
    assert f"status: {state.upper()} after {budget} of at most {budget} model evaluations" in r.stdout
    text = (tmp_path / "out" / "calibrated.yaml").read_text()
    assert text.startswith(f"# NOT CALIBRATED ({state})") and "CALIBRATED MODEL" not in text
    assert "# WARNING: not calibrated: the fit used its budget" in text
    report = json.loads((tmp_path / "out" / "calibration.json").read_text())
    assert report["calibrated_model"] is False and report["fit_status"] == state
    assert report["max_evaluations"] == budget and report["warnings"][0].startswith("not calibrated")
    # the same data with the default budget: converged, headed calibrated, exit status 0
    ok = _cli(capsys, "calibrate", path, "--out", tmp_path / "ok")
    assert ok.returncode == 0, ok.stderr
    report = json.loads((tmp_path / "ok" / "calibration.json").read_text())
    assert report["calibrated_model"] is True and report["fit_status"] == "converged" and report["warnings"] == []
    assert (tmp_path / "ok" / "calibrated.yaml").read_text().startswith("# CALIBRATED MODEL")


def test_a_fit_pressed_against_a_bound_is_flagged(tmp_path):
    """The data want C10 = 0.2; its upper bound 0.15 stops it a little inside that bound, where
    least_squares' strictly feasible iterates end, and it is flagged there; chi2/dof is flagged too."""
    _write_data(tmp_path)
    params = [{"path": "material.C10", "lower": 0.05, "upper": 0.15, "start": 0.1},
              {"path": "scene.calibration", "lower": 1.0, "upper": 10.0}]
    path = _config(tmp_path, parameters=params)
    run = calibrate(prepare(load_config(path), path), tmp_path)
    out = run.outcome
    assert out.state == "converged" and out.at_bound == ("upper", None)
    # inside the bound (not on it), within the fit's tolerance; whichever local fit is reported
    assert 0.0 < 0.15 - out.values[0] <= out.tolerance * 0.1
    assert all(0.0 < 0.15 - f.values[0] <= out.tolerance * 0.1 for f in out.starts) and len(out.starts) == 2
    assert out.chi2_high and out.chi2_per_dof > chi2_limit(out.dof)
    report = json.loads((tmp_path / "calibration.json").read_text())
    assert report["parameters"][0]["at_bound"] == "upper" and report["parameters"][1]["at_bound"] is None
    assert report["chi2_per_dof"] == pytest.approx(out.chi2 / out.dof)
    assert report["chi2_per_dof_limit"] == pytest.approx(chi2_limit(out.dof))
    assert any("material.C10 = 0.15 is at its upper bound" in w for w in report["warnings"])
    assert any(w.startswith("chi2/dof = ") for w in report["warnings"])
    text = (tmp_path / "calibrated.yaml").read_text()
    assert "(at its upper bound)" in text and "# WARNING: material.C10" in text and "# WARNING: chi2/dof" in text
    assert "WARNING: material.C10 = 0.15 is at its upper bound" in run.summary


def test_the_bound_and_chi2_limits():
    """At a bound: within tolerance x range of the nearer bound (least_squares' active-set rule with
    xtol = tolerance); chi2/dof limit: the 99th percentile of chi2_nu / nu."""
    from whisker_opt.calibration.parameters import ModelParameter

    p = ModelParameter(path="material.C10", lower=0.0, upper=2.0, start=1.0, unit="MPa", description="")
    got = bounds_reached([2.0 - 2e-4, 2e-4, 1.0, 2.0 - 4e-3, 2.0], [p] * 5, 1e-3)
    assert got == ("upper", "lower", None, None, "upper")
    assert chi2_limit(5) == pytest.approx(3.017, abs=1e-3) and chi2_limit(1) == pytest.approx(6.635, abs=1e-3)
    assert np.isnan(chi2_limit(0))


@pytest.mark.parametrize("name", ["calibrate_base.yaml", "calibrate_base_rubber.yaml", "calibrate_base_gauge.yaml"])
def test_the_shipped_mechanism_calibrations_fit_the_ratios_and_hold_out_both_restores(name):
    """The base-mechanism calibrations (docs/physics.md §14.2): the six sensitivity ratios fitted, the vent (one
    specimen) and the converse (two specimens) held out, every fitted key inside the run file's own range."""
    path = Path(__file__).parents[1] / "configs" / name
    prepared = prepare(load_config(path), path)
    assert [w.observation.kind for w in prepared.fitted] == ["response"] * 6
    held = {w.observation.name: w.observation.specimens for w in prepared.held_out}
    assert held == {"vent_65_matches_70": 1, "pressurise_70_matches_65": 2}
    assert prepared.cfg.scene.base_support == "compliant"
